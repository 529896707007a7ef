"""The stable-baselines3 algorithms the main job trains, by name (what training uses
and what loading a saved run needs, without one importing the other): the learned
controllers of :mod:`chaincart_env.tools.controllers`."""

from __future__ import annotations

from typing import Any

from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.controllers import LEARNED, controller_class

__all__ = ["algorithm_class"]


def algorithm_class(name: str) -> Any:
    """The SB3 class of ``name`` (``ppo``, ``sac`` or ``td3``, any case)."""
    key = name.lower() if isinstance(name, str) else name
    if key not in LEARNED:
        raise InvalidInputError(f"unknown algorithm {name!r}: expected one of {list(LEARNED)}")
    return controller_class(key)
