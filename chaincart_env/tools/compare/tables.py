"""The comparison table: printed, and written as CSV and Markdown.

A variant of a policy (``PPO best``, the best model by evaluation; ``LQR oracle``, the
LQR designed on the true parameters) gets a row of its own only where its numbers
differ from the policy's: where the best model is the final one, or the true system is
the model, the two rows would repeat each other, and a note says so instead."""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path
from typing import Any, Optional, Sequence

from chaincart_env.tools.controllers import VARIANTS

__all__ = [
    "left_out_note", "markdown_table", "repeated_variants", "variant_base", "variant_name", "variant_notes", "write_csv",
    "write_markdown",
]  # fmt: skip

_VARIANT = re.compile(rf"(?P<base>.+) (?P<variant>{'|'.join(VARIANTS)})(?P<seed> \(seed \d+\))?")

#: Why a variant can act exactly as the policy it varies.
_SAME_BECAUSE = {
    "best": "the best model by evaluation is the final one",
    "oracle": "the true system is the model",
}


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


def variant_base(policy: str) -> Optional[str]:
    """The policy a variant varies: ``"PPO best"`` -> ``"PPO"``, ``"PPO best (seed 3)"``
    -> ``"PPO (seed 3)"``, ``"LQR oracle"`` -> ``"LQR"``; None for no variant."""
    match = _VARIANT.fullmatch(policy)
    return None if match is None else match["base"] + (match["seed"] or "")


def variant_name(policy: str) -> str:
    """A policy's name without its seed: ``"PPO best (seed 3)"`` -> ``"PPO best"``."""
    return _variant_parts(policy)[0]


def _same_numbers(a: dict[str, Any], b: dict[str, Any]) -> bool:
    keys = (set(a) | set(b)) - {"policy"}
    return all(
        a.get(k) == b.get(k)
        or (isinstance(a.get(k), float) and isinstance(b.get(k), float) and math.isnan(a[k]) and math.isnan(b[k]))
        for k in keys
    )


def repeated_variants(rows: Sequence[dict[str, Any]], setting: Sequence[str] = ()) -> dict[int, str]:
    """The rows (by index) of variants whose numbers are exactly those of the policy
    they vary at the same ``setting`` (the row keys that say where it was measured,
    e.g. ``("axis", "value")``), each with that policy's name."""
    by_key = {(r["policy"], *(r.get(k) for k in setting)): r for r in rows}
    repeated = {}
    for index, row in enumerate(rows):
        base = variant_base(row["policy"])
        other = by_key.get((base, *(row.get(k) for k in setting))) if base else None
        if other is not None and _same_numbers(row, other):
            repeated[index] = str(base)
    return repeated


def _variant_parts(policy: str) -> tuple[str, str, str]:
    """``"PPO best (seed 3)"`` -> ``("PPO best", "PPO", "best")``: the variant's and its
    policy's names without the seed, and the variant word."""
    match = _VARIANT.fullmatch(policy)
    if match is None:
        return policy, policy, ""
    return f"{match['base']} {match['variant']}", str(match["base"]), str(match["variant"])


def left_out_note(variant: str, everywhere: bool) -> str:
    """The sentence that says why ``variant`` (a variant's name, ``"PPO best"``) has no
    row where it repeats its policy: nowhere at all (``everywhere``) or only in places."""
    name, base, word = _variant_parts(variant)
    reason = _SAME_BECAUSE.get(word, "")
    reason_text = f" ({reason})" if reason else ""
    if everywhere:
        return f"{name} has no rows of its own: its numbers are {base}'s wherever it was measured{reason_text}."
    return f"{name} has rows only where its numbers differ from {base}'s; elsewhere they are the same{reason_text}."


def variant_notes(rows: Sequence[dict[str, Any]], repeated: dict[int, str]) -> list[str]:
    """One sentence per variant with rows in ``repeated`` (:func:`left_out_note`; a
    variant with other rows among ``rows`` is left out only in places)."""
    kept = {_variant_parts(r["policy"])[0] for k, r in enumerate(rows) if k not in repeated}
    names = dict.fromkeys(_variant_parts(rows[k]["policy"])[0] for k in repeated)
    return [left_out_note(name, name not in kept) for name in names]


def markdown_table(summaries: Sequence[dict[str, Any]], notes: bool = True) -> str:
    """One row per policy: mean ± std over the evaluation episodes. A variant whose
    numbers repeat its policy's is left out, and (``notes``) a note under the table
    says so."""
    repeated = repeated_variants(summaries)
    notes_text = variant_notes(summaries, repeated) if notes else []
    summaries = [s for k, s in enumerate(summaries) if k not in repeated]
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
    return "\n".join(lines) + "\n" + "".join(f"\n{note}\n" for note in notes_text)


def write_markdown(path: Path, title: str, summaries: Sequence[dict[str, Any]], notes: Sequence[str]) -> str:
    """Writes ``# title``, the table and the notes; returns the text."""
    text = f"# {title}\n\n{markdown_table(summaries)}\n" + "".join(f"{note}\n" for note in notes)
    Path(path).write_text(text)
    return text
