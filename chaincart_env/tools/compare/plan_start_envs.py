"""The native training envs with a share of their episodes starting along the planner's
plan: the curriculum of :mod:`chaincart_env.tools.compare.curriculum` as an SB3
``VecEnvWrapper``."""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.curriculum import SEED_OFFSET, PlanStarts, plan_states

__all__ = ["PlanStartEnvs", "plan_start_envs"]


class PlanStartEnvs(VecEnvWrapper):
    """The native ``ChainCartVecEnv`` ``venv`` with a share ``fraction`` of its episodes
    starting at one of ``states`` (drawn uniformly), the draws seeded by ``seed``.
    Place it directly around the native envs (inside ``VecMonitor``)."""

    def __init__(self, venv: Any, states: np.ndarray, fraction: float, seed: int) -> None:
        PlanStarts(fraction)  # validated
        states = np.asarray(states, dtype=np.float64)
        if states.ndim != 2 or states.shape[0] < 1:
            raise InvalidInputError(f"plan states of shape {states.shape}: expected (K + 1, state_dim) with K >= 0")
        super().__init__(venv)
        self.states, self.fraction = states, float(fraction)
        self.rng = np.random.default_rng(seed + SEED_OFFSET)
        self.plan_episodes = 0

    def _start_on_plan(self, envs: np.ndarray, observations: np.ndarray) -> None:
        """Moves each of ``envs`` (just reset) onto the plan with probability ``fraction``."""
        draws = self.rng.random(len(envs))
        picks = self.rng.integers(0, self.states.shape[0], len(envs))
        chosen = [(int(i), int(k)) for i, k, u in zip(envs, picks, draws) if u < self.fraction]
        if not chosen:
            return
        native = self.venv
        for i, k in chosen:
            native.env_method("set_state", self.states[k], indices=i)
        fresh = native._batch.observations()
        for i, _ in chosen:
            observations[i] = fresh[i]
        self.plan_episodes += len(chosen)

    def reset(self) -> VecEnvObs:
        observations = self.venv.reset()
        self._start_on_plan(np.arange(self.num_envs), observations)
        return observations

    def step_wait(self) -> VecEnvStepReturn:
        observations, rewards, dones, infos = self.venv.step_wait()
        ended = np.flatnonzero(dones)
        if ended.size:
            self._start_on_plan(ended, observations)
        return observations, rewards, dones, infos

    # VecEnvWrapper keeps its class's members in an attribute and does not pickle; the
    # checkpoints pickle the training envs, so the wrapper pickles as its parts.
    def __getstate__(self) -> dict[str, Any]:
        return {"venv": self.venv, "states": self.states, "fraction": self.fraction,
                "rng": self.rng.bit_generator.state, "plan_episodes": self.plan_episodes}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["venv"], state["states"], state["fraction"], 0)
        self.rng.bit_generator.state = state["rng"]
        self.plan_episodes = state["plan_episodes"]


def plan_start_envs(venv: Any, config: Any, curriculum: PlanStarts, seed: int) -> PlanStartEnvs:
    """``venv`` (native envs of ``config``) with ``curriculum``'s plan starts, seeded by ``seed``."""
    return PlanStartEnvs(venv, plan_states(config), curriculum.fraction, seed)
