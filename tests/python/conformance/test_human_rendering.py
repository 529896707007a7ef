"""The real windows of human mode, on a virtual X display (Xvfb): the envs' own
matplotlib window and Gymnasium's HumanRendering wrappers (pygame) around the
rgb_array envs."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import HumanRendering, vector as VW

from chaincart_env import ChainCartEnv, ChainCartVecEnv, ChainCartVectorEnv

SMALL = dict(render_width=96, render_height=48)


def shown_pixels(figure) -> np.ndarray:
    """The figure's canvas as an RGB array (what the window shows)."""
    figure.canvas.draw()
    return np.asarray(figure.canvas.buffer_rgba())[..., :3]


def test_the_single_env_opens_a_window_and_shows_its_frames(on_xvfb: str) -> None:
    import matplotlib.pyplot as plt

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no headless warning: a window opens
        env = ChainCartEnv(render_mode="human", scene="inverted-1", **SMALL)
        env.reset(seed=0)
        window = env._rendering.window
        assert window.unavailable is None and window.is_open
        first = shown_pixels(window._figure).copy()
        for _ in range(5):
            env.step(np.ones(1, np.float32))
        assert env.render() is None
        assert not np.array_equal(shown_pixels(window._figure), first)  # the picture moved
        frame = ChainCartEnv(render_mode="rgb_array", scene="inverted-1", **SMALL)
        frame.reset(seed=0)
        for _ in range(5):
            frame.step(np.ones(1, np.float32))
        np.testing.assert_array_equal(window._image.get_array(), frame.render())
    assert plt.get_backend().lower() != "agg"
    env.close()
    assert not window.is_open


def test_the_vector_envs_show_their_tiles_in_a_window(on_xvfb: str) -> None:
    for envs in (ChainCartVectorEnv(3, render_mode="human", **SMALL), ChainCartVecEnv(3, render_mode="human", **SMALL)):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            envs.reset()
            window = envs._rendering.window
            assert window.is_open
            image = window._image.get_array()
            assert image.shape == (2 * 48 + 2, 2 * 96 + 2, 3)
        envs.close()
        assert not window.is_open


# (rgb_array_list returns each env's list of frames, as SyncVectorEnv does, which
# HumanRendering does not take from SyncVectorEnv either.)
@pytest.mark.parametrize("num_envs", [1, 3, 9])
@pytest.mark.parametrize("screen_size", [None, (300, 200)])
def test_gymnasiums_vector_human_rendering_wraps_the_native_vector_env(on_xvfb: str, num_envs: int, screen_size) -> None:
    envs = VW.HumanRendering(ChainCartVectorEnv(num_envs, render_mode="rgb_array", **SMALL), screen_size=screen_size)
    assert envs.render_mode == "human"
    envs.reset(seed=0)
    for _ in range(5):
        envs.step(envs.action_space.sample())
    assert envs.window is not None and envs.screen_size is not None
    envs.close()


def test_gymnasiums_human_rendering_wraps_the_single_env(on_xvfb: str) -> None:
    env = HumanRendering(gym.make("ChainCart-v0", render_mode="rgb_array", **SMALL))
    env.reset(seed=0)
    for _ in range(3):
        env.step(env.action_space.sample())
    assert env.window is not None
    env.close()
