"""``report.md``: the study in one page (tables and the PNGs beside it), and the one
summary figure (``summary.png``) a README can show."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from chaincart_env.tools.compare.plan_bands import bands_markdown
from chaincart_env.tools.compare.tables import (
    left_out_note,
    markdown_table,
    repeated_variants,
    variant_name,
    variant_notes,
)

__all__ = ["REPORT_FILE", "SUMMARY_FIGURE", "seed_lines", "sweep_markdown", "write_report", "write_summary_figure"]

REPORT_FILE = "report.md"
SUMMARY_FIGURE = "summary.png"


def _interval(row: dict[str, Any]) -> str:
    if not math.isfinite(row["ci_low"]):
        return "–"
    return f"[{row['ci_low']:.2f}, {row['ci_high']:.2f}]"


def _number(value: float, digits: int = 2) -> str:
    return "–" if not math.isfinite(value) else f"{value:.{digits}f}"


def sweep_markdown(rows: Sequence[dict[str, Any]], axis_label: str, notes: bool = True) -> str:
    """One table per axis: a row per value and policy with the success rate and its
    95% interval, mean return, mean time to settle and mean peak force. A variant
    (``PPO best``, ``LQR oracle``) whose numbers at a value repeat its policy's has no
    row there; (``notes``) a note says so."""
    lines = [
        f"| {axis_label} | policy | success [95% interval] | return | time to settle (s) | peak force (N) |",
        "|---:|---|---:|---:|---:|---:|",
    ]
    repeated = repeated_variants(rows, ("value",))
    rows_left = [r for k, r in enumerate(rows) if k not in repeated]
    policies = list(dict.fromkeys(r["policy"] for r in rows))
    for value in sorted({r["value"] for r in rows}):
        for policy in policies:
            row = next((r for r in rows_left if r["value"] == value and r["policy"] == policy), None)
            if row is None:
                continue
            lines.append(
                f"| {value:g} | {policy} | {row['success_rate']:.2f} {_interval(row)} | "
                f"{_number(row['return_mean'], 1)} | {_number(row['settle_time_mean'])} | "
                f"{_number(row['peak_force_mean'])} |"
            )
    intervals = sorted(
        {f"{r['policy']}: {r['interval']} ({r['seeds']} seed{'s' if r['seeds'] != 1 else ''})" for r in rows_left}
    )
    notes_text = variant_notes(rows, repeated) if notes else []
    return ("\n".join(lines) + "\n\nIntervals: " + "; ".join(intervals) + ".\n"
            + "".join(f"\n{note}\n" for note in notes_text))  # fmt: skip


def seed_lines(aggregates: Sequence[dict[str, Any]]) -> list[str]:
    """A line per trained policy with its numbers over its training seeds (an interval
    only with several; that one seed gives none is said once, after them). A variant
    whose numbers repeat its policy's (``PPO best``: the best model is the final one)
    gets no line of its own (:func:`write_report` says so once for the whole report)."""
    repeated = repeated_variants(aggregates)
    lines = []
    single = False
    for index, row in enumerate(aggregates):
        if index in repeated:
            continue
        if row["seeds"] < 2:
            single = True
            lines.append(f"{row['policy']}, one training seed: success {row['success_mean']:.2f}, return "
                         f"{row['return_mean']:.1f}.")  # fmt: skip
        else:
            lines.append(
                f"{row['policy']} over {row['seeds']} training seeds: success {row['success_mean']:.2f} "
                f"[{row['success_ci_low']:.2f}, {row['success_ci_high']:.2f}], return {row['return_mean']:.1f} "
                f"[{row['return_ci_low']:.1f}, {row['return_ci_high']:.1f}] (mean over seeds, 95% percentile "
                "bootstrap interval over seeds)."
            )
    if single:
        lines.append("One seed gives no interval over seeds (train several with --seeds).")
    return lines


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
    plan_bands: Sequence[dict[str, Any]] = (),
) -> str:
    """Writes ``report.md`` into ``directory``: the verdict (lines of Markdown), the
    setup, the comparison on the main starts, one table per sweep axis, training notes
    and the pictures (``(file, caption)``; only files that exist are linked). Returns
    the text. ``transitions``: success per policy and (start, target) pair
    (:func:`~chaincart_env.tools.compare.evaluation.transition_table`), shown after the comparison;
    ``plan_bands``: success from starts along the plan
    (:func:`~chaincart_env.tools.compare.plan_bands.band_rows`), after them."""
    setup = [*setup, *_left_out_notes(comparison, sweeps)]
    parts = [f"# {title}\n\n", "## Verdict\n\n", *[f"{line}\n" for line in verdict], "\n## Setup\n\n",
             *[f"{line}\n\n" for line in setup], "## On the evaluation starts\n\n",
             markdown_table(comparison, notes=False)]  # fmt: skip
    if transitions:
        parts.append("\n## Per transition (successes / episodes)\n\n")
        parts.append(transitions_markdown(transitions))
    if plan_bands:
        parts.append("\n## Along the plan (starts in bands of the planner's plan, from its end)\n\n")
        parts.append(bands_markdown(plan_bands))
    for axis, (label, rows) in sweeps.items():
        parts.append(f"\n## Sweep: {label}\n\n")
        parts.append(sweep_markdown(rows, label, notes=False))
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


def _left_out_notes(
    comparison: Sequence[dict[str, Any]], sweeps: dict[str, tuple[str, Sequence[dict[str, Any]]]]
) -> list[str]:
    """Once for the report: each variant left out of a table where it repeats its
    policy, and whether it has rows anywhere."""
    tables = [(comparison, repeated_variants(comparison))]
    tables += [(rows, repeated_variants(rows, ("value",))) for _, rows in sweeps.values()]
    left_out: dict[str, None] = {}
    kept: set[str] = set()
    for rows, repeated in tables:
        left_out.update(dict.fromkeys(variant_name(rows[k]["policy"]) for k in repeated))
        kept |= {variant_name(r["policy"]) for k, r in enumerate(rows) if k not in repeated}
    return [left_out_note(name, name not in kept) for name in left_out]


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

    from chaincart_env.tools.compare.study_plots import draw_errors, draw_evaluation_curves, draw_sweep

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
    strip_ax.set_title("the same start, one row per policy, frames at the same times, crowded where the chain moves")
    fig.savefig(path)
