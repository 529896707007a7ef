"""The command line as an installed package's user meets it: bad input is one line
and exit status 2, a missing optional dependency is one line naming the extra before
any work, and compare says what it trains when SB3 rounds to whole rollouts."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from chaincart_env.__main__ import main


@pytest.mark.parametrize(
    "argv, message",
    [
        (["demo", "--scene", "nope"], 'unknown scene "nope"'),
        (["demo", "--steps", "-3"], "--steps -3: expected an integer >= 0"),
        (["soak", "--scene", "nope", "--steps", "10"], 'unknown scene "nope"'),
        (["soak", "--num-envs", "-1"], "--num-envs -1: expected an integer >= 1"),
        (["soak", "--steps", "-5"], "--steps -5: expected an integer >= 1"),
        (["roa", "--scene", "nope", "--starts", "2"], 'unknown scene "nope"'),
        (["roa", "--start", "sideways", "--starts", "2"], "sideways"),
    ],
)
def test_bad_input_is_one_line_and_status_2(argv: list[str], message: str, capsys, tmp_path: Path) -> None:
    if argv[0] == "roa":
        argv = [*argv, "--out", str(tmp_path / "roa")]
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and message in err and err.startswith(f"python -m chaincart_env {argv[0]}: error:")
    assert "Traceback" not in err and out == ""
    assert not (tmp_path / "roa").exists()


def without(monkeypatch: pytest.MonkeyPatch, *modules: str) -> None:
    """Makes ``modules`` look not installed to the extras check."""
    real = importlib.util.find_spec
    monkeypatch.setattr(
        "chaincart_env.extras.importlib.util.find_spec", lambda name, *a: None if name in modules else real(name, *a)
    )


@pytest.mark.parametrize(
    "argv, missing, expected",
    [
        (["figures"], ("matplotlib",), "figures needs matplotlib, not installed: pip install 'chaincart-env[plot]'"),
        (["roa"], ("matplotlib",), "roa needs matplotlib"),
        (["compare"], ("stable_baselines3",), "compare needs stable-baselines3, not installed: "
                                              "pip install 'chaincart-env[sb3]'"),
        (["evaluate", "x"], ("stable_baselines3", "matplotlib"), "pip install 'chaincart-env[sb3,plot]'"),
        (["animate"], ("PIL",), "animate needs pillow, not installed: pip install 'chaincart-env[plot]'"),
        (["animate", "--out", "a.mp4"], ("imageio_ffmpeg",), "animate needs imageio-ffmpeg"),
        (["animate", "--policy", "runs/ppo.zip", "--out", "a.gif"], ("stable_baselines3",), "[sb3]"),
    ],
)  # fmt: skip
def test_a_missing_extra_is_named_before_any_work(argv, missing, expected, monkeypatch, capsys, tmp_path) -> None:
    without(monkeypatch, *missing)
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 1
    out, err = capsys.readouterr()
    assert expected in err and err.count("\n") == 1 and out == ""
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_built_in_animate_policies_need_no_sb3_and_a_saved_model_in_any_slot_does() -> None:
    from argparse import Namespace

    from chaincart_env.tools.animate import animate_needs

    built_in = ["random", "zero", "lqr", "trajectory", "mpc", "energy"]
    assert animate_needs(Namespace(out=None, policies=built_in)) == {"plot": ("PIL",)}
    mixed = Namespace(out=None, policies=["lqr", "runs/ppo"])
    assert animate_needs(mixed)["sb3"] == ("stable_baselines3",)
    mp4 = Namespace(out="a.mp4", policies=["lqr"])
    assert animate_needs(mp4) == {"plot": ("PIL", "imageio", "imageio_ffmpeg")}


def test_the_vecenv_class_names_its_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    import chaincart_env

    without(monkeypatch, "stable_baselines3")
    with pytest.raises(chaincart_env.MissingExtraError, match=r"pip install 'chaincart-env\[sb3\]'"):
        chaincart_env.ChainCartVecEnv  # noqa: B018


def test_compare_says_what_it_trains_when_sb3_rounds_up(capsys, tmp_path: Path) -> None:
    # 2 envs x 64-step rollouts: 100 timesteps asked become 2 rollouts = 128 steps.
    argv = ["compare", "--timesteps", "100", "--num-envs", "2", "--eval-episodes", "1", "--no-progress",
            "--set", "max_episode_steps=20", "--algo-kwarg", "n_steps=64", "--algo-kwarg", "batch_size=64",
            "--sweep", "start_noise=0.05", "--out", str(tmp_path)]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    said = "PPO trains in whole rollouts of n_steps x num_envs = 64 x 2 = 128 steps: 100 timesteps asked, 128 trained"
    assert said in out and out.index(said) < out.index("trained in")
    run = json.loads((tmp_path / "seed-0" / "run.json").read_text())
    assert run["timesteps"] == 100 and run["timesteps_trained"] == 128
    curve = (tmp_path / "seed-0" / "learning_curve.csv").read_text().splitlines()
    assert int(curve[-1].split(",")[0]) <= 128 and int(curve[-1].split(",")[0]) > 100


def test_steps_trained_for_on_and_off_policy_algorithms() -> None:
    from stable_baselines3 import PPO, TD3

    from chaincart_env import ChainCartVecEnv
    from chaincart_env.tools.compare.training import steps_trained

    venv = ChainCartVecEnv(3)
    assert steps_trained(PPO("MlpPolicy", venv, n_steps=10, batch_size=30, device="cpu"), 31)[0] == 60
    assert steps_trained(PPO("MlpPolicy", venv, n_steps=10, batch_size=30, device="cpu"), 30)[0] == 30
    td3 = TD3("MlpPolicy", venv, train_freq=2, device="cpu")
    planned, unit = steps_trained(td3, 13)
    assert planned == 18 and "train_freq x num_envs = 2 x 3 = 6 steps" in unit
