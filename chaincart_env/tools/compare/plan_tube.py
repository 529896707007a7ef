"""The plan tube: a training episode ends once the chain has left the planner's path.

Motion imitation learns fast, whip-like motions by ending an episode as soon as the
character strays from its reference (the early termination of Peng et al.'s
DeepMimic, 2018), beside starting episodes on the reference (our plan starts). Along a
swing-up the same holds: a chain that missed the plan's catch swings on for hundreds of
steps, and those steps fill the rollouts with motions no swing-up visits, while the
value of having strayed is what the episode's end makes it, nothing more. The scene's
``fall_limit`` does this near the target only; the tube does it along the whole path.

The distance is :class:`~chaincart_env.tools.compare.plan_path.PlanPath`'s, to the
nearest plan state: no clock, so a chain that keeps to the path but lags behind the
plan's timing stays in the tube. A training-only term (a setting of
:class:`~chaincart_env.tools.compare.shaping.Shaping`); evaluations end episodes as
the scene does."""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from chaincart_env.errors import InvalidInputError
from chaincart_env.front_end import episode_info
from chaincart_env.history import PicklableVecWrapper
from chaincart_env.tools.compare.plan_path import PlanPath
from chaincart_env.tools.compare.shaping import LEFT_PLAN, check_plan_tube

__all__ = ["PlanTube"]


class PlanTube(PicklableVecWrapper, VecEnvWrapper):  # type: ignore[misc]
    """The native ``ChainCartVecEnv`` ``venv`` whose episodes end (terminated) at the
    first step that leaves the chain farther than ``radius`` from every state of
    ``plan`` (model layout). That step's info says :data:`LEFT_PLAN`, with the episode
    keys of any episode's end (none of the scene's ends, the step's ``e_q`` and
    ``e_w``) and the step's observation as ``terminal_observation``; the env then starts
    its next episode as the native envs start any, from its own seeded stream. Place it
    directly around the native envs (plan starts go around it, so that they place the
    new episode too)."""

    def __init__(self, venv: Any, plan: np.ndarray, radius: float) -> None:
        from chaincart_env.sb3 import ChainCartVecEnv

        if not isinstance(venv, ChainCartVecEnv):
            raise InvalidInputError(f"the plan tube wraps the native ChainCartVecEnv: got {type(venv).__name__}")
        radius = check_plan_tube(radius)
        if radius == 0.0:  # Shaping's 0 means no tube; a tube of radius 0 would end every step
            raise InvalidInputError("plan tube = 0.0 for the wrapper: expected a radius > 0 (leave the wrapper out "
                                    "for no tube)")
        super().__init__(venv)
        self.radius = radius
        self._path = PlanPath(venv.model, plan)
        #: Episodes the tube ended so far.
        self.episodes_ended = 0

    def reset(self) -> Any:
        """The native envs' reset."""
        return self.venv.reset()

    def step_wait(self) -> VecEnvStepReturn:
        """The native envs' step; a running episode whose chain left the tube ends here."""
        native: Any = self.venv
        stepped, rewards, dones, infos = native.step_wait()
        observations = np.asarray(stepped)
        running = np.flatnonzero(~dones)
        if running.size:
            nearest = self._path.squared_distances(native._batch.states()[running]).min(axis=1)
            left = running[nearest > self.radius * self.radius]
            if left.size:
                dones = dones.copy()
                self._end(left, observations, dones, infos)
        return observations, rewards, dones, infos

    def _end(self, left: np.ndarray, observations: np.ndarray, dones: np.ndarray, infos: list[dict[str, Any]]) -> None:
        """Ends the episodes of envs ``left`` in place and starts their next ones."""
        native: Any = self.venv
        errors = native._batch.errors()
        for i in left:
            infos[i].update(episode_info(0, errors[i, 0], errors[i, 1]))
            infos[i].update({LEFT_PLAN: True, "TimeLimit.truncated": False, "terminal_observation": observations[i].copy()})
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[left] = True
        fresh = native._batch.reset(None, mask)
        observations[left] = fresh[left]
        dones[left] = True
        if native.config.has_param_gap:
            for i in left:
                infos[i]["params"] = native._batch.env_params(int(i))  # of the new episode, as the native envs say
        self.episodes_ended += int(left.size)
