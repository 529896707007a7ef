"""Pictures drawn with matplotlib's Agg canvas (no pyplot, no display): the learning
curve and the errors ``e_q(t)``, ``e_w(t)`` of the compared policies on one start."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import EngFormatter

from chaincart_env.tools.compare.evaluation import Rollouts
from chaincart_env.tools.compare.styles import band, coinciding_with, legend_label, policy_style

__all__ = [
    "FIGURE_SIZE_PX", "draw_errors", "draw_evaluation_curves", "draw_sweep", "plot_errors", "plot_evaluation_curves",
    "plot_learning_curve", "plot_sweep",
]

_DPI = 100
#: (width, height) in pixels of every plot PNG.
FIGURE_SIZE_PX = (1000, 420)


def _figure() -> Figure:
    return Figure(figsize=(FIGURE_SIZE_PX[0] / _DPI, FIGURE_SIZE_PX[1] / _DPI), dpi=_DPI, layout="constrained")


def plot_learning_curve(
    path: Path, curve: Sequence[dict[str, Any]], algo: str, baseline: Optional[dict[str, Any]]
) -> None:
    """Mean training-episode return and success rate against timesteps, with the
    baseline's evaluation values (when there is one) as lines in its look."""
    fig = _figure()
    ret, succ = fig.subplots(1, 2)
    steps = np.array([row["timesteps"] for row in curve], dtype=float)
    mean = np.array([row["return_mean"] for row in curve], dtype=float)
    std = np.array([row["return_std"] for row in curve], dtype=float)
    agent = policy_style(algo)
    ret.plot(steps, mean, color=agent.color, ls=agent.linestyle, marker=".", label=f"{algo} (training episodes)")
    ret.fill_between(steps, mean - std, mean + std, color=agent.color, alpha=0.2, label="± std over episodes")
    ret.set(xlabel="timesteps", ylabel="episode return", title="return")
    succ.plot(steps, [row["success_rate"] for row in curve], color=agent.color, ls=agent.linestyle, marker=".",
              label=f"{algo} (training episodes)")
    if baseline is not None:
        look = policy_style(baseline["policy"])
        for ax, key in ((ret, "return_mean"), (succ, "success_rate")):
            ax.axhline(baseline[key], color=look.color, ls=look.linestyle, label=f"{baseline['policy']} (evaluation)")
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
        draw_errors(ax, runs, key, tol)
        ax.set(title=f"{key}(t), seed {int(runs[0].seeds[0])}")
    fig.savefig(path)


#: Width of the first policy's error curve, and how much wider each later one is drawn
#: beneath it: where the curves meet (every settled policy ends near zero error), the
#: one on top shows inside, each one beneath as a margin on either side.
_ERROR_LINE_WIDTH = 1.3
_ERROR_LINE_WIDEN = 1.4
#: Smallest error shown (the log scale has no zero), and the room (a factor) above and
#: below the curves and the tolerance, so that no line lies on the frame.
_ERROR_FLOOR = 1e-8
_ERROR_ROOM = 3.0


def draw_errors(ax: Any, runs: Sequence[Rollouts], key: str, tolerance: float) -> None:
    """``key`` (``e_q`` or ``e_w``) against time of each policy's first episode, log
    scale, each policy in its style (coinciding curves named), the tolerance grey. The
    first policy is drawn on top and each later one beneath it, wider; the y-range
    spans the curves and the tolerance with room on both sides."""
    drawn: list[tuple[str, np.ndarray, np.ndarray]] = []
    low = high = float(tolerance)
    for order, run in enumerate(runs):
        series = np.maximum(getattr(run, key)[0, : run.lengths[0] + 1], _ERROR_FLOOR)
        t = np.arange(series.size) * run.dt
        style = policy_style(run.policy)
        hidden = coinciding_with(t, series, drawn)
        ax.semilogy(t, series, color=style.color, ls=style.linestyle, label=legend_label(run.policy, hidden),
                    lw=_ERROR_LINE_WIDTH + _ERROR_LINE_WIDEN * order, zorder=3 + len(runs) - order)
        drawn.append((run.policy, t, series))
        finite = series[np.isfinite(series)]
        if finite.size:
            low, high = min(low, float(finite.min())), max(high, float(finite.max()))
    ax.axhline(tolerance, color="0.5", ls=(0, (1, 1)), lw=1, label="success tolerance", zorder=2)
    ax.set_ylim(low / _ERROR_ROOM, high * _ERROR_ROOM)
    ax.set(xlabel="t (s)", ylabel=key)
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="best", fontsize="small")


