"""The SB3 ``VecEnv`` wrappers of the training reward's shaping
(:mod:`~chaincart_env.tools.compare.shaping` has the settings and why)."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper

from chaincart_env.errors import InvalidInputError
from chaincart_env.history import PicklableVecWrapper
from chaincart_env.tools.compare.plan_path import PlanPath
from chaincart_env.tools.compare.shaping import (
    Shaping,
    check_action_change_penalty,
    check_off_track_penalty,
    check_plan_bonus,
)

__all__ = ["ActionChangePenalty", "OffTrackPenalty", "PlanProgress", "shaped_envs"]


class OffTrackPenalty(PicklableVecWrapper, VecEnvWrapper):  # type: ignore[misc]
    """A stable-baselines3 ``VecEnv`` (whose infos say ``out_of_track``) with ``penalty``
    subtracted from the reward of each step that leaves the track."""

    def __init__(self, venv: Any, penalty: float) -> None:
        super().__init__(venv)
        self.penalty = check_off_track_penalty(penalty)

    def reset(self) -> Any:
        """The wrapped envs' reset."""
        return self.venv.reset()

    def step_wait(self) -> Any:
        """The wrapped envs' step, with the penalty on each step that left the track."""
        obs, rewards, dones, infos = self.venv.step_wait()
        for i in np.flatnonzero(dones):
            if infos[i].get("out_of_track", False):
                rewards[i] -= self.penalty
        return obs, rewards, dones, infos


class PlanProgress(PicklableVecWrapper, VecEnvWrapper):  # type: ignore[misc]
    """chaincart's SB3 ``VecEnv`` (possibly wrapped) with the plan bonus
    ``scale * max_k (k / K) exp(-d_k^2 / width^2)`` added to the reward of each step that
    did not end its episode (an ended env already holds its next start). ``d_k``: the
    distance of the chain's state to state ``k`` of the ``K + 1`` of ``plan`` (model
    layout), as :class:`~chaincart_env.tools.compare.plan_path.PlanPath` measures it."""

    def __init__(self, venv: Any, scale: float, plan: np.ndarray, width: float = 0.5) -> None:
        super().__init__(venv)
        self.scale = check_plan_bonus(scale)
        self._path = PlanPath(venv.unwrapped.model, plan)
        self._progress = np.linspace(0.0, 1.0, self._path.knots)
        self._inverse_width2 = 1.0 / (width * width)

    def bonus(self, states: np.ndarray) -> np.ndarray:
        """The bonus of each of ``states`` (model layout, one per row)."""
        distance2 = self._path.squared_distances(states)
        return self.scale * (self._progress * np.exp(-distance2 * self._inverse_width2)).max(axis=1)

    def reset(self) -> Any:
        """The wrapped envs' reset."""
        return self.venv.reset()

    def step_wait(self) -> Any:
        """The wrapped envs' step, with the bonus on each step that did not end an episode."""
        obs, rewards, dones, infos = self.venv.step_wait()
        running = ~np.asarray(dones, dtype=bool)
        if running.any():
            native: Any = self.venv.unwrapped  # chaincart's envs: the states after the step
            states = native._batch.states()[running]
            rewards = np.array(rewards, dtype=np.float32)
            rewards[running] += self.bonus(states).astype(np.float32)
        return obs, rewards, dones, infos


class ActionChangePenalty(PicklableVecWrapper, VecEnvWrapper):  # type: ignore[misc]
    """A stable-baselines3 ``VecEnv`` with ``scale`` times the mean squared change of each
    env's action (clipped to the action space, then scaled to [-1, 1]; the action before
    an episode's first is 0) subtracted from every step's reward."""

    def __init__(self, venv: Any, scale: float) -> None:
        super().__init__(venv)
        self.scale = check_action_change_penalty(scale)
        low, high = np.asarray(venv.action_space.low, np.float64), np.asarray(venv.action_space.high, np.float64)
        if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and np.all(high > low)):
            raise InvalidInputError(f"action space {venv.action_space}: expected a bounded Box")
        self._low, self._high = low, high
        self._previous = np.zeros((venv.num_envs, low.size))
        self._actions = self._previous.copy()

    def _unit(self, actions: np.ndarray) -> np.ndarray:
        clipped = np.clip(np.asarray(actions, np.float64).reshape(self._previous.shape), self._low, self._high)
        return 2.0 * (clipped - self._low) / (self._high - self._low) - 1.0

    def reset(self) -> Any:
        """The wrapped envs' reset: every env's previous action 0."""
        self._previous[:] = 0.0
        return self.venv.reset()

    def step_async(self, actions: np.ndarray) -> None:
        """Remember the actions, then send them on."""
        self._actions = self._unit(actions)
        self.venv.step_async(actions)

    def step_wait(self) -> Any:
        """The wrapped envs' step, with the penalty on each env's change of action."""
        obs, rewards, dones, infos = self.venv.step_wait()
        change2 = ((self._actions - self._previous) ** 2).mean(axis=1)
        rewards = np.array(rewards, dtype=np.float32) - (self.scale * change2).astype(np.float32)
        self._previous = np.where(np.asarray(dones, dtype=bool)[:, None], 0.0, self._actions)
        return obs, rewards, dones, infos


def shaped_envs(venv: Any, shaping: Shaping, plan: Optional[np.ndarray]) -> Any:
    """``venv`` (chaincart's SB3 envs, possibly wrapped) with the terms of ``shaping`` in
    use: the plan bonus (along ``plan``, the planner's states) inside, then the
    action-change penalty, the off-track penalty outside."""
    if shaping.plan_bonus:
        if plan is None:
            raise InvalidInputError(f"plan bonus {shaping.plan_bonus} without a plan: expected the planner's states")
        venv = PlanProgress(venv, shaping.plan_bonus, plan)
    if shaping.action_change_penalty:
        venv = ActionChangePenalty(venv, shaping.action_change_penalty)
    if shaping.off_track_penalty:
        venv = OffTrackPenalty(venv, shaping.off_track_penalty)
    return venv
