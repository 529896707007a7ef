"""chaincart-env as a new user has it: the wheel built by maturin, installed without
extras into a fresh venv (numpy and gymnasium only), used from a directory outside
the source tree. Every command either works or says which extra to install.

The wheel is built with ``maturin build --profile setup`` in the source tree's cargo
target directory for this interpreter, as ``scripts/setup.sh`` builds the extension (it
runs ``maturin develop --profile setup`` with the same python, whose path maturin hands
to PyO3's build script as PYO3_PYTHON): cargo finds the build of set-up fresh, and
neither command invalidates the other's build."""

from __future__ import annotations

import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest
from conformance_support import clean_environ

import chaincart_env

ROOT = Path(chaincart_env.__file__).resolve().parents[1]
EXTRA_MESSAGE = "not installed: pip install 'chaincart-env["


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The python of a fresh venv holding the wheel and its two dependencies only."""
    assert (ROOT / "Cargo.toml").is_file(), "the wheel test runs from a source checkout"
    wheels = tmp_path_factory.mktemp("wheels")
    build = subprocess.run(
        [sys.executable, "-m", "maturin", "build", "--profile", "setup", "--interpreter", sys.executable, "-o", str(wheels)],
        cwd=ROOT, capture_output=True, text=True, env=clean_environ(), timeout=1500,
    )  # fmt: skip
    assert build.returncode == 0, build.stderr[-3000:]
    # Only a change of the Rust sources since set-up may compile anything here (the
    # chaincart crate); PyO3's crates recompile when the interpreter or environment
    # differs from set-up's, and then the two commands rebuild each other.
    assert "Compiling pyo3" not in build.stderr, build.stderr[-3000:]
    (wheel,) = wheels.glob("chaincart_env-*.whl")
    env_dir = tmp_path_factory.mktemp("venv")
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    install = subprocess.run(
        [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check", str(wheel)],
        capture_output=True, text=True, env=clean_environ(), timeout=600,
    )  # fmt: skip
    assert install.returncode == 0, install.stderr[-3000:]
    return python


def run(python: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """``python args`` in ``cwd`` with no display and no cargo on PATH."""
    env = clean_environ()
    env.pop("DISPLAY", None)
    env["PATH"] = os.pathsep.join([str(python.parent), "/usr/bin", "/bin"])
    return subprocess.run([str(python), *args], cwd=cwd, capture_output=True, text=True, env=env, timeout=600)


def test_only_numpy_and_gymnasium_come_along(installed: Path, tmp_path: Path) -> None:
    done = run(installed, tmp_path, "-m", "pip", "list", "--format=freeze", "--disable-pip-version-check")
    names = {line.split("==")[0].lower() for line in done.stdout.split()}
    assert {"chaincart-env", "numpy", "gymnasium"} <= names
    assert not names & {"stable-baselines3", "torch", "matplotlib", "pillow", "mujoco"}
    where = run(installed, tmp_path, "-c", "import chaincart_env; print(chaincart_env.__file__)")
    assert "site-packages" in where.stdout and str(ROOT) not in where.stdout


def test_bench_quick_runs_every_section_without_cargo(installed: Path, tmp_path: Path) -> None:
    done = run(installed, tmp_path, "-m", "chaincart_env", "bench", "--quick")
    assert done.returncode == 0, done.stderr[-3000:]
    out = done.stdout
    assert "## Scaling with the number of links" in out and "fitted slope" in out
    assert "dense form (LU), accelerations" in out
    assert "No criterion results (this is an installed package" in out and "cargo bench --bench dynamics" in out
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize(
    "command, extras",
    [
        (["compare", "--timesteps", "10"], "sb3,plot"),
        (["evaluate", "runs/none"], "sb3,plot"),
        (["evaluate", "pretrained:swingup-2/ppo"], "plot"),  # a shipped agent acts with numpy alone
        (["compare", "--address", "auto"], "sb3,plot,rllib"),  # a Ray cluster needs Ray
        (["evaluate", "runs/none", "--address", "local"], "sb3,plot,rllib"),
        (["figures"], "plot"),
        (["roa", "--starts", "2"], "plot"),
        (["animate"], "plot"),
        (["animate", "--out", "run.mp4"], "plot"),
    ],
)
def test_commands_without_their_extra_say_which_to_install(installed: Path, tmp_path: Path, command, extras) -> None:
    done = run(installed, tmp_path, "-m", "chaincart_env", *command)
    assert done.returncode == 1
    assert done.stderr.count("\n") == 1 and f"{EXTRA_MESSAGE}{extras}]'" in done.stderr
    assert "Traceback" not in done.stderr and done.stdout == ""  # nothing done before
    assert list(tmp_path.iterdir()) == []


def test_shipped_agents_come_in_the_wheel_and_act_without_torch(installed: Path, tmp_path: Path) -> None:
    code = (
        "import sys, gymnasium as gym, chaincart_env\n"
        "policy = chaincart_env.pretrained('inverted-2', 'ppo')\n"
        "env = gym.make('ChainCart-inverted-2-v0')\n"
        "obs, info = env.reset(seed=policy.record['success']['seeds'][0])\n"
        "done = False\n"
        "while not done:\n"
        "    action, _ = policy.predict(obs, deterministic=True)\n"
        "    obs, reward, terminated, truncated, info = env.step(action)\n"
        "    done = terminated or truncated\n"
        "print('success', info['is_success'], 'torch' in sys.modules)\n"
    )
    done = run(installed, tmp_path, "-c", code)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.split() == ["success", "True", "False"]


def test_classes_and_commands_that_need_no_extra(installed: Path, tmp_path: Path) -> None:
    code = (
        "import chaincart_env, gymnasium as gym\n"
        "try:\n"
        "    chaincart_env.ChainCartVecEnv\n"
        "except chaincart_env.MissingExtraError as e:\n"
        "    print('vecenv:', e)\n"
        "env = gym.make('ChainCart-v0', render_mode='human')\n"  # no matplotlib, no display: a warning
        "env.reset(seed=0); env.step(env.action_space.sample())\n"
        "print('human ok')\n"
    )
    done = run(installed, tmp_path, "-c", code)
    assert done.returncode == 0, done.stderr
    assert f"vecenv: ChainCartVecEnv needs stable-baselines3, {EXTRA_MESSAGE}sb3]'" in done.stdout
    assert "human ok" in done.stdout and "human-mode frames are not shown" in done.stderr
    demo = run(installed, tmp_path, "-m", "chaincart_env", "demo", "--steps", "5")
    assert demo.returncode == 0 and "scene inverted-2" in demo.stdout
    bad = run(installed, tmp_path, "-m", "chaincart_env", "soak", "--scene", "nope")
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and 'unknown scene "nope"' in bad.stderr


def test_a_source_checkout_without_the_native_module_gives_a_hint(tmp_path: Path) -> None:
    # A copy of the package beside a Cargo.toml, as in a fresh clone before building.
    checkout = tmp_path / "checkout"
    (checkout / "chaincart_env").mkdir(parents=True)
    (checkout / "Cargo.toml").write_text("[package]\nname = 'chaincart'\n")
    for source in (ROOT / "chaincart_env").glob("*.py"):
        (checkout / "chaincart_env" / source.name).write_text(source.read_text())
    done = subprocess.run([sys.executable, "-c", "import chaincart_env"], cwd=checkout, capture_output=True,
                          text=True, env=clean_environ())  # fmt: skip
    assert done.returncode == 1
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("ModuleNotFoundError: chaincart_env is imported from the source checkout")
    assert "maturin develop --release" in last


def test_an_install_whose_numpy_cannot_be_imported_says_so_without_a_panic(installed: Path, tmp_path: Path) -> None:
    # numpy, a required dependency, made unimportable (as a broken install leaves it).
    done = run(installed, tmp_path, "-c", "import sys; sys.modules['numpy'] = None; import chaincart_env")
    assert done.returncode == 1
    assert "panicked" not in done.stderr and "PanicException" not in done.stderr, done.stderr[-2000:]
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("ModuleNotFoundError: chaincart_env needs numpy, a required dependency"), last
    assert "pip install numpy" in last


NATIVE_WITHOUT_ITS_ERRORS = """
import importlib.machinery, importlib.util, pathlib, sys, types
(folder,) = importlib.util.find_spec("chaincart_env").submodule_search_locations
library = next(pathlib.Path(folder).glob("_core*.so"))
package = types.ModuleType("chaincart_env")  # the package's folder, its __init__ not run
package.__path__ = [folder]
sys.modules["chaincart_env"] = package
sys.modules["chaincart_env.errors"] = None  # the exceptions' module cannot be imported
loader = importlib.machinery.ExtensionFileLoader("chaincart_env._core", str(library))
importlib.util.module_from_spec(importlib.util.spec_from_file_location("chaincart_env._core", library, loader=loader))
"""


def test_the_native_module_whose_exceptions_cannot_be_imported_raises_that_import_error(
    installed: Path, tmp_path: Path
) -> None:
    # The native module's own initialisation, reached past the package's checks.
    done = run(installed, tmp_path, "-c", NATIVE_WITHOUT_ITS_ERRORS)
    assert done.returncode == 1
    assert "panicked" not in done.stderr and "PanicException" not in done.stderr, done.stderr[-2000:]
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("ModuleNotFoundError: import of chaincart_env.errors halted"), last
