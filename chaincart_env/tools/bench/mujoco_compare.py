"""MuJoCo section: the paper's 5-link chain in MuJoCo (``mujoco_chain.build_mjcf``),
verified against chaincart's accelerations, then cost and accuracy at equal step sizes
for MuJoCo's RK4, Euler and implicitfast next to every chaincart integrator, and
batched throughput (``mujoco.rollout`` on all cores vs chaincart's native batch).

Skipped with a note (not an error) when the ``mujoco`` extra is not installed.
"""

from __future__ import annotations

import contextlib
import os
from typing import Any, Iterator, Optional

import numpy as np

from chaincart_env import _core
from chaincart_env.config import ChainCartConfig
from chaincart_env.model import ChainCart
from chaincart_env.tools.bench import fig1
from chaincart_env.tools.bench.bench_report import fmt_rate, fmt_ratio, fmt_sci
from chaincart_env.tools.bench.context import BenchContext, mujoco_available
from chaincart_env.tools.bench.fig1 import AccuracyPoint
from chaincart_env.tools.bench.mujoco_chain import (
    MUJOCO_INTEGRATORS,
    acceleration_mismatch,
    build_mjcf,
    mujoco_to_state,
    random_spatial_state,
    state_to_mujoco,
)
from chaincart_env.tools.bench.timing import rate

__all__ = ["mujoco_section", "fig1_point", "mujoco_model", "MISSING_NOTE"]

MISSING_NOTE = (
    "MuJoCo is not installed (`pip install 'chaincart-env[mujoco]'`): MuJoCo comparisons skipped."
)
CHAINCART_INTEGRATORS = tuple(_core.INTEGRATORS)


def mujoco_model(chain: ChainCart, dt: float, integrator: str) -> Any:
    """A MuJoCo model of ``chain`` (point-mass links) stepping by ``dt`` with ``integrator``."""
    import mujoco

    xml = build_mjcf(chain.cart_mass, chain.link_masses, chain.link_lengths, chain.gravity, dt, integrator)
    return mujoco.MjModel.from_xml_string(xml)


def _initial_physics_state(mj_model: Any, chain: ChainCart) -> np.ndarray:
    import mujoco

    data = mujoco.MjData(mj_model)
    data.qpos[:], data.qvel[:] = state_to_mujoco(chain.n_links, fig1.fig1_state())
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(mj_model, spec))
    mujoco.mj_getState(mj_model, data, state, spec)
    return state


def _to_ours(mj_model: Any, chain: ChainCart, physics: np.ndarray) -> np.ndarray:
    """Our spatial states from rows of MuJoCo's full physics state [time, qpos, qvel, ...]."""
    nq, nv = mj_model.nq, mj_model.nv
    return np.array([mujoco_to_state(chain.n_links, row[1 : 1 + nq], row[1 + nq : 1 + nq + nv]) for row in physics])


class MujocoDiverged(RuntimeError):
    """MuJoCo flagged the simulation unstable and reset it (its time restarted)."""


@contextlib.contextmanager
def _warnings_collected() -> Iterator[list[str]]:
    """Collects MuJoCo's warnings instead of letting it write MUJOCO_LOG.TXT into the cwd."""
    import mujoco

    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(previous)


def _check_clock(out: np.ndarray, done: int, dt: float) -> None:
    """MuJoCo resets an unstable simulation, restarting its clock: find where."""
    expected = (done + 1 + np.arange(out.shape[0])) * dt
    wrong = np.flatnonzero(np.abs(out[:, 0] - expected) > 0.5 * dt)
    if wrong.size:
        raise MujocoDiverged(f"diverged at t = {expected[wrong[0]]:.3g} s (MuJoCo reset the state)")


