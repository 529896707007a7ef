"""Robustness: bad input everywhere, random configs and actions, threads, memory.

Hypothesis drives random scenes (masses and lengths over several decades, forces up
to 1e6 N, steps from 1e-4 s to 0.1 s, every fixed-step integrator) and random action
sequences through the env and the vector env: every observation is finite and in the
observation space, or the episode ended with a flag saying why.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from chaincart_env import ChainCartEnv, ChainCartError, ChainCartVectorEnv

FIXED_STEP = ("rk4", "rkmk4", "variational", "lie_euler")


def log_uniform(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(np.log10(lo), np.log10(hi)).map(lambda e: float(10.0**e))


@st.composite
def configs(draw: st.DrawFn) -> dict:
    n = draw(st.integers(1, 4))
    return dict(
        n_links=n,
        planar=draw(st.booleans()),
        cart_mass=draw(log_uniform(1e-2, 1e2)),
        link_masses=[draw(log_uniform(1e-3, 1e2)) for _ in range(n)],
        link_lengths=[draw(log_uniform(1e-2, 10.0)) for _ in range(n)],
        target=[draw(st.sampled_from([-1, 1])) for _ in range(n)],
        start=draw(st.sampled_from(["target", "hanging", "inverted"])),
        start_noise=draw(st.floats(0.0, 0.5)),
        dt=draw(log_uniform(1e-4, 0.1)),
        integrator=draw(st.sampled_from(FIXED_STEP)),
        substeps=draw(st.integers(1, 3)),
        max_force=draw(st.one_of(st.just(0.0), log_uniform(1e-2, 1e6))),
        track_limit=draw(log_uniform(0.1, 100.0)),
        max_episode_steps=draw(st.integers(5, 30)),
    )


def actions(dim: int) -> st.SearchStrategy[np.ndarray]:
    # Out-of-range values on purpose: they are clipped to [-1, 1].
    return st.lists(st.lists(st.floats(-3.0, 3.0), min_size=dim, max_size=dim), min_size=1, max_size=30).map(
        lambda rows: np.asarray(rows, dtype=np.float32)
    )


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(config=configs(), data=st.data())
def test_observations_are_in_the_space_or_the_episode_is_flagged(config: dict, data: st.DataObject) -> None:
    env = ChainCartEnv(**config)
    obs, _ = env.reset(seed=data.draw(st.integers(0, 2**32)))
    assert env.observation_space.contains(obs)
    for action in data.draw(actions(env.action_space.shape[0])):
        obs, reward, terminated, truncated, info = env.step(action)
        assert np.all(np.isfinite(obs)), obs
        assert env.observation_space.contains(obs)
        assert 0.0 <= reward <= 1.0
        if terminated:
            # A termination always says why.
            assert info["numerical_failure"] or info["out_of_track"], info
        if terminated or truncated:
            break


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(config=configs(), seed=st.integers(0, 2**32), data=st.data())
def test_env_0_of_a_vector_env_is_the_single_env(config: dict, seed: int, data: st.DataObject) -> None:
    single = ChainCartEnv(**config)
    vector = ChainCartVectorEnv(num_envs=3, **config)
    obs, _ = single.reset(seed=seed)
    vobs, _ = vector.reset(seed=seed)
    assert np.array_equal(obs, vobs[0])
    for action in data.draw(actions(single.action_space.shape[0])):
        obs, reward, terminated, truncated, _ = single.step(action)
        batch = np.repeat(action[None, :], 3, axis=0)
        vobs, vreward, vterminated, vtruncated, _ = vector.step(batch)
        assert np.array_equal(obs, vobs[0]) and reward == vreward[0]
        assert (terminated, truncated) == (vterminated[0], vtruncated[0])
        if terminated or truncated:
            break


def test_extreme_scenes_give_finite_observations_or_flags() -> None:
    cases = [
        dict(n_links=256, planar=False, dt=1e-3, substeps=1, max_force=10.0, start_noise=0.1),
        dict(n_links=6, link_masses=[1e4, 1e-4, 1.0, 1e2, 1e-2, 1e-4], link_lengths=[1e2, 1e-3, 1.0, 0.1, 10.0, 1e-3]),
        dict(n_links=5, max_force=1e6, dt=1e-3, track_limit=1e9),
        dict(n_links=2, dt=1e-6, max_episode_steps=1000),
        dict(n_links=3, dt=0.5, integrator="lie_euler", max_force=1e3, start_noise=0.5),
    ]
    for config in cases:
        env = ChainCartEnv(**config)
        env.reset(seed=1)
        rng = np.random.default_rng(0)
        for _ in range(200):
            obs, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
            assert np.all(np.isfinite(obs)), config
            if terminated:
                assert info["numerical_failure"] or info["out_of_track"]
            if terminated or truncated:
                break


def test_huge_force_with_coarse_steps_is_flagged_not_silent() -> None:
    env = ChainCartEnv(n_links=5, planar=False, max_force=1e6, dt=1e-3, track_limit=1e9, start_noise=0.0)
    env.reset(seed=0)
    obs, reward, terminated, _, info = env.step(np.ones(2, dtype=np.float32))
    assert terminated and info["numerical_failure"] and reward == 0.0
    assert np.all(np.isfinite(obs))


def test_reset_options_are_checked_and_a_start_state_can_be_given() -> None:
    env = ChainCartEnv()
    with pytest.raises(ChainCartError, match=r"unknown keys \['bogus'\]"):
        env.reset(options={"bogus": 1})
    with pytest.raises(ChainCartError, match="expected a dict"):
        env.reset(options="state")  # type: ignore[arg-type]
    with pytest.raises(ChainCartError, match=r"state has shape \(2,\)"):
        env.reset(options={"state": [1.0, 2.0]})
    with pytest.raises(ChainCartError, match="unit vectors"):
        env.reset(options={"state": np.zeros(8)})
    with pytest.raises(ChainCartError, match="finite"):
        env.reset(options={"state": [np.nan] * 8})
    start = np.array([0.1, 0.0, 0.0, -1.0, 0.6, -0.8, 0.5, -0.2])
    obs, _ = env.reset(options={"state": start})
    assert np.array_equal(obs, start.astype(np.float32))
    # The unwrapped env's state is the full (spatial) state; this scene is planar.
    assert np.array_equal(env.unwrapped.state, env.unwrapped.model.to_spatial(start))
    vector = ChainCartVectorEnv(num_envs=2)
    with pytest.raises(ChainCartError, match=r"unknown keys \['state'\]"):
        vector.reset(options={"state": start})


@pytest.mark.parametrize("seed", [-1, 1.5, "abc", 2**64, True])
def test_bad_seeds_are_rejected(seed: object) -> None:
    with pytest.raises(ChainCartError, match="seed"):
        ChainCartEnv().reset(seed=seed)  # type: ignore[arg-type]


def _rollout(num_envs: int, seed: int, steps: int) -> np.ndarray:
    env = ChainCartVectorEnv(num_envs=num_envs, n_links=3, planar=False, start_noise=0.3)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(steps):
        obs, *_ = env.step(rng.uniform(-1, 1, (num_envs, 2)).astype(np.float32))
        out.append(obs)
    return np.stack(out)


def test_vector_envs_stepped_from_several_threads_match_sequential_runs() -> None:
    # The native step releases the GIL, so these really run at once.
    seeds = [11, 12, 13, 14]
    expected = [_rollout(300, s, 40) for s in seeds]
    results: dict[int, np.ndarray] = {}
    errors: list[BaseException] = []

    def work(s: int) -> None:
        try:
            results[s] = _rollout(300, s, 40)
        except BaseException as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(s,)) for s in seeds]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for s, e in zip(seeds, expected):
        assert np.array_equal(results[s], e)


def test_one_env_shared_by_threads_is_never_corrupted() -> None:
    # Concurrent calls on one env are serialised (the native object is borrowed for
    # the duration of a step): each call sees a consistent batch.
    env = ChainCartVectorEnv(num_envs=64, n_links=2)
    env.reset(seed=0)
    errors: list[BaseException] = []

    def work() -> None:
        try:
            for _ in range(200):
                obs, *_ = env.step(np.zeros((64, 1), dtype=np.float32))
                assert np.all(np.isfinite(obs))
        except BaseException as e:
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    # Either every call went through or the clash was reported as an error, never a crash.
    assert all(isinstance(e, (RuntimeError, ChainCartError)) for e in errors), errors


def test_a_soak_keeps_memory_constant_and_observations_finite() -> None:
    # The 10-million-step soak is `python -m chaincart_env soak`; this is its short form.
    from chaincart_env.tools.soak import soak

    report = soak(300_000, num_envs=256, warmup=200, n_links=3, planar=False, start_noise=0.3, max_episode_steps=50)
    assert report.env_steps >= 300_000 and report.episodes_ended > 0
    assert report.rss_start > 0
    # Nothing grows with the number of steps: allow 2 MiB of allocator noise.
    assert report.rss_growth < 2 * 1024 * 1024, report.markdown()


def test_soak_rejects_bad_sizes() -> None:
    from chaincart_env.tools.soak import soak

    with pytest.raises(ValueError, match="steps = 0"):
        soak(0)
