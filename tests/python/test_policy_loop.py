"""The README's loop with one policy object over several seeded episodes:
``obs, info = env.reset(seed=s)``, then ``policy.predict(obs)`` and ``env.step`` until
the episode ends, with neither ``episode_start`` nor ``policy.reset()``. Every built-in
policy must act in each episode exactly as it does when told where episodes begin
(``reset()`` between episodes, or SB3's ``episode_start`` flags), also under the
leaderboard's strongest observation noise, delay, mismatch, force noise and rate limit,
where the plan followers must not take a noisy step for a new episode."""

from __future__ import annotations

from typing import Any, Callable, Optional

import gymnasium as gym
import numpy as np
import pytest

import chaincart_env  # noqa: F401  (registers the ids)
from chaincart_env import ChainCartConfig, ChainCartEnv, LQRPolicy
from chaincart_env.policies import EnergyPolicy, MPCPolicy, TrajectoryPolicy
from chaincart_env.tools.leaderboard.axes import AXES

#: MPC with a compute budget no step reaches: its iterations bound it, so that its
#: actions do not depend on the machine's load and two runs can be compared exactly.
MPC_OPTIONS = {"budget": 10.0}


def _episode(env: Any, policy: Any, seed: int, flags: bool) -> tuple[bool, np.ndarray]:
    """One episode from ``env.reset(seed=seed)``: whether it succeeded and its actions;
    ``flags``: pass SB3's ``episode_start`` (true on the first step only)."""
    obs, info = env.reset(seed=seed)
    actions = []
    first = True
    while True:
        start = np.array([first]) if flags else None
        action, _ = policy.predict(obs, episode_start=start, deterministic=True)
        first = False
        actions.append(np.asarray(action))
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            return bool(info.get("is_success", False)), np.array(actions)


def _loop(
    env: Any, policy: Any, seeds: list[int], *, flags: bool = False, between: Optional[Callable[[], None]] = None
) -> list[tuple[bool, np.ndarray]]:
    """The README's loop over ``seeds`` with one policy; ``between`` runs before each episode."""
    results = []
    for seed in seeds:
        if between is not None:
            between()
        results.append(_episode(env, policy, seed, flags))
    return results


def _assert_same_episodes(plain: list[tuple[bool, np.ndarray]], told: list[tuple[bool, np.ndarray]]) -> None:
    assert [ok for ok, _ in plain] == [ok for ok, _ in told]
    for k, ((_, a), (_, b)) in enumerate(zip(plain, told)):
        assert a.shape == b.shape, f"episode {k}: {a.shape[0]} steps against {b.shape[0]}"
        np.testing.assert_array_equal(a, b, err_msg=f"episode {k}")


#: A true system drawn per episode 20 % around the model: the oracle reads it anew each episode.
MISMATCHED = {"randomize": {key: 0.2 for key in ("cart_mass", "link_masses", "link_lengths")}}

POLICIES = {
    "lqr": ("ChainCart-v0", {}, lambda env: LQRPolicy.from_env(env), [0, 1, 2, 100]),
    "lqr-oracle": ("ChainCart-v0", MISMATCHED, lambda env: LQRPolicy.from_env(env, oracle=True), [0, 1, 2, 100]),
    "energy": ("ChainCart-swingup-1-v0", {}, lambda env: EnergyPolicy.from_env(env), [0, 1, 100]),
    "trajectory": ("ChainCart-swingup-2-v0", {}, lambda env: TrajectoryPolicy.from_env(env), [0, 1, 100, 1000]),
    "mpc": ("ChainCart-swingup-2-v0", {}, lambda env: MPCPolicy.from_env(env, **MPC_OPTIONS), [0, 100, 1000]),
}


@pytest.mark.parametrize("name", list(POLICIES))
def test_the_readme_loop_succeeds_as_often_as_with_reset_between_episodes(name: str) -> None:
    env_id, keywords, build, seeds = POLICIES[name]
    env = gym.make(env_id, **keywords)
    plain = _loop(env, build(env), seeds)
    policy = build(env)
    told = _loop(env, policy, seeds, between=getattr(policy, "reset", None))
    assert sum(ok for ok, _ in told) == len(seeds), "the policy itself fails these starts: no test of the loop"
    _assert_same_episodes(plain, told)


#: The leaderboard axes that act within an episode.
WITHIN_EPISODE_AXES = ("obs_noise", "delay", "mismatch", "force_noise", "force_rate_limit")


def _strongest_value(axis_name: str) -> float:
    """An axis's strongest value: the lowest rate limit, the largest of the others."""
    axis = next(a for a in AXES if a.name == axis_name)
    return min(axis.values) if axis_name == "force_rate_limit" else max(axis.values)


def _strongest(axis_name: str, config: Optional[ChainCartConfig] = None) -> ChainCartConfig:
    """``config`` (default ``swingup-2``) at the strongest value of a leaderboard axis."""
    axis = next(a for a in AXES if a.name == axis_name)
    return axis.apply(config or ChainCartConfig(scene="swingup-2"), _strongest_value(axis_name))


@pytest.mark.parametrize("axis", WITHIN_EPISODE_AXES)
def test_no_new_episode_is_seen_within_one_under_the_leaderboard_axes(axis: str) -> None:
    env = ChainCartEnv(_strongest(axis))
    seeds = [3, 4]
    plain = _loop(env, TrajectoryPolicy.from_env(env), seeds)
    _assert_same_episodes(plain, _loop(env, TrajectoryPolicy.from_env(env), seeds, flags=True))


