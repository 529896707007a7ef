"""Where a study's training runs live in its run directory, and what they are called
in ``run.json``.

Each learned algorithm trains once per training seed. With one learned algorithm (the
default, and every run written before several could be compared) training seed ``s``
lives in ``seed-<s>/`` and is recorded in ``run.json``'s ``seed_runs`` as ``"<s>"``;
with several, algorithm ``a``'s seed ``s`` lives in ``<a>/seed-<s>/`` and is recorded
as ``"<a>/<s>"``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

__all__ = ["TrainingRun", "seed_directory", "training_runs"]


def seed_directory(out: Path, seed: int) -> Path:
    """Where training seed ``seed`` of a study of one learned algorithm keeps its agent
    and logs."""
    return Path(out) / f"seed-{seed}"


@dataclass(frozen=True)
class TrainingRun:
    """One learned algorithm trained with one training seed. ``shared``: the study
    trains several algorithms (their runs then live in a folder per algorithm)."""

    algo: str
    seed: int
    shared: bool = False

    def directory(self, out: Path) -> Path:
        """The run's folder in the study's directory ``out``."""
        return Path(out) / self.algo / f"seed-{self.seed}" if self.shared else seed_directory(out, self.seed)

    @property
    def key(self) -> str:
        """The run's key in ``run.json``'s ``seed_runs``."""
        return f"{self.algo}/{self.seed}" if self.shared else str(self.seed)


def training_runs(algos: Sequence[str], seeds: Sequence[int]) -> list[TrainingRun]:
    """Every training run of a study, algorithm by algorithm, each over the seeds in
    order."""
    shared = len(algos) > 1
    return [TrainingRun(algo, seed, shared) for algo in algos for seed in seeds]
