"""Model-based policies, with the stable-baselines3 calling convention
(``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)``):

* :class:`LQRPolicy`: the paper's LQR at the target equilibrium (the baseline), and
  :class:`OracleLQRPolicy`, designed on each env's true parameters;
* :class:`TrajectoryPolicy`: a plan from the episode's start equilibrium to its target
  (``ChainCart.plan``), tracked with time-varying LQR, then the LQR at the target;
* :class:`MPCPolicy`: receding-horizon iLQR along that plan, with a compute budget per
  control step;
* :class:`EnergyPolicy`: energy shaping for one link, then the LQR catch.

The plan followers share the episode bookkeeping (``planned.py``: a clock per env along
its plan, plans cached per start and target, the goal read from the observation in
goal-conditioned scenes) that the stateless LQR does not need. One policy object serves episode after
episode in the plain Gymnasium loop (``env.reset(seed=s)``, then ``predict(obs)`` and
``env.step`` until the episode ends): without ``episode_start`` the plan followers
notice a new episode themselves (the episode's time limit, or a jump of the observed
positions no control period makes); ``EnergyPolicy`` keeps nothing between steps.
"""

from __future__ import annotations

from chaincart_env.policies.energy import EnergyPolicy
from chaincart_env.policies.lqr import LQRPolicy, OracleLQRPolicy
from chaincart_env.policies.mpc import MPCPolicy
from chaincart_env.policies.trajectory import TrajectoryPolicy

__all__ = ["EnergyPolicy", "LQRPolicy", "MPCPolicy", "OracleLQRPolicy", "TrajectoryPolicy"]
