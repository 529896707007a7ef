"""How far a chain's state lies from the planner's path, as the training terms that
follow the plan measure it (the plan bonus, the plan tube).

The distance leaves the cart out, so that the path may run anywhere on the track, and
weighs angular velocities by ``rate_weight`` (0.1: a spin off by 10 rad/s counts as
much as a link turned by about one radian), since along a swing-up they reach tens of
rad/s while each link direction moves on the unit circle or sphere."""

from __future__ import annotations

from typing import Any

import numpy as np

from chaincart_env.errors import InvalidInputError

__all__ = ["RATE_WEIGHT", "PlanPath"]

#: Weight of the angular velocities in the distance to the plan.
RATE_WEIGHT = 0.1


class PlanPath:
    """The ``K + 1`` states of ``plan`` (model layout of ``model``) as points of the
    distance above (link directions, and angular velocities times ``rate_weight``)."""

    def __init__(self, model: Any, plan: np.ndarray, rate_weight: float = RATE_WEIGHT) -> None:
        plan = np.asarray(plan, dtype=np.float64)
        if plan.ndim != 2 or plan.shape[0] < 2 or plan.shape[1] != model.state_dim:
            raise InvalidInputError(f"plan of shape {plan.shape}: expected (K + 1, state_dim) states with K >= 1")
        (q_start, q_stop), (w_start, w_stop) = model.state_layout["q"], model.state_layout["w"]
        self._columns = np.r_[q_start:q_stop, w_start:w_stop]
        self._weights = np.r_[np.ones(q_stop - q_start), np.full(w_stop - w_start, rate_weight)]
        self._points = plan[:, self._columns] * self._weights

    @property
    def knots(self) -> int:
        """Number of plan states, ``K + 1``."""
        return int(self._points.shape[0])

    def squared_distances(self, states: np.ndarray) -> np.ndarray:
        """The squared distance of each of ``states`` (model layout, one per row) to
        each plan state, shape ``(len(states), K + 1)``."""
        chain = np.asarray(states, dtype=np.float64)[:, self._columns] * self._weights
        return ((chain[:, None, :] - self._points[None, :, :]) ** 2).sum(axis=2)
