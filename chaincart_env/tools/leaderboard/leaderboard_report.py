"""The leaderboard's tables, figures and ``leaderboard.md``.

Per scene and controller:

* **robustness score**: the mean over axes of the axis score, an axis score being the
  success fraction over all of that axis's values (and seeds), as the ``double_pendulum``
  benchmark scores its controllers;
* **IQM**: the interquartile mean of the success fractions of all cells (axis values) and
  seeds, with its 95 % stratified-bootstrap interval over seeds
  (:mod:`~chaincart_env.tools.leaderboard.statistics`);
* cost per control step (microseconds of ``predict`` per env-step), peak and RMS force;
* the probability that one controller beats another on a cell, and performance
  profiles (the fraction of cells and seeds above each success level).
"""

from __future__ import annotations

import datetime
import math
import os
import platform
from collections import defaultdict
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from chaincart_env.tools.compare.styles import band, policy_style
from chaincart_env.tools.compare.tables import write_csv
from chaincart_env.tools.compare.uncertainty import wilson_interval
from chaincart_env.tools.controllers import is_learned
from chaincart_env.tools.leaderboard.statistics import (
    Estimate,
    iqm_estimate,
    performance_profile,
    probability_of_improvement,
    probability_of_improvement_estimate,
)  # fmt: skip

__all__ = ["SCORE_COLUMNS", "score_rows", "write_report"]

#: Columns of ``scores.csv``: one row per (scene, controller).
SCORE_COLUMNS = (
    "scene", "controller", "robustness", "iqm", "iqm_low", "iqm_high", "us_per_step", "peak_force", "rms_force",
)  # fmt: skip

def _group(rows: Iterable[Mapping[str, Any]], *keys: str) -> dict[tuple[Any, ...], list[Mapping[str, Any]]]:
    groups: dict[tuple[Any, ...], list[Mapping[str, Any]]] = defaultdict(list)
    for row in rows:
        groups[tuple(row[k] for k in keys)].append(row)
    return groups


