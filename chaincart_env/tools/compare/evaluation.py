"""Evaluation of policies on a fixed set of seeded starts, and the metrics compared.

Every policy runs on the same starts (env ``i`` reset with ``seeds[i]``, all envs in
one native batch), with deterministic actions, for one episode each. Per step the
paper's errors ``e_q``, ``e_w`` and the applied force are recorded.

**Time to settle** of an episode: the first time ``t = k dt`` (``k = 0`` is the start)
from which ``e_q <= tol_q`` and ``e_w <= tol_w`` hold at every later step to the end
of the episode, ``(tol_q, tol_w)`` being the success tolerances. It is defined exactly
for the successful episodes (those end inside the tolerances without termination);
for the others it is NaN ("never").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional, Protocol, Sequence

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import ChainCartError, InvalidInputError
from chaincart_env.policies.settings import nearest_equilibrium

__all__ = [
    "EPISODE_COLUMNS",
    "METRIC_COLUMNS",
    "Policy",
    "Rollouts",
    "TRANSITION_COLUMNS",
    "episode_table",
    "evaluate_policies",
    "evaluation_seeds",
    "rollout",
    "settle_times",
    "signs_text",
    "summarize",
    "tabulate",
    "transition_table",
]


class Policy(Protocol):
    """Anything with SB3's ``predict`` (SB3 models, :class:`~chaincart_env.LQRPolicy`)."""

    def predict(
        self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = False
    ) -> tuple[np.ndarray, Any]:
        """The actions for ``observation`` (SB3's ``predict``): ``(actions, state)``."""


def evaluation_seeds(first_seed: int, episodes: int) -> list[int]:
    """The fixed seeded starts: ``first_seed, first_seed + 1, ...``."""
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise InvalidInputError(f"eval episodes = {episodes!r}: expected an integer >= 1")
    if isinstance(first_seed, bool) or not isinstance(first_seed, int) or first_seed < 0:
        raise InvalidInputError(f"eval seed = {first_seed!r}: expected an integer >= 0")
    return [first_seed + i for i in range(episodes)]


@dataclass(frozen=True)
class Rollouts:
    """One episode per seed of one policy. Time series have one column per step
    (``e_q``/``e_w``: the start and the state after each step; ``force``: the norm of
    the applied force in N) and are NaN after an episode's end."""

    policy: str
    dt: float
    seeds: np.ndarray
    returns: np.ndarray
    lengths: np.ndarray
    success: np.ndarray
    terminated: np.ndarray
    e_q: np.ndarray
    e_w: np.ndarray
    force: np.ndarray
    #: Spatial states of the first episode, start included, shape (length + 1, 4 + 6n).
    first_states: np.ndarray
    #: Applied forces (N) of the first episode, shape (length, 2) (spatial layout).
    first_forces: np.ndarray
    #: Each episode's start equilibrium (the one nearest to its first state) and target, as signs.
    starts: tuple[tuple[int, ...], ...] = ()
    targets: tuple[tuple[int, ...], ...] = ()

    @property
    def episodes(self) -> int:
        """Number of episodes."""
        return int(self.seeds.shape[0])

    def final_errors(self) -> tuple[np.ndarray, np.ndarray]:
        """``(e_q, e_w)`` at each episode's last state."""
        rows = np.arange(self.episodes)
        return self.e_q[rows, self.lengths], self.e_w[rows, self.lengths]


def _spatial_force(force: np.ndarray) -> np.ndarray:
    return np.array([force[0], 0.0]) if force.shape[0] == 1 else force


