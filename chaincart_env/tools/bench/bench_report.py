"""Markdown output of the benchmark suite: tables, number formats, the collected report."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

__all__ = ["Report", "markdown_table", "fmt_rate", "fmt_ratio", "fmt_sci", "fmt_time"]


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]], numeric_from: int = 1) -> list[str]:
    """A Markdown table; columns from ``numeric_from`` on are right-aligned."""
    if any(len(row) != len(header) for row in rows):
        raise ValueError(f"every row needs {len(header)} cells (the header's), got {[len(r) for r in rows]}")
    align = ["---" if i < numeric_from else "---:" for i in range(len(header))]
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def fmt_rate(x: Optional[float]) -> str:
    """Steps per second with an SI prefix (k, M)."""
    if x is None or not math.isfinite(x):
        return "n/a"
    if x >= 1e6:
        return f"{x / 1e6:.2f} M"
    if x >= 1e3:
        return f"{x / 1e3:.1f} k"
    return f"{x:.0f}"


def fmt_ratio(a: Optional[float], b: Optional[float]) -> str:
    """``a / b`` as ``1.23x``."""
    if a is None or b is None or b <= 0:
        return "n/a"
    return f"{a / b:.2f}x"


def fmt_sci(x: Optional[float]) -> str:
    """``x`` in scientific notation with two digits, ``n/a`` when missing or not finite."""
    if x is None or not math.isfinite(x):
        return "n/a"
    return f"{x:.1e}"


def fmt_time(seconds: Optional[float]) -> str:
    """A duration in the unit that keeps 3 significant digits readable."""
    if seconds is None or not math.isfinite(seconds):
        return "n/a"
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6)):
        if seconds >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds / 1e-9:.3g} ns"


@dataclass
class Report:
    """The suite's Markdown, built section by section (printed as it grows)."""

    lines: list[str] = field(default_factory=list)
    echo: bool = True
    heading_level: int = 2

    def _emit(self, new: Sequence[str]) -> None:
        self.lines.extend(new)
        if self.echo:
            print("\n".join(new), flush=True)

    def heading(self, text: str, depth: int = 0) -> None:
        """Appends a heading ``depth`` levels below the report's own."""
        self._emit(["#" * (self.heading_level + depth) + " " + text, ""])

    def paragraph(self, text: str) -> None:
        """Appends a paragraph."""
        self._emit([text, ""])

    def table(self, header: Sequence[str], rows: Sequence[Sequence[str]], numeric_from: int = 1) -> None:
        """Appends a Markdown table (columns from ``numeric_from`` on right-aligned)."""
        self._emit(markdown_table(header, rows, numeric_from) + [""])

    def text(self) -> str:
        """The whole report as Markdown."""
        return "\n".join(self.lines).rstrip() + "\n"
