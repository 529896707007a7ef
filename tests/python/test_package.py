"""Packaging: the native stub is honest, the public API is what __all__ says, the
command line runs."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import chaincart_env
from chaincart_env import _core

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_stub_matches_the_native_module() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "--mypy-config-file", str(ROOT / "tests/python/stubtest.ini"),
         "chaincart_env._core"],
        capture_output=True, text=True, cwd=ROOT,
    )  # fmt: skip
    assert out.returncode == 0, out.stdout + out.stderr


def test_every_public_native_name_is_documented_in_the_stub() -> None:
    stub = (pathlib.Path(chaincart_env.__file__).parent / "_core.pyi").read_text()
    for name in _core.__all__:
        assert name in stub, name
    for cls in (_core.ChainCart, _core.EnvBatch):
        for name in dir(cls):
            if not name.startswith("_"):
                assert f"def {name}(" in stub, f"{cls.__name__}.{name}"
    assert (pathlib.Path(chaincart_env.__file__).parent / "py.typed").exists()


def test_all_is_explicit_and_importable() -> None:
    for name in chaincart_env.__all__:
        assert getattr(chaincart_env, name) is not None, name
    assert issubclass(chaincart_env.InvalidInputError, chaincart_env.ChainCartError)
    assert issubclass(chaincart_env.InvalidInputError, ValueError)
    assert chaincart_env.ChainCartError is _core.ChainCartError


def test_demo_command_runs_the_default_scene() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "chaincart_env", "demo", "--seed", "1"], capture_output=True, text=True, cwd=ROOT
    )
    assert out.returncode == 0, out.stderr
    assert "scene inverted-2" in out.stdout and "success True" in out.stdout


def test_bench_command_prints_markdown_tables() -> None:
    out = subprocess.run(
        # The throughput section only: the other sections have their own tests in test_bench.py.
        [sys.executable, "-m", "chaincart_env", "bench", "--quick", "--sections", "throughput", "--sizes", "1,16",
         "--links", "1"],
        capture_output=True, text=True, cwd=ROOT,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    for heading in ("## Single env", "## Raw model step", "## Vector envs", "## Python-side overhead"):
        assert heading in out.stdout
    assert "| CartPole-v1 (gym.make) |" in out.stdout and "| 16 |" in out.stdout
