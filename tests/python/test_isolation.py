"""The suite does not depend on what else runs on the machine, and one failing docs
example fails one test: with a foreign Ray cluster up (started with ``ray start``,
named by ``RAY_ADDRESS``), the examples and the commands that start their own local
Ray keep to it; an example that raises is reported as an ordinary failure and the
session goes on."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


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


@pytest.fixture(scope="module")
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


def run_pytest(*args: str, cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", *args],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=900,
    )  # fmt: skip


def summary_counts(output: str) -> dict[str, int]:
    """pytest's closing counts, e.g. {"failed": 1, "passed": 1}."""
    last = output.strip().splitlines()[-1]
    return {word: int(count) for count, word in re.findall(r"(\d+) (passed|failed|errors?|skipped)", last)}


PAGE = """# A page

```python
def connect():
    raise ValueError("the cluster said no")


connect()
print(1)
#> 1
```

```python
import io

buffer = io.StringIO()
print("into a file", file=buffer)
print(buffer.getvalue().strip())
#> into a file
```

```python
print(1 + 1)
#> 3
```
"""

RUNNER = """import sys
sys.path.insert(0, {here!r})
from pathlib import Path
import pytest
from docs_examples import examples_of, run_example
@pytest.mark.parametrize("example", examples_of(Path(__file__).parent / "page.md"), ids=str)
def test_block(example, eval_example):
    run_example(example, eval_example)
def test_after_the_examples():
    pass
"""


def test_a_failing_docs_example_is_an_ordinary_failure_and_the_session_goes_on(tmp_path: Path) -> None:
    (tmp_path / "page.md").write_text(PAGE)
    (tmp_path / "test_page.py").write_text(RUNNER.format(here=str(HERE)))
    done = run_pytest("test_page.py", cwd=tmp_path, env=dict(os.environ))
    out = done.stdout + done.stderr
    assert "INTERNALERROR" not in out, out[-3000:]
    assert done.returncode == 1, out[-3000:]
    assert summary_counts(done.stdout) == {"failed": 2, "passed": 2}, out[-3000:]
    # The error itself, and the page's lines that raised it.
    assert "ValueError: the cluster said no" in out
    assert f"{tmp_path / 'page.md'}:8: connect()" in out
    assert f"{tmp_path / 'page.md'}:5: raise ValueError(\"the cluster said no\")" in out
    # A print into a file reaches the file; a wrong documented output is still caught.
    assert "-#> 3\n" in out and "+#> 2\n" in out


def test_docs_examples_and_tests_start_their_own_ray_beside_a_running_cluster(
    foreign_ray_cluster: str, tmp_path: Path
) -> None:
    env = dict(os.environ, RAY_ADDRESS=foreign_ray_cluster)
    env.pop("PYTHONPATH", None)
    done = run_pytest(
        str(HERE / "test_docs.py"), "-k", "distributed",
        cwd=tmp_path, env=env,
    )  # fmt: skip
    assert done.returncode == 0, (done.stdout + done.stderr)[-4000:]
    assert summary_counts(done.stdout) == {"passed": 1}, done.stdout[-3000:]


def test_compares_local_ray_cluster_is_its_own_beside_a_running_cluster(
    foreign_ray_cluster: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    import ray

    from chaincart_env.tools.compare.cell_runner import ray_cluster

    monkeypatch.setenv("RAY_ADDRESS", foreign_ray_cluster)
    assert not ray.is_initialized()
    with ray_cluster(None, 1) as where:
        assert where.startswith("a local Ray cluster")
        assert ray.get_runtime_context().gcs_address != foreign_ray_cluster
        assert int(ray.cluster_resources()["CPU"]) == max(os.cpu_count() or 1, 1)
    assert not ray.is_initialized()
