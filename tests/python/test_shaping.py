"""The training-only off-track penalty: exactly the penalty on each step that leaves the
track and nothing else, kept through a checkpoint's pickling, the scene's default
recorded in the run's settings, and bad values refused by name."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartVecEnv
from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.job import _training_settings
from chaincart_env.tools.compare.shaping import OffTrackPenalty, check_off_track_penalty

PENALTY = 7.5


def _short_track_envs() -> ChainCartVecEnv:
    # A track of 5 cm and full pushes one way: some envs leave it within a few steps.
    return ChainCartVecEnv(4, ChainCartConfig(scene="inverted-2", track_limit=0.05, max_episode_steps=40), seed=3)


def _steps(envs, actions: np.ndarray, steps: int) -> tuple[np.ndarray, np.ndarray]:
    envs.reset()
    rewards, left = [], []
    for _ in range(steps):
        _, reward, dones, infos = envs.step(actions)
        rewards.append(np.array(reward, dtype=np.float64))
        left.append([bool(d and info.get("out_of_track", False)) for d, info in zip(dones, infos)])
    return np.array(rewards), np.array(left)


def test_the_penalty_falls_on_the_steps_that_leave_the_track_only():
    actions = np.array([[1.0], [-1.0], [0.5], [0.0]], dtype=np.float32)
    plain, left = _steps(_short_track_envs(), actions, 30)
    shaped, left_shaped = _steps(OffTrackPenalty(_short_track_envs(), PENALTY), actions, 30)
    assert left.any() and (~left).any()
    assert np.array_equal(left, left_shaped)
    assert np.array_equal(shaped[~left], plain[~left])
    assert np.allclose(shaped[left], plain[left] - PENALTY, rtol=0, atol=1e-5)  # rewards are float32


def test_a_pickled_penalty_wrapper_steps_on_alike():
    actions = np.array([[1.0], [-1.0], [0.5], [0.0]], dtype=np.float32)
    envs = OffTrackPenalty(_short_track_envs(), PENALTY)
    envs.reset()
    envs.step(actions)
    copy = pickle.loads(pickle.dumps(envs))
    assert copy.penalty == PENALTY
    for _ in range(10):
        a, b = envs.step(actions), copy.step(actions)
        assert np.array_equal(a[1], b[1]) and np.array_equal(a[2], b[2])


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf"), True, "10"])
def test_a_bad_penalty_names_itself(bad):
    with pytest.raises(InvalidInputError, match=r"off-track penalty = .*: expected a finite number >= 0"):
        check_off_track_penalty(bad)


def test_the_scene_default_and_a_given_penalty_are_recorded(monkeypatch):
    from chaincart_env.tools.compare import curriculum

    monkeypatch.setitem(curriculum.SCENE_OFF_TRACK_PENALTIES, "swingup-2", 10.0)

    def penalty(scene: str, given=None, trainer="sb3") -> float:
        settings = _training_settings(ChainCartConfig(scene=scene), ["ppo"], trainer, None, None, {}, {},
                                      imitation=False, curriculum=None, training_reward=None,
                                      off_track_penalty=given)
        return settings["ppo"]["off_track_penalty"]

    assert penalty("swingup-2") == 10.0 and penalty("inverted-2") == 0.0 and penalty("inverted-2", 3.0) == 3.0
    assert penalty("swingup-2", trainer="rllib") == 0.0
    with pytest.raises(InvalidInputError, match="--off-track-penalty 3.0 with --trainer rllib: expected the sb3"):
        penalty("inverted-2", 3.0, trainer="rllib")


def test_the_command_line_refuses_a_negative_penalty(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["compare", "--off-track-penalty", "-2", "--out", str(tmp_path)])
    assert "off-track penalty = -2.0: expected a finite number >= 0" in capsys.readouterr().err
