"""Bench section ``control``: planning the swing-ups and the receding-horizon
controller's time per control step, from Python (the GIL released inside each call)."""

from __future__ import annotations

import time

import numpy as np

from chaincart_env import _core
from chaincart_env.config import ChainCartConfig
from chaincart_env.policies.settings import SCENE_PLANS
from chaincart_env.tools.bench.context import BenchContext

__all__ = ["control_section"]

#: The swing-up scenes, planned with their own force limit, track and the plan length of
#: the plan-following policies there (``SCENE_PLANS``, else the planner's default).
SWINGUPS = ("swingup-2", "swingup-3", "spatial-swingup-2")


def _mpc_step_times(model: _core.ChainCart, plan, steps: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Seconds of each MPC control step along the plan and one second beyond, from a
    start 1 cm off, the model stepping in between."""
    mpc = plan.mpc()
    y = np.array(plan.states[0])
    y[0] += 0.01
    times = np.empty(steps)
    for k in range(steps):
        began = time.perf_counter()
        u = mpc.force(k, y)
        times[k] = time.perf_counter() - began
        y = model.step(y, u, plan.dt, "rk4", plan.substeps)
    return times


def control_section(ctx: BenchContext) -> None:
    """Time planning each swing-up scene and the MPC steps along its plan, and report
    them."""
    ctx.report.heading("Large motions: planning and MPC")
    repeats = ctx.settings.repeats
    rows, results = [], {}
    for name in SWINGUPS:
        duration = SCENE_PLANS.get(name, (None, ""))[0]
        config = ChainCartConfig(scene=name)
        model = config.make_model()
        plans = [
            model.plan("hanging", "inverted", duration=duration, max_force=config.max_force,
                       track_limit=config.track_limit)
            for _ in range(repeats)
        ]
        plan_seconds = min(p.report["seconds"] for p in plans)
        plan = plans[0]
        steps = plan.forces.shape[0] + int(round(1.0 / plan.dt))
        step_times = min((_mpc_step_times(model, plan, steps) for _ in range(repeats)), key=np.mean)
        mean, worst = float(np.mean(step_times)), float(np.max(step_times))
        results[name] = {"plan_s": plan_seconds, "mpc_mean_s": mean, "mpc_max_s": worst}
        rows.append([
            name, f"{plan.times[-1]:g}", "yes" if plan.converged else "no", f"{plan_seconds:.3f}",
            str(plan.report["iterations"]),
            f"{mean * 1e3:.2f}", f"{np.percentile(step_times, 99) * 1e3:.2f}", f"{worst * 1e3:.2f}",
            f"{plan.dt / mean:.0f}x",
        ])
    ctx.results["control"] = results
    ctx.report.paragraph(
        "The swing-up scenes: the default scene's physics (1 kg cart, 0.1 kg at the end of each 0.5 m "
        "link), their force limit and 3 m track (20 N for two links, 30 N for three), 20 ms control period "
        "with 2 RK4 substeps. Planning: `ChainCart.plan('hanging', 'inverted')` on "
        "one core (best of the repeats). MPC: `Plan.mpc()` (40 steps ahead, at most 2 iLQR iterations and "
        "2 ms per step) along the plan and one second beyond from a start 1 cm off; real-time factor = "
        "control period / mean step time."
    )
    ctx.report.table(
        ["scene", "plan length (s)", "planned", "planning (s)", "iterations", "MPC mean (ms)", "MPC p99 (ms)", "MPC max (ms)",
         "real-time factor"],
        rows, 2,
    )
