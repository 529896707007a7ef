"""Running a leaderboard: every controller on every scene, along every axis, for every
seed, into a run directory (``cells.csv``, the agents of the learned controllers, the
scores, ``leaderboard.md`` and one figure per scene).

A run can be repeated into the same directory: agents that were trained there are
reused, and the cells are evaluated again (they are cheap next to training).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.tables import write_csv
from chaincart_env.tools.leaderboard.axes import AXES, RobustnessAxis, axis_values
from chaincart_env.tools.leaderboard.cells import CELL_COLUMNS, cells_of, run_cell
from chaincart_env.tools.leaderboard.controllers import (
    LEARNED, NotApplicable, learned_agent, model_based, seeds_checked,
)  # fmt: skip

__all__ = ["LeaderboardSettings", "QUICK_EPISODES", "QUICK_TIMESTEPS", "run_leaderboard"]

#: Episodes per cell and training budget of learned agents in a quick run.
QUICK_EPISODES = 3
QUICK_TIMESTEPS = 2048
#: Episodes per cell of a full run.
FULL_EPISODES = 20


@dataclass(frozen=True)
class LeaderboardSettings:
    """What a leaderboard run evaluates."""

    scenes: tuple[str, ...]
    controllers: tuple[str, ...]
    seeds: tuple[int, ...] = (0,)
    axes: tuple[RobustnessAxis, ...] = AXES
    quick: bool = False
    episodes: Optional[int] = None
    timesteps: Optional[int] = None
    progress_bar: bool = False
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def episodes_per_cell(self) -> int:
        """Episodes of every cell."""
        if self.episodes is not None:
            return self.episodes
        return QUICK_EPISODES if self.quick else FULL_EPISODES

    @property
    def training_timesteps(self) -> Optional[int]:
        """The learned agents' budget (None: each recipe's own)."""
        if self.timesteps is not None:
            return self.timesteps
        return QUICK_TIMESTEPS if self.quick else None

    def values(self) -> dict[str, Sequence[float]]:
        """The values evaluated on each axis."""
        return {axis.name: axis_values(axis, self.quick) for axis in self.axes}

    def describe(self) -> dict[str, Any]:
        """The settings as ``leaderboard.json`` records them."""
        return dict(
            scenes=list(self.scenes), controllers=list(self.controllers), seeds=list(self.seeds),
            axes={name: [v if math.isfinite(v) else "inf" for v in values] for name, values in self.values().items()},
            quick=self.quick, episodes_per_cell=self.episodes_per_cell, training_timesteps=self.training_timesteps,
        )


def _checked(settings: LeaderboardSettings) -> None:
    seeds_checked(settings.seeds)
    if not settings.scenes or not settings.controllers:
        raise InvalidInputError("a leaderboard needs at least one scene and one controller")
    episodes = settings.episodes_per_cell
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise InvalidInputError(f"episodes = {episodes!r}: expected an integer >= 1")
    budget = settings.training_timesteps
    if budget is not None and (isinstance(budget, bool) or not isinstance(budget, int) or budget < 1):
        raise InvalidInputError(f"timesteps = {budget!r}: expected an integer >= 1")


def _controller_for_seed(
    name: str, config: ChainCartConfig, seed: int, out: Path, settings: LeaderboardSettings, cache: dict[str, Any]
) -> Any:
    if name in LEARNED:
        directory = out / "agents" / config.scene / name / f"seed-{seed}"
        return learned_agent(name, config, seed, directory, timesteps=settings.training_timesteps,
                             progress_bar=settings.progress_bar, tiny=settings.quick)
    if name not in cache:  # model-based: one design per scene, whatever the seed
        cache[name] = model_based(name, config)
    return cache[name]


def run_leaderboard(
    settings: LeaderboardSettings, out: Path, report: Optional[Path] = None,
    log: Callable[[str], None] = print,
) -> list[dict[str, Any]]:
    """Runs every cell of ``settings`` into ``out`` and writes the report (to ``report``,
    default ``out/leaderboard.md``); returns the rows of ``cells.csv``."""
    from chaincart_env.tools.leaderboard.report import write_report

    _checked(settings)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "leaderboard.json").write_text(json.dumps(settings.describe(), indent=2) + "\n")
    rows: list[dict[str, Any]] = []
    skipped: dict[tuple[str, str], str] = {}
    for scene in settings.scenes:
        config = ChainCartConfig(scene=scene, **settings.extra)
        designs: dict[str, Any] = {}
        for name in settings.controllers:
            for seed in settings.seeds:
                try:
                    policy = _controller_for_seed(name, config, seed, out, settings, designs)
                except NotApplicable as reason:
                    skipped[(scene, name)] = str(reason)
                    log(f"leaderboard: {reason} (not scored)")
                    break
                for cell in cells_of(scene, name, settings.axes, settings.values(), seed, settings.episodes_per_cell):
                    rows.append(run_cell(cell, config, policy))
                log(f"leaderboard: {scene}, {name}, seed {seed}: done")
    write_csv(out / "cells.csv", rows, CELL_COLUMNS)
    write_report(rows, settings, out, report or out / "leaderboard.md", skipped)
    return rows
