"""Gymnasium specs of chaincart envs that survive ``EnvSpec.to_json``.

``gymnasium.make`` records the constructor keywords in ``env.spec.kwargs``; a
``ChainCartConfig`` or ``RewardWeights`` object, a NumPy array or an
``AutoresetMode`` there cannot be written as JSON. The envs store such values as
their plain equivalents (``ChainCartConfig.to_dict`` and so on), which the
constructors accept and turn into an equal config, so
``gymnasium.make(EnvSpec.from_json(env.spec.to_json()))`` makes the same env.
"""

from __future__ import annotations

import dataclasses
import enum
from typing import Any, Optional

import numpy as np
from gymnasium.envs.registration import EnvSpec

from chaincart_env.config import ChainCartConfig, RewardWeights

__all__ = ["JsonSpec", "plain_spec", "plain_value"]


def plain_value(value: Any) -> Any:
    """``value`` as JSON-ready Python data, for the types the env constructors accept."""
    if isinstance(value, ChainCartConfig):
        return plain_value(value.to_dict())
    if isinstance(value, RewardWeights):
        return dataclasses.asdict(value)
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    if isinstance(value, dict):
        return {k: plain_value(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain_value(v) for v in value]
    return value


def plain_spec(spec: Optional[EnvSpec]) -> Optional[EnvSpec]:
    """``spec`` with its keywords as plain data (see :func:`plain_value`)."""
    if spec is None:
        return None
    kwargs = {k: (v if k == "wrappers" else plain_value(v)) for k, v in spec.kwargs.items()}
    return dataclasses.replace(spec, kwargs=kwargs)


class JsonSpec:
    """An env whose ``spec`` holds only JSON-ready keywords (set by ``gymnasium.make``)."""

    _spec: Optional[EnvSpec] = None

    @property
    def spec(self) -> Optional[EnvSpec]:
        """The env's ``EnvSpec`` (its keyword arguments kept as plain values)."""
        return self._spec

    @spec.setter
    def spec(self, value: Optional[EnvSpec]) -> None:
        self._spec = plain_spec(value)
