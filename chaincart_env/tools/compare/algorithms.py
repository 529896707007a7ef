"""The stable-baselines3 algorithms the main job trains, by name (what training uses
and what loading a saved run needs, without one importing the other)."""

from __future__ import annotations

from stable_baselines3 import PPO, SAC, TD3
from stable_baselines3.common.base_class import BaseAlgorithm

from chaincart_env.errors import InvalidInputError

__all__ = ["ALGORITHMS", "algorithm_class"]

#: The stable-baselines3 algorithms the main job offers.
ALGORITHMS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "sac": SAC, "td3": TD3}


def algorithm_class(name: str) -> type[BaseAlgorithm]:
    """The SB3 class of ``name`` (``ppo``, ``sac`` or ``td3``, any case)."""
    try:
        return ALGORITHMS[name.lower()]
    except (KeyError, AttributeError):
        raise InvalidInputError(f"unknown algorithm {name!r}: expected one of {sorted(ALGORITHMS)}") from None
