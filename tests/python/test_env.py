"""The single Gymnasium env: API conformance, spaces, episode logic, errors, copies."""

from __future__ import annotations

import copy
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

from chaincart_env import ChainCartConfig, ChainCartEnv, ChainCartError, LQRPolicy


def rollout(env: gym.Env, actions: np.ndarray, seed: int) -> list:
    """(obs, reward, terminated, truncated, info) of each step; resets after an episode end."""
    out = [env.reset(seed=seed)]
    for a in actions:
        step = env.step(a)
        out.append(step)
        if step[2] or step[3]:
            out.append(env.reset())
    return out


def same(a: list, b: list) -> bool:
    if len(a) != len(b):
        return False
    for x, y in zip(a, b):
        for u, v in zip(x, y):
            if isinstance(u, np.ndarray):
                if not np.array_equal(u, v):
                    return False
            elif u != v:
                return False
    return True


@pytest.mark.parametrize(
    "kwargs",
    [dict(), dict(scene="paper-fig3"), dict(scene="paper-fig1"), dict(n_links=3, planar=False, obs_dtype="float64")],
)
def test_gymnasium_and_sb3_env_checkers_pass(kwargs: dict) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the checkers' warnings count as failures
        # Infinite bounds are Gymnasium's convention for unbounded components; its own
        # env tests ignore these two warnings of the checker as well.
        warnings.filterwarnings("ignore", message=r".*Box observation space m(in|ax)imum value is -?infinity")
        gym_check_env(ChainCartEnv(**kwargs), skip_render_check=True)
        sb3_check_env(ChainCartEnv(**kwargs), warn=True, skip_render_check=True)
        # And through gymnasium.make, with its wrappers.
        gym_check_env(gym.make("ChainCart-v0", **kwargs).unwrapped, skip_render_check=True)


def test_spaces_dtypes_and_python_types() -> None:
    env = gym.make("ChainCart-v0", scene="inverted-1")
    assert env.observation_space.shape == (5,) and env.observation_space.dtype == np.float32
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    obs, info = env.reset(seed=3)
    assert obs.dtype == np.float32 and obs in env.observation_space and info == {}
    obs, reward, terminated, truncated, info = env.step(np.array([0.2], np.float32))
    assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
    assert obs.dtype == np.float32 and obs in env.observation_space

    spatial = gym.make("ChainCart-v0", n_links=3, planar=False, obs_dtype="float64")
    assert spatial.observation_space.shape == (22,) and spatial.observation_space.dtype == np.float64
    assert spatial.action_space.shape == (2,)
    obs, _ = spatial.reset(seed=0)
    assert obs.dtype == np.float64 and obs in spatial.observation_space
    # q components are bounded by 1, everything else unbounded (Gymnasium's -inf/inf).
    big = np.inf
    expected = np.r_[np.full(4, big), np.ones(9), np.full(9, big)]
    assert np.array_equal(spatial.observation_space.high, expected)
    assert np.array_equal(spatial.observation_space.low, -expected)


def test_observation_is_the_state_and_attributes() -> None:
    env = ChainCartEnv(n_links=2, obs_dtype="float64")
    obs, _ = env.reset(seed=1)
    assert np.array_equal(obs, env.model_state)
    assert env.state.shape == (16,) and np.array_equal(env.model.from_spatial(env.state), env.model_state)
    assert env.dt == 0.02 and env.model.n_links == 2 and env.model.planar
    obs32, _ = ChainCartEnv(n_links=2).reset(seed=1)
    assert np.array_equal(obs32, obs.astype(np.float32))
    env.step(np.array([0.5]))
    assert env.elapsed_steps == 1


