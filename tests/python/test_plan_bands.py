"""Success along the planner's plan: the bands of plan starts, an oracle (the LQR,
which catches the chain only near the top), and the study's table for agents of a
reverse curriculum."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from chaincart_env import ChainCartConfig
from chaincart_env.tools.compare.curriculum import PlanStarts, window_start
from chaincart_env.tools.compare.plan_bands import (
    BAND_COLUMNS,
    BANDS_FILE,
    BANDS_PAST_WINDOW,
    band_cells,
    band_indices,
    band_rows,
    bands_markdown,
    bands_to,
    evaluate_band_cell,
    widest_window,
)

SWINGUP = ChainCartConfig(scene="swingup-2", fall_limit=0.6)


def test_bands_cover_the_reach_in_steps_of_the_width() -> None:
    assert bands_to(0.1, 0.02) == [(0.0, 0.02), (0.02, 0.04), (0.04, 0.06), (0.06, 0.08), (0.08, 0.1)]
    assert bands_to(0.95, 0.3) == [(0.0, 0.3), (0.3, 0.6), (0.6, 0.9), (0.9, 1.0)]
    assert bands_to(2.0, 0.5) == [(0.0, 0.5), (0.5, 1.0)]  # never past the plan's start


def test_band_starts_lie_where_the_curriculum_windows_put_them() -> None:
    last = 150
    first = band_indices(last, (0.0, 0.1), 400, seed=1)
    # The first band is the curriculum's first window of 0.1: its start to the plan's end.
    assert first.min() >= window_start(last, 0.1) and first.max() == last
    later = band_indices(last, (0.1, 0.2), 400, seed=1)
    # A later band is what the widening from 0.1 to 0.2 added: not the first window's steps.
    assert later.min() == window_start(last, 0.2) and later.max() == window_start(last, 0.1) - 1
    assert np.array_equal(band_indices(last, (0.1, 0.2), 400, seed=1), later)  # seeded
    assert not np.array_equal(band_indices(last, (0.1, 0.2), 400, seed=2), later)


def test_the_widest_window_is_read_from_the_curriculum_log(tmp_path: Path) -> None:
    log = tmp_path / "curriculum.csv"
    curriculum = PlanStarts(1.0, reverse=True, window=0.02)
    assert widest_window(log, curriculum) == pytest.approx(0.02)  # no log: the first window
    log.write_text("env_steps,window\n0,0.02\n1514496,0.04\n1753856,0.06\n")
    assert widest_window(log, curriculum) == pytest.approx(0.06)


def test_the_lqr_catches_the_chain_from_the_plans_end_and_not_from_its_swing() -> None:
    from chaincart_env.tools.compare.policy_sources import PolicySource

    # The LQR at the upright target holds the chain from near the top; from the swing's
    # early part (60-70 % of the plan from its end) it cannot catch it.
    cells = band_cells(SWINGUP, {"LQR": (0.6, 0.1)}, eval_seed=1000, episodes=8)
    assert [cell.band for cell in cells] == bands_to(0.6 + BANDS_PAST_WINDOW * 0.1, 0.1)
    sources = {"LQR": PolicySource.lqr(SWINGUP)}
    rows = band_rows(cells, [evaluate_band_cell(sources, cell) for cell in cells])
    by_band = {(row["band_start"], row["band_end"]): row for row in rows}
    assert by_band[("0", "0.1")]["success_rate"] == 1.0 and by_band[("0", "0.1")]["held_rate"] == 1.0
    assert by_band[("0.6", "0.7")]["success_rate"] == 0.0 and by_band[("0.6", "0.7")]["held_rate"] == 0.0
    assert all(row["episodes"] == 8 for row in rows)
    assert band_rows(cells, [evaluate_band_cell(sources, cell) for cell in cells]) == rows  # seeded starts
    assert "| LQR | 0%-10% | 8 | 1.00 | 1.00 |" in bands_markdown(rows)
    # Without a fall limit there is no "held": the column stays empty.
    plain = ChainCartConfig(scene="swingup-2")
    cells = band_cells(plain, {"LQR": (0.1, 0.1)}, eval_seed=1000, episodes=2)[:1]
    (row,) = band_rows(cells, [evaluate_band_cell({"LQR": PolicySource.lqr(plain)}, cells[0])])
    assert row["held_rate"] == "" and row["success_rate"] == 1.0


def test_a_reverse_curriculum_study_reports_its_agents_success_along_the_plan(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from chaincart_env.__main__ import main

    tiny = ["--timesteps", "256", "--num-envs", "4", "--eval-episodes", "2", "--eval-starts", "2",
            "--eval-every", "128", "--checkpoint-every", "128", "--sweep", "start_noise=0.05", "--no-progress",
            "--algo-kwarg", "n_steps=32", "--algo-kwarg", "batch_size=64", "--fall-limit", "0.6",
            "--curriculum", "reverse", "--curriculum-window", "0.25", "--plan-fraction", "1", "--no-imitation",
            "--set", "max_episode_steps=60"]  # fmt: skip
    out = tmp_path / "run"
    assert main(["compare", "--scene", "swingup-2", "--policies", "ppo", *tiny, "--out", str(out)]) == 0
    assert f"{BANDS_FILE} and a folder per training run in" in capsys.readouterr().out
    with (out / BANDS_FILE).open(newline="") as file:
        rows = list(csv.DictReader(file))
    assert list(rows[0]) == list(BAND_COLUMNS)
    # The first window (0.25) and two bands past it, for the final and the kept best model.
    bands = [("0", "0.25"), ("0.25", "0.5"), ("0.5", "0.75")]
    for policy in ("PPO (seed 0)", "PPO best (seed 0)"):
        mine = [row for row in rows if row["policy"] == policy]
        assert [(row["band_start"], row["band_end"]) for row in mine] == bands
        assert all(row["episodes"] == "32" and 0.0 <= float(row["held_rate"]) <= 1.0 for row in mine)
    assert "## Along the plan" in (out / "report.md").read_text()
    assert json.loads((out / "seed-0" / "run.json").read_text())["curriculum"]["reverse"] is True
