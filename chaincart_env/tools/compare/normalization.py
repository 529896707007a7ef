"""Observation (and reward) normalisation of a training recipe: the zoo's ``normalize``.

A recipe with ``normalize`` trains its agent on SB3's ``VecNormalize`` wrapped around the
``VecMonitor`` of the native envs, as RL Baselines3 Zoo does. The agent then acts on
normalised observations, so the running statistics belong to the agent: they are saved
beside every model file (``vecnormalize.pkl`` beside ``model.zip``,
``best_vecnormalize.pkl`` beside ``best_model.zip``; SB3's ``VecNormalize.save``) and a
loaded agent is a :class:`NormalizedPolicy` that normalises with them, frozen. A model
without a statistics file loads as the bare SB3 model.

A curriculum's ``spread_floor`` trains on :class:`FlooredVecNormalize`: the same
statistics, divided by a spread no smaller than a floor per component.
"""

from __future__ import annotations

import io
import pickle
from pathlib import Path
from typing import Any, Mapping, Optional

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from chaincart_env.errors import InvalidInputError

__all__ = [
    "FlooredVecNormalize", "NormalizedPolicy", "copy_agent", "load_statistics", "normalization_file",
    "normalized_envs", "observation_variance", "read_statistics", "save_agent", "variance_floor_of",
    "with_statistics",
]  # fmt: skip


class FlooredVecNormalize(VecNormalize):
    """SB3's ``VecNormalize`` whose observations are divided by a spread of at least
    ``sqrt(variance_floor)`` per component (the statistics themselves count as SB3's do).
    The floor pickles with the statistics, so a saved agent normalises as it trained."""

    def __init__(self, venv: VecEnv, variance_floor: np.ndarray, **kwargs: Any) -> None:
        super().__init__(venv, **kwargs)
        floor = np.asarray(variance_floor, dtype=np.float64)
        if floor.shape != self.observation_space.shape or not np.all(np.isfinite(floor) & (floor >= 0.0)):
            raise InvalidInputError(f"variance floor of shape {floor.shape}: expected finite values >= 0 of the "
                                    f"observations' shape {self.observation_space.shape}")
        self.variance_floor = floor

    def _normalize_obs(self, obs: np.ndarray, obs_rms: Any) -> np.ndarray:
        spread = np.sqrt(np.maximum(obs_rms.var, self.variance_floor) + self.epsilon)
        return np.clip((obs - obs_rms.mean) / spread, -self.clip_obs, self.clip_obs)

    def _unnormalize_obs(self, obs: np.ndarray, obs_rms: Any) -> np.ndarray:
        return obs * np.sqrt(np.maximum(obs_rms.var, self.variance_floor) + self.epsilon) + obs_rms.mean


def normalized_envs(
    envs: VecEnv, setting: Optional[Mapping[str, Any]], variance_floor: Optional[np.ndarray] = None
) -> VecEnv:
    """``envs`` in ``VecNormalize`` with ``setting``'s keywords (``envs`` as they are for
    ``None``); in :class:`FlooredVecNormalize` when ``variance_floor`` is given."""
    if setting is None:
        return envs
    return VecNormalize(envs, **setting) if variance_floor is None else FlooredVecNormalize(
        envs, variance_floor, **setting)


def variance_floor_of(statistics: VecNormalize) -> Optional[np.ndarray]:
    """The variance floor of a :class:`FlooredVecNormalize`, ``None`` for SB3's own. (No
    ``getattr`` with a default: on statistics loaded without envs, SB3's wrapper looks a
    missing attribute up in envs that are not there, without end.)"""
    return statistics.variance_floor if isinstance(statistics, FlooredVecNormalize) else None


def observation_variance(statistics: VecNormalize) -> np.ndarray:
    """The variance ``statistics`` divide observations by (before ``epsilon``): the counted
    one, raised to the floor of a :class:`FlooredVecNormalize`."""
    rms: Any = statistics.obs_rms
    floor = variance_floor_of(statistics)
    return np.asarray(rms.var) if floor is None else np.maximum(rms.var, floor)


def normalization_file(model_path: Path) -> Path:
    """Where the statistics of the model saved at ``model_path`` go: ``vecnormalize.pkl``
    beside ``model.zip``, ``best_vecnormalize.pkl`` beside ``best_model.zip``,
    ``<name>_vecnormalize.pkl`` beside any other ``<name>.zip``."""
    stem = Path(model_path).stem
    prefix = stem[: -len("model")] if stem.endswith("model") else stem + "_"
    return Path(model_path).with_name(prefix + "vecnormalize.pkl")


def save_agent(model: BaseAlgorithm, path: Path) -> None:
    """Saves ``model`` at ``path`` and its envs' normalisation statistics beside it
    (removing a stale statistics file when it has none)."""
    model.save(path)
    statistics, stats_path = model.get_vec_normalize_env(), normalization_file(path)
    if statistics is not None:
        statistics.save(str(stats_path))
    elif stats_path.is_file():
        stats_path.unlink()


def copy_agent(source: Path, destination: Path) -> None:
    """Copies the agent saved at ``source`` (by :func:`save_agent`) to ``destination``,
    its statistics with it (removing a stale statistics file when it has none); the
    model file goes last, so an existing ``destination`` means a complete copy."""
    import shutil

    statistics, copied = normalization_file(source), normalization_file(destination)
    if statistics.is_file():
        shutil.copyfile(statistics, copied)
    elif copied.is_file():
        copied.unlink()
    shutil.copyfile(source, destination)


def read_statistics(data: bytes) -> VecNormalize:
    """The ``VecNormalize`` pickled in ``data`` (a statistics file's contents), without envs: only
    its ``normalize_obs`` is used."""
    statistics = pickle.load(io.BytesIO(data))
    if not isinstance(statistics, VecNormalize):
        raise InvalidInputError(f"normalisation statistics hold {type(statistics).__name__}: expected a VecNormalize")
    return statistics


def load_statistics(model_path: Path) -> Optional[VecNormalize]:
    """The statistics saved beside the model file ``model_path``, or ``None`` without a file."""
    path = normalization_file(model_path)
    return read_statistics(path.read_bytes()) if path.is_file() else None


class NormalizedPolicy:
    """An SB3 model that acts on observations normalised with ``statistics`` (a
    ``VecNormalize``; only its ``normalize_obs`` is called, which never updates it).
    Everything else is the model's."""

    def __init__(self, model: BaseAlgorithm, statistics: VecNormalize) -> None:
        self.model, self.statistics = model, statistics

    def predict(
        self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = False
    ) -> tuple[np.ndarray, Any]:
        """The model's ``predict`` on ``observation`` normalised."""
        normalized = self.statistics.normalize_obs(np.asarray(observation))
        return self.model.predict(normalized, state=state, episode_start=episode_start, deterministic=deterministic)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.model, name)


def with_statistics(model: BaseAlgorithm, statistics: Optional[VecNormalize]) -> Any:
    """``model`` acting through ``statistics`` (the bare model for ``None``)."""
    return model if statistics is None else NormalizedPolicy(model, statistics)
