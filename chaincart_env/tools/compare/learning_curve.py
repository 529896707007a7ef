"""The learning curve: training episodes (``training_episodes.csv``) binned by
timesteps into mean return and success rate (of the stochastic training policy)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

from chaincart_env.tools.compare.shaping import LEFT_PLAN

__all__ = [
    "EPISODES_FILE", "EPISODE_END_COLUMNS", "LEARNING_CURVE_COLUMNS", "TRAINING_EPISODE_COLUMNS", "episode_ends",
    "episode_log_columns", "episode_row", "learning_curve", "read_learning_curve", "read_training_episodes",
]

#: A training run's log of every training episode (written by either trainer).
EPISODES_FILE = "training_episodes.csv"
#: Columns of ``training_episodes.csv``.
TRAINING_EPISODE_COLUMNS = (
    "timesteps", "wall_time_s", "episode", "return", "length", "is_success", "out_of_track", "numerical_failure",
    "fell", LEFT_PLAN,
)
#: How an episode ended: the columns after ``length``, each 0 or 1 from the episode's last
#: info (``left_plan``: the training's plan tube ended it).
EPISODE_END_COLUMNS = ("is_success", "out_of_track", "numerical_failure", "fell", LEFT_PLAN)


def episode_ends(info: Any) -> tuple[int, ...]:
    """The :data:`EPISODE_END_COLUMNS` of an episode whose last step's info is ``info``."""
    return tuple(int(bool(info.get(key, False))) for key in EPISODE_END_COLUMNS)


def episode_log_columns(path: Path) -> tuple[str, ...]:
    """The columns of the episode log at ``path`` that a resumed run appends to: its
    header (a log begun before a column existed goes on without it)."""
    with Path(path).open(newline="") as file:
        return tuple(next(csv.reader(file), TRAINING_EPISODE_COLUMNS))


def episode_row(columns: tuple[str, ...], start: list[Any], ends: tuple[int, ...]) -> list[Any]:
    """An episode log row in ``columns``: ``start`` (timesteps, wall time, episode, return,
    length), then how the episode ended (``ends``, :func:`episode_ends`)."""
    values = dict(zip(TRAINING_EPISODE_COLUMNS, [*start, *ends]))
    return [values[column] for column in columns]


#: Columns of ``learning_curve.csv``.
LEARNING_CURVE_COLUMNS = ("timesteps", "episodes", "return_mean", "return_std", "success_rate")


def read_training_episodes(path: Path) -> dict[str, np.ndarray]:
    """The columns of a ``training_episodes.csv`` as float arrays."""
    with Path(path).open(newline="") as file:
        rows = list(csv.DictReader(file))
    keys = ("timesteps", "wall_time_s", "return", "is_success")
    return {key: np.array([float(row[key]) for row in rows], dtype=np.float64) for key in keys}


def learning_curve(episodes: dict[str, np.ndarray], total_timesteps: int, bins: int = 40) -> list[dict[str, Any]]:
    """One row per non-empty bin of ``total_timesteps / bins`` steps, labelled by the
    bin's last timestep: the episodes that ended in it, their mean and std return and
    their success rate."""
    edges = np.linspace(0, max(total_timesteps, 1), bins + 1)
    which = np.clip(np.searchsorted(edges, episodes["timesteps"], side="left") - 1, 0, bins - 1)
    rows = []
    for b in range(bins):
        members = which == b
        if not members.any():
            continue
        returns = episodes["return"][members]
        rows.append(dict(
            timesteps=int(round(edges[b + 1])), episodes=int(members.sum()),
            return_mean=float(returns.mean()), return_std=float(returns.std()),
            success_rate=float(episodes["is_success"][members].mean()),
        ))
    return rows


def read_learning_curve(path: Path) -> list[dict[str, Any]]:
    """The rows of a ``learning_curve.csv`` (numbers as floats, counts as ints)."""
    with Path(path).open(newline="") as file:
        rows = list(csv.DictReader(file))
    integers = {"timesteps", "episodes"}
    return [{k: int(v) if k in integers else float(v) for k, v in row.items()} for row in rows]