def run_mujoco(chain: ChainCart, integrator: str, dt: float, t_end: float, every: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Like :func:`fig1.run_chaincart` for MuJoCo: final state and sampled states (ours).
    Raises :class:`MujocoDiverged` when MuJoCo reset an unstable simulation."""
    import mujoco
    from mujoco import rollout

    mj_model = mujoco_model(chain, dt, integrator)
    data = mujoco.MjData(mj_model)
    physics = _initial_physics_state(mj_model, chain)
    steps_left, done, samples = int(round(t_end / dt)), 0, [physics[None]]
    while steps_left:
        k = min(fig1.CHUNK, steps_left)
        with _warnings_collected():
            out, _ = rollout.rollout(mj_model, data, physics[None], np.zeros((1, k, mj_model.nu)), nstep=k)
        _check_clock(out[0], done, dt)
        if every:
            first = (every - 1 - done) % every
            samples.append(out[0, first::every])
        physics, done, steps_left = out[0, -1], done + k, steps_left - k
    final = _to_ours(mj_model, chain, physics[None])[0]
    return final, (_to_ours(mj_model, chain, np.vstack(samples)) if every else np.empty((0, len(final))))


def _mujoco_wall_per_sim_s(chain: ChainCart, integrator: str, dt: float, min_time: float, repeats: int) -> float:
    """One thread, mj_step in rollout's C loop, 1 simulated second per call."""
    import mujoco
    from mujoco import rollout

    mj_model = mujoco_model(chain, dt, integrator)
    data = mujoco.MjData(mj_model)
    steps = int(round(1.0 / dt))
    init = _initial_physics_state(mj_model, chain)[None]
    control = np.zeros((1, steps, mj_model.nu))
    out = np.empty((1, steps, len(init[0])))
    with _warnings_collected():
        return 1.0 / rate(lambda: rollout.rollout(mj_model, data, init, control, nstep=steps, state=out), min_time, repeats)


def mujoco_point(chain: ChainCart, ref: fig1.Reference, integrator: str, dt: float, min_time: float, repeats: int) -> AccuracyPoint:
    """MuJoCo's :class:`AccuracyPoint` for ``integrator`` at step ``dt``, against the same reference
    as chaincart's."""
    lengths = np.array(chain.link_lengths)
    try:
        final, _ = run_mujoco(chain, integrator, dt, 1.0)
    except MujocoDiverged as exc:
        return AccuracyPoint("mujoco", integrator, dt, None, None, None, str(exc))
    error = fig1.position_error(final, ref.positions, lengths)
    wall = _mujoco_wall_per_sim_s(chain, integrator, dt, min_time, repeats)
    try:
        _, samples = run_mujoco(chain, integrator, dt, fig1.DRIFT_HORIZON, fig1.sample_every(dt))
        drift: Optional[float] = fig1.energy_drift(chain, samples)
        failure = ""
    except MujocoDiverged as exc:
        drift, failure = None, f"10-s run {exc}"
    return AccuracyPoint("mujoco", integrator, dt, error, drift, wall, failure)


def fig1_reference(ctx: BenchContext) -> fig1.Reference:
    """The Fig. 1 reference, computed once per run and kept in ``ctx.results``."""
    if "fig1_reference" not in ctx.results:
        ctx.results["fig1_reference"] = fig1.reference(fig1.paper_model())
    return ctx.results["fig1_reference"]  # type: ignore[no-any-return]


def fig1_point(ctx: BenchContext, engine: str, integrator: str, dt: float) -> AccuracyPoint:
    """The Fig. 1 accuracy/cost point, measured once per run and shared by sections."""
    points = ctx.results.setdefault("fig1_points", {})
    key = (engine, integrator, dt)
    if key not in points:
        chain, ref = fig1.paper_model(), fig1_reference(ctx)
        s = ctx.settings
        measure = fig1.chaincart_point if engine == "chaincart" else mujoco_point
        points[key] = measure(chain, ref, integrator, dt, s.min_time, s.repeats)
    return points[key]  # type: ignore[no-any-return]


def _verification(ctx: BenchContext) -> float:
    chain, rng = fig1.paper_model(), np.random.default_rng(1)
    samples = 20 if ctx.settings.quick else 200
    states = np.array([random_spatial_state(chain.n_links, rng) for _ in range(samples)])
    forces = rng.normal(size=(samples, 2))
    worst = acceleration_mismatch(chain, mujoco_model(chain, 1e-3, "rk4"), states, forces)
    ctx.results["mujoco_acceleration_mismatch"] = worst
    return worst


def _equal_step_table(ctx: BenchContext) -> None:
    steps = (1e-3,) if ctx.settings.quick else (1e-3, 1e-4)
    rows = []
    for dt in steps:
        base = fig1_point(ctx, "mujoco", "rk4", dt)
        entries = [fig1_point(ctx, "mujoco", m, dt) for m in MUJOCO_INTEGRATORS]
        entries += [fig1_point(ctx, "chaincart", m, dt) for m in CHAINCART_INTEGRATORS]
        for p in entries:
            per_step = p.wall_per_sim_s * dt if p.wall_per_sim_s else None
            speedup = fmt_ratio(base.wall_per_sim_s, p.wall_per_sim_s) if p.wall_per_sim_s else "n/a"
            rows.append([
                p.engine, p.integrator + (" (control period; own steps)" if p.integrator == "adaptive" else ""),
                f"{dt:g}", f"{per_step * 1e6:.2f}" if per_step else "n/a", speedup,
                fmt_sci(p.error_1s), fmt_sci(p.drift_10s), p.failure,
            ])  # fmt: skip
    ctx.report.table(
        ["engine", "integrator", "dt (s)", "us/step (1 thread)", "speed vs MuJoCo RK4", "error at 1 s (m)",
         "energy drift 10 s", "note"],
        rows, 2,
    )  # fmt: skip


def _batched_table(ctx: BenchContext) -> None:
    import mujoco
    from mujoco import rollout

    chain, dt = fig1.paper_model(), 1e-3
    sizes = [n for n in ctx.settings.sizes if n > 1] or [16]
    nthread = os.cpu_count() or 1
    rows = []
    for n in sizes:
        nstep = max(1, min(100, 40_000 // n))
        mj_model = mujoco_model(chain, dt, "rk4")
        datas = [mujoco.MjData(mj_model) for _ in range(nthread)]
        init = np.repeat(_initial_physics_state(mj_model, chain)[None], n, axis=0)
        control = np.zeros((n, nstep, mj_model.nu))
        out = np.empty((n, nstep, init.shape[1]))
        with rollout.Rollout(nthread=nthread) as pool:
            r_mj = n * nstep * rate(lambda: pool.rollout(mj_model, datas, init, control, nstep=nstep, state=out),
                                    ctx.settings.min_time, ctx.settings.repeats)  # fmt: skip
        config = ChainCartConfig(scene="paper-fig1", dt=dt, substeps=1, integrator="rk4")
        batch = config.make_batch(n, "next_step", 0)
        batch.reset()
        actions = np.zeros((n, config.force_dim), dtype=np.float32)
        r_cc = n * rate(lambda: batch.step(actions), ctx.settings.min_time, ctx.settings.repeats)
        rows.append([str(n), fmt_rate(r_mj), fmt_rate(r_cc), fmt_ratio(r_cc, r_mj)])
    ctx.results["mujoco_batched"] = rows
    ctx.report.paragraph(
        f"Batched, paper system, RK4 at dt = 1 ms, env-steps/s on {nthread} threads: MuJoCo `rollout.Rollout(nthread="
        f"{nthread})` (open-loop, states copied out every step) vs chaincart's native `EnvBatch.step` (rk4, plus "
        "the task layer: reward, termination, observation)."
    )
    ctx.report.table(["N", "MuJoCo rollout", "chaincart EnvBatch", "chaincart / MuJoCo"], rows)


def mujoco_section(ctx: BenchContext) -> None:
    """The MuJoCo section: the same chain in MuJoCo, its agreement with chaincart and the step rates
    side by side (a note when MuJoCo is missing)."""
    ctx.report.heading("The same physics in MuJoCo (paper's 5-link chain, Fig. 1 start)")
    if not mujoco_available():
        ctx.report.paragraph(MISSING_NOTE)
        return
    worst = _verification(ctx)
    ctx.report.paragraph(
        "Model check: MuJoCo's cart and link-point accelerations vs chaincart's at random states and forces: "
        f"largest relative difference {worst:.1e}. " + _reference_note(ctx)
    )
    _equal_step_table(ctx)
    _batched_table(ctx)


def _reference_note(ctx: BenchContext) -> str:
    ref = fig1_reference(ctx)
    return (
        f"Reference for the error at 1 s: chaincart rk4 at dt = 2e-6 s (estimated own error {ref.self_error:.0e} m; "
        f"differs from the adaptive 5(4) method at a 1e-4 s control period by {ref.adaptive_difference:.0e} m)."
    )