def rollout(
    policy: Policy, name: str, config: ChainCartConfig, seeds: Sequence[int], start_states: Optional[np.ndarray] = None
) -> Rollouts:
    """Runs ``policy`` (deterministic) for one episode from each seeded start;
    ``start_states`` (model layout, one row per seed) replaces the seeded starts' states
    (the draws of a randomised scene stay the seed's)."""
    from chaincart_env.env import action_space, observation_space
    from chaincart_env.residual import on_plain_env

    n, horizon = len(seeds), config.max_episode_steps
    # An agent trained with history or the elapsed time: they are appended as it acts (and
    # a residual agent's base added).
    policy = on_plain_env(policy, observation_space(config), action_space(config), horizon)
    model = config.make_model()
    batch = config.make_batch(n, "same_step")
    obs = batch.reset(list(seeds), None)
    if start_states is not None:
        for i, state in enumerate(np.asarray(start_states, dtype=np.float64).reshape(n, -1)):
            batch.set_state(i, state)
        obs = batch.observations()
    bind = getattr(policy, "bind", None)
    if callable(bind):  # a policy that reads the true parameters (the oracle LQR)
        bind(batch)
    e_q = np.full((n, horizon + 1), np.nan)
    e_w = np.full((n, horizon + 1), np.nan)
    # Each episode's own target (drawn per reset in the goal-conditioned scenes).
    targets = [tuple(int(s) for s in row) for row in batch.targets()]
    e_q[:, 0], e_w[:, 0] = np.array([model.errors(y, t) for y, t in zip(batch.states(), targets)]).T
    starts = [nearest_equilibrium(model, np.asarray(y, dtype=np.float64)) for y in batch.states()]
    force = np.full((n, horizon), np.nan)
    returns, lengths = np.zeros(n), np.zeros(n, dtype=np.int64)
    success, terminated = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    first_states = [model.to_spatial(batch.states()[0])]
    first_forces: list[np.ndarray] = []
    active = np.ones(n, dtype=bool)
    # SB3's convention: episode_start marks the observations that begin an episode, so
    # stateful policies (a clock along a plan, a warm start) reset exactly there.
    episode_start = np.ones(n, dtype=bool)
    policy_state = None
    for k in range(horizon):
        action_batch, policy_state = policy.predict(
            obs, state=policy_state, episode_start=episode_start, deterministic=True
        )
        actions = np.asarray(action_batch, dtype=np.float32).reshape(n, -1)
        applied = np.clip(actions.astype(np.float64), -1.0, 1.0) * config.max_force
        obs, rewards, terminated_now, _, n_ended = batch.step(actions)
        errors = batch.errors()
        ended = is_success = np.zeros(n, dtype=bool)
        if n_ended:
            ended, is_success, *_, end_e_q, end_e_w = batch.episode_arrays()
            errors = np.where(ended[:, None], np.stack([end_e_q, end_e_w], axis=1), errors)
        returns[active] += rewards[active]
        force[active, k] = np.linalg.norm(applied[active], axis=1)
        e_q[active, k + 1], e_w[active, k + 1] = errors[active, 0], errors[active, 1]
        if active[0]:
            # An ended episode's last state is in its final observation (a goal-conditioned
            # scene's observation carries the target's signs after the state).
            last = batch.final_observations()[0][: model.state_dim] if ended[0] else batch.states()[0]
            first_states.append(model.to_spatial(np.asarray(last, dtype=np.float64)))
            first_forces.append(_spatial_force(applied[0]))
        episode_start = np.asarray(ended, dtype=bool).copy()
        just_ended = active & ended
        lengths[just_ended] = k + 1
        success[just_ended] = is_success[just_ended]
        terminated[just_ended] = terminated_now[just_ended]
        active &= ~ended
        if not active.any():
            break
    if active.any():
        raise ChainCartError(f"{int(active.sum())} episodes did not end within max_episode_steps = {horizon}")
    return Rollouts(
        policy=name, dt=config.dt, seeds=np.asarray(seeds, dtype=np.int64), returns=returns, lengths=lengths,
        success=success, terminated=terminated, e_q=e_q, e_w=e_w, force=force,
        first_states=np.array(first_states), first_forces=np.array(first_forces).reshape(-1, 2),
        starts=tuple(starts), targets=tuple(targets),
    )


def settle_times(rollouts: Rollouts, tolerances: tuple[float, float]) -> np.ndarray:
    """Time to settle of each episode (s; NaN when it never settles; module docstring)."""
    tol_q, tol_w = tolerances
    times = np.full(rollouts.episodes, np.nan)
    for i in np.flatnonzero(rollouts.success):
        end = rollouts.lengths[i] + 1
        outside = (rollouts.e_q[i, :end] > tol_q) | (rollouts.e_w[i, :end] > tol_w)
        if outside[-1]:
            continue  # a success always ends inside; kept for a foreign tolerance
        violations = np.flatnonzero(outside)
        times[i] = 0.0 if violations.size == 0 else (violations[-1] + 1) * rollouts.dt
    return times


#: Per-episode columns of ``episodes.csv``.
EPISODE_COLUMNS = (
    "policy", "seed", "return", "length", "is_success", "terminated",
    "final_e_q", "final_e_w", "peak_force", "rms_force", "settle_time",
)