def test_reset_seeds_reproduce_bit_for_bit() -> None:
    env = ChainCartEnv(n_links=2, start_noise=0.2, max_episode_steps=30, track_limit=0.5)
    actions = np.random.default_rng(0).uniform(-1, 1, (100, 1)).astype(np.float32)
    first = rollout(env, actions, seed=11)
    second = rollout(ChainCartEnv(n_links=2, start_noise=0.2, max_episode_steps=30, track_limit=0.5), actions, 11)
    assert same(first, second)
    assert sum(1 for s in first[1:] if len(s) == 5 and (s[2] or s[3])) >= 2  # several episodes ran
    other = rollout(env, actions, seed=12)
    assert not np.array_equal(first[0][0], other[0][0])
    # reset() without a seed continues the stream: different starts, still reproducible.
    a, b = env.reset(seed=5)[0], env.reset()[0]
    c, d = env.reset(seed=5)[0], env.reset()[0]
    assert np.array_equal(a, c) and np.array_equal(b, d) and not np.array_equal(a, b)


def test_start_noise_is_uniform_within_its_half_width() -> None:
    env = ChainCartEnv(n_links=1, planar=False, start_noise=0.1, obs_dtype="float64")
    starts = np.array([env.reset(seed=k)[0] for k in range(300)])
    cart = starts[:, :4]
    assert np.abs(cart).max() <= 0.1 and np.abs(cart).max() > 0.09
    assert abs(cart.mean()) < 0.01  # centred
    tilt = np.arccos(np.clip(-starts[:, 6], -1, 1))  # angle from upright (q = -e3)
    assert tilt.max() <= 0.1 * np.sqrt(2) + 1e-12 and tilt.max() > 0.08
    assert np.allclose(np.linalg.norm(starts[:, 4:7], axis=1), 1.0, atol=1e-15)
    assert np.abs(np.sum(starts[:, 4:7] * starts[:, 7:10], axis=1)).max() < 1e-15


def test_actions_are_clipped_and_bad_actions_rejected() -> None:
    def final_obs(action: np.ndarray) -> np.ndarray:
        env = ChainCartEnv(n_links=1, planar=False)
        env.reset(seed=0)
        for _ in range(5):
            obs = env.step(action)[0]
        return obs

    assert np.array_equal(final_obs(np.array([3.0, -7.0])), final_obs(np.array([1.0, -1.0])))
    assert not np.array_equal(final_obs(np.array([0.5, -1.0])), final_obs(np.array([1.0, -1.0])))
    env = ChainCartEnv()
    env.reset(seed=0)
    before = env.model_state
    with pytest.raises(ChainCartError, match=r"actions\[0\] = NaN: expected a finite number"):
        env.step(np.array([np.nan], np.float32))
    with pytest.raises(ChainCartError, match=r"= inf"):
        env.step(np.array([np.inf]))
    with pytest.raises(ChainCartError, match=r"action has shape \(2,\), expected \(1,\)"):
        env.step(np.zeros(2, np.float32))
    with pytest.raises(ChainCartError, match=r"action has shape \(\), expected \(1,\)"):
        env.step(0.5)
    assert np.array_equal(env.model_state, before) and env.elapsed_steps == 0
    env.step([0.25])  # array-likes of numbers are converted
    assert env.elapsed_steps == 1


def test_reward_is_one_at_the_target_and_the_default_scene_is_stabilised_by_lqr() -> None:
    env = ChainCartEnv(start_noise=0.0)
    env.reset(seed=0)
    assert env.step(np.zeros(1, np.float32))[1] == 1.0
    env = gym.make("ChainCart-v0")
    policy = LQRPolicy.from_env(env)
    obs, _ = env.reset(seed=123)
    total, info, steps = 0.0, {}, 0
    while True:
        obs, reward, terminated, truncated, info = env.step(policy.predict(obs)[0])
        total += reward
        steps += 1
        if terminated or truncated:
            break
    assert truncated and not terminated and steps == 500
    assert info["is_success"] is True and info["numerical_failure"] is False and info["out_of_track"] is False
    assert info["e_q"] < 0.01 and info["e_w"] < 0.01
    assert total > 490.0


