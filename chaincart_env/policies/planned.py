"""The episode bookkeeping the plan-following policies share: per env, a clock along
its plan and a controller; plans cached per (start equilibrium, target); the target
read from the observation in goal-conditioned scenes."""

from __future__ import annotations

import warnings
from typing import Any, Optional

import numpy as np

from chaincart_env.errors import InvalidInputError, PlanningError
from chaincart_env.policies.settings import (
    SCENE_PLANS, EnvSettings, env_settings, goal_signs, nearest_equilibrium, observation_batch,
)

__all__ = ["ON_FAILURE", "PLAN_FROM", "PlannedPolicy"]

Pair = tuple[tuple[int, ...], tuple[int, ...]]

#: What a plan that misses its target may do.
ON_FAILURE = ("raise", "track")

#: Where an episode's plan starts: the equilibrium nearest to its first observation (one
#: plan per pair, cached), or that observed state itself (one plan per episode).
PLAN_FROM = ("equilibrium", "state")


class PlannedPolicy:
    """Base class: subclasses say what controller follows a plan (:meth:`_controller`)
    and how it computes a force (:meth:`_force`).

    An env's episode begins where ``episode_start`` is true (SB3's convention; on the
    first call every env begins), or where the observed target changes. Its start
    equilibrium is the one nearest to the first observation; the plan from it to the
    target is computed once and cached (:meth:`plan`), so a seeded start near an
    equilibrium reuses the same plan and the feedback absorbs the difference. With
    ``plan_from="state"`` each episode plans instead from its first observed state (a
    plan per episode, one to a few seconds for three links): from a start near an unstable
    equilibrium the chain leaves it before the feedback catches up, and a plan that
    starts where the chain is needs no catching up. Where that plan misses its target,
    the cached plan from the equilibrium is followed.
    """

    def __init__(
        self, settings: EnvSettings, duration: Optional[float] = None, on_failure: str = "raise",
        plan_from: str = "equilibrium", **plan_options: Any,
    ) -> None:
        if on_failure not in ON_FAILURE:
            raise InvalidInputError(f"on_failure = {on_failure!r}: expected one of {list(ON_FAILURE)}")
        if plan_from not in PLAN_FROM:
            raise InvalidInputError(f"plan_from = {plan_from!r}: expected one of {list(PLAN_FROM)}")
        self.settings = settings
        self.duration = duration
        #: What a plan that misses its target does: "raise" a PlanningError, or "track"
        #: it anyway (the episode then fails as the plan does; :attr:`failed_pairs` lists it).
        self.on_failure = on_failure
        self.failed_pairs: set[Pair] = set()
        #: Where each episode's plan starts (:data:`PLAN_FROM`).
        self.plan_from = plan_from
        self.plan_options = plan_options
        self._plans: dict[Pair, Any] = {}
        self._clock = np.zeros(0, dtype=np.int64)
        self._pairs: list[Optional[Pair]] = []
        self._controllers: list[Any] = []

    @classmethod
    def from_env(
        cls, env: Any, *, oracle: bool = False, duration: Optional[float] = None, on_failure: str = "raise",
        plan_from: Optional[str] = None, **options: Any,
    ) -> Any:
        """For a ``ChainCartEnv``, its vector envs or SB3 VecEnv: the env's nominal model
        (``oracle=True``: its true parameters), force limit, track, control period and
        target (or, in goal-conditioned scenes, the target in each observation).
        ``duration`` (s) and the other keywords go to ``ChainCart.plan``; ``on_failure``
        says what a plan that misses its target does (``"raise"`` or ``"track"``);
        ``plan_from`` where each episode's plan starts (``"equilibrium"`` or ``"state"``).
        Left out, ``duration`` and ``plan_from`` are the scene's on ``swingup-3`` and
        ``transitions-3`` (:data:`~chaincart_env.policies.settings.SCENE_PLANS`), the
        planner's default length and ``"equilibrium"`` elsewhere."""
        settings = env_settings(env, oracle)
        scene_duration, scene_start = SCENE_PLANS.get(settings.scene, (None, "equilibrium"))
        return cls(
            settings, duration=scene_duration if duration is None else duration, on_failure=on_failure,
            plan_from=scene_start if plan_from is None else plan_from, **options,
        )

    def plan(self, start: tuple[int, ...], target: tuple[int, ...]) -> Any:
        """The plan from equilibrium ``start`` to ``target`` (cached); if it does not
        reach the target, raises :class:`~chaincart_env.errors.PlanningError`
        (``on_failure="raise"``) or warns once and returns it all the same
        (``"track"``)."""
        key = (tuple(start), tuple(target))
        plan = self._plans.get(key)
        if plan is None:
            plan = self._planned(list(start), target)
            if not plan.converged:
                message = f"no plan from {list(start)} to {list(target)}: {plan.report['reason']}"
                if self.on_failure == "raise":
                    raise PlanningError(message)
                warnings.warn(f"{message}; tracking it all the same", RuntimeWarning, stacklevel=2)
                self.failed_pairs.add(key)
            self._plans[key] = plan
        return plan

    def plan_from_state(self, state: np.ndarray, start: tuple[int, ...], target: tuple[int, ...]) -> Any:
        """A plan from the full ``state`` to ``target``, or, if it misses, the plan from the
        equilibrium ``start`` (:meth:`plan`)."""
        plan = self._planned(np.asarray(state, dtype=np.float64), target)
        return plan if plan.converged else self.plan(start, target)

    def _planned(self, start: Any, target: tuple[int, ...]) -> Any:
        """``ChainCart.plan`` from ``start`` (signs or a state) with the env's limits and this policy's options."""
        s = self.settings
        return s.model.plan(
            start, list(target), max_force=s.max_force, track_limit=s.track_limit, duration=self.duration,
            dt=s.dt, substeps=s.substeps, **self.plan_options,
        )

    def reset(self) -> None:
        """Forgets every env's episode (the next call begins new ones)."""
        self._clock = np.zeros(0, dtype=np.int64)
        self._pairs, self._controllers = [], []

    def _controller(self, plan: Any, previous: Any) -> Any:
        raise NotImplementedError

    def _force(self, controller: Any, step: int, state: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _resize(self, n: int) -> None:
        if n != len(self._pairs):
            self._clock = np.zeros(n, dtype=np.int64)
            self._pairs, self._controllers = [None] * n, [None] * n

    def forces(self, observation: Any, episode_start: Optional[Any] = None) -> np.ndarray:
        """Forces in newtons, shape (N, force_dim), advancing each env's clock."""
        batch = observation_batch(self.settings, observation)
        n, s = batch.shape[0], self.settings
        self._resize(n)
        starts = np.ones(n, dtype=bool) if episode_start is None else np.asarray(episode_start, dtype=bool).reshape(-1)
        if starts.shape[0] != n:
            raise InvalidInputError(f"episode_start has {starts.shape[0]} entries: expected {n}")
        out = np.zeros((n, s.model.force_dim))
        for i in range(n):
            state = batch[i, : s.state_dim]
            target = goal_signs(batch[i], s.n_links) if s.goal_observation else s.target
            pair = self._pairs[i]
            begins = starts[i] if episode_start is not None else pair is None
            if begins or pair is None or pair[1] != target:
                start = nearest_equilibrium(s.model, state)
                from_state = self.plan_from == "state"
                plan = self.plan_from_state(state, start, target) if from_state else self.plan(start, target)
                self._controllers[i] = self._controller(plan, self._controllers[i])
                self._pairs[i], self._clock[i] = (start, target), 0
            out[i] = self._force(self._controllers[i], int(self._clock[i]), state)
            self._clock[i] += 1
        return out

    def predict(
        self,
        observation: Any,
        state: Optional[Any] = None,
        episode_start: Optional[Any] = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Optional[Any]]:
        """Actions in the env's normalised space, clipped to [-1, 1], for one observation
        or a batch. Without ``episode_start`` an env's episode begins on its first call
        (and when its target changes); call :meth:`reset` between episodes then."""
        single = np.asarray(observation).ndim == 1
        forces = self.forces(observation, episode_start)
        actions = np.clip(forces / self.settings.max_force, -1.0, 1.0).astype(np.float32)
        return (actions[0] if single else actions), state

    def __call__(self, observation: Any) -> np.ndarray:
        return self.predict(observation)[0]
