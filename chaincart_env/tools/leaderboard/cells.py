"""The leaderboard's unit of work: one controller on one scene at one value of one
axis, over one seed's block of seeded episodes.

Seed ``s`` means the same thing for every controller: the block of evaluation starts
``s * 1000 + i`` (``i < episodes``, the same starts and the same true systems for every
controller) and, for a learned controller, its training seed. The cells are independent
of each other: they can run in any order, and their rows do not depend on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.tools.compare.evaluation import rollout
from chaincart_env.tools.leaderboard.axes import RobustnessAxis
from chaincart_env.tools.leaderboard.contestants import TimedPolicy

__all__ = ["CELL_COLUMNS", "Cell", "episode_seeds", "run_cell"]

#: Columns of ``cells.csv``: one row per (scene, controller, axis, value, seed).
CELL_COLUMNS = (
    "scene", "controller", "axis", "value", "seed", "episodes", "successes", "success_rate",
    "peak_force_mean", "rms_force_mean", "us_per_step",
)  # fmt: skip


def episode_seeds(seed: int, episodes: int) -> list[int]:
    """The evaluation starts of ``seed``'s block."""
    return [seed * 1000 + i for i in range(episodes)]


@dataclass(frozen=True)
class Cell:
    """One scene, axis value and seed of one controller."""

    scene: str
    controller: str
    axis: RobustnessAxis
    value: float
    seed: int
    episodes: int


def run_cell(cell: Cell, config: ChainCartConfig, policy: Any) -> dict[str, Any]:
    """Runs ``policy`` (deterministic) on the cell's episodes and returns its row of
    :data:`CELL_COLUMNS`."""
    variant = cell.axis.apply(config, cell.value)
    timed = TimedPolicy(policy)
    run = rollout(timed, cell.controller, variant, episode_seeds(cell.seed, cell.episodes))
    peaks, rms = [], []
    for i in range(run.episodes):
        forces = run.force[i, : run.lengths[i]]
        peaks.append(float(forces.max()))
        rms.append(float(np.sqrt(np.mean(forces**2))))
    successes = int(run.success.sum())
    return dict(
        scene=cell.scene, controller=cell.controller, axis=cell.axis.name, value=float(cell.value), seed=cell.seed,
        episodes=run.episodes, successes=successes, success_rate=successes / run.episodes,
        peak_force_mean=float(np.mean(peaks)), rms_force_mean=float(np.mean(rms)),
        us_per_step=timed.microseconds_per_step(),
    )


def cells_of(scene: str, controller: str, axes: Sequence[RobustnessAxis], values: dict[str, Sequence[float]],
             seed: int, episodes: int) -> list[Cell]:
    """Every cell of one controller on one scene for one seed, in table order."""
    return [Cell(scene, controller, axis, float(v), seed, episodes) for axis in axes for v in values[axis.name]]
