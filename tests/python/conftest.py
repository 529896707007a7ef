"""Fixtures several test modules share."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def stop_group(process: subprocess.Popen[bytes], grace: float) -> None:
    """Ends ``process`` and everything it started (its own process group)."""
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=30)
    try:  # children that outlived their parent
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


@pytest.fixture(scope="session")
def foreign_ray_cluster() -> Iterator[str]:
    """A one-CPU Ray cluster of another user of the machine (``ray start --head``, in a
    temporary directory of its own): its address, as ``RAY_ADDRESS`` would name it."""
    temp_dir = Path(f"/tmp/cc-ray-{os.getpid()}")  # short: Ray's socket paths have a length limit
    temp_dir.mkdir()
    log = (temp_dir / "ray-start.log").open("wb")
    command = [
        sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--block", f"--port={free_port()}",
        f"--dashboard-agent-listen-port={free_port()}", "--num-cpus=1", "--include-dashboard=false",
        "--disable-usage-stats", f"--temp-dir={temp_dir}",
    ]  # fmt: skip
    process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        address_file = temp_dir / "ray_current_cluster"
        deadline = time.monotonic() + 120
        while not (address_file.is_file() and address_file.read_text().strip()):
            assert process.poll() is None, (temp_dir / "ray-start.log").read_text()[-3000:]
            assert time.monotonic() < deadline, "ray start did not come up in 120 s"
            time.sleep(0.2)
        yield address_file.read_text().strip()
    finally:
        stop_group(process, grace=5)  # its processes stop at once; only `ray start` itself drains
        log.close()
        subprocess.run(["rm", "-rf", str(temp_dir)], check=False)
