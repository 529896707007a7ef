"""Speed-vs-accuracy section: for every chaincart integrator and step size (1e-2 ..
1e-4 s) on the paper's Fig. 1 start, the position error at t = 1 s and the energy
drift over 10 s against wall time per simulated second, as a table and a log-log
Pareto plot, with MuJoCo's integrators (when installed) on the same axes.
See :mod:`chaincart_env.tools.bench.fig1` for how each number is measured."""

from __future__ import annotations

from typing import Sequence

from chaincart_env.tools.bench import fig1
from chaincart_env.tools.bench.bench_report import fmt_sci, fmt_time
from chaincart_env.tools.bench.context import BenchContext, mujoco_available
from chaincart_env.tools.bench.fig1 import AccuracyPoint
from chaincart_env.tools.bench.mujoco_chain import MUJOCO_INTEGRATORS
from chaincart_env.tools.bench.mujoco_compare import (
    CHAINCART_INTEGRATORS,
    MISSING_NOTE,
    _reference_note,
    fig1_point,
    fig1_reference,
)
from chaincart_env.tools.bench.precision import precision_table

__all__ = ["accuracy_section", "pareto_front"]


def pareto_front(points: Sequence[AccuracyPoint], metric: str = "error_1s") -> list[AccuracyPoint]:
    """The points no other point beats on both wall time and ``metric`` (failed runs excluded)."""
    ok = [p for p in points if p.wall_per_sim_s is not None and getattr(p, metric) is not None]
    front = []
    for p in ok:
        dominated = any(
            q.wall_per_sim_s <= p.wall_per_sim_s and getattr(q, metric) <= getattr(p, metric)  # type: ignore[operator]
            and (q.wall_per_sim_s, getattr(q, metric)) != (p.wall_per_sim_s, getattr(p, metric))
            for q in ok
        )
        if not dominated:
            front.append(p)
    return sorted(front, key=lambda p: p.wall_per_sim_s)  # type: ignore[arg-type,return-value]


def _plot(ctx: BenchContext, points: Sequence[AccuracyPoint]) -> None:
    path = ctx.plot_path("speed_accuracy.png")
    if path is None:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    labels = sorted({p.label for p in points}, key=lambda s: (s.startswith("mujoco"), s))
    markers = "osD^v<>ph*"
    for k, label in enumerate(labels):
        mine = sorted((p for p in points if p.label == label), key=lambda p: p.dt)
        style = "--" if label.startswith("mujoco") else "-"
        for ax, metric in zip(axes, ("error_1s", "drift_10s")):
            ok = [p for p in mine if p.wall_per_sim_s and getattr(p, metric)]
            ax.plot([p.wall_per_sim_s for p in ok], [getattr(p, metric) for p in ok], style + markers[k % len(markers)],
                    label=label, ms=5)  # fmt: skip
    for ax, ylabel in zip(axes, ("position error of the masses at t = 1 s (m)", "energy drift over 10 s (relative)")):
        ax.set(xscale="log", yscale="log", xlabel="wall time per simulated second (s), one core", ylabel=ylabel)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("Accuracy vs cost (lower left is better)")
    axes[1].set_title("Energy drift vs cost; points: step 1e-2 .. 1e-4 s")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def accuracy_section(ctx: BenchContext) -> None:
    """The speed-vs-accuracy section: error at 1 s and energy drift against wall time for every
    integrator and step size (and MuJoCo's when installed), with the Pareto plot."""
    ctx.report.heading("Speed vs accuracy (paper's Fig. 1 start, u = 0)")
    steps = fig1.QUICK_STEP_SIZES if ctx.settings.quick else fig1.STEP_SIZES
    engines = [("chaincart", m) for m in CHAINCART_INTEGRATORS]
    if mujoco_available():
        engines += [("mujoco", m) for m in MUJOCO_INTEGRATORS]
    points = [fig1_point(ctx, engine, m, dt) for engine, m in engines for dt in steps]
    ctx.report.paragraph(
        "Error: largest distance of a link mass from the reference at t = 1 s. Drift: max |E - E0| / max T over 10 s. "
        "Cost: wall time per simulated second of one native call on one core (chaincart `simulate`, MuJoCo "
        "`rollout` nbatch 1). `adaptive` takes the step as its control period and picks its own steps "
        "(tolerance 1e-9). " + _reference_note(ctx) + ("" if mujoco_available() else " " + MISSING_NOTE)
    )
    front = {(p.engine, p.integrator, p.dt) for p in pareto_front(points)}
    rows = [
        [p.engine, p.integrator, f"{p.dt:g}", fmt_sci(p.error_1s), fmt_sci(p.drift_10s), fmt_time(p.wall_per_sim_s),
         "yes" if (p.engine, p.integrator, p.dt) in front else "", p.failure]
        for p in points
    ]  # fmt: skip
    ctx.report.table(
        ["engine", "integrator", "step (s)", "error at 1 s (m)", "energy drift 10 s", "wall / simulated s",
         "on the error Pareto front", "note"],
        rows, 2,
    )  # fmt: skip
    _plot(ctx, points)
    precision_table(ctx, fig1_reference(ctx))