def test_truncation_success_and_reset_needed() -> None:
    env = ChainCartEnv(start_noise=0.0, max_episode_steps=3)
    env.reset(seed=0)
    with pytest.raises(ResetNeeded):
        ChainCartEnv().step(np.zeros(1))  # no reset yet
    infos = [env.step(np.zeros(1, np.float32)) for _ in range(3)]
    assert [s[3] for s in infos] == [False, False, True] and not any(s[2] for s in infos)
    assert infos[0][4] == {} and infos[2][4] == dict(
        is_success=True, numerical_failure=False, out_of_track=False, fell=False, e_q=0.0, e_w=0.0
    )
    with pytest.raises(ResetNeeded):
        env.step(np.zeros(1))
    env.reset()
    env.step(np.zeros(1))


def test_leaving_the_track_terminates() -> None:
    env = ChainCartEnv(track_limit=0.2, start_noise=0.0)
    env.reset(seed=0)
    for k in range(200):
        obs, reward, terminated, truncated, info = env.step(np.ones(1, np.float32))
        if terminated:
            break
    assert terminated and info["out_of_track"] and not info["is_success"] and not info["numerical_failure"]
    assert abs(obs[0]) > 0.2 and 0.0 < reward < 1.0


def test_a_lost_balance_ends_the_episode_as_a_fall_with_fall_limit() -> None:
    def unforced_episode(**keywords: float) -> tuple[int, bool, dict]:
        env = ChainCartEnv(n_links=2, start_noise=0.05, track_limit=1e300, **keywords)
        env.reset(seed=3)
        for steps in range(1, 501):
            _, _, terminated, truncated, info = env.step(np.zeros(1, np.float32))
            if terminated or truncated:
                return steps, terminated, info
        raise AssertionError("the episode did not end")

    steps, terminated, info = unforced_episode(fall_limit=0.5)
    assert terminated and info["fell"] and not info["out_of_track"] and not info["is_success"]
    assert 0.5 < info["e_q"] < 1.0 and steps < 100
    # Without a limit the fallen chain runs on to the time limit.
    steps, terminated, info = unforced_episode()
    assert not terminated and steps == 500 and not info["fell"]


def test_a_fall_hold_arms_the_fall_only_after_that_long_within_the_limit() -> None:
    def unforced_end(**keywords: float) -> tuple[int, bool]:
        env = ChainCartEnv(n_links=2, start_noise=0.05, track_limit=1e300, fall_limit=0.5, **keywords)
        env.reset(seed=3)
        for steps in range(1, 201):
            _, _, terminated, _, info = env.step(np.zeros(1, np.float32))
            if terminated:
                return steps, info["fell"]
        return 0, False

    steps, fell = unforced_end()
    assert fell and steps > 3
    dt = ChainCartEnv(n_links=2).config.dt
    # Within the limit for steps - 1 steps before the fall: a shorter hold arms it in time.
    assert unforced_end(fall_hold=(steps - 1.5) * dt) == (steps, True)
    assert unforced_end(fall_hold=(steps - 0.5) * dt) == (0, False)


def test_a_snapshot_keeps_the_steps_counted_toward_the_fall_hold() -> None:
    config = ChainCartConfig(n_links=2, start_noise=0.05, track_limit=1e300, fall_limit=0.5, fall_hold=0.2)
    batch = config.make_batch(2, "disabled")
    batch.reset([3, 4], None)
    zeros = np.zeros((2, 1), np.float32)
    for _ in range(5):  # within the limit, not yet armed (10 steps)
        batch.step(zeros)
    snap = batch.snapshot()
    assert snap["caught"].tolist() == [5, 5]

    def terminations() -> list[list[bool]]:  # up to the first episode's end
        ends = [batch.step(zeros)[2].tolist()]
        while len(ends) < 150 and not any(ends[-1]):
            ends.append(batch.step(zeros)[2].tolist())
        return ends

    ahead = terminations()
    assert len(ahead) < 150
    batch.restore(snap)
    assert terminations() == ahead
    # A snapshot from before the hold existed flags a catch: it restores as one step within.
    batch.restore({**snap, "caught": snap["caught"] > 0})
    assert batch.snapshot()["caught"].tolist() == [1, 1]


