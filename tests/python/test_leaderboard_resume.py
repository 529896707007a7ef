"""A leaderboard run that is interrupted picks up its finished cells, and the
model-based rows do not depend on the machine's load: two runs write the same cells and
scores (but for the measured compute time per step)."""

from __future__ import annotations

import csv
import math
import pathlib

import pytest

from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.leaderboard import contestants, run
from chaincart_env.tools.leaderboard.axes import parse_axes
from chaincart_env.tools.leaderboard.run import FULL_EPISODES, LeaderboardSettings, run_leaderboard

TIMING_COLUMNS = ("us_per_step",)
EVALUATE_CELL = run.evaluate_cell_job


class Interrupted(Exception):
    """The run stopped as a kill would stop it: between two cells."""


def _settings(**changes) -> LeaderboardSettings:
    base = dict(scenes=("inverted-1",), controllers=("lqr", "trajectory", "mpc"), axes=parse_axes("mismatch,delay"),
                quick=True, episodes=2)
    return LeaderboardSettings(**{**base, **changes})


def _table(path: pathlib.Path) -> list[dict[str, str]]:
    """A CSV file's rows without its timing columns, exactly as written."""
    with path.open(newline="") as file:
        return [{k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in csv.DictReader(file)]


class _CountingCells:
    """Counts evaluated cells and, past ``fail_after``, stops the run as a kill would."""

    def __init__(self, fail_after: float = math.inf) -> None:
        self.evaluated, self.fail_after = 0, fail_after

    def __call__(self, sources, job):
        if self.evaluated >= self.fail_after:
            raise Interrupted(f"stopped after {self.evaluated} cells")
        self.evaluated += 1
        return EVALUATE_CELL(sources, job)


def _fresh_process(monkeypatch: pytest.MonkeyPatch) -> None:
    """No controller built by an earlier run in this process (as in a new process)."""
    monkeypatch.setattr(contestants, "_DESIGNS", {})


def test_an_interrupted_run_resumes_from_its_finished_cells(tmp_path: pathlib.Path, monkeypatch) -> None:
    quiet = lambda _: None  # noqa: E731
    settings = _settings()
    _fresh_process(monkeypatch)
    whole = run_leaderboard(settings, tmp_path / "whole", log=quiet)
    cells = len(whole)
    assert cells == 3 * 2 * 2

    _fresh_process(monkeypatch)
    interrupted = _CountingCells(fail_after=5)
    monkeypatch.setattr(run, "evaluate_cell_job", interrupted)
    with pytest.raises(Interrupted):
        run_leaderboard(settings, tmp_path / "resumed", log=quiet)
    # The five finished cells are on disk, in the order they finished.
    assert len(_table(tmp_path / "resumed" / "cells.csv")) == 5

    _fresh_process(monkeypatch)
    resumed = _CountingCells()
    monkeypatch.setattr(run, "evaluate_cell_job", resumed)
    run_leaderboard(settings, tmp_path / "resumed", log=quiet)
    assert resumed.evaluated == cells - 5  # the finished ones were read back, not evaluated again
    for name in ("cells.csv", "scores.csv"):
        assert _table(tmp_path / "resumed" / name) == _table(tmp_path / "whole" / name), name

    # A complete run evaluates nothing when run again.
    again = _CountingCells()
    monkeypatch.setattr(run, "evaluate_cell_job", again)
    run_leaderboard(settings, tmp_path / "resumed", log=quiet)
    assert again.evaluated == 0


def test_other_settings_are_an_error_unless_fresh(tmp_path: pathlib.Path, monkeypatch, capsys) -> None:
    quiet = lambda _: None  # noqa: E731
    out = tmp_path / "run"
    run_leaderboard(_settings(controllers=("lqr",)), out, log=quiet)
    with pytest.raises(InvalidInputError, match=r"episodes_per_cell = 2 there, 3 now.*--fresh"):
        run_leaderboard(_settings(controllers=("lqr",), episodes=3), out, log=quiet)
    counting = _CountingCells()
    monkeypatch.setattr(run, "evaluate_cell_job", counting)
    rows = run_leaderboard(_settings(controllers=("lqr",), episodes=3), out, log=quiet, fresh=True)
    assert counting.evaluated == len(rows) == 4 and all(r["episodes"] == 3 for r in rows)
    # The command line says the same, and --fresh is its way out.
    argv = ["leaderboard", "--scenes", "inverted-1", "--policies", "lqr", "--quick", "--axes", "mismatch,delay",
            "--episodes", "2", "--out", str(out), "--no-progress"]  # fmt: skip
    with pytest.raises(SystemExit):
        main(argv)
    assert "episodes_per_cell = 3 there, 2 now" in capsys.readouterr().err
    assert main([*argv, "--fresh"]) == 0


def test_model_based_rows_repeat_bit_for_bit(tmp_path: pathlib.Path, monkeypatch) -> None:
    quiet = lambda _: None  # noqa: E731
    settings = _settings(controllers=("trajectory", "mpc"))
    for name in ("first", "second"):
        _fresh_process(monkeypatch)
        run_leaderboard(settings, tmp_path / name, log=quiet)
    for name in ("cells.csv", "scores.csv"):
        first, second = (tmp_path / d / name for d in ("first", "second"))
        assert _table(first) == _table(second), name
    # What makes them repeat: no wall-clock limit on the planner or on MPC's step.
    mpc = contestants.DesignSource.of("mpc", run.ChainCartConfig(scene="inverted-1")).build()
    assert mpc.mpc_options["budget"] == math.inf and mpc.plan_options["max_time"] == math.inf
    timed = contestants.DesignSource.of("mpc", run.ChainCartConfig(scene="inverted-1"), wall_clock=True).build()
    assert timed.mpc_options["budget"] == 0.002 and "max_time" not in timed.plan_options


def test_the_defaults_fit_a_published_leaderboard() -> None:
    settings = LeaderboardSettings(scenes=("inverted-1",), controllers=("lqr",))
    assert FULL_EPISODES >= 30 and settings.episodes_per_cell == FULL_EPISODES
    assert settings.wall_clock is False and settings.describe()["wall_clock_budgets"] is False


def test_a_run_on_a_ray_cluster_resumes_the_same_way(tmp_path: pathlib.Path, monkeypatch) -> None:
    quiet = lambda _: None  # noqa: E731
    settings = _settings(controllers=("lqr",))
    run_leaderboard(settings, tmp_path / "serial", log=quiet)
    interrupted = _CountingCells(fail_after=3)
    monkeypatch.setattr(run, "evaluate_cell_job", interrupted)
    with pytest.raises(Interrupted):
        run_leaderboard(settings, tmp_path / "spread", log=quiet)
    monkeypatch.setattr(run, "evaluate_cell_job", EVALUATE_CELL)
    rows = run_leaderboard(settings, tmp_path / "spread", log=quiet, address="local")
    assert len(rows) == 4
    assert _table(tmp_path / "spread" / "cells.csv") == _table(tmp_path / "serial" / "cells.csv")
    assert "cluster" in (tmp_path / "spread" / "leaderboard.json").read_text()


def test_a_fresh_run_interrupted_early_leaves_no_old_cells_to_resume(tmp_path: pathlib.Path, monkeypatch) -> None:
    quiet = lambda _: None  # noqa: E731
    out = tmp_path / "run"
    run_leaderboard(_settings(controllers=("lqr",)), out, log=quiet)

    def training_interrupted(*_):
        raise Interrupted("stopped while the agents train, before any cell")

    with monkeypatch.context() as patch:
        patch.setattr(run, "_train_agents", training_interrupted)
        with pytest.raises(Interrupted):
            run_leaderboard(_settings(controllers=("lqr",), episodes=3), out, log=quiet, fresh=True)
    counting = _CountingCells()
    monkeypatch.setattr(run, "evaluate_cell_job", counting)
    rows = run_leaderboard(_settings(controllers=("lqr",), episodes=3), out, log=quiet)
    assert counting.evaluated == 4 and all(r["episodes"] == 3 for r in rows)


def test_a_run_whose_cells_are_all_read_back_trains_no_agent(tmp_path: pathlib.Path, monkeypatch) -> None:
    # As from a published run's cells.csv and leaderboard.json, without its agents.
    import shutil

    settings = _settings(controllers=("ppo", "lqr"), axes=parse_axes("delay"))
    _fresh_process(monkeypatch)
    out = tmp_path / "run"
    whole = run_leaderboard(settings, out, log=lambda _: None)
    shutil.rmtree(out / "agents")
    lines: list[str] = []
    _fresh_process(monkeypatch)
    again = run_leaderboard(settings, out, log=lines.append)
    assert not [line for line in lines if "training" in line], lines
    assert not (out / "agents").exists()
    assert [{k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in again] == [
        {k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in whole]
    # A cell to evaluate again brings its agent's training back.
    rows = _table(out / "cells.csv")
    with (out / "cells.csv").open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]) + list(TIMING_COLUMNS))
        writer.writeheader()
        writer.writerows({**row, "us_per_step": "1.0"} for row in rows if row["controller"] != "ppo" or row["seed"] != "0"
                         or row["value"] != rows[-1]["value"])
    lines.clear()
    _fresh_process(monkeypatch)
    run_leaderboard(settings, out, log=lines.append)
    assert [line for line in lines if "training ppo" in line], lines