def draw_evaluation_curves(
    ax: Any, curves: dict[str, dict[str, Sequence[dict[str, Any]]]], baselines: Sequence[dict[str, Any]],
    key: str = "success_rate",
) -> None:
    """Deterministic evaluations during training (``curves``: by trained policy's label,
    then by training seed; one thin line per seed, the mean over seeds bold) against
    each baseline's value on the evaluation starts (a horizontal line in its look)."""
    for agent_label, by_seed in curves.items():
        agent = policy_style(agent_label)
        series = []
        for seed, rows in sorted(by_seed.items()):
            steps = np.array([r["timesteps"] for r in rows], dtype=float)
            values = np.array([r[key] for r in rows], dtype=float)
            series.append((steps, values))
            ax.plot(steps, values, color=agent.color, ls=agent.linestyle, alpha=0.45, lw=1,
                    label=f"{agent_label}, seed {seed}" if len(by_seed) <= 5 else None)
        if len(series) > 1 and all(s[0].shape == series[0][0].shape and np.array_equal(s[0], series[0][0])
                                   for s in series):
            ax.plot(series[0][0], np.mean([s[1] for s in series], axis=0), color=agent.color, lw=2.5,
                    label=f"{agent_label}, mean over {len(series)} seeds")
    for baseline in baselines:
        look = policy_style(baseline["policy"])
        ax.axhline(baseline[key], color=look.color, ls=look.linestyle, lw=1.2, label=f"{baseline['policy']}")
    label = "success rate" if key == "success_rate" else "mean return"
    ax.set(xlabel="training timesteps", ylabel=label, title=f"deterministic evaluation: {label}")
    if key == "success_rate":
        ax.set_ylim(-0.05, 1.05)
    ax.xaxis.set_major_formatter(EngFormatter())
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize="small")


def draw_sweep(ax: Any, rows: Sequence[dict[str, Any]], axis_label: str) -> None:
    """Success rate against one sweep axis, one line per policy in its style with its
    95% interval as a band in its colour and hatch (``summarize_sweep`` rows of one
    axis); a line lying exactly on an earlier one is named as such in the legend."""
    policies = list(dict.fromkeys(r["policy"] for r in rows))
    drawn: list[tuple[str, np.ndarray, np.ndarray]] = []
    for policy in policies:
        mine = sorted((r for r in rows if r["policy"] == policy), key=lambda r: r["value"])
        x = np.array([r["value"] for r in mine], dtype=float)
        y = np.array([r["success_rate"] for r in mine], dtype=float)
        style = policy_style(policy)
        hidden = coinciding_with(x, y, drawn)
        ax.plot(x, y, **style.line(), label=legend_label(policy, hidden))
        band(ax, x, [r["ci_low"] for r in mine], [r["ci_high"] for r in mine], style)
        drawn.append((policy, x, y))
    ax.set(xlabel=axis_label, ylabel="success rate", ylim=(-0.05, 1.05), title=f"success vs {axis_label}")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize="small")


def plot_sweep(path: Path, rows: Sequence[dict[str, Any]], axis_label: str) -> None:
    """:func:`draw_sweep` alone in a PNG."""
    fig = _figure()
    draw_sweep(fig.subplots(1, 1), rows, axis_label)
    fig.savefig(path)


def plot_evaluation_curves(
    path: Path, curves: dict[str, dict[str, Sequence[dict[str, Any]]]], baselines: Sequence[dict[str, Any]]
) -> None:
    """Success rate and mean return of the deterministic evaluations during training
    (:func:`draw_evaluation_curves`)."""
    fig = _figure()
    left, right = fig.subplots(1, 2)
    draw_evaluation_curves(left, curves, baselines, "success_rate")
    draw_evaluation_curves(right, curves, baselines, "return_mean")
    fig.savefig(path)