def test_a_copy_taken_after_the_catch_falls_where_the_original_falls() -> None:
    env = ChainCartEnv(n_links=2, start_noise=0.05, track_limit=1e300, fall_limit=0.5)
    env.reset(seed=3)
    env.step(np.zeros(1, np.float32))  # within the limit: caught
    twin = pickle.loads(pickle.dumps(env))
    ends = []
    for e in (env, twin):
        for steps in range(1, 500):
            _, _, terminated, _, info = e.step(np.zeros(1, np.float32))
            if terminated:
                ends.append((steps, info["fell"], info["e_q"]))
                break
    assert len(ends) == 2 and ends[0] == ends[1] and ends[0][1]


def test_a_numerical_failure_ends_the_episode_with_finite_observations() -> None:
    env = ChainCartEnv(
        n_links=2, planar=False, integrator="lie_euler", dt=5.0, max_force=1e6, track_limit=1e300, start_noise=0.3
    )
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for k in range(100):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        assert np.all(np.isfinite(obs))
        if terminated:
            break
    assert terminated and info["numerical_failure"] is True and info["is_success"] is False
    assert reward == 0.0
    assert np.all(np.isfinite(env.state)) and max(env.model.residuals(env.model_state)) < 1e-6


def test_diagnostics_only_when_asked() -> None:
    env = ChainCartEnv(n_links=2, planar=False, diagnostics=True, obs_dtype="float64")
    env.reset(seed=2)
    _, _, _, _, info = env.step(np.array([0.3, -0.2], np.float32))
    y = env.model_state
    assert info["energy"] == pytest.approx(env.model.energy(y), rel=1e-14)
    assert info["kinetic_energy"] == pytest.approx(env.model.kinetic_energy(y), rel=1e-14)
    assert info["potential_energy"] == pytest.approx(env.model.potential_energy(y), rel=1e-14)
    assert (info["residual_unit_length"], info["residual_tangency"]) == pytest.approx(env.model.residuals(y))
    assert (info["e_q"], info["e_w"]) == pytest.approx(env.model.errors(y, "inverted"))
    plain = ChainCartEnv(n_links=2, planar=False)
    plain.reset(seed=2)
    assert plain.step(np.array([0.3, -0.2], np.float32))[4] == {}


def test_render_modes() -> None:
    # More in test_render.py.
    assert ChainCartEnv.metadata["render_modes"] == ["rgb_array", "human"]
    env = ChainCartEnv(render_mode="rgb_array", render_width=64, render_height=32)
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.shape == (32, 64, 3)
    with pytest.raises(ChainCartError, match="render_mode = 'video'"):
        ChainCartEnv(render_mode="video")


def test_gym_make_passes_the_config_keywords() -> None:
    env = gym.make("ChainCart-v0", scene="paper-fig2", substeps=2, reward_weights={"x": 0.0})
    config = env.unwrapped.config
    assert (config.n_links, config.substeps, config.reward_weights.x, config.target_signs) == (5, 2, 0.0, (1,) * 5)
    env = gym.make("ChainCart-v0", config=ChainCartConfig(max_episode_steps=7))
    assert env.unwrapped.config.max_episode_steps == 7


@pytest.mark.parametrize("clone", [copy.deepcopy, lambda e: pickle.loads(pickle.dumps(e))])
def test_copies_mid_episode_continue_identically(clone) -> None:
    env = ChainCartEnv(n_links=2, start_noise=0.2, max_episode_steps=25)
    env.reset(seed=4)
    rng = np.random.default_rng(1)
    for _ in range(10):
        env.step(rng.uniform(-1, 1, 1).astype(np.float32))
    twin = clone(env)
    assert twin is not env and twin.elapsed_steps == 10
    actions = rng.uniform(-1, 1, (60, 1)).astype(np.float32)
    a, b = [], []
    for e, out in ((env, a), (twin, b)):
        for act in actions:
            step = e.step(act)
            out.append(step)
            if step[2] or step[3]:
                out.append(e.reset())  # continues the copied RNG stream
    assert same(a, b)
    # The copies are independent: stepping one does not move the other.
    twin.step(actions[0])
    assert twin.elapsed_steps != env.elapsed_steps or not np.array_equal(twin.model_state, env.model_state)
