"""The chain's mirror symmetry: reflecting the whole system in the plane ``x_1 = 0``.

Gravity is along ``e3`` and the cart moves in the ``e1``-``e2`` plane, so the reflection
``R = diag(-1, 1, 1)`` maps every motion of the chain to another motion of it: a state
``y`` driven by forces ``f(t)`` goes where the mirrored state driven by the mirrored forces
goes, mirrored. For the quantities of a state that means:

* positions and velocities of the cart, unit vectors ``q_i``: ``v -> R v`` (the ``e1``
  component changes sign);
* angular velocities ``w_i``, which are pseudovectors: ``w -> det(R) R w = -R w`` (the
  ``e2`` and ``e3`` components change sign);
* the force on the cart: ``f -> R f``.

In the planar layout ``[x, xdot, (q_i.e1, q_i.e3)_i, (w_i.e2)_i]`` this negates ``x``,
``xdot``, each ``q_i.e1`` and each ``w_i.e2``, and the (one-component) force. The
equilibria are symmetric (``q_i = +-e3``), so a goal's signs at the end of a
goal-conditioned observation stay as they are, and so do the rewards, terminations and
successes of mirrored episodes. Learners can use it to double their data (mirrored
copies of collected transitions) or to check a policy's symmetry.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError

__all__ = ["Mirror"]


class Mirror:
    """The mirror images of states, observations and actions of ``config``'s scene."""

    def __init__(self, config: ChainCartConfig) -> None:
        n = config.n_links
        self._spatial = np.array([-1.0, 1.0, -1.0, 1.0] + [-1.0, 1.0, 1.0] * n + [1.0, -1.0, -1.0] * n)
        if config.planar:
            self._scene = np.array([-1.0, -1.0] + [-1.0, 1.0] * n + [-1.0] * n)
            self._action = np.array([-1.0])
        else:
            self._scene = self._spatial
            self._action = np.array([-1.0, 1.0])
        # A goal-conditioned observation ends with the target's signs, which the mirror keeps.
        tail = n if config.goal_observation else 0
        self._observation = np.concatenate([self._scene, np.ones(tail)])

    def _apply(self, signs: np.ndarray, values: Any, what: str) -> np.ndarray:
        array = np.asarray(values)
        if array.shape[-1:] != signs.shape:
            raise InvalidInputError(f"{what} of shape {array.shape}: expected a last axis of length {signs.size}")
        return array * signs.astype(array.dtype if np.issubdtype(array.dtype, np.floating) else np.float64)

    def state(self, state: Any) -> np.ndarray:
        """The mirrored state (or batch of states, last axis the state): in the scene's
        layout (the ``state`` reset option's) or, for a planar scene, the spatial one it
        embeds into (``env.state``)."""
        array = np.asarray(state)
        spatial = array.shape[-1:] == self._spatial.shape and self._scene.shape != self._spatial.shape
        return self._apply(self._spatial if spatial else self._scene, array, "state")

    def observation(self, observation: Any) -> np.ndarray:
        """The mirrored observation (or batch), in the observation's dtype."""
        return self._apply(self._observation, observation, "observation")

    def action(self, action: Any) -> np.ndarray:
        """The mirrored action (or batch): the force's ``e1`` component negated."""
        return self._apply(self._action, action, "action")

    def observation_signs(self, history: int = 0) -> np.ndarray:
        """The mirror of an observation as a sign per component (the mirror only flips
        signs): for observations carrying ``history`` steps of history
        (:mod:`chaincart_env.history`: the observation, the ``history`` before it, then
        the ``history`` actions before it), their signs too."""
        if isinstance(history, bool) or not isinstance(history, int) or history < 0:
            raise InvalidInputError(f"history = {history!r}: expected an integer >= 0")
        return np.concatenate([self._observation] * (history + 1) + [self._action] * history)

    def action_signs(self) -> np.ndarray:
        """The mirror of an action as a sign per component."""
        return self._action.copy()
