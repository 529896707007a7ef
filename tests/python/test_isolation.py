"""The suite does not depend on what else runs on the machine, and one failing docs
example fails one test: with a foreign Ray cluster up (``foreign_ray_cluster``, named
by ``RAY_ADDRESS``), the commands that start their own local Ray keep to it (the docs
examples that start Ray run beside it in test_docs.py); an example that raises is
reported as an ordinary failure and the session goes on."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


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
