"""Every Gymnasium wrapper that accepts a Box-observation, Box-action env (the
generic part of Gymnasium's tests/wrappers) on ChainCart-v0, for float32 and
float64 observations: it resets, steps with sampled actions, and its observations
(and samples of its observation space) lie in its observation space."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np
import pytest
from conformance_support import unexpected_warnings
from gymnasium import wrappers as W

from chaincart_env import ChainCartEnv

DTYPES = ("float32", "float64")
RGB = dict(render_mode="rgb_array", render_width=48, render_height=24)


def make(dtype: str, **kwargs: Any) -> gym.Env:
    return gym.make("ChainCart-v0", obs_dtype=dtype, **kwargs)


def rescaled(dtype: str) -> gym.Env:
    # Unbounded components keep infinite bounds (Gymnasium requires it), bounded
    # ones (the unit-vector entries) are rescaled to [0, 2].
    env = make(dtype)
    low, high = env.observation_space.low, env.observation_space.high
    return W.RescaleObservation(env, np.where(np.isinf(low), low, 0.0), np.where(np.isinf(high), high, 2.0))


WRAPPERS: dict[str, Callable[[str], gym.Env]] = {
    "DelayObservation": lambda d: W.DelayObservation(make(d), 2),
    "DtypeObservation-float16": lambda d: W.DtypeObservation(make(d), np.float16),
    "DtypeObservation-float32": lambda d: W.DtypeObservation(make(d), np.float32),
    "DtypeObservation-float64": lambda d: W.DtypeObservation(make(d), np.float64),
    "FlattenObservation": lambda d: W.FlattenObservation(make(d)),
    "FrameStackObservation": lambda d: W.FrameStackObservation(make(d), 3),
    "TransformObservation": lambda d: W.TransformObservation(make(d), lambda o: o.copy(), None),
    "MaxAndSkipObservation": lambda d: W.MaxAndSkipObservation(make(d), 2),
    "NormalizeObservation": lambda d: W.NormalizeObservation(make(d)),
    "AddRenderObservation": lambda d: W.AddRenderObservation(make(d, **RGB)),
    "ReshapeObservation": lambda d: W.ReshapeObservation(make(d), (2, 4)),
    "RescaleObservation": rescaled,
    "TimeAwareObservation": lambda d: W.TimeAwareObservation(make(d)),
    "ClipAction": lambda d: W.ClipAction(make(d)),
    "DiscretizeAction": lambda d: W.DiscretizeAction(make(d), 5),
    "TransformAction": lambda d: W.TransformAction(make(d), lambda a: 0.5 * a, None),
    "RescaleAction": lambda d: W.RescaleAction(make(d), 0.0, 2.0),
    "StickyAction": lambda d: W.StickyAction(make(d), 0.5),
    "ClipReward": lambda d: W.ClipReward(make(d), 0.1, 0.5),
    "TransformReward": lambda d: W.TransformReward(make(d), lambda r: 2 * r),
    "NormalizeReward": lambda d: W.NormalizeReward(make(d)),
    "TimeLimit": lambda d: W.TimeLimit(ChainCartEnv(obs_dtype=d), 7),
    "Autoreset": lambda d: W.Autoreset(make(d)),
    "PassiveEnvChecker": lambda d: W.PassiveEnvChecker(ChainCartEnv(obs_dtype=d)),
    "OrderEnforcing": lambda d: W.OrderEnforcing(ChainCartEnv(obs_dtype=d)),
    "RecordEpisodeStatistics": lambda d: W.RecordEpisodeStatistics(make(d)),
    "AddWhiteNoise": lambda d: W.AddWhiteNoise(make(d, **RGB), 0.1),
    "ObstructView": lambda d: W.ObstructView(make(d, **RGB), 0.2, 4),
    "RenderCollection": lambda d: W.RenderCollection(make(d, **RGB)),
    "NumpyToTorch": lambda d: W.NumpyToTorch(make(d)),
}


def as_numpy(x: Any) -> Any:
    return x.numpy() if hasattr(x, "numpy") else x


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("name", WRAPPERS)
def test_the_wrapper_runs_and_its_observations_are_in_its_space(name: str, dtype: str) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = WRAPPERS[name](dtype)
        obs, _ = env.reset(seed=0)
        assert as_numpy(obs) in env.observation_space
        env.action_space.seed(0)
        for _ in range(25):
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            assert as_numpy(obs) in env.observation_space and np.isfinite(float(reward))
            if terminated or truncated:
                env.reset()
        env.observation_space.seed(0)
        for _ in range(5):
            assert env.observation_space.sample() in env.observation_space
        env.close()
    # Casting the bounds to a narrower float is what DtypeObservation and RescaleAction
    # warn about for any env; anything else would be ours.
    assert unexpected_warnings(caught, ("precision lowered by casting",)) == []


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.filterwarnings("ignore:.*precision lowered by casting")
def test_dtype_and_rescale_keep_finite_observations_finite(dtype: str) -> None:
    # With finfo.max bounds the rescaling overflowed to inf/nan; with infinite bounds
    # unbounded components pass through and bounded ones map affinely.
    env = rescaled(dtype)
    obs, _ = env.reset(seed=3)
    base = env.unwrapped.model_state
    assert np.all(np.isfinite(obs))
    q = slice(2, 6)  # planar double pendulum: [x, xdot, q1(2), q2(2), w1, w2]
    np.testing.assert_allclose(obs[q], base[q] + 1.0, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(obs[:2], base[:2], rtol=1e-6, atol=1e-6)
    half = W.DtypeObservation(make(dtype), np.float16)
    obs16, _ = half.reset(seed=3)
    assert obs16.dtype == np.float16 and np.all(np.isfinite(obs16))
    np.testing.assert_allclose(obs16, base, atol=2e-3)


def test_flatten_observation_sample_is_finite_and_inside() -> None:
    space = W.FlattenObservation(make("float64")).observation_space
    space.seed(1)
    sample = space.sample()
    assert np.all(np.isfinite(sample)) and sample in space and np.all(np.abs(sample[2:6]) <= 1)


def test_render_collection_through_make_and_record_video(tmp_path: Path) -> None:
    env = gym.make("ChainCart-v0", render_mode="rgb_array_list", render_width=48, render_height=24)
    env.reset(seed=0)
    for _ in range(3):
        env.step(env.action_space.sample())
    frames = env.render()
    assert len(frames) == 4 and all(f.shape == (24, 48, 3) for f in frames)
    video = W.RecordVideo(make("float32", **RGB), str(tmp_path / "videos"), episode_trigger=lambda e: e == 0,
                          name_prefix="chain", disable_logger=True)  # fmt: skip
    video.reset(seed=0)
    for _ in range(10):
        video.step(video.action_space.sample())
    video.close()
    assert [p.name for p in (tmp_path / "videos").glob("*.mp4")] == ["chain-episode-0.mp4"]
    assert (tmp_path / "videos" / "chain-episode-0.mp4").stat().st_size > 1000
