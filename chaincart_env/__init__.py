"""chaincart_env: the chain pendulum on a cart as Gymnasium and stable-baselines3
environments, its physics and RL task in Rust (``chaincart_env._core``).

* :class:`ChainCart`: the physics model (derivative, step, simulate, energy, ...).
* :class:`ChainCartConfig`, :data:`SCENES`: the validated env configuration.
* :class:`ChainCartEnv` (``gymnasium.make("ChainCart-v0", ...)``, or a scene's own id
  ``gymnasium.make("ChainCart-<scene>-v0")``: :func:`scene_env_id`) and
  :class:`ChainCartVectorEnv` (``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``).
* :class:`ChainCartVecEnv`: a stable-baselines3 VecEnv on the same Rust batch
  (imported on first use; needs the ``sb3`` extra).
* :class:`HistoryObservation`, :class:`VecHistoryObservation`: the last ``k``
  observations and actions appended to each observation (:mod:`chaincart_env.history`),
  for policies that must cope with a control delay (the VecEnv one needs the ``sb3`` extra).
* :class:`ElapsedTimeObservation`, :class:`VecElapsedTimeObservation`: the elapsed
  fraction of the episode appended to each observation (:mod:`chaincart_env.elapsed_time`),
  for policies that follow a clock, as the planner's time-varying controller does.
* :class:`ResidualAction`, :class:`VecResidualAction`, :class:`ResidualPolicy`: an agent
  whose action corrects a model-based controller (the planner's time-varying LQR, or the
  LQR where episodes start at their target) instead of replacing it
  (:mod:`chaincart_env.residual`).
* :func:`pretrained`: a shipped pretrained agent (``pretrained("inverted-2", "ppo")``),
  plain arrays acting in numpy: no torch, no unpickling.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

from chaincart_env._native import load_native_module

load_native_module()

from chaincart_env.config import DEFAULT_SCENE, SCENES, ChainCartConfig, RewardWeights  # noqa: E402
from chaincart_env.env import ChainCartEnv  # noqa: E402
from chaincart_env.errors import (  # noqa: E402
    AnalysisError,
    ChainCartError,
    IntegrationError,
    InvalidInputError,
    InvalidTypeError,
    MissingExtraError,
    PlanningError,
    UnknownKeyError,
)
from chaincart_env.model import ChainCart  # noqa: E402
from chaincart_env.registration import ENV_ID, register_envs, scene_env_id  # noqa: E402
from chaincart_env.vector import ChainCartVectorEnv  # noqa: E402

if TYPE_CHECKING:
    from chaincart_env.elapsed_time import ElapsedTimeObservation, VecElapsedTimeObservation
    from chaincart_env.history import HistoryObservation, VecHistoryObservation
    from chaincart_env.policies import EnergyPolicy, MPCPolicy, TrajectoryPolicy
    from chaincart_env.policies.lqr import LQRPolicy
    from chaincart_env.pretrained_agents import pretrained
    from chaincart_env.residual import ResidualAction, ResidualPolicy, VecResidualAction
    from chaincart_env.roa import region_of_attraction
    from chaincart_env.sb3 import ChainCartVecEnv

__all__ = [
    "AnalysisError",
    "ENV_ID",
    "IntegrationError",
    "InvalidInputError",
    "InvalidTypeError",
    "UnknownKeyError",
    "MissingExtraError",
    "ChainCart",
    "ChainCartConfig",
    "ChainCartEnv",
    "ChainCartError",
    "ChainCartVecEnv",
    "ChainCartVectorEnv",
    "DEFAULT_SCENE",
    "ElapsedTimeObservation",
    "EnergyPolicy",
    "HistoryObservation",
    "LQRPolicy",
    "MPCPolicy",
    "PlanningError",
    "ResidualAction",
    "ResidualPolicy",
    "RewardWeights",
    "SCENES",
    "TrajectoryPolicy",
    "VecElapsedTimeObservation",
    "VecHistoryObservation",
    "VecResidualAction",
    "__version__",
    "pretrained",
    "region_of_attraction",
    "scene_env_id",
]

try:
    __version__ = version("chaincart-env")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

register_envs()


def __getattr__(name: str) -> Any:
    # Lazy: stable-baselines3 (and torch) load only when the SB3 VecEnv is used.
    if name == "ChainCartVecEnv":
        from chaincart_env.extras import require

        require("ChainCartVecEnv", {"sb3": ("stable_baselines3",)})
        from chaincart_env.sb3 import ChainCartVecEnv

        return ChainCartVecEnv
    if name in ("HistoryObservation", "VecHistoryObservation"):
        from chaincart_env import history

        return getattr(history, name)
    if name in ("ElapsedTimeObservation", "VecElapsedTimeObservation"):
        from chaincart_env import elapsed_time

        return getattr(elapsed_time, name)
    if name in ("ResidualAction", "ResidualPolicy", "VecResidualAction"):
        from chaincart_env import residual

        return getattr(residual, name)
    if name == "LQRPolicy":
        from chaincart_env.policies.lqr import LQRPolicy

        return LQRPolicy
    if name in ("EnergyPolicy", "MPCPolicy", "TrajectoryPolicy"):
        from chaincart_env import policies

        return getattr(policies, name)
    if name == "pretrained":
        from chaincart_env.pretrained_agents import pretrained

        return pretrained
    if name == "region_of_attraction":
        from chaincart_env.roa import region_of_attraction

        return region_of_attraction
    raise AttributeError(f"module 'chaincart_env' has no attribute {name!r}")