def test_mpc_sees_no_new_episode_within_one_under_the_strongest_observation_noise() -> None:
    env = ChainCartEnv(_strongest("obs_noise"))
    seeds = [3, 4]
    plain = _loop(env, MPCPolicy.from_env(env, **MPC_OPTIONS), seeds)
    _assert_same_episodes(plain, _loop(env, MPCPolicy.from_env(env, **MPC_OPTIONS), seeds, flags=True))


def test_within_an_episode_the_positions_stay_far_inside_the_tolerance() -> None:
    """The gap between observation and prediction under every axis at once stays below
    half the tolerance, and a reset's is above it."""
    config = ChainCartConfig(scene="swingup-2")
    for axis in WITHIN_EPISODE_AXES:
        config = _strongest(axis, config)
    env = ChainCartEnv(config)
    policy = TrajectoryPolicy.from_env(env)
    gaps = []
    obs, _ = env.reset(seed=5)
    for step in range(config.max_episode_steps):
        if step:
            gaps.append(policy.jump(0, obs.astype(np.float64)))
        action, _ = policy.predict(obs, episode_start=np.array([step == 0]))
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    assert max(gaps) < 0.5 * policy.jump_tolerance, max(gaps)
    reset_obs, _ = env.reset(seed=6)
    assert policy.jump(0, reset_obs.astype(np.float64)) > 2 * policy.jump_tolerance


def test_an_episode_cut_short_by_a_shorter_time_limit_is_noticed_by_its_jump() -> None:
    """A ``TimeLimit`` shorter than the scene's ends episodes mid-swing: no clock can
    tell, the jump of the reset does."""
    env = gym.make("ChainCart-swingup-2-v0", max_episode_steps=60)
    seeds = [0, 1, 2]
    plain = _loop(env, TrajectoryPolicy.from_env(env), seeds)
    assert all(actions.shape[0] == 60 for _, actions in plain)
    _assert_same_episodes(plain, _loop(env, TrajectoryPolicy.from_env(env), seeds, flags=True))


def test_an_episode_ended_on_the_track_limit_is_noticed_by_its_jump() -> None:
    """The plan is made for the scene's track; the env's is shorter, so the cart leaves
    it and the episode terminates early; the next episode starts over."""
    planning_env = ChainCartEnv(scene="swingup-2")
    env = ChainCartEnv(scene="swingup-2", track_limit=0.6)
    seeds = [0, 1]
    plain = _loop(env, TrajectoryPolicy.from_env(planning_env), seeds)
    assert all(actions.shape[0] < env.config.max_episode_steps for _, actions in plain)
    _assert_same_episodes(plain, _loop(env, TrajectoryPolicy.from_env(planning_env), seeds, flags=True))


def test_episode_start_and_reset_still_say_where_episodes_begin() -> None:
    """``episode_start`` overrides what the policy would notice: a false flag keeps the
    episode going, a true one starts it over; ``reset()`` forgets every episode."""
    env = ChainCartEnv(scene="swingup-2")
    policy = TrajectoryPolicy.from_env(env)
    obs, _ = env.reset(seed=0)
    first, _ = policy.predict(obs, episode_start=np.array([True]))
    for _ in range(30):
        obs, *_ = env.step(policy.predict(obs, episode_start=np.array([False]))[0])
    start, _ = env.reset(seed=0)
    # The reset jumps, but a false flag says the episode goes on: the clock is not 0.
    continued, _ = policy.predict(start, episode_start=np.array([False]))
    assert not np.array_equal(continued, first)
    again, _ = policy.predict(start, episode_start=np.array([True]))
    np.testing.assert_array_equal(again, first)
    policy.predict(start)
    policy.reset()
    np.testing.assert_array_equal(policy.predict(start)[0], first)



def _vector_run(mode: Any, flags: bool, steps: int) -> tuple[np.ndarray, int]:
    """Observations of a two-env vector env with autoreset ``mode`` driven by one
    policy for ``steps`` steps, and how many episodes ended; ``flags``: pass
    ``episode_start`` where an env's observation is a reset's."""
    from gymnasium.vector import AutoresetMode

    from chaincart_env import ChainCartVectorEnv

    env = ChainCartVectorEnv(2, scene="swingup-2", max_episode_steps=120, track_limit=1.0, autoreset_mode=mode)
    policy = TrajectoryPolicy.from_env(ChainCartEnv(scene="swingup-2"))
    obs, _ = env.reset(seed=7)
    starts, previous_done, ended, seen = np.ones(2, dtype=bool), np.zeros(2, dtype=bool), 0, [obs]
    for _ in range(steps):
        actions, _ = policy.predict(obs, episode_start=starts if flags else None)
        obs, _, terminated, truncated, _ = env.step(actions)
        done = terminated | truncated
        ended += int(done.sum())
        # Same-step autoreset: a done step's observation is already the reset's;
        # next-step: the observation after a done one is.
        starts = done if mode == AutoresetMode.SAME_STEP else previous_done
        previous_done = done
        seen.append(obs)
    return np.array(seen), ended


@pytest.mark.parametrize("mode", ["next_step", "same_step"])
def test_a_vector_env_s_autoresets_are_noticed_per_env(mode: str) -> None:
    """Episodes shortened (120 steps, a 1 m track) so that the envs end at different
    steps, on the time limit or the track's; without the flags the observations are
    the same as with them."""
    from chaincart_env.vector import autoreset_mode_of

    kind = autoreset_mode_of(mode)
    plain, ended = _vector_run(kind, flags=False, steps=400)
    told, _ = _vector_run(kind, flags=True, steps=400)
    assert ended >= 4
    np.testing.assert_array_equal(plain, told)
