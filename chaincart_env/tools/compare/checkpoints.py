"""Checkpoints of a training run, and resuming from the last one.

Every ``every`` timesteps, at the first rollout boundary past each multiple (after an
update, before the next rollout is collected), :class:`Checkpointer` saves into
``checkpoints/`` everything the next rollout depends on:

* the agent (``model.zip``: weights, optimizer state, step counters, last observations;
  the replay buffer too for off-policy agents),
* the training envs mid-episode (``envs.pkl``: the ``VecMonitor`` and the native
  ``ChainCartVecEnv`` pickle with their states and per-env random streams, and the
  ``VecNormalize`` statistics of a run that normalises),
* the global random states that SB3 draws from (Python's ``random``, NumPy's legacy
  global generator, torch's CPU generator),
* how many rows the run's CSV logs had, and the best model so far.

:func:`restore` undoes an interruption: it loads all of that and cuts the logs back to
the checkpoint, so that training continued from there runs exactly as the uninterrupted
run would have (tested bit for bit for PPO; for SAC and TD3 the replay buffer is saved
too, but their exactness is not tested).
"""

from __future__ import annotations

import json
import pickle
import random
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.run_files import replace_directory, truncate_csv

__all__ = ["CHECKPOINT_DIR", "Checkpointer", "restore", "truncate_csv"]

CHECKPOINT_DIR = "checkpoints"
_MODEL, _ENVS, _RANDOM, _STATE, _BUFFER = "model.zip", "envs.pkl", "random_state.pkl", "state.json", "replay_buffer.pkl"


def _data_rows(path: Path) -> int:
    return max(0, len(Path(path).read_text().splitlines()) - 1) if Path(path).is_file() else 0


#: The counters of ``VecMonitor`` that the episode statistics continue from.
_MONITOR_FIELDS = ("episode_returns", "episode_lengths", "episode_count", "t_start")


def _envs_state(envs: Any) -> dict[str, Any]:
    """The training envs as picklable data: a ``VecMonitor`` does not pickle (it keeps
    its class's attribute table), so its counters are saved beside the native envs; a
    ``VecNormalize`` pickles without its envs and its discounted returns, saved beside it."""
    if isinstance(envs, VecNormalize):
        return {**_envs_state(envs.venv), "normalize": envs, "returns": envs.returns.copy()}
    if isinstance(envs, VecMonitor):
        return {"envs": envs.venv, "monitor": {name: getattr(envs, name) for name in _MONITOR_FIELDS}}
    return {"envs": envs, "monitor": None}


def _envs_from_state(state: dict[str, Any]) -> Any:
    envs = state["envs"]
    if state["monitor"] is not None:
        envs = VecMonitor(envs)
        for name, value in state["monitor"].items():
            setattr(envs, name, value)
    normalize = state.get("normalize")
    if normalize is None:
        return envs
    normalize.set_venv(envs)
    normalize.returns = state["returns"]
    return normalize


class Checkpointer(BaseCallback):
    """Saves a checkpoint into ``directory/checkpoints`` every ``every`` timesteps (see
    the module docstring). ``logs`` are the CSV files (names in ``directory``) whose
    row counts are recorded; ``keep`` are files copied with the checkpoint (the best
    model so far)."""

    def __init__(self, directory: Path, every: int, logs: tuple[str, ...] = (), keep: tuple[str, ...] = ()) -> None:
        super().__init__()
        if isinstance(every, bool) or not isinstance(every, int) or every < 1:
            raise InvalidInputError(f"checkpoint interval = {every!r}: expected an integer >= 1 (timesteps)")
        self.directory, self.every, self.logs, self.keep = Path(directory), every, logs, keep
        self.saved = 0
        self._next = every

    def _on_training_start(self) -> None:
        self._next = (self.num_timesteps // self.every + 1) * self.every

    def _on_rollout_start(self) -> None:
        if self.num_timesteps >= self._next:
            self.save()
            self._next = (self.num_timesteps // self.every + 1) * self.every

    def _on_step(self) -> bool:
        return True

    def save(self) -> None:
        """Writes the checkpoint into a fresh folder, then swaps it in, so an
        interruption while saving leaves the previous checkpoint whole."""
        import torch

        final = self.directory / CHECKPOINT_DIR
        staging = self.directory / (CHECKPOINT_DIR + ".tmp")
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir(parents=True)
        self.model.save(staging / _MODEL)
        if isinstance(self.model, OffPolicyAlgorithm):
            self.model.save_replay_buffer(staging / _BUFFER)
        with (staging / _ENVS).open("wb") as file:
            pickle.dump(_envs_state(self.model.get_env()), file)
        with (staging / _RANDOM).open("wb") as file:
            pickle.dump(
                {"python": random.getstate(), "numpy": np.random.get_state(), "torch": torch.get_rng_state()}, file
            )
        for name in self.keep:
            if (self.directory / name).is_file():
                shutil.copy2(self.directory / name, staging / name)
        state = {
            "timesteps": int(self.num_timesteps),
            "log_rows": {name: _data_rows(self.directory / name) for name in self.logs},
            "kept": [name for name in self.keep if (staging / name).is_file()],
        }
        (staging / _STATE).write_text(json.dumps(state, indent=2) + "\n")
        replace_directory(staging, final)
        self.saved += 1


def restore(directory: Path, algorithm: type[BaseAlgorithm]) -> tuple[BaseAlgorithm, dict[str, Any]]:
    """The agent of ``directory``'s checkpoint with its envs and random states restored
    and the run's logs cut back to it; returns the agent and the checkpoint's state."""
    import torch

    checkpoint = Path(directory) / CHECKPOINT_DIR
    if not (checkpoint / _STATE).is_file():
        raise InvalidInputError(
            f"{directory} has no checkpoint ({checkpoint / _STATE} is missing): expected a run of compare "
            "interrupted after its first checkpoint"
        )
    state = json.loads((checkpoint / _STATE).read_text())
    with (checkpoint / _ENVS).open("rb") as file:
        envs = _envs_from_state(pickle.load(file))
    model = algorithm.load(checkpoint / _MODEL, env=None, device="cpu")
    model.set_env(envs, force_reset=False)
    if (checkpoint / _BUFFER).is_file() and isinstance(model, OffPolicyAlgorithm):
        model.load_replay_buffer(checkpoint / _BUFFER)
    with (checkpoint / _RANDOM).open("rb") as file:
        states = pickle.load(file)
    random.setstate(states["python"])
    np.random.set_state(states["numpy"])
    torch.set_rng_state(states["torch"])
    for name, rows in state["log_rows"].items():
        if (Path(directory) / name).is_file():
            truncate_csv(Path(directory) / name, rows)
    for name in state["kept"]:
        shutil.copy2(checkpoint / name, Path(directory) / name)
    return model, state
