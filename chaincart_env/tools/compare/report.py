"""``report.md``: the study in one page (tables and the PNGs beside it), and the one
summary figure (``summary.png``) a README can show."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from chaincart_env.tools.compare.tables import markdown_table

__all__ = ["REPORT_FILE", "SUMMARY_FIGURE", "sweep_markdown", "write_report", "write_summary_figure"]

REPORT_FILE = "report.md"
SUMMARY_FIGURE = "summary.png"


def _interval(row: dict[str, Any]) -> str:
    if not math.isfinite(row["ci_low"]):
        return "–"
    return f"[{row['ci_low']:.2f}, {row['ci_high']:.2f}]"


def _number(value: float, digits: int = 2) -> str:
    return "–" if not math.isfinite(value) else f"{value:.{digits}f}"


def sweep_markdown(rows: Sequence[dict[str, Any]], axis_label: str) -> str:
    """One table per axis: a row per value and policy with the success rate and its
    95% interval, mean return, mean time to settle and mean peak force."""
    lines = [
        f"| {axis_label} | policy | success [95% interval] | return | time to settle (s) | peak force (N) |",
        "|---:|---|---:|---:|---:|---:|",
    ]
    policies = list(dict.fromkeys(r["policy"] for r in rows))
    for value in sorted({r["value"] for r in rows}):
        for policy in policies:
            row = next(r for r in rows if r["value"] == value and r["policy"] == policy)
            lines.append(
                f"| {value:g} | {policy} | {row['success_rate']:.2f} {_interval(row)} | "
                f"{_number(row['return_mean'], 1)} | {_number(row['settle_time_mean'])} | "
                f"{_number(row['peak_force_mean'])} |"
            )
    intervals = sorted({f"{r['policy']}: {r['interval']} ({r['seeds']} seed{'s' if r['seeds'] != 1 else ''})" for r in rows})
    return "\n".join(lines) + "\n\nIntervals: " + "; ".join(intervals) + ".\n"


def write_report(
    directory: Path,
    *,
    title: str,
    verdict: Sequence[str],
    setup: Sequence[str],
    comparison: Sequence[dict[str, Any]],
    sweeps: dict[str, tuple[str, Sequence[dict[str, Any]]]],
    training: Sequence[str],
    pictures: Sequence[tuple[str, str]],
    transitions: Sequence[dict[str, Any]] = (),
) -> str:
    """Writes ``report.md`` into ``directory``: the verdict (lines of Markdown), the
    setup, the comparison on the main starts, one table per sweep axis, training notes
    and the pictures (``(file, caption)``; only files that exist are linked). Returns
    the text. ``transitions``: success per policy and (start, target) pair
    (:func:`~chaincart_env.tools.compare.evaluation.transition_table`), shown after the comparison."""
    parts = [f"# {title}\n\n", "## Verdict\n\n", *[f"{line}\n" for line in verdict], "\n## Setup\n\n",
             *[f"{line}\n\n" for line in setup], "## On the evaluation starts\n\n", markdown_table(comparison)]
    if transitions:
        parts.append("\n## Per transition (successes / episodes)\n\n")
        parts.append(transitions_markdown(transitions))
    for axis, (label, rows) in sweeps.items():
        parts.append(f"\n## Sweep: {label}\n\n")
        parts.append(sweep_markdown(rows, label))
    if training:
        parts.append("\n## Training\n\n")
        parts.extend(f"{line}\n\n" for line in training)
    shown = [(name, caption) for name, caption in pictures if (Path(directory) / name).is_file()]
    if shown:
        parts.append("\n## Pictures\n")
        parts.extend(f"\n![{caption}]({name})\n\n*{caption}*\n" for name, caption in shown)
    text = "".join(parts)
    (Path(directory) / REPORT_FILE).write_text(text)
    return text


def transitions_markdown(rows: Sequence[dict[str, Any]]) -> str:
    """One row per (start, target) pair, one column per policy: successes / episodes."""
    policies = list(dict.fromkeys(row["policy"] for row in rows))
    pairs = list(dict.fromkeys((row["start"], row["target"]) for row in rows))
    cells = {(row["policy"], row["start"], row["target"]): f"{row['successes']}/{row['episodes']}" for row in rows}
    lines = ["| start | target | " + " | ".join(policies) + " |", "|---|---|" + "---:|" * len(policies)]
    for start, target in pairs:
        lines.append(f"| {start} | {target} | " + " | ".join(cells.get((p, start, target), "–") for p in policies) + " |")
    return "\n".join(lines) + "\n"


def write_summary_figure(
    path: Path,
    *,
    curves: dict[str, dict[str, Sequence[dict[str, Any]]]],
    baselines: Sequence[dict[str, Any]],
    sweeps: dict[str, tuple[str, Sequence[dict[str, Any]]]],
    errors: Sequence[Any],
    tolerances: tuple[float, float],
    filmstrip: Path,
) -> None:
    """One figure: the evaluation learning curves against the baselines (when something
    was trained), success against each sweep axis with its bands, ``e_q(t)`` of every
    policy from the first start, and the filmstrip of that start."""
    from matplotlib.figure import Figure
    from PIL import Image

    from chaincart_env.tools.compare.plots import draw_errors, draw_evaluation_curves, draw_sweep

    panels = (1 if curves else 0) + len(sweeps) + 1
    columns = 2
    rows = (panels + 1) // columns + 1
    # The filmstrip's row is taller, so that its chains are large enough to read.
    strip_height = 5.4
    fig = Figure(figsize=(12, 3.6 * (rows - 1) + strip_height), dpi=100, layout="constrained")
    grid = fig.add_gridspec(rows, columns, height_ratios=[3.6] * (rows - 1) + [strip_height])
    axes = [fig.add_subplot(grid[i // columns, i % columns]) for i in range(panels - 1)]
    # The last panel (e_q(t)) takes the rest of its row.
    last = panels - 1
    axes.append(fig.add_subplot(grid[last // columns, last % columns:]))
    if curves:
        draw_evaluation_curves(axes[0], curves, baselines, "success_rate")
    for ax, (label, sweep_rows) in zip(axes[1 if curves else 0:], sweeps.values()):
        draw_sweep(ax, sweep_rows, label)
    draw_errors(axes[-1], errors, "e_q", tolerances[0])
    axes[-1].set(title=f"e_q(t) from start seed {int(errors[0].seeds[0])}")
    strip_ax = fig.add_subplot(grid[rows - 1, :])
    if Path(filmstrip).is_file():
        strip_ax.imshow(np.asarray(Image.open(filmstrip)))
    strip_ax.set_axis_off()
    strip_ax.set_title("the same start, frames at the same times (one row per policy)")
    fig.savefig(path)
