"""Pictures drawn with matplotlib's Agg canvas (no pyplot, no display): the learning
curve and the errors ``e_q(t)``, ``e_w(t)`` of the compared policies on one start."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import EngFormatter

from chaincart_env.compare.evaluation import Rollouts

__all__ = ["FIGURE_SIZE_PX", "plot_errors", "plot_learning_curve"]

_DPI = 100
#: (width, height) in pixels of every plot PNG.
FIGURE_SIZE_PX = (1000, 420)


def _figure() -> Figure:
    return Figure(figsize=(FIGURE_SIZE_PX[0] / _DPI, FIGURE_SIZE_PX[1] / _DPI), dpi=_DPI, layout="constrained")


def plot_learning_curve(
    path: Path, curve: Sequence[dict[str, Any]], algo: str, baseline: dict[str, Any]
) -> None:
    """Mean training-episode return and success rate against timesteps, with the
    baseline's evaluation values as dashed lines."""
    fig = _figure()
    ret, succ = fig.subplots(1, 2)
    steps = np.array([row["timesteps"] for row in curve], dtype=float)
    mean = np.array([row["return_mean"] for row in curve], dtype=float)
    std = np.array([row["return_std"] for row in curve], dtype=float)
    ret.plot(steps, mean, marker=".", label=f"{algo} (training episodes)")
    ret.fill_between(steps, mean - std, mean + std, alpha=0.2)
    ret.axhline(baseline["return_mean"], color="k", ls="--", label=f"{baseline['policy']} (evaluation)")
    ret.set(xlabel="timesteps", ylabel="episode return", title="return")
    succ.plot(steps, [row["success_rate"] for row in curve], marker=".", label=f"{algo} (training episodes)")
    succ.axhline(baseline["success_rate"], color="k", ls="--", label=f"{baseline['policy']} (evaluation)")
    succ.set(xlabel="timesteps", ylabel="success rate", title="success rate", ylim=(-0.05, 1.05))
    for ax in (ret, succ):
        ax.xaxis.set_major_formatter(EngFormatter())
        ax.grid(alpha=0.3)
        ax.legend(loc="best")
    fig.savefig(path)


def plot_errors(path: Path, runs: Sequence[Rollouts], tolerances: tuple[float, float]) -> None:
    """``e_q(t)`` and ``e_w(t)`` of each policy's first episode (the same seeded
    start), log scale, with the success tolerances dashed."""
    fig = _figure()
    axes = fig.subplots(1, 2)
    for ax, key, tol in zip(axes, ("e_q", "e_w"), tolerances):
        for run in runs:
            series = getattr(run, key)[0, : run.lengths[0] + 1]
            t = np.arange(series.size) * run.dt
            ax.semilogy(t, np.maximum(series, 1e-8), label=run.policy)
        ax.axhline(tol, color="k", ls="--", lw=1, label="success tolerance")
        ax.set(xlabel="t (s)", ylabel=key, title=f"{key}(t), seed {int(runs[0].seeds[0])}")
        ax.grid(alpha=0.3, which="both")
        ax.legend(loc="best")
    fig.savefig(path)
