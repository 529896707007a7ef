"""Shared pieces of the conformance tests: the generic tests Gymnasium and
stable-baselines3 run on their own envs, ported to chaincart's three env classes."""

from __future__ import annotations

import shutil
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest


@pytest.fixture
def headless(monkeypatch: pytest.MonkeyPatch) -> None:
    """A machine without a display (as CI without Xvfb), with the once-per-process
    headless warning re-armed."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    monkeypatch.setattr("chaincart_env.rendering.window._warned_headless", False)


def _free_display() -> int:
    for number in range(90, 200):
        if not Path(f"/tmp/.X11-unix/X{number}").exists() and not Path(f"/tmp/.X{number}-lock").exists():
            return number
    raise RuntimeError("no free X display number in :90..:199")


@pytest.fixture(scope="session")
def xvfb_display() -> Iterator[str]:
    """A virtual X display (Xvfb) for the real-window tests; scripts/setup.sh
    installs Xvfb on Debian machines, so a missing Xvfb is a failure, not a skip."""
    binary = shutil.which("Xvfb")
    assert binary is not None, "Xvfb is not installed: run scripts/setup.sh (or apt-get install xvfb)"
    number = _free_display()
    process = subprocess.Popen(
        [binary, f":{number}", "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        socket = Path(f"/tmp/.X11-unix/X{number}")
        deadline = time.monotonic() + 20
        while not socket.exists():
            assert process.poll() is None, f"Xvfb :{number} exited with {process.returncode}"
            assert time.monotonic() < deadline, f"Xvfb :{number} did not start in 20 s"
            time.sleep(0.05)
        yield f":{number}"
    finally:
        process.terminate()
        process.wait(timeout=10)


@pytest.fixture
def on_xvfb(xvfb_display: str, monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """DISPLAY set to the Xvfb display for one test; matplotlib's backend restored after."""
    import matplotlib
    import matplotlib.pyplot as plt

    backend = matplotlib.get_backend()
    monkeypatch.setenv("DISPLAY", xvfb_display)
    monkeypatch.delenv("SDL_VIDEODRIVER", raising=False)
    try:
        yield xvfb_display
    finally:
        plt.close("all")
        plt.switch_backend(backend)
