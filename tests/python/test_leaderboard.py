"""The robustness leaderboard: a tiny run writes every file, its numbers are the cells',
and every option is checked."""

from __future__ import annotations

import csv
import pathlib

import numpy as np
import pytest

from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.controllers import parse_controllers
from chaincart_env.tools.leaderboard.axes import AXIS_NAMES, parse_axes
from chaincart_env.tools.leaderboard.leaderboard_report import axis_scores, score_rows


def _read(path: pathlib.Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


def test_a_tiny_leaderboard_writes_every_file_and_scores_its_cells(tmp_path: pathlib.Path) -> None:
    out, report = tmp_path / "run", tmp_path / "docs" / "board.md"
    argv = ["leaderboard", "--scenes", "inverted-1", "--policies", "lqr,ppo", "--quick", "--axes", "mismatch,delay",
            "--episodes", "2", "--out", str(out), "--report", str(report), "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    for name in ("cells.csv", "scores.csv", "leaderboard.json"):
        assert (out / name).is_file(), name
    assert (out / "agents" / "inverted-1" / "ppo" / "seed-0" / "model.zip").is_file()
    figures = report.parent / "board-figures"
    assert (figures / "inverted-1.png").stat().st_size > 10_000 and (figures / "profiles.png").is_file()
    cells = _read(out / "cells.csv")
    # Two controllers x two axes x two quick values x one seed.
    assert len(cells) == 8 and {c["axis"] for c in cells} == {"mismatch", "delay"}
    assert all(int(c["episodes"]) == 2 and 0 <= float(c["success_rate"]) <= 1 for c in cells)
    # The robustness score is the mean over axes of each axis's success fraction.
    scores = {s["controller"]: s for s in _read(out / "scores.csv")}
    for controller in ("lqr", "ppo"):
        mine = [c for c in cells if c["controller"] == controller]
        per_axis = [
            sum(int(c["successes"]) for c in mine if c["axis"] == a) / sum(int(c["episodes"]) for c in mine if c["axis"] == a)
            for a in ("mismatch", "delay")
        ]
        assert float(scores[controller]["robustness"]) == pytest.approx(sum(per_axis) / 2)
    text = report.read_text()
    assert "## inverted-1" in text and "](board-figures/inverted-1.png)" in text and "1 seed: no interval" in text
    # Running again reuses the trained agent (same numbers: same starts, same agent).
    stamp = (out / "agents" / "inverted-1" / "ppo" / "seed-0" / "model.zip").stat().st_mtime_ns
    assert main(argv) == 0
    assert (out / "agents" / "inverted-1" / "ppo" / "seed-0" / "model.zip").stat().st_mtime_ns == stamp
    assert _read(out / "cells.csv") == [{**c, "us_per_step": _read(out / "cells.csv")[i]["us_per_step"]}
                                         for i, c in enumerate(cells)]


def test_scores_follow_their_definitions_on_made_up_cells() -> None:
    def cell(controller: str, axis: str, value: float, seed: int, wins: int) -> dict:
        return dict(scene="s", controller=controller, axis=axis, value=value, seed=seed, episodes=4, successes=wins,
                    success_rate=wins / 4, peak_force_mean=2.0, rms_force_mean=1.0, us_per_step=10.0)

    rows = [cell("a", "mismatch", v, s, w) for v, s, w in [(0, 0, 4), (0.4, 0, 0), (0, 1, 4), (0.4, 1, 2)]]
    rows += [cell("a", "delay", v, s, 4) for v in (0, 2) for s in (0, 1)]
    # mismatch: 10 of 16 episodes; delay: 16 of 16.
    assert axis_scores(rows) == {"mismatch": 10 / 16, "delay": 1.0}
    (score,) = score_rows(rows)
    assert score["robustness"] == pytest.approx((10 / 16 + 1) / 2)
    # Scores of all cells and seeds: 1, 0, 1, .5, 1, 1, 1, 1 -> middle half 1, 1, 1, 1.
    assert score["iqm"] == pytest.approx(1.0) and score["iqm_low"] <= score["iqm"] <= score["iqm_high"]


def test_options_are_checked_with_the_value_and_what_was_expected(tmp_path: pathlib.Path, capsys) -> None:
    with pytest.raises(InvalidInputError, match="'lqr,dqn'.*expected distinct names among"):
        parse_controllers("lqr,dqn")
    with pytest.raises(InvalidInputError, match="distinct"):
        parse_controllers("lqr,lqr")
    with pytest.raises(InvalidInputError, match="'speed'.*expected names among"):
        parse_axes("speed")
    assert [a.name for a in parse_axes(None)] == list(AXIS_NAMES)
    for bad, message in [
        (["--scenes", "nowhere"], "expected scene names among"),
        (["--scenes", "inverted-1", "--seeds", "0,0"], "seeds = (0, 0): expected distinct integers"),
        (["--scenes", "inverted-1", "--episodes", "0"], "episodes = 0: expected an integer >= 1"),
        (["--scenes", "inverted-1", "--timesteps", "-5"], "timesteps = -5: expected an integer >= 1"),
        (["--scenes", "inverted-1", "--torch-threads", "0"], "torch-threads = '0': expected an integer >= 1"),
    ]:
        with pytest.raises(SystemExit):
            main(["leaderboard", "--policies", "lqr", "--out", str(tmp_path / "x"), *bad])
        assert message in capsys.readouterr().err, bad


def test_a_cluster_needs_ray_and_learned_controllers_need_sb3() -> None:
    from argparse import Namespace

    from chaincart_env.tools.leaderboard.leaderboard_cli import leaderboard_needs

    assert set(leaderboard_needs(Namespace(policies="lqr,mpc", address=None))) == {"plot"}
    assert set(leaderboard_needs(Namespace(policies="lqr,SAC", address=None))) == {"plot", "sb3"}
    assert leaderboard_needs(Namespace(policies="lqr", address="local"))["rllib"] == ("ray",)


def test_friction_and_damping_axes_change_the_true_system_not_the_design() -> None:
    from chaincart_env import ChainCartConfig, ChainCartEnv
    from chaincart_env.policies import LQRPolicy
    from chaincart_env.tools.leaderboard.contestants import DesignSource, fixed_source

    config = ChainCartConfig(scene="inverted-1")
    source = fixed_source("lqr", config)  # what every cell of the scene runs
    assert source == DesignSource.of("lqr", config)
    scene_gain = LQRPolicy.from_env(ChainCartEnv(config)).gain
    for name, value in (("joint_damping", 0.02), ("cart_friction", 0.5)):
        (axis,) = parse_axes(name)
        variant = axis.apply(config, value)
        assert axis.apply(config, 0.0) == config and variant.has_rig_effects and not config.has_rig_effects
        np.testing.assert_array_equal(source.load().gain, scene_gain)
        cell_gain = LQRPolicy.from_env(ChainCartEnv(variant)).gain
        if name == "joint_damping":
            # Designed on the cell's system the gain would differ: the axis is unmodelled.
            assert np.max(np.abs(cell_gain - scene_gain)) > 1e-3
        else:
            # The axis's friction is Coulomb's, which an LQR design leaves out anyway.
            np.testing.assert_allclose(cell_gain, scene_gain, rtol=1e-12, atol=1e-12)
    (damping,) = parse_axes("joint_damping")
    assert damping.apply(ChainCartConfig(joint_damping=[0.01, 0.02]), 0.01).joint_damping == (0.02, 0.03)
    (friction,) = parse_axes("cart_friction")
    servo = ChainCartConfig(actuation="acceleration")
    assert friction.apply(servo, 0.5) == servo  # a servo axis absorbs cart friction


def test_a_quick_leaderboard_has_the_friction_and_damping_axes(tmp_path: pathlib.Path) -> None:
    out, report = tmp_path / "run", tmp_path / "board.md"
    argv = ["leaderboard", "--scenes", "inverted-1", "--policies", "lqr", "--quick", "--axes", "joint_damping,cart_friction",
            "--episodes", "2", "--out", str(out), "--report", str(report), "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    cells = _read(out / "cells.csv")
    assert [(c["axis"], float(c["value"])) for c in cells] == [
        ("joint_damping", 0.0), ("joint_damping", 0.02), ("cart_friction", 0.0), ("cart_friction", 0.5)]
    header = next(line for line in report.read_text().splitlines() if line.startswith("| controller | robustness"))
    assert "| joint_damping | cart_friction |" in header
