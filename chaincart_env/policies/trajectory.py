"""Plan, track the plan with time-varying LQR, then hold the target with its LQR."""

from __future__ import annotations

from typing import Any

import numpy as np

from chaincart_env.policies.planned import PlannedPolicy

__all__ = ["TrajectoryPolicy"]


class TrajectoryPolicy(PlannedPolicy):
    """The classical swing-up: a feed-forward plan (``ChainCart.plan``, control-limited
    iLQR) from the episode's start equilibrium to its target, tracked with time-varying
    LQR on the exact step Jacobians, then the target's LQR (same weights) once the plan
    is over. Build it with :meth:`from_env`; ``predict`` like an SB3 model. One object
    serves episode after episode: with ``episode_start`` (SB3's convention), after
    :meth:`reset`, or in the plain Gymnasium loop without either, where it notices a
    new episode itself (its time limit, or a jump of the observed positions; see
    :class:`~chaincart_env.policies.planned.PlannedPolicy`) and plans anew."""

    def _controller(self, plan: Any, previous: Any) -> Any:
        return plan.tracker()

    def _force(self, controller: Any, step: int, state: np.ndarray) -> np.ndarray:
        return np.asarray(controller.force(step, state))
