"""The benchmark suite: the MuJoCo model against chaincart and the NumPy oracle, the
slope fit, the Pareto front, the Markdown helpers, and a tiny `bench --quick` run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import mujoco  # the `mujoco` extra is installed by scripts/setup.sh: these tests must run, not skip
import numpy as np
import pytest
from paper_dense import elwm_derivative, link_accelerations

from chaincart_env import ChainCart
from chaincart_env.tools.bench.accuracy import pareto_front
from chaincart_env.tools.bench.bench_report import markdown_table
from chaincart_env.tools.bench.fig1 import AccuracyPoint, mass_positions
from chaincart_env.tools.bench.mujoco_chain import (
    build_mjcf,
    chain_point_accelerations,
    mujoco_accelerations,
    mujoco_to_state,
    random_spatial_state,
    state_to_mujoco,
)
from chaincart_env.tools.bench.scaling import fit_loglog_slope, parse_scaling_output
from chaincart_env.tools.bench.suite import parse_sections

ROOT = Path(__file__).resolve().parents[2]
#: Measured: MuJoCo's accelerations match ours to ~1e-11 relative (1e-14 kg m^2 link
#: inertia, round-off of its recursive algorithm); 1e-8 leaves room for other systems.
RELATIVE_BOUND = 1e-8

SYSTEMS = [
    ("paper", 0.5, [0.1] * 5, [0.1] * 5),
    ("uneven", 1.3, [0.2, 0.05, 0.4], [0.3, 0.1, 0.25]),
    ("single", 0.7, [0.3], [0.6]),
]


def _model_pair(cart: float, masses: list[float], lengths: list[float]) -> tuple[ChainCart, object]:
    chain = ChainCart(len(masses), cart_mass=cart, link_masses=masses, link_lengths=lengths)
    return chain, mujoco.MjModel.from_xml_string(build_mjcf(cart, masses, lengths))


def _stacked(xdd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    return np.concatenate([xdd, np.asarray(qdd).reshape(-1)])


@pytest.mark.parametrize("name, cart, masses, lengths", SYSTEMS)
def test_mujoco_accelerations_match_chaincart_and_numpy_oracle(name, cart, masses, lengths) -> None:
    chain, mj_model = _model_pair(cart, masses, lengths)
    data = mujoco.MjData(mj_model)
    rng = np.random.default_rng(7)
    n = len(masses)
    for _ in range(25):
        state = random_spatial_state(n, rng)
        force = rng.normal(scale=2.0, size=2)
        theirs = mujoco_accelerations(mj_model, data, n, state, force)
        ours = _stacked(*chain_point_accelerations(chain.derivative(state, force), state, n))
        dense = elwm_derivative(cart, masses, lengths, 9.81, state, force)
        oracle = _stacked(dense[2:4], link_accelerations(state, dense, n))
        scale = np.linalg.norm(oracle)
        assert np.linalg.norm(theirs - oracle) <= RELATIVE_BOUND * scale, (name, theirs, oracle)
        assert np.linalg.norm(ours - oracle) <= 1e-11 * scale


def test_state_maps_round_trip_and_mujoco_follows_our_motion() -> None:
    """ours -> MuJoCo -> ours is the identity, and 0.2 s of MuJoCo RK4 at 1e-4 s lands
    where chaincart's rk4 does (both far more accurate than the tolerance)."""
    chain, _ = _model_pair(0.5, [0.1] * 3, [0.1] * 3)
    state = random_spatial_state(3, np.random.default_rng(3))
    qpos, qvel = state_to_mujoco(3, state)
    np.testing.assert_allclose(mujoco_to_state(3, qpos, qvel), state, atol=1e-12)

    mj_model = mujoco.MjModel.from_xml_string(build_mjcf(0.5, [0.1] * 3, [0.1] * 3, timestep=1e-4, integrator="rk4"))
    data = mujoco.MjData(mj_model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    for _ in range(2000):
        mujoco.mj_step(mj_model, data)
    theirs = mujoco_to_state(3, data.qpos, data.qvel)
    ours = chain.simulate(state, np.zeros((2000, 2)), 1e-4)[-1]
    lengths = np.full(3, 0.1)
    moved = np.abs(mass_positions(ours, lengths) - mass_positions(state, lengths)).max()
    assert moved > 1e-2  # the test compares motion, not two resting chains
    np.testing.assert_allclose(mass_positions(theirs, lengths), mass_positions(ours, lengths), atol=1e-6)


@pytest.mark.parametrize("slope", [1.0, 3.0, 0.5])
def test_loglog_fit_recovers_the_slope_of_a_power_law(slope: float) -> None:
    ns = [8, 16, 32, 64, 128, 256]
    rng = np.random.default_rng(0)
    times = [2e-8 * n**slope * np.exp(rng.normal(scale=0.02)) for n in ns]  # 2% timing noise
    fitted, prefactor = fit_loglog_slope(ns, times)
    assert fitted == pytest.approx(slope, abs=0.03)
    assert prefactor == pytest.approx(2e-8, rel=0.15)


def test_loglog_fit_rejects_degenerate_input() -> None:
    with pytest.raises(ValueError, match="two distinct n"):
        fit_loglog_slope([4, 4], [1e-6, 2e-6])
    with pytest.raises(ValueError, match="positive finite"):
        fit_loglog_slope([1, 2], [1e-6, 0.0])


def test_scaling_output_parses_and_ignores_other_lines() -> None:
    text = "Compiling chaincart\nfast 1 1.5e-8\ndense 1 2.0e-7\nfast 2 3.0e-8\nfast_rk4_step 2 9e-8\njunk 3\n"
    assert parse_scaling_output(text) == {"fast": {1: 1.5e-8, 2: 3.0e-8}, "dense": {1: 2.0e-7}, "fast_rk4_step": {2: 9e-8}}


def test_pareto_front_keeps_only_undominated_points() -> None:
    def point(name: str, error: float | None, wall: float | None) -> AccuracyPoint:
        return AccuracyPoint("chaincart", name, 1e-3, error, 0.0, wall)

    points = [point("a", 1e-3, 1.0), point("b", 1e-5, 2.0), point("c", 1e-4, 3.0), point("d", None, None)]
    assert [p.integrator for p in pareto_front(points)] == ["a", "b"]


def test_mass_positions_chain_the_links_from_the_cart() -> None:
    state = np.zeros(4 + 12)
    state[:2] = [1.0, 2.0]
    state[4:10] = [0, 0, 1, 1, 0, 0]  # link 1 hangs, link 2 points along e1
    np.testing.assert_allclose(mass_positions(state, np.array([0.5, 0.25])), [[1, 2, 0.5], [1.25, 2, 0.5]])


def test_markdown_table_and_section_names_are_checked() -> None:
    assert markdown_table(["a", "b"], [["x", "1"]]) == ["| a | b |", "|---|---:|", "| x | 1 |"]
    with pytest.raises(ValueError, match="2 cells"):
        markdown_table(["a", "b"], [["x"]])
    assert parse_sections("scaling,throughput") == ["throughput", "scaling"]
    with pytest.raises(ValueError, match="nosuch"):
        parse_sections("nosuch")


def test_bench_quick_prints_tables_and_writes_plots(tmp_path: Path) -> None:
    markdown = tmp_path / "bench.md"
    out = subprocess.run(
        [sys.executable, "-m", "chaincart_env", "bench", "--quick", "--sections", "accuracy,targets",
         "--out", str(tmp_path), "--markdown", str(markdown)],
        capture_output=True, text=True, cwd=ROOT, timeout=120,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    for heading in ("## Speed vs accuracy", "## Speed targets"):
        assert heading in out.stdout
    assert "| chaincart | rk4 | 0.001 |" in out.stdout and "| mujoco | rk4 | 0.001 |" in out.stdout
    assert (tmp_path / "speed_accuracy.png").stat().st_size > 10_000
    section = markdown.read_text()
    assert section.startswith("# Performance\n") and "\n## Speed vs accuracy" in section
    assert "| chaincart | rk4 | 0.001 |" in section
    assert "| f64 | 0.001 |" in section and "| f32 | 0.001 |" in section


def test_speed_targets_judge_the_lane_and_vector_goals_from_the_measured_rates() -> None:
    from types import SimpleNamespace

    from chaincart_env.tools.bench.targets import _lane_targets, _vector_speed_targets

    per_step = {"batch_kernel/avx2/4096": 4096 / 15e6, "batch_kernel/avx512/4096": 4096 / 25e6,
                "batch_kernel/f32/4096": 4096 / 30e6, "batch_kernel/avx512/1": 1e-9}  # fmt: skip
    rows = _lane_targets({k: {"median": t} for k, t in per_step.items()})
    # The widest kernel's rate counts (not the N = 1 row); f64 met, f32 short of 35 M.
    assert [r[2:] for r in rows] == [["25.00 M", "met"], ["30.00 M", "NOT met"]]
    assert [r[3] for r in _lane_targets({})] == ["not measured", "not measured"]
    results = {
        "vector": {"chaincart": {(5, 4096): {"vector": 7.5e6}, (1, 4096): {"vector": 9e6}}},
        "planar_link": {"cartpole": 20e6, "f64": {"vector": 18e6}, "f32": {"vector": 21e6}},
    }
    rows = _vector_speed_targets(SimpleNamespace(results=results))  # type: ignore[arg-type]
    assert [r[3] for r in rows] == ["NOT met", "NOT met", "met"]
    assert rows[2][2] == "21.00 M vs 20.00 M"
    assert [r[3] for r in _vector_speed_targets(SimpleNamespace(results={}))] == ["not measured"] * 3  # type: ignore[arg-type]


def test_the_lane_trajectories_follow_the_model_in_f64_and_stay_within_the_bound_in_f32() -> None:
    from chaincart_env.tools.bench import fig1
    from chaincart_env.tools.bench.precision import lane_trajectory

    model = fig1.paper_model()
    lengths = np.array(model.link_lengths)
    exact, _ = fig1.run_chaincart(model, "rk4", 1e-3, 0.5)
    f64, samples = lane_trajectory("f64", 1e-3, 0.5, 100)
    f32, _ = lane_trajectory("f32", 1e-3, 0.5, 100)
    assert np.array_equal(f64, exact)  # the lanes compute what the model's rk4 computes
    assert len(samples) == 6 and np.array_equal(samples[0], fig1.fig1_state())
    # f32 round-off, far below the published 1e-3 m after 1 s.
    assert 0 < fig1.position_error(f32, fig1.mass_positions(exact, lengths), lengths) < 1e-4


def test_bench_rejects_unknown_sections() -> None:
    out = subprocess.run([sys.executable, "-m", "chaincart_env", "bench", "--sections", "warp"],
                         capture_output=True, text=True, cwd=ROOT)  # fmt: skip
    assert out.returncode == 2 and "warp" in out.stderr


def test_mujoco_reset_of_an_unstable_run_is_reported_as_divergence(tmp_path: Path, monkeypatch) -> None:
    """MuJoCo's Euler at 5 ms blows up on the Fig. 1 start at 9.95 s and MuJoCo silently
    resets the state (measured); the benchmark must report it (not measure drift on the reset run)
    and must not leave MUJOCO_LOG.TXT behind."""
    from chaincart_env.tools.bench.mujoco_compare import MujocoDiverged, run_mujoco

    monkeypatch.chdir(tmp_path)
    with pytest.raises(MujocoDiverged, match="diverged at t = "):
        run_mujoco(ChainCart(5), "euler", 5e-3, 10.0)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    final, _ = run_mujoco(ChainCart(5), "rk4", 1e-3, 0.1)  # a stable run raises nothing
    assert np.all(np.isfinite(final))


def test_cells_section_times_serial_and_distributed_cells() -> None:
    from chaincart_env.tools.bench.bench_report import Report
    from chaincart_env.tools.bench.study_cells import cells_section
    from chaincart_env.tools.bench.suite import BenchContext, BenchSettings

    ctx = BenchContext(BenchSettings(quick=True), Report(echo=False))
    cells_section(ctx)  # on a local Ray cluster of its own
    timing = ctx.results["cells"]
    assert timing["serial_s"] > 0 and timing["distributed_s"] > 0 and timing["cold_s"] > 0
    assert "| as Ray tasks" in ctx.report.text()


def test_render_section_reports_every_view_with_the_3d_goal() -> None:
    from chaincart_env.tools.bench.bench_report import Report
    from chaincart_env.tools.bench.render_fps import CASES, GOAL_3D_FPS, render_section
    from chaincart_env.tools.bench.suite import BenchContext, BenchSettings

    ctx = BenchContext(BenchSettings(quick=True), Report(echo=False))
    render_section(ctx)  # quick: about 0.02 s per measurement
    fps = ctx.results["render_fps"]
    assert set(fps) == set(CASES) and ("3d", 480, 480) in fps and all(r > 0 for r in fps.values())
    text = ctx.report.text()
    assert "## Render frames per second" in text
    for view, width, height in CASES:
        assert f"| {view} | {width}x{height} | " in text
    verdict = "met" if fps[("3d", 480, 480)] >= GOAL_3D_FPS else "NOT met"
    assert f"| 3d | 480x480 | {fps[('3d', 480, 480)]:.0f} | " in text and f">= {GOAL_3D_FPS}: {verdict} |" in text
    for scene in ("inverted-2", "paper-fig3"):  # the env-level rows
        assert f"| {scene} | env | 480x240 |" in text and f"| {scene} | vector, 4 tiles | 960x480 |" in text


def test_learners_section_times_each_installed_learner_and_names_the_missing(monkeypatch, tmp_path) -> None:
    import tempfile

    from chaincart_env.tools.bench import learners
    from chaincart_env.tools.bench.bench_report import Report
    from chaincart_env.tools.bench.suite import BenchContext, BenchSettings

    ppo = next(learner for learner in learners.LEARNERS if learner.label == "SB3 PPO")
    sac = next(learner for learner in learners.LEARNERS if learner.label == "SB3 SAC" and learner.n_envs == 64)
    absent = learners.Learner("Nowhere PPO", "no_such_learner_library", "PPO", 1, {}, 1.0)
    small_ppo = learners.Learner(ppo.label, ppo.module, ppo.cls, 4, {**ppo.keywords, "n_steps": 16, "batch_size": 32},
                                 ppo.gradient_steps_per_env_step)
    monkeypatch.setattr(learners, "LEARNERS", (small_ppo, sac, absent))
    ticks = iter(range(100))
    real = learners.measure_learner
    # A clock of whole seconds: a timed learn of N env steps takes 1 s, so the rate is N.
    monkeypatch.setattr(learners, "measure_learner", lambda learner, steps, repeats: real(
        learner, steps, repeats, clock=lambda: float(next(ticks))))
    ctx = BenchContext(BenchSettings(quick=True), Report(echo=False))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    learners.learners_section(ctx)
    rates = ctx.results["learners"]
    assert rates == {("SB3 PPO", 4): 16 * 4, ("SB3 SAC", 64): 256 * 8}  # one rollout; 256 x n_envs / 8 steps
    text = ctx.report.text()
    assert "| SB3 SAC | 64 | 0.01562 |" in text
    assert "Not installed, not measured: Nowhere PPO" in text
    assert sac.gradient_steps_per_env_step == 1 / 64 and ppo.gradient_steps_per_env_step == 10 / 512
    assert not list(tmp_path.glob("SB3-*"))  # no log folder of SB3's in the temporary directory
