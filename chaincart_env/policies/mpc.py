"""Receding-horizon iLQR along the plan, warm-started, with a budget per control step."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np

from chaincart_env.policies.planned import PlannedPolicy
from chaincart_env.policies.settings import EnvSettings

__all__ = ["MPCPolicy"]


class MPCPolicy(PlannedPolicy):
    """Model-predictive control: at every step, iLQR over the next ``horizon`` steps
    from the measured state, warm-started by the previous solution shifted by one step,
    with the plan's cost-to-go as terminal cost and at most ``iterations`` iterations
    and ``budget`` seconds per step (``Plan.mpc``). It recovers from disturbances the
    plan's feedback alone cannot. Build it with :meth:`from_env`. Like
    :class:`~chaincart_env.policies.TrajectoryPolicy` it serves episode after episode
    without ``episode_start`` or :meth:`reset`, noticing a new episode itself (see
    :class:`~chaincart_env.policies.planned.PlannedPolicy`)."""

    def __init__(
        self,
        settings: EnvSettings,
        duration: Optional[float] = None,
        *,
        horizon: int = 40,
        hold_horizon: int = 25,
        iterations: int = 2,
        budget: float = 0.002,
        **plan_options: Any,
    ) -> None:
        super().__init__(settings, duration, **plan_options)
        self.mpc_options = {"horizon": horizon, "hold_horizon": hold_horizon, "iterations": iterations, "budget": budget}

    def _controller(self, plan: Any, previous: Any) -> Any:
        controller = plan.mpc(**self.mpc_options)
        return controller

    def _force(self, controller: Any, step: int, state: np.ndarray) -> np.ndarray:
        return np.asarray(controller.force(step, state))
