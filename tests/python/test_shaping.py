"""The training-only reward shaping. The off-track penalty: exactly the penalty on each
step that leaves the track and nothing else. The plan bonus: the scale times the
progress along the plan on the plan's own states, nothing hanging still, and only on
steps that did not end an episode. Both kept through a checkpoint's pickling, the
scene's default recorded in the run's settings, and bad values refused by name. The
action-change penalty: the scale times the mean squared change of the clipped action in
[-1, 1] units, counted from 0 at every episode's start."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartVecEnv
from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.curriculum import plan_states
from chaincart_env.tools.compare.job import _training_settings
from chaincart_env.tools.compare.shaped_rewards import ActionChangePenalty, OffTrackPenalty, PlanProgress
from chaincart_env.tools.compare.shaping import (
    Shaping,
    check_action_change_penalty,
    check_off_track_penalty,
    check_plan_bonus,
)

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


def test_the_scene_default_and_given_terms_are_recorded():
    def shaping(scene: str, trainer="sb3", **given) -> dict:
        settings = _training_settings(ChainCartConfig(scene=scene), ["ppo"], trainer, None, None, {}, {},
                                      imitation=False, curriculum=None, training_reward=None, shaping=given)
        return settings["ppo"]["shaping"]

    none = {"off_track_penalty": 0.0, "plan_bonus": 0.0, "action_change_penalty": 0.0, "plan_tube": 0.0}
    assert shaping("swingup-2") == {**none, "plan_bonus": 0.3}
    assert shaping("inverted-2") == none
    assert shaping("swingup-2", off_track_penalty=3.0, plan_bonus=None) == {**none, "off_track_penalty": 3.0,
                                                                            "plan_bonus": 0.3}
    assert shaping("swingup-2", plan_bonus=0.0) == none
    assert shaping("inverted-2", action_change_penalty=0.05) == {**none, "action_change_penalty": 0.05}
    assert shaping("swingup-2", trainer="rllib") == none
    with pytest.raises(InvalidInputError, match="--off-track-penalty 3.0 with --trainer rllib: expected the sb3"):
        shaping("inverted-2", trainer="rllib", off_track_penalty=3.0)
    with pytest.raises(InvalidInputError, match="transitions-2"):  # no single plan to follow
        shaping("transitions-2", plan_bonus=0.3)


@pytest.mark.parametrize("option, name", [("--off-track-penalty", "off-track penalty"), ("--plan-bonus", "plan bonus"),
                                          ("--action-change-penalty", "action-change penalty")])
def test_the_command_line_refuses_a_negative_term(option, name, tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["compare", option, "-2", "--out", str(tmp_path)])
    assert f"{name} = -2.0: expected a finite number >= 0" in capsys.readouterr().err


SCALE = 0.3


def _swingup_envs() -> tuple[ChainCartVecEnv, np.ndarray]:
    config = ChainCartConfig(scene="swingup-2", reward="exp")
    return ChainCartVecEnv(4, config, seed=5), plan_states(config)


def test_the_plan_bonus_pays_the_progress_along_the_plan():
    envs, plan = _swingup_envs()
    bonus = PlanProgress(envs, SCALE, plan)
    progress = np.linspace(0.0, 1.0, len(plan))
    on_plan = bonus.bonus(plan)
    assert np.all(on_plan >= SCALE * progress - 1e-12) and np.all(on_plan <= SCALE)
    model = envs.model
    hanging, upright = model.equilibrium([1, 1]), model.equilibrium([-1, -1])
    assert bonus.bonus(hanging[None])[0] < 0.05 * SCALE  # only the first states of the plan are near it
    assert bonus.bonus(upright[None])[0] == pytest.approx(SCALE, rel=1e-3)
    moved = upright.copy()
    moved[0] += 1.0  # the cart's place is left out
    assert bonus.bonus(moved[None])[0] == bonus.bonus(upright[None])[0]


def test_the_plan_bonus_falls_on_running_steps_only_and_pickles():
    plain, plan = _swingup_envs()
    shaped = PlanProgress(_swingup_envs()[0], SCALE, plan)
    actions = np.array([[1.0], [-1.0], [0.5], [0.0]], dtype=np.float32)
    plain.reset(), shaped.reset()
    any_ended = False
    for step in range(320):  # past the 300-step episodes' end
        _, expected, ended, _ = plain.step(actions)
        states = plain._batch.states()
        _, got, ended_too, _ = shaped.step(actions)
        assert np.array_equal(ended, ended_too)
        any_ended |= bool(ended.any())
        extra = np.where(ended, 0.0, shaped.bonus(states))
        assert np.allclose(got, expected + extra, rtol=0, atol=1e-6), step
    assert any_ended
    copy = pickle.loads(pickle.dumps(shaped))
    for _ in range(5):
        a, b = shaped.step(actions), copy.step(actions)
        assert np.array_equal(a[1], b[1])


def test_the_plan_bonus_refuses_a_bad_scale_or_plan():
    envs, plan = _swingup_envs()
    with pytest.raises(InvalidInputError, match=r"plan of shape \(151, 3\)"):
        PlanProgress(envs, SCALE, plan[:, :3])
    for bad in (-0.1, float("nan"), True, "0.3"):
        with pytest.raises(InvalidInputError, match=r"plan bonus = .*: expected a finite number >= 0"):
            check_plan_bonus(bad)
    with pytest.raises(InvalidInputError, match=r"plan bonus = -1"):
        Shaping(plan_bonus=-1)


CHANGE_SCALE = 0.05


def _planar_envs(num_envs: int = 3) -> ChainCartVecEnv:
    return ChainCartVecEnv(num_envs, ChainCartConfig(scene="inverted-2", max_episode_steps=5), seed=11)


def test_the_action_change_penalty_is_the_scaled_mean_squared_change_from_zero_at_each_start():
    plain, shaped = _planar_envs(), ActionChangePenalty(_planar_envs(), CHANGE_SCALE)
    plain.reset(), shaped.reset()
    rng = np.random.default_rng(0)
    previous = np.zeros((3, 1))
    any_ended = False
    for step in range(12):  # two episode ends of 5 steps
        actions = rng.uniform(-1.5, 1.5, size=(3, 1)).astype(np.float32)  # some beyond the bounds
        _, expected, ended, _ = plain.step(actions)
        _, got, ended_too, _ = shaped.step(actions)
        assert np.array_equal(ended, ended_too)
        applied = np.clip(actions.astype(np.float64), -1.0, 1.0)
        penalty = CHANGE_SCALE * ((applied - previous) ** 2).mean(axis=1)
        assert np.allclose(got, expected - penalty, rtol=0, atol=1e-6), step
        previous = np.where(ended[:, None], 0.0, applied)
        any_ended |= bool(ended.any())
    assert any_ended


def test_a_steady_action_costs_nothing_after_the_first_step_and_pickles():
    shaped = ActionChangePenalty(_planar_envs(1), CHANGE_SCALE)
    plain = _planar_envs(1)
    shaped.reset(), plain.reset()
    actions = np.array([[1.0]], dtype=np.float32)
    first = shaped.step(actions)[1][0] - plain.step(actions)[1][0]
    assert first == pytest.approx(-CHANGE_SCALE, abs=1e-6)  # from 0 to a full push: 1 squared
    copy = pickle.loads(pickle.dumps(shaped))
    plain_copy = pickle.loads(pickle.dumps(plain))
    for _ in range(3):
        assert shaped.step(actions)[1][0] == plain.step(actions)[1][0]
        assert copy.step(actions)[1][0] == plain_copy.step(actions)[1][0]


def test_a_bad_action_change_penalty_names_itself():
    for bad in (-0.5, float("inf"), None, "0.1"):
        with pytest.raises(InvalidInputError, match=r"action-change penalty = .*: expected a finite number >= 0"):
            check_action_change_penalty(bad)
    with pytest.raises(InvalidInputError, match=r"action-change penalty = -1"):
        Shaping(action_change_penalty=-1)
