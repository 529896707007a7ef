"""The mirror symmetry against the model: the episode from the mirrored start, driven by
the mirrored forces, is the mirror image of the episode (observations, rewards, ends)."""

from __future__ import annotations

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv
from chaincart_env.errors import InvalidInputError
from chaincart_env.symmetry import Mirror


@pytest.mark.parametrize("scene", ["swingup-2", "spatial-inverted-2", "transitions-2", "swingup-3", "paper-fig1"])
def test_the_mirrored_episode_is_the_mirror_image_of_the_episode(scene: str):
    config = ChainCartConfig(scene=scene, obs_dtype="float64", max_episode_steps=150)
    mirror = Mirror(config)
    env, mirrored_env = ChainCartEnv(config), ChainCartEnv(config)
    obs, _ = env.reset(seed=3)
    n = config.n_links
    state = obs[: 2 + 3 * n if config.planar else 4 + 6 * n].copy()  # the scene's layout, as the reset option takes
    # A start off the symmetry plane and away from rest, so that nothing is mirror-symmetric by itself.
    rng = np.random.default_rng(0)
    assert not np.allclose(mirror.state(state), state)
    obs, _ = env.reset(seed=3, options={"state": state})
    mirrored_obs, _ = mirrored_env.reset(seed=3, options={"state": mirror.state(state)})
    if config.goal_observation:  # the same target drawn from the same seed
        assert np.array_equal(obs[-config.n_links:], mirrored_obs[-config.n_links:])
    assert np.allclose(mirrored_obs, mirror.observation(obs), rtol=0, atol=1e-12)
    for _ in range(150):
        action = rng.uniform(-1, 1, env.action_space.shape)
        obs, reward, terminated, truncated, _ = env.step(action)
        mirrored_obs, mirrored_reward, m_terminated, m_truncated, _ = mirrored_env.step(mirror.action(action))
        assert np.allclose(mirrored_obs, mirror.observation(obs), rtol=0, atol=1e-9)
        assert mirrored_reward == pytest.approx(reward, rel=1e-9, abs=1e-12)
        assert (m_terminated, m_truncated) == (terminated, truncated)
        if terminated or truncated:
            break


def test_mirroring_twice_is_the_identity_and_a_batch_mirrors_row_by_row():
    config = ChainCartConfig(scene="spatial-inverted-2")
    mirror = Mirror(config)
    batch = np.random.default_rng(1).normal(size=(5, 4 + 6 * 2)).astype(np.float32)
    planar = Mirror(ChainCartConfig(scene="swingup-2"))
    spatial_state = ChainCartEnv(ChainCartConfig(scene="swingup-2")).state  # a planar chain's embedded state
    assert np.array_equal(planar.state(spatial_state), mirror.state(spatial_state))
    assert np.array_equal(mirror.observation(mirror.observation(batch)), batch)
    assert mirror.observation(batch).dtype == np.float32
    assert np.array_equal(mirror.observation(batch)[2], mirror.observation(batch[2]))
    assert np.array_equal(mirror.action(np.array([[0.5, -0.25]])), np.array([[-0.5, -0.25]]))


def test_a_wrong_length_is_named():
    mirror = Mirror(ChainCartConfig(scene="swingup-2"))
    with pytest.raises(InvalidInputError, match=r"observation of shape \(7,\): expected a last axis of length 8"):
        mirror.observation(np.zeros(7))
