"""The comparison table: printed, and written as CSV and Markdown."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any, Sequence

__all__ = ["markdown_table", "write_csv", "write_markdown"]


def write_csv(path: Path, rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> None:
    """Rows as CSV with a header; floats in full precision (``repr``)."""
    with Path(path).open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(columns))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items() if k in columns})


def _pm(mean: float, std: float, digits: int, style: str = "f") -> str:
    if math.isnan(mean):
        return "never"
    return f"{mean:.{digits}{style}} ± {std:.{digits}{style}}"


def markdown_table(summaries: Sequence[dict[str, Any]]) -> str:
    """One row per policy: mean ± std over the evaluation episodes."""
    header = (
        "| policy | episodes | return | success | final e_q | final e_w | peak force (N) | RMS force (N) "
        "| time to settle (s) |"
    )
    lines = [header, "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for s in summaries:
        settle = _pm(s["settle_time_mean"], s["settle_time_std"], 2)
        lines.append(
            f"| {s['policy']} | {s['episodes']} | {_pm(s['return_mean'], s['return_std'], 1)} "
            f"| {s['success_rate']:.0%} | {_pm(s['final_e_q_mean'], s['final_e_q_std'], 1, 'e')} "
            f"| {_pm(s['final_e_w_mean'], s['final_e_w_std'], 1, 'e')} "
            f"| {_pm(s['peak_force_mean'], s['peak_force_std'], 2)} "
            f"| {_pm(s['rms_force_mean'], s['rms_force_std'], 2)} "
            f"| {settle} ({s['settled']}/{s['episodes']} settled) |"
        )
    return "\n".join(lines) + "\n"


def write_markdown(path: Path, title: str, summaries: Sequence[dict[str, Any]], notes: Sequence[str]) -> str:
    """Writes ``# title``, the table and the notes; returns the text."""
    text = f"# {title}\n\n{markdown_table(summaries)}\n" + "".join(f"{note}\n" for note in notes)
    Path(path).write_text(text)
    return text
