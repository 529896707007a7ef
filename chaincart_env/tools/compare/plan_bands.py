"""How far back along the planner's plan a trained agent swings up from.

A reverse curriculum widens its training starts from the end of the planner's plan
towards its start (:class:`~chaincart_env.tools.compare.curriculum.PlanStarts`). Until
the agent masters the whole plan it fails from the scene's own starts, so the study's
comparison shows no progress. This module measures what the agent did learn: its
deterministic success, and the share of episodes it held (reached the time limit
within the scene's ``fall_limit``), from starts drawn in bands of the plan counted
from its end, each band as wide as one widening of the curriculum, up to
:data:`BANDS_PAST_WINDOW` bands past the widest window the training reached.
``compare`` writes the rows to :data:`BANDS_FILE` and the report's "Along the plan"
section.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.tools.compare.curriculum import PlanStarts, plan_states, window_start
from chaincart_env.tools.compare.evaluation import Rollouts, rollout

__all__ = [
    "BANDS_FILE", "BANDS_PAST_WINDOW", "BAND_COLUMNS", "BAND_EPISODES", "BandCell", "band_cells", "band_indices",
    "band_rows", "bands_markdown", "bands_to", "evaluate_band_cell", "widest_window",
]  # fmt: skip

#: The study's table of success along the plan.
BANDS_FILE = "plan_bands.csv"
#: Episodes per band and policy.
BAND_EPISODES = 32
#: Bands measured past the widest window of the training: where the agent stops.
BANDS_PAST_WINDOW = 2
BAND_COLUMNS = ("policy", "band_start", "band_end", "episodes", "success_rate", "held_rate")


def bands_to(reach: float, width: float) -> list[tuple[float, float]]:
    """Bands of ``width`` (shares of the plan from its end) covering ``[0, reach]``,
    the last one ending at 1 at most."""
    count = max(1, math.ceil(min(1.0, reach) / width - 1e-9))
    # Rounded: 3 x 0.02 is 0.06, not 0.06000000000000001, in the tables.
    return [(round(k * width, 12), round(min(1.0, (k + 1) * width), 12)) for k in range(count)]


def band_indices(last: int, band: tuple[float, float], episodes: int, seed: int) -> np.ndarray:
    """``episodes`` steps of a plan of steps ``0..last`` drawn uniformly (seeded by
    ``seed``) from ``band``: from the start of the window ``band[1]`` up to, not
    including, the start of the window ``band[0]`` (to the plan's end for the first band)."""
    first = window_start(last, band[1])
    stop = window_start(last, band[0]) if band[0] > 0 else last + 1
    return np.random.default_rng(seed).integers(first, max(stop, first + 1), episodes)


def widest_window(curriculum_log: Path, curriculum: PlanStarts) -> float:
    """The widest window a run's curriculum log (``curriculum.csv``) records; the first
    window where the log is missing."""
    if not curriculum_log.is_file():
        return curriculum.first_window()
    with curriculum_log.open(newline="") as file:
        return max((float(row["window"]) for row in csv.DictReader(file)), default=curriculum.first_window())


@dataclass(frozen=True)
class BandCell:
    """One policy (by its name in the tables) from starts in one band of the plan:
    the seeded resets ``seeds`` moved to the plan's ``states``."""

    policy: str
    config: ChainCartConfig
    band: tuple[float, float]
    seeds: tuple[int, ...]
    states: np.ndarray


def band_cells(
    config: ChainCartConfig, reaches: Mapping[str, tuple[float, float]], eval_seed: int, episodes: int = BAND_EPISODES
) -> list[BandCell]:
    """The cells of the policies in ``reaches`` (name: ``(widest window, band width)``):
    every band to :data:`BANDS_PAST_WINDOW` bands past the widest window. Every policy
    starts from the same states in a band (drawn with ``eval_seed`` and the band's number)."""
    if not reaches:
        return []
    states = plan_states(config)
    last = states.shape[0] - 1
    seeds = tuple(eval_seed + i for i in range(episodes))
    cells = []
    for name, (window, width) in reaches.items():
        for number, band in enumerate(bands_to(window + BANDS_PAST_WINDOW * width, width)):
            picks = band_indices(last, band, episodes, eval_seed + number)
            cells.append(BandCell(name, config, band, seeds, states[picks]))
    return cells


def evaluate_band_cell(sources: Mapping[str, Any], cell: BandCell) -> Rollouts:
    """The rollouts of one :class:`BandCell` (``sources``: the policies by name, as
    :func:`~chaincart_env.tools.compare.study.evaluate_cell` takes them)."""
    return rollout(sources[cell.policy].load(), cell.policy, cell.config, cell.seeds, start_states=cell.states)


def band_rows(cells: Sequence[BandCell], runs: Sequence[Rollouts]) -> list[dict[str, Any]]:
    """One row per cell: its success rate and, where the scene sets a ``fall_limit``, the
    share of its episodes held (ended by the time limit within it; empty otherwise)."""
    rows = []
    for cell, run in zip(cells, runs):
        fall_limit = cell.config.fall_limit
        held: Optional[float] = None
        if fall_limit > 0:
            final_e_q, _ = run.final_errors()
            at_limit = (run.lengths == cell.config.max_episode_steps) & ~run.terminated
            held = float(np.mean(at_limit & (final_e_q <= fall_limit)))
        rows.append(dict(policy=cell.policy, band_start=f"{cell.band[0]:.4g}", band_end=f"{cell.band[1]:.4g}",
                         episodes=run.episodes, success_rate=float(np.mean(run.success)),
                         held_rate="" if held is None else held))
    return rows


def bands_markdown(rows: Sequence[dict[str, Any]]) -> str:
    """The rows as a Markdown table, one line per policy and band."""
    lines = ["| policy | starts in the plan's last | episodes | success | held |", "|---|---|---:|---:|---:|"]
    for row in rows:
        held = row["held_rate"]
        lines.append(f"| {row['policy']} | {float(row['band_start']):.0%}-{float(row['band_end']):.0%} | "
                     f"{row['episodes']} | {row['success_rate']:.2f} | {'' if held == '' else f'{held:.2f}'} |")
    return "\n".join(lines) + "\n"
