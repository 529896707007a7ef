"""The LQR baseline's region of attraction (``chaincart_env.roa``, ``python -m chaincart_env roa``): the
success curve on the default scene, its statistics and its outputs."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy.stats import binomtest

from chaincart_env import ChainCartEnv, LQRPolicy
from chaincart_env.__main__ import main
from chaincart_env.config import ChainCartConfig
from chaincart_env.roa import region_of_attraction, success_fractions, wilson_interval


def test_success_falls_with_the_perturbation_on_the_default_scene() -> None:
    # Measured with 200 starts: 1.0 up to noise 0.1, 0.70 at 0.3, 0.16 at 0.8 (every
    # failure leaves the track: 20 N cannot catch the chain in 2.4 m).
    points = region_of_attraction(sizes=[0.01, 0.3, 0.8], starts=32, seed=5)
    success = [p.success for p in points]
    assert success[0] == 1.0
    assert success[2] < 0.5
    assert success[0] >= success[1] >= success[2]
    for p in points:
        assert p.scene == "inverted-2" and p.starts == 32
        assert p.success + p.out_of_track + p.numerical_failure + p.unsettled == pytest.approx(1.0)
        assert p.ci_low <= p.success <= p.ci_high


def test_a_point_counts_the_envs_own_success_flag() -> None:
    # Start i of a point is the single env reset with seed + i; its is_success decides.
    config = ChainCartConfig(start_noise=0.3)
    point = success_fractions(config, starts=6, seed=11)
    wins = 0
    for i in range(6):
        env = ChainCartEnv(config)
        policy = LQRPolicy.from_env(env)
        obs, _ = env.reset(seed=11 + i)
        terminated = truncated = False
        while not (terminated or truncated):
            obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        wins += info["is_success"]
    assert point.success == wins / 6


@pytest.mark.parametrize("successes, trials", [(0, 10), (3, 10), (10, 10), (57, 200), (1, 1)])
def test_wilson_interval_matches_scipy(successes: int, trials: int) -> None:
    ci = binomtest(successes, trials).proportion_ci(confidence_level=0.95, method="wilson")
    assert wilson_interval(successes, trials) == pytest.approx((ci.low, ci.high), abs=1e-12)


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(ValueError, match="starts = 0: expected an integer >= 1"):
        success_fractions(ChainCartConfig(), starts=0)
    with pytest.raises(ValueError, match="start noise -0.1: expected a finite number >= 0"):
        region_of_attraction(sizes=[0.1, -0.1], starts=2)
    with pytest.raises(ValueError, match="sizes is empty"):
        region_of_attraction(sizes=[], starts=2)
    with pytest.raises(SystemExit):
        main(["roa", "--sizes", "0.1,abc"])


def test_roa_command_writes_table_csv_and_png(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["roa", "--sizes", "0.01,0.8", "--starts", "16", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "| start noise | starts | stabilised |" in out
    assert "| 0.01 | 16 | 1.000 |" in out
    with open(tmp_path / "roa_inverted-2.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["start_noise"]) for r in rows] == [0.01, 0.8]
    assert float(rows[0]["success"]) == 1.0 > float(rows[1]["success"])
    assert all(int(r["starts"]) == 16 and r["scene"] == "inverted-2" for r in rows)
    with Image.open(tmp_path / "roa_inverted-2.png") as image:
        image.load()
        assert image.format == "PNG" and np.asarray(image).std() > 0


def test_the_package_root_exports_the_librarys_curve() -> None:
    import chaincart_env
    import chaincart_env.roa

    assert chaincart_env.region_of_attraction is chaincart_env.roa.region_of_attraction
