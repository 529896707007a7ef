"""Model-based policies for large motions, with the stable-baselines3 calling convention
(``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)``):

* :class:`TrajectoryPolicy`: a plan from the episode's start equilibrium to its target
  (``ChainCart.plan``), tracked with time-varying LQR, then the LQR at the target;
* :class:`MPCPolicy`: receding-horizon iLQR along that plan, with a compute budget per
  control step;
* :class:`EnergyPolicy`: energy shaping for one link, then the LQR catch.

They live in a subpackage of their own because they share the episode bookkeeping
(``planned.py``: a clock per env along its plan, plans cached per start and target, the
goal read from the observation in goal-conditioned scenes) that the stateless
:class:`~chaincart_env.LQRPolicy` does not need. One policy object serves episode after
episode in the plain Gymnasium loop (``env.reset(seed=s)``, then ``predict(obs)`` and
``env.step`` until the episode ends): without ``episode_start`` the plan followers
notice a new episode themselves (the episode's time limit, or a jump of the observed
positions no control period makes); ``EnergyPolicy`` keeps nothing between steps.
"""

from __future__ import annotations

from chaincart_env.policies.energy import EnergyPolicy
from chaincart_env.policies.mpc import MPCPolicy
from chaincart_env.policies.trajectory import TrajectoryPolicy

__all__ = ["EnergyPolicy", "MPCPolicy", "TrajectoryPolicy"]