def episode_table(rollouts: Rollouts, tolerances: tuple[float, float]) -> list[dict[str, Any]]:
    """One row per episode with :data:`EPISODE_COLUMNS`."""
    final_q, final_w = rollouts.final_errors()
    settle = settle_times(rollouts, tolerances)
    rows = []
    for i in range(rollouts.episodes):
        forces = rollouts.force[i, : rollouts.lengths[i]]
        rows.append(dict(
            policy=rollouts.policy, seed=int(rollouts.seeds[i]), **{"return": float(rollouts.returns[i])},
            length=int(rollouts.lengths[i]), is_success=int(rollouts.success[i]),
            terminated=int(rollouts.terminated[i]), final_e_q=float(final_q[i]), final_e_w=float(final_w[i]),
            peak_force=float(forces.max()), rms_force=float(np.sqrt(np.mean(forces**2))),
            settle_time=float(settle[i]),
        ))
    return rows


#: Columns of ``transitions.csv`` (one row per policy and transition between equilibria).
TRANSITION_COLUMNS = ("policy", "start", "target", "episodes", "successes", "success_rate")


def signs_text(signs: Sequence[int]) -> str:
    """An equilibrium's signs as the docs write them: ``(+,-)``."""
    return "(" + ",".join("+" if s > 0 else "-" for s in signs) + ")"


def transition_table(runs: Sequence[Rollouts]) -> list[dict[str, Any]]:
    """Success per policy and (start, target) pair met, pairs in sorted order (most
    useful on the goal-conditioned scenes, where every episode draws its pair)."""
    rows = []
    for run in runs:
        pairs = sorted(set(zip(run.starts, run.targets)), reverse=True)
        for start, target in pairs:
            mask = np.array([(s, t) == (start, target) for s, t in zip(run.starts, run.targets)])
            successes = int(run.success[mask].sum())
            rows.append(dict(policy=run.policy, start=signs_text(start), target=signs_text(target),
                             episodes=int(mask.sum()), successes=successes,
                             success_rate=successes / int(mask.sum())))
    return rows


#: Columns of ``comparison.csv`` (one row per policy).
METRIC_COLUMNS = (
    "policy", "episodes", "return_mean", "return_std", "success_rate",
    "final_e_q_mean", "final_e_q_std", "final_e_w_mean", "final_e_w_std",
    "peak_force_mean", "peak_force_std", "rms_force_mean", "rms_force_std",
    "settled", "settle_time_mean", "settle_time_std",
)


def _mean_std(values: np.ndarray) -> tuple[float, float]:
    values = values[np.isfinite(values)]
    if values.size == 0:
        return float("nan"), float("nan")
    return float(values.mean()), float(values.std())


def summarize(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The :data:`METRIC_COLUMNS` of one policy's :func:`episode_table` rows (std is
    the population standard deviation over episodes; settle time over settled ones)."""
    if not rows:
        raise InvalidInputError("no episodes to summarize: expected at least one")
    column = lambda key: np.array([row[key] for row in rows], dtype=np.float64)  # noqa: E731
    out: dict[str, Any] = {"policy": rows[0]["policy"], "episodes": len(rows)}
    for key in ("return", "final_e_q", "final_e_w", "peak_force", "rms_force", "settle_time"):
        out[f"{key}_mean"], out[f"{key}_std"] = _mean_std(column(key))
    out["success_rate"] = float(column("is_success").mean())
    out["settled"] = int(np.isfinite(column("settle_time")).sum())
    return {key: out[key] for key in METRIC_COLUMNS}


def evaluate_policies(
    policies: Sequence[tuple[str, Policy]], config: ChainCartConfig, seeds: Sequence[int],
    tolerances: Optional[tuple[float, float]] = None,
) -> tuple[list[Rollouts], list[dict[str, Any]], list[dict[str, Any]]]:
    """Rollouts, per-episode rows and summaries of each ``(name, policy)`` on ``seeds``."""
    runs = [rollout(policy, name, config, seeds) for name, policy in policies]
    return (runs, *tabulate(runs, config.success_tolerances if tolerances is None else tolerances))


def tabulate(
    runs: Sequence[Rollouts], tolerances: tuple[float, float]
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Per-episode rows and per-policy summaries of the rollouts of several policies."""
    episodes = [row for run in runs for row in episode_table(run, tolerances)]
    summaries = [summarize([row for row in episodes if row["policy"] == run.policy]) for run in runs]
    return episodes, summaries
