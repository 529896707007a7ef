"""The episode bookkeeping the plan-following policies share: per env, a clock along
its plan and a controller; plans cached per (start equilibrium, target); the target
read from the observation in goal-conditioned scenes."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any, Optional

import numpy as np

from chaincart_env import _core
from chaincart_env.errors import ChainCartError, InvalidInputError, PlanningError
from chaincart_env.policies.settings import (
    SCENE_PLANS,
    EnvSettings,
    env_settings,
    goal_signs,
    nearest_equilibrium,
    observation_batch,
)

__all__ = ["EPISODE_JUMP", "NOISE_MARGIN", "ON_FAILURE", "PLAN_FROM", "PlannedPolicy", "checked_plan_weights"]

Pair = tuple[tuple[int, ...], tuple[int, ...]]

#: What a plan that misses its target may do.
ON_FAILURE = ("raise", "track")

#: Where an episode's plan starts: the equilibrium nearest to its first observation (one
#: plan per pair, cached), or that observed state itself (one plan per episode).
PLAN_FROM = ("equilibrium", "state")

#: How far (m, or components of a link's unit vector) an observed position may lie from
#: where the model puts it one control period after the previous observation, under the
#: force the policy asked for then, before the observation is taken for the first of a
#: new episode. Within an episode the positions follow the model to a few hundredths
#: per period even at the leaderboard's strongest model mismatch (40 %), control delay
#: (4 periods), force noise (50 %) and force-rate limit (200 N/s) (the tests check all
#: of them at once against half the tolerance); a reset moves the cart from wherever
#: the last episode left it (off the track, when it ended early) and the links from
#: wherever they were to the start.
EPISODE_JUMP = 0.3
#: Standard deviations of the env's observation noise added to :data:`EPISODE_JUMP`:
#: two noisy observations differ by sqrt(2) of it, and ten of it is never reached.
NOISE_MARGIN = 10.0


def checked_plan_weights(weights: Any) -> dict[str, float]:
    """``weights`` (some of the planner's cost weights, ``ChainCart.plan``'s) as every
    weight, the defaults for those not given, checked; an InvalidInputError names a bad one."""
    if not isinstance(weights, Mapping):
        raise InvalidInputError(f"weights = {weights!r}: expected a dict of the planner's cost weights "
                                f"(some of {list(_core.check_plan_weights())})")
    return dict(_core.check_plan_weights(dict(weights)))


class PlannedPolicy:
    """Base class: subclasses say what controller follows a plan (:meth:`_controller`)
    and how it computes a force (:meth:`_force`).

    An env's episode begins where ``episode_start`` is true (SB3's convention; on the
    first call every env begins), or where the observed target changes. Called without
    ``episode_start`` (the plain Gymnasium loop, ``policy.predict(obs)`` after every
    ``env.reset()``), the policy notices a new episode by itself, so that one policy
    object serves episode after episode:

    * its episode has lasted the env's ``max_episode_steps``, which no episode outlasts
      (an episode that reached its time limit), or
    * the observed positions (cart, links) lie more than :attr:`jump_tolerance` from
      where the model puts them one control period after the previous observation
      under the force asked for then: a jump no control period makes (a reset after
      an episode that ended early, on the track limit, or that the caller stopped).

    The tolerance (:data:`EPISODE_JUMP` plus :data:`NOISE_MARGIN` standard deviations of
    the env's observation noise) is far above what observation noise, control delay,
    model mismatch, force noise and force-rate limits do within an episode, and far
    below a reset's jump. :meth:`reset` forgets every episode at once. Its start
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
        if plan_options.get("weights") is not None:  # checked now, not at the first plan
            plan_options["weights"] = checked_plan_weights(plan_options["weights"])
        self.plan_options = plan_options
        self._plans: dict[Pair, Any] = {}
        #: Largest gap between observed and predicted positions within one episode
        #: (class docstring): :data:`EPISODE_JUMP` plus :data:`NOISE_MARGIN` standard
        #: deviations of the env's observation noise.
        self.jump_tolerance = EPISODE_JUMP + NOISE_MARGIN * settings.obs_noise
        self._positions = _position_indices(settings.model)
        self._clock = np.zeros(0, dtype=np.int64)
        self._pairs: list[Optional[Pair]] = []
        self._controllers: list[Any] = []
        self._last_states = np.zeros((0, settings.state_dim))
        self._last_forces = np.zeros((0, settings.model.force_dim))

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
        planner's default length and ``"equilibrium"`` elsewhere. On a rig
        (:attr:`ChainCartConfig.has_rig_effects`) it plans, tracks and predicts on the
        nominal model with the config's rig (:meth:`ChainCartConfig.rig_model`): joint
        damping and cart friction move its plans, and its commands are the actuation's
        (a force, the cart's acceleration or the motor's voltage, within the env's
        command limit)."""
        settings = env_settings(env, oracle, cls.__name__, rig=True)
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
        equilibrium ``start`` (:meth:`plan`). A noisy observation is first brought onto the
        states the model has (unit link directions, spins normal to them)."""
        plan = self._planned(_on_manifold(self.settings.model, state), target)
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
        self._resize(0)

    def __getstate__(self) -> dict[str, Any]:
        # Plans and controllers are the core's objects, which do not pickle; the pairs
        # and clocks do, and a restored policy plans its pairs again (__setstate__).
        state = dict(self.__dict__)
        state["_plans"], state["_controllers"] = {}, [None] * len(self._controllers)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Restores a pickled policy: each running episode's controller is built again
        from the plan of its pair, planned anew (the planner is deterministic, so it is
        the same plan where the planner's time limit did not cut it short; an episode
        that followed a plan from its own start state follows its pair's plan)."""
        self.__dict__.update(state)
        for i, pair in enumerate(self._pairs):
            if pair is not None:
                self._controllers[i] = self._controller(self.plan(*pair), None)

    def _controller(self, plan: Any, previous: Any) -> Any:
        raise NotImplementedError

    def _force(self, controller: Any, step: int, state: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _resize(self, n: int) -> None:
        if n != len(self._pairs):
            self._clock = np.zeros(n, dtype=np.int64)
            self._pairs, self._controllers = [None] * n, [None] * n
            self._last_states = np.zeros((n, self.settings.state_dim))
            self._last_forces = np.zeros((n, self.settings.model.force_dim))

    def _new_episode(self, i: int, state: np.ndarray) -> bool:
        """Whether env ``i``'s observed ``state`` begins an episode nobody announced: its
        episode has lasted as long as the env's can, or the state jumped (class docstring)."""
        limit = self.settings.max_episode_steps
        if limit and self._clock[i] >= limit:
            return True
        return self.jump(i, state) > self.jump_tolerance

    def jump(self, i: int, state: np.ndarray) -> float:
        """The largest gap (m, or unit-vector components) between env ``i``'s observed
        positions in ``state`` and the model's prediction from its previous observation
        under the force asked for then (``inf`` where the model cannot step from it)."""
        previous = _on_manifold(self.settings.model, self._last_states[i])
        s = self.settings
        try:
            predicted = s.model.step(previous, self._last_forces[i], s.dt, "rk4", s.substeps)
        except ChainCartError:
            return float("inf")
        return float(np.max(np.abs(state[self._positions] - predicted[self._positions])))

    def forces(self, observation: Any, episode_start: Optional[Any] = None) -> np.ndarray:
        """Commands (newtons; on a rig, the actuation's unit), shape (N, force_dim),
        advancing each env's clock."""
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
            if episode_start is not None:
                begins = bool(starts[i])
            else:
                begins = pair is None or self._new_episode(i, state)
            if begins or pair is None or pair[1] != target:
                start = nearest_equilibrium(s.model, state)
                from_state = self.plan_from == "state"
                plan = self.plan_from_state(state, start, target) if from_state else self.plan(start, target)
                self._controllers[i] = self._controller(plan, self._controllers[i])
                self._pairs[i], self._clock[i] = (start, target), 0
            out[i] = self._force(self._controllers[i], int(self._clock[i]), state)
            self._clock[i] += 1
            # What the env applies (it clips the action to [-1, 1]): the next call's prediction.
            self._last_states[i] = state
            self._last_forces[i] = np.clip(out[i], -s.max_force, s.max_force)
        return out

    def predict(
        self,
        observation: Any,
        state: Optional[Any] = None,
        episode_start: Optional[Any] = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Optional[Any]]:
        """Actions in the env's normalised space, clipped to [-1, 1], for one observation
        or a batch. ``episode_start`` (one bool per env) says where episodes begin;
        without it an env's episode begins on its first call, when its target changes,
        and where the policy notices a new one (class docstring), so the plain
        Gymnasium loop needs neither ``episode_start`` nor :meth:`reset`."""
        single = np.asarray(observation).ndim == 1
        forces = self.forces(observation, episode_start)
        actions = np.clip(forces / self.settings.max_force, -1.0, 1.0).astype(np.float32)
        return (actions[0] if single else actions), state

    def __call__(self, observation: Any) -> np.ndarray:
        return self.predict(observation)[0]


def _position_indices(model: Any) -> np.ndarray:
    """The entries of a state that are positions: the cart's and the links' directions."""
    layout = model.state_layout
    return np.concatenate([np.arange(*layout["x"]), np.arange(*layout["q"])])


def _on_manifold(model: Any, state: np.ndarray) -> np.ndarray:
    """``state`` with unit link directions and (spatial) spins normal to them, as the
    model steps only such states; a noisy observation is close to one."""
    out = np.array(state, dtype=np.float64)
    n = model.n_links
    q_start, q_stop = model.state_layout["q"]
    w_start, w_stop = model.state_layout["w"]
    q = out[q_start:q_stop].reshape(n, -1)
    norms = np.linalg.norm(q, axis=1, keepdims=True)
    q /= np.where(norms > 0.0, norms, 1.0)
    if not model.planar:
        w = out[w_start:w_stop].reshape(n, -1)
        w -= np.sum(w * q, axis=1, keepdims=True) * q
    return out
