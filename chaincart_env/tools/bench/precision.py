"""The env batch's lane physics in f64 and f32 on the paper's Fig. 1 start (u = 0): the
same error at 1 s and energy drift over 10 s as the speed-vs-accuracy table, the drift
over 1000 s at 1 ms, guard failures, and the cost per env of a batch of 4096.

The trajectory is that of env 0 of an env batch of the ``paper-fig1`` scene (force 0,
start exactly at the figure's initial condition) with the step as its control period
and one integrator step per period, stepped call by call; a numerical failure ends the
episode (the guard's flag), which is reported as a failure at that time.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.tools.bench import fig1
from chaincart_env.tools.bench.bench_report import fmt_sci, fmt_time
from chaincart_env.tools.bench.context import BenchContext
from chaincart_env.tools.bench.timing import rate

__all__ = ["precision_table", "lane_trajectory", "LaneFailure"]

STEP_SIZES = (5e-3, 2e-3, 1e-3, 5e-4)
QUICK_STEP_SIZES = (1e-3,)
#: The long drift horizon, run at this step only (10^6 calls).
LONG_HORIZON, LONG_STEP = 1000.0, 1e-3
QUICK_LONG_HORIZON = 20.0
BATCH_ENVS = 4096


class LaneFailure(RuntimeError):
    """The guard ended the episode (the time is in the message)."""


def _config(precision: str, dt: float) -> ChainCartConfig:
    return ChainCartConfig(
        scene=fig1.FIG1, dt=dt, substeps=1, precision=precision, obs_dtype="float64", max_episode_steps=10**12
    )


def lane_trajectory(precision: str, dt: float, t_end: float, every: int) -> tuple[np.ndarray, np.ndarray]:
    """Env 0's state after ``t_end`` and its states every ``every`` steps (with the start)."""
    batch = _config(precision, dt).make_batch(1, "next_step")
    y = batch.states()[0]
    samples, zero = [y], np.zeros((1, 2))
    for k in range(1, int(round(t_end / dt)) + 1):
        obs, _, terminated, _, _ = batch.step(zero)
        if terminated[0]:
            raise LaneFailure(f"failed at t = {k * dt:.3g} s")
        if k % every == 0:
            samples.append(obs[0])
    return batch.states()[0], np.array(samples)


def _batch_envs(ctx: BenchContext) -> int:
    return 64 if ctx.settings.quick else BATCH_ENVS


def _cost_per_env(ctx: BenchContext, precision: str, dt: float) -> float:
    """Wall time per simulated second of one env in a batch of :data:`BATCH_ENVS`."""
    envs = _batch_envs(ctx)
    batch = _config(precision, dt).make_batch(envs, "next_step")
    zero = np.zeros((envs, 2))
    calls_per_s = rate(lambda: batch.step(zero), ctx.settings.min_time, ctx.settings.repeats)
    return 1.0 / calls_per_s / envs / dt


def _row(ctx: BenchContext, ref: fig1.Reference, precision: str, dt: float) -> list[str]:
    model = fig1.paper_model()
    lengths = np.array(model.link_lengths)
    try:
        final, _ = lane_trajectory(precision, dt, 1.0, 10**9)
        error = fig1.position_error(final, ref.positions, lengths)
        _, samples = lane_trajectory(precision, dt, fig1.DRIFT_HORIZON, fig1.sample_every(dt))
        drift = fig1.energy_drift(model, samples)
    except LaneFailure as exc:
        return [precision, f"{dt:g}", "n/a", "n/a", "", "n/a", str(exc)]
    long_drift: Optional[float] = None
    note = ""
    if dt == LONG_STEP:
        horizon = QUICK_LONG_HORIZON if ctx.settings.quick else LONG_HORIZON
        try:
            _, samples = lane_trajectory(precision, dt, horizon, 100 * fig1.sample_every(dt))
            long_drift = fig1.energy_drift(model, samples)
            note = f"no failure in {horizon:g} s"
        except LaneFailure as exc:
            note = f"{horizon:g}-s run {exc}"
    cost = _cost_per_env(ctx, precision, dt)
    long_text = fmt_sci(long_drift) if long_drift is not None else ""
    return [precision, f"{dt:g}", fmt_sci(error), fmt_sci(drift), long_text, fmt_time(cost), note]


def precision_table(ctx: BenchContext, ref: fig1.Reference) -> None:
    """The f64/f32 table of the speed-vs-accuracy section."""
    steps = QUICK_STEP_SIZES if ctx.settings.quick else STEP_SIZES
    horizon = QUICK_LONG_HORIZON if ctx.settings.quick else LONG_HORIZON
    envs = _batch_envs(ctx)
    rows = [_row(ctx, ref, precision, dt) for dt in steps for precision in ("f64", "f32")]
    ctx.report.paragraph(
        "The env batch's rk4 on the SIMD lane kernel in f64 (bit-identical to the rows above) and f32 "
        "(`precision=\"f32\"`): env 0 of a `paper-fig1` env batch with the step as its control period. Long "
        f"drift: the same measure over {horizon:g} s (E sampled every 0.1 s), at {LONG_STEP:g} s only. "
        f"Cost: wall time per simulated second of one env in a batch of {envs} stepped by one call per "
        "period (task layer included, all threads)."
    )
    ctx.report.table(
        ["precision", "step (s)", "error at 1 s (m)", "energy drift 10 s", "energy drift, long",
         "wall / simulated s per env", "note"],
        rows, 2,
    )  # fmt: skip
