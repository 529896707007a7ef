"""Energy shaping for one link (Astrom & Furuta 2000), then the LQR catch."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np

from chaincart_env import _core
from chaincart_env.errors import InvalidInputError
from chaincart_env.policies.settings import EnvSettings, env_settings, observation_batch

__all__ = ["EnergyPolicy"]


class EnergyPolicy:
    """The classical swing-up of a single pendulum: the cart acceleration
    ``k (E - E_up)`` along the mass's horizontal velocity pumps the pendulum's energy
    ``E`` to the upright's, within the force limit, and once the link is near upright
    and slow the LQR takes over (``_core.EnergyController``). Stateless. Build it with
    :meth:`from_env` for a one-link scene whose target is upright (``swingup-1``)."""

    def __init__(self, settings: EnvSettings, **gains: Any) -> None:
        if settings.n_links != 1 or settings.target != (-1,):
            raise InvalidInputError(
                f"EnergyPolicy for {settings.n_links} links and target {list(settings.target)}: "
                "expected one link and the upright target [-1]"
            )
        self.settings = settings
        self.controller = _core.EnergyController(settings.model, settings.max_force, **gains)

    @classmethod
    def from_env(cls, env: Any, *, oracle: bool = False, **gains: Any) -> "EnergyPolicy":
        """For a one-link ``ChainCartEnv`` (or its vector envs, SB3 VecEnv) with the upright
        target: the env's nominal model (``oracle=True``: its true parameters) and force
        limit. ``gains`` go to ``_core.EnergyController``. Refused unless the env's actions
        command a force (``actuation="force"``)."""
        return cls(env_settings(env, oracle, cls.__name__), **gains)

    def forces(self, observation: Any) -> np.ndarray:
        """Forces in newtons, shape (N, force_dim)."""
        batch = observation_batch(self.settings, observation)
        return np.array([self.controller.force(row[: self.settings.state_dim]) for row in batch])

    def predict(
        self,
        observation: Any,
        state: Optional[Any] = None,
        episode_start: Optional[Any] = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Optional[Any]]:
        """Actions in the env's normalised space, clipped to [-1, 1], for one observation
        or a batch."""
        single = np.asarray(observation).ndim == 1
        actions = np.clip(self.forces(observation) / self.settings.max_force, -1.0, 1.0).astype(np.float32)
        return (actions[0] if single else actions), state

    def __call__(self, observation: Any) -> np.ndarray:
        return self.predict(observation)[0]
