"""Deterministic evaluation during training, on a fixed set of seeded starts.

The training episodes of an on-policy agent are played with its stochastic policy and
end whenever they end; they say little about the deterministic policy a user deploys.
:class:`PeriodicEvaluation` runs that deterministic policy from the same seeded starts
(:func:`chaincart_env.tools.compare.evaluation.rollout`, one native batch) at the start of
training, every ``every`` timesteps (at the first rollout boundary past each multiple)
and at the end, writes one row per evaluation to ``evaluations.csv`` and keeps the
best model so far in ``best_model.zip`` (highest success rate, then highest mean
return; the earliest wins a tie). An agent trained on normalised observations is
evaluated through the training statistics as they are (not updated by the evaluation),
and they are saved with the best model (``best_vecnormalize.pkl``).

Evaluation draws no random numbers from the agent or the training envs, so a run
trains exactly the same with or without it.
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.evaluation import rollout
from chaincart_env.tools.compare.normalization import save_agent, with_statistics
from chaincart_env.tools.compare.run_files import (
    BEST_MODEL_FILE,
    EVALUATION_COLUMNS,
    EVALUATIONS_FILE,
    read_evaluations,
)  # fmt: skip
from chaincart_env.tools.compare.uncertainty import wilson_interval

__all__ = ["PeriodicEvaluation"]


def _score(row: dict[str, float]) -> tuple[float, float]:
    return (row["success_rate"], row["return_mean"])


class PeriodicEvaluation(BaseCallback):
    """Evaluates the deterministic policy on ``seeds`` every ``every`` timesteps (see
    the module docstring); rows go to ``directory/evaluations.csv`` and the best model
    to ``directory/best_model.zip``. With ``resume=True`` an existing file is extended
    and its best row stays the one to beat."""

    def __init__(
        self, config: ChainCartConfig, seeds: Sequence[int], every: int, directory: Path, resume: bool = False
    ) -> None:
        super().__init__()
        if isinstance(every, bool) or not isinstance(every, int) or every < 1:
            raise InvalidInputError(f"evaluation interval = {every!r}: expected an integer >= 1 (timesteps)")
        if len(seeds) == 0:
            raise InvalidInputError("evaluation seeds are empty: expected at least one seeded start")
        self.config, self.seeds, self.every = config, list(seeds), every
        self.path, self.best_path = Path(directory) / EVALUATIONS_FILE, Path(directory) / BEST_MODEL_FILE
        self.resume = resume
        self.rows: list[dict[str, float]] = []
        self.best: Optional[dict[str, float]] = None
        self._next = 0
        self._start = 0.0

    def _on_training_start(self) -> None:
        self._start = time.perf_counter()
        if self.resume and self.path.is_file():
            self.rows = read_evaluations(self.path)
            self.best = max(self.rows, key=_score, default=None)
            self._next = (int(self.rows[-1]["timesteps"]) // self.every + 1) * self.every if self.rows else 0
            offset = self.rows[-1]["wall_time_s"] if self.rows else 0.0
            self._start -= offset
        else:
            with self.path.open("w", newline="") as file:
                csv.writer(file).writerow(EVALUATION_COLUMNS)
        if self.num_timesteps >= self._next:
            self._evaluate()

    def _on_rollout_start(self) -> None:
        # After the previous update: the policy evaluated is the one that will act next.
        if self.num_timesteps >= self._next:
            self._evaluate()

    def _on_step(self) -> bool:
        return True

    def _on_training_end(self) -> None:
        if not self.rows or int(self.rows[-1]["timesteps"]) != self.num_timesteps:
            self._evaluate()

    def _evaluate(self) -> None:
        # On normalised observations, with the training statistics as they are now (read, not updated).
        policy = with_statistics(self.model, self.model.get_vec_normalize_env())
        run = rollout(policy, "agent", self.config, self.seeds)
        wins = int(run.success.sum())
        low, high = wilson_interval(wins, run.episodes)
        row = dict(
            timesteps=float(self.num_timesteps), wall_time_s=round(time.perf_counter() - self._start, 3),
            episodes=float(run.episodes), success_rate=wins / run.episodes, ci_low=low, ci_high=high,
            return_mean=float(np.mean(run.returns)), return_std=float(np.std(run.returns)),
        )
        self.rows.append(row)
        with self.path.open("a", newline="") as file:
            csv.writer(file).writerow([repr(row[key]) for key in EVALUATION_COLUMNS])
        if self.best is None or _score(row) > _score(self.best):
            self.best = row
            save_agent(self.model, self.best_path)
        self._next = (self.num_timesteps // self.every + 1) * self.every

    @property
    def best_timesteps(self) -> Optional[int]:
        """Timesteps of the best evaluation so far (``None`` before the first)."""
        return None if self.best is None else int(self.best["timesteps"])

    def summary(self) -> dict[str, Any]:
        """The best evaluation and the last one, for ``run.json``."""
        return {"best": self.best, "last": self.rows[-1] if self.rows else None, "evaluations": len(self.rows)}