def _score_matrix(rows: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """Success fractions of one controller on one scene as ``(seeds, cells)``."""
    seeds = sorted({r["seed"] for r in rows})
    cells = list(dict.fromkeys((r["axis"], r["value"]) for r in rows))
    index = {(r["seed"], r["axis"], r["value"]): r["success_rate"] for r in rows}
    return np.array([[index[(s, a, v)] for a, v in cells] for s in seeds])


def axis_scores(rows: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """Success fraction over every episode of each axis (all values and seeds)."""
    out = {}
    for (axis,), mine in _group(rows, "axis").items():
        out[axis] = sum(r["successes"] for r in mine) / sum(r["episodes"] for r in mine)
    return out


def score_rows(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One row of :data:`SCORE_COLUMNS` per (scene, controller)."""
    out = []
    for (scene, controller), mine in _group(rows, "scene", "controller").items():
        iqm = iqm_estimate(_score_matrix(mine))
        out.append(dict(
            scene=scene, controller=controller, robustness=float(np.mean(list(axis_scores(mine).values()))),
            iqm=iqm.value, iqm_low=iqm.low, iqm_high=iqm.high,
            us_per_step=float(np.mean([r["us_per_step"] for r in mine])),
            peak_force=float(np.mean([r["peak_force_mean"] for r in mine])),
            rms_force=float(np.mean([r["rms_force_mean"] for r in mine])),
        ))
    return out


def _scene_table(scene_rows: Sequence[Mapping[str, Any]], scores: Sequence[Mapping[str, Any]], axes: Sequence[str]) -> str:
    seeds = len({r["seed"] for r in scene_rows})
    header = "| controller | robustness | IQM [95 % CI] | " + " | ".join(axes) + " | us/step | peak N | RMS N |"
    lines = [header, "|---|---:|---:|" + "---:|" * len(axes) + "---:|---:|---:|"]
    by_controller = _group(scene_rows, "controller")
    for score in sorted(scores, key=lambda s: -s["robustness"]):
        per_axis = axis_scores(by_controller[(score["controller"],)])
        cells = " | ".join(f"{per_axis[a]:.2f}" if a in per_axis else "-" for a in axes)
        interval = (
            Estimate(score["iqm"], score["iqm_low"], score["iqm_high"]).describe()
            if seeds > 1 else f"{score['iqm']:.2f} (1 seed: no interval)"
        )
        lines.append(
            f"| {score['controller']} | **{score['robustness']:.2f}** | {interval} | {cells} "
            f"| {score['us_per_step']:.0f} | {score['peak_force']:.1f} | {score['rms_force']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def _improvement_table(scene_rows: Sequence[Mapping[str, Any]]) -> str:
    seeds = len({r["seed"] for r in scene_rows})
    by_controller = {c: _score_matrix(rows) for (c,), rows in _group(scene_rows, "controller").items()}
    names = list(by_controller)
    lines = ["| P(row beats column) | " + " | ".join(names) + " |", "|---|" + "---:|" * len(names)]
    for x in names:
        cells = []
        for y in names:
            if x == y:
                cells.append("-")
                continue
            if seeds == 1:  # nothing to resample: the cells are the only variation
                cells.append(f"{probability_of_improvement(by_controller[x], by_controller[y]):.2f}")
                continue
            estimate = probability_of_improvement_estimate(by_controller[x], by_controller[y], resamples=500)
            cells.append(estimate.describe())
        lines.append(f"| {x} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _verdicts(scores: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]], axes: Sequence[str]) -> list[str]:
    """Where the best learned controller beats the best model-based one, axis by axis, as measured."""
    out = []
    for (scene,), mine in _group(scores, "scene").items():
        learned = [s for s in mine if is_learned(s["controller"])]
        model = [s for s in mine if not is_learned(s["controller"])]
        if not learned or not model:
            continue
        best_l = max(learned, key=lambda s: s["robustness"])
        best_m = max(model, key=lambda s: s["robustness"])
        scene_rows = [r for r in rows if r["scene"] == scene]
        axes_l = axis_scores([r for r in scene_rows if r["controller"] == best_l["controller"]])
        axes_m = axis_scores([r for r in scene_rows if r["controller"] == best_m["controller"]])
        wins = [a for a in axes if axes_l.get(a, 0.0) > axes_m.get(a, 0.0)]
        losses = [a for a in axes if axes_l.get(a, 0.0) < axes_m.get(a, 0.0)]
        verdict = "beats" if best_l["robustness"] > best_m["robustness"] else (
            "ties with" if best_l["robustness"] == best_m["robustness"] else "loses to")
        out.append(
            f"- **{scene}**: the best learned controller, {best_l['controller']} ({best_l['robustness']:.2f}), "
            f"{verdict} the best model-based one, {best_m['controller']} ({best_m['robustness']:.2f}). "
            f"Learning is ahead on: {', '.join(wins) or 'no axis'}; behind on: {', '.join(losses) or 'no axis'}."
        )
    return out


def _plot_scene(path: Path, scene_rows: Sequence[Mapping[str, Any]], axes: Sequence[Any], scene: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    columns = min(3, len(axes))
    rows_n = math.ceil(len(axes) / columns)
    fig, grid = plt.subplots(rows_n, columns, figsize=(4.2 * columns, 3.2 * rows_n), squeeze=False)
    by_key = _group(scene_rows, "controller", "axis")
    controllers = list(dict.fromkeys(r["controller"] for r in scene_rows))
    for k, axis in enumerate(axes):
        ax = grid[k // columns][k % columns]
        shown = [v for v in dict.fromkeys(r["value"] for r in scene_rows if r["axis"] == axis.name)]
        positions = np.arange(len(shown))
        for offset, controller in enumerate(controllers):
            mine = by_key.get((controller, axis.name), [])
            if not mine:
                continue
            rates, lows, highs = [], [], []
            for v in shown:
                at = [r for r in mine if r["value"] == v]
                wins, trials = sum(r["successes"] for r in at), sum(r["episodes"] for r in at)
                low, high = wilson_interval(wins, trials)
                rates.append(wins / trials)
                lows.append(low)
                highs.append(high)
            # A small sideways offset per controller keeps coinciding curves visible.
            x = positions + 0.04 * (offset - (len(controllers) - 1) / 2)
            style = policy_style(controller)
            ax.plot(x, rates, label=controller, lw=1.8, ms=5, **style.line())
            band(ax, x, lows, highs, style)
        ax.set_xticks(positions, [("none" if math.isinf(v) else f"{v:g}") for v in shown])
        ax.set_xlabel(axis.label)
        ax.set_ylim(-0.05, 1.05)
        ax.set_ylabel("success fraction")
        ax.grid(alpha=0.3)
    for k in range(len(axes), rows_n * columns):
        grid[k // columns][k % columns].set_visible(False)
    handles, labels = grid[0][0].get_legend_handles_labels()
    fig.suptitle(f"{scene}: success along each robustness axis (bands: 95 % Wilson interval over episodes)", y=0.99,
                 fontsize=10)
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.95), ncol=len(labels), frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _plot_profiles(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    taus = np.linspace(0.0, 1.0, 41)
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for (controller,), mine in _group(rows, "controller").items():
        matrix = np.concatenate([_score_matrix(r) for r in _group(mine, "scene").values()], axis=1)
        profile, low, high = performance_profile(matrix, taus, resamples=500)
        style = policy_style(controller)
        ax.plot(taus, profile, label=controller, lw=1.8, markevery=8, ms=4, **style.line())
        band(ax, taus, low, high, style)
    ax.set_xlabel("success fraction tau")
    ax.set_ylabel("fraction of cells with success > tau")
    ax.grid(alpha=0.3)
    ax.legend(frameon=False, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write_report(
    rows: Sequence[Mapping[str, Any]], settings: Any, out: Path, report: Path, skipped: Mapping[tuple[str, str], str]
) -> str:
    """Writes ``scores.csv``, the figures and the Markdown report; returns the text."""
    out, report = Path(out), Path(report)
    report.parent.mkdir(parents=True, exist_ok=True)
    figures = report.parent / (report.stem + "-figures")
    figures.mkdir(exist_ok=True)
    scores = score_rows(rows)
    write_csv(out / "scores.csv", scores, SCORE_COLUMNS)
    axes = [a.name for a in settings.axes]
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Robustness leaderboard", "",
        f"Generated {now} on {platform.machine()} ({os.cpu_count()} CPUs) by `python -m chaincart_env leaderboard "
        f"--scenes {','.join(settings.scenes)} --policies {','.join(settings.controllers)} --seeds "
        f"{','.join(map(str, settings.seeds))}{' --quick' if settings.quick else ''}"
        f"{' --wall-clock-budgets' if getattr(settings, 'wall_clock', False) else ''}`: "
        f"{settings.episodes_per_cell} episodes per cell and seed, axes {', '.join(axes)}; "
        + ("the planner and MPC also stopped at their wall-clock budgets." if getattr(settings, "wall_clock", False)
           else "the planner and MPC bounded by iteration counts alone."), "",
    ]
    verdicts = _verdicts(scores, rows, axes)
    if verdicts:
        lines += ["## Learning against the best model-based controller", "", *verdicts, ""]
    for scene in settings.scenes:
        scene_rows = [r for r in rows if r["scene"] == scene]
        lines += [f"## {scene}", ""]
        if scene_rows:
            figure = figures / f"{scene}.png"
            _plot_scene(figure, scene_rows, settings.axes, scene)
            lines += [_scene_table(scene_rows, [s for s in scores if s["scene"] == scene], axes),
                      f"![{scene}]({os.path.relpath(figure, report.parent)})", ""]
            if len({r["controller"] for r in scene_rows}) > 1:
                lines += ["Probability that the row's controller beats the column's on a cell (with its 95 % interval "
                          "over seeds when there are several):", "",
                          _improvement_table(scene_rows)]
        for (s, name), reason in skipped.items():
            if s == scene:
                lines.append(f"- not scored: {reason}")
        lines.append("")
    if rows:
        profile = figures / "profiles.png"
        _plot_profiles(profile, rows)
        lines += ["## Performance profiles", "", f"![performance profiles]({os.path.relpath(profile, report.parent)})",
                  ""]
    lines += [
        "## How to read it", "",
        "- A cell is one scene at one value of one axis; its score is the success fraction of its seeded episodes.",
        "- Robustness: the mean over axes of each axis's success fraction over all its values.",
        "- IQM: the interquartile mean over cells and seeds, with a 95 % stratified-bootstrap interval over seeds "
        "(a run of one seed has no interval).",
        "- Seed s: the training seed of a learned controller and, for every controller, the block of evaluation "
        "starts s * 1000 + i: all controllers meet the same starts and the same true systems.",
        "- us/step: the controller's compute time per env-step (batched `predict` over the cell's episodes).",
    ]
    text = "\n".join(lines) + "\n"
    report.write_text(text)
    return text
