"""What every benchmark section shares: the run's settings and the context a section
writes its Markdown, plots and numbers into."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

from chaincart_env.tools.bench.bench_report import Report

__all__ = ["BenchSettings", "BenchContext", "mujoco_available"]


@dataclass(frozen=True)
class BenchSettings:
    """How the suite runs: ``quick`` (a smoke run), the vector-env sizes and link
    counts measured, where plots go (``None``: no plots) and a note for the report."""

    quick: bool = False
    sizes: tuple[int, ...] = (1, 16, 256, 4096)
    links: tuple[int, ...] = (1, 2, 5, 10)
    out_dir: Optional[Path] = None
    note: str = ""

    @property
    def min_time(self) -> float:
        """Seconds each timed loop runs at least."""
        return 0.02 if self.quick else 0.25

    @property
    def repeats(self) -> int:
        """Timed runs per measurement; the best counts (the machine is shared)."""
        return 1 if self.quick else 3


@dataclass
class BenchContext:
    """What the sections share: the settings, the report they append to, the numbers
    later sections read (``results``) and the plots written so far."""

    settings: BenchSettings
    report: Report = field(default_factory=Report)
    results: dict[str, Any] = field(default_factory=dict)
    plots: list[Path] = field(default_factory=list)

    def plot_path(self, name: str) -> Optional[Path]:
        """Where to save plot ``name`` (None when no --out was given)."""
        if self.settings.out_dir is None:
            return None
        self.settings.out_dir.mkdir(parents=True, exist_ok=True)
        path = self.settings.out_dir / name
        self.plots.append(path)
        return path


def mujoco_available() -> bool:
    """Whether MuJoCo (the ``mujoco`` extra) can be imported."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True
