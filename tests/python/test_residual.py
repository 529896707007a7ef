"""Residual agents: the env applies a model-based controller's command (the planner's
time-varying LQR, or the LQR where episodes start at their target) plus a scaled
correction, for one env and an SB3 VecEnv alike; the observation carries the base's
command; a trained agent records its base and acts through it on the plain env."""

from __future__ import annotations

import math
import pickle
from typing import Any

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from chaincart_env import ChainCartConfig, ChainCartEnv
from chaincart_env.errors import InvalidInputError
from chaincart_env.policies import LQRPolicy, TrajectoryPolicy
from chaincart_env.residual import (
    RESIDUAL_ATTRIBUTE,
    ResidualAction,
    ResidualPolicy,
    check_scale,
    checked_setting,
    residual_setting,
    residual_space,
)

SHORT = ChainCartConfig(scene="swingup-2", max_episode_steps=40, start_noise=0.3)


def action(step: int, n: int = 1) -> np.ndarray:
    return np.array([[1.5 * np.sin(0.7 * step + i)] for i in range(n)], dtype=np.float32)


def tracker(config: ChainCartConfig = SHORT, weights: Any = None) -> TrajectoryPolicy:
    """The base as a plain controller: the planner's tracker from the nearest equilibrium."""
    options = {} if weights is None else {"weights": weights}
    return TrajectoryPolicy.from_env(ChainCartEnv(config), plan_from="equilibrium", max_time=math.inf, **options)


def test_the_env_applies_the_planners_command_plus_the_scaled_clipped_action() -> None:
    residual, plain, base = ResidualAction(ChainCartEnv(SHORT), scale=0.3), ChainCartEnv(SHORT), tracker()
    obs, _ = residual.reset(seed=4)
    plain_obs, _ = plain.reset(seed=4)
    for t in range(SHORT.max_episode_steps):
        command = base.predict(plain_obs, episode_start=np.array([t == 0]))[0]
        np.testing.assert_array_equal(obs, np.concatenate([plain_obs, command]).astype(np.float32))
        # Summed in float64, sent as the env's float32 action.
        sent = np.clip(command.astype(np.float64) + 0.3 * np.clip(action(t)[0].astype(np.float64), -1, 1), -1, 1)
        sent = sent.astype(np.float32)
        obs, reward, terminated, truncated, _ = residual.step(action(t)[0])
        plain_obs, plain_reward, *_ = plain.step(sent)
        assert reward == plain_reward
        if terminated or truncated:
            break
    assert truncated


def test_with_no_correction_the_agent_is_the_planners_controller_and_swings_up() -> None:
    config = ChainCartConfig(scene="swingup-2")
    env, plain, base = ResidualAction(ChainCartEnv(config)), ChainCartEnv(config), tracker(config)
    env.reset(seed=1)
    obs, _ = plain.reset(seed=1)
    info: dict[str, Any] = {}
    for t in range(config.max_episode_steps):
        _, _, terminated, truncated, info = env.step(np.zeros(1, dtype=np.float32))
        obs, *_ = plain.step(base.predict(obs, episode_start=np.array([t == 0]))[0])
        np.testing.assert_array_equal(env.unwrapped.model_state, plain.unwrapped.model_state)
        if terminated or truncated:
            break
    assert info["is_success"]


def test_where_episodes_start_at_the_target_the_base_is_the_lqr_and_no_correction_balances_as_it() -> None:
    from chaincart_env.residual import base_controller

    config = ChainCartConfig(scene="inverted-2", start_noise=0.2)
    assert isinstance(base_controller(config), LQRPolicy)
    tracker_base = base_controller(ChainCartConfig(scene="swingup-2"))
    assert isinstance(tracker_base, TrajectoryPolicy)
    assert tracker_base.on_failure == "track"  # a missed plan fails its episodes, not the training
    env, plain, lqr = ResidualAction(ChainCartEnv(config)), ChainCartEnv(config), LQRPolicy.from_env(ChainCartEnv(config))
    env.reset(seed=3)
    obs, _ = plain.reset(seed=3)
    info: dict[str, Any] = {}
    for _ in range(config.max_episode_steps):
        residual_obs, _, terminated, truncated, info = env.step(np.zeros(1, dtype=np.float32))
        obs, *_ = plain.step(lqr.predict(obs)[0])
        np.testing.assert_array_equal(env.unwrapped.model_state, plain.unwrapped.model_state)
        np.testing.assert_array_equal(residual_obs[-1:], lqr.predict(obs)[0])  # the command it would correct next
        if terminated or truncated:
            break
    assert truncated and info["is_success"]
    agent = Zero(residual_space(plain.observation_space, plain.action_space))
    policy = ResidualPolicy(agent, {"scale": 0.2, "config": config.to_dict()}, plain.observation_space,
                            plain.action_space, config.max_episode_steps)
    policy.reset()  # the LQR base keeps nothing to forget
    np.testing.assert_array_equal(policy.predict(obs)[0], lqr.predict(obs)[0])


def test_the_single_env_wrapper_passes_gymnasiums_checker() -> None:
    check_env(ResidualAction(ChainCartEnv(SHORT)), skip_render_check=True)


def test_the_vec_env_equals_the_single_env_across_autoresets() -> None:
    from chaincart_env.residual import VecResidualAction
    from chaincart_env.sb3 import ChainCartVecEnv

    n = 3
    venv = VecResidualAction(ChainCartVecEnv(n, SHORT, seed=11), scale=0.5)
    singles = [ResidualAction(ChainCartEnv(SHORT), scale=0.5) for _ in range(n)]
    obs = venv.reset()
    expected = np.stack([env.reset(seed=11 + i)[0] for i, env in enumerate(singles)])
    np.testing.assert_array_equal(obs, expected)
    ended = 0
    for t in range(90):
        obs, _, dones, infos = venv.step(action(t, n))
        for i, env in enumerate(singles):
            single, _, terminated, truncated, _ = env.step(action(t, n)[i])
            if terminated or truncated:
                ended += 1
                assert dones[i]
                final = infos[i]["terminal_observation"]
                np.testing.assert_array_equal(final[: SHORT.obs_dim], single[: SHORT.obs_dim])
                assert final[SHORT.obs_dim:].tolist() == [0.0]  # no command follows a final state
                single, _ = env.reset()
            np.testing.assert_array_equal(obs[i], single, err_msg=f"step {t} env {i}")
    assert ended >= 2 * n


def test_a_pickled_vec_env_goes_on_as_the_original_mid_episode() -> None:
    from chaincart_env.residual import VecResidualAction
    from chaincart_env.sb3 import ChainCartVecEnv

    venv = VecResidualAction(ChainCartVecEnv(2, SHORT, seed=3))
    venv.reset()
    for t in range(15):
        venv.step(action(t, 2))
    copy = pickle.loads(pickle.dumps(venv))
    for t in range(15, 60):
        obs, rewards, dones, _ = venv.step(action(t, 2))
        copy_obs, copy_rewards, copy_dones, _ = copy.step(action(t, 2))
        np.testing.assert_array_equal(obs, copy_obs, err_msg=f"step {t}")
        np.testing.assert_array_equal(rewards, copy_rewards)
        np.testing.assert_array_equal(dones, copy_dones)


class Zero:
    """An agent that never corrects, observing the residual space with ``extra`` more numbers."""

    def __init__(self, space: Any) -> None:
        self.observation_space = space
        self.seen: list[np.ndarray] = []

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        batch = np.atleast_2d(observation)
        self.seen.append(batch.copy())
        return np.zeros((batch.shape[0], 1), dtype=np.float32), state


def test_the_policy_adds_the_base_on_the_plain_env_episode_after_episode() -> None:
    env = ChainCartEnv(SHORT)
    space = residual_space(env.observation_space, env.action_space)
    agent = Zero(space)
    setting = {"scale": 0.2, "config": SHORT.to_dict()}
    policy, base = ResidualPolicy(agent, setting, env.observation_space, env.action_space, 40), tracker()
    for episode in range(2):  # the plain Gymnasium loop: no episode_start
        obs, _ = env.reset(seed=episode)
        for _ in range(SHORT.max_episode_steps):
            expected = base.predict(obs)[0]
            sent = policy.predict(obs)[0]
            np.testing.assert_array_equal(sent, expected)
            np.testing.assert_array_equal(agent.seen[-1][0], np.concatenate([obs, expected]))
            obs, _, terminated, truncated, _ = env.step(sent)
            if terminated or truncated:
                break


def test_the_setting_and_the_scale_are_checked() -> None:
    for bad in (0, -0.1, 2.5, True, "0.2", math.nan):
        with pytest.raises(InvalidInputError, match="residual scale"):
            check_scale(bad)
    with pytest.raises(InvalidInputError, match="residual scale"):
        ResidualAction(ChainCartEnv(SHORT), scale=0)

    class Agent:
        pass

    agent = Agent()
    assert residual_setting(agent) is None
    setattr(agent, RESIDUAL_ATTRIBUTE, {"scale": 0.2})
    with pytest.raises(InvalidInputError, match=RESIDUAL_ATTRIBUTE):
        residual_setting(agent)
    setattr(agent, RESIDUAL_ATTRIBUTE, {"scale": 3.0, "config": {}})
    with pytest.raises(InvalidInputError, match="residual scale = 3.0"):
        residual_setting(agent)


def test_the_base_plans_with_the_cost_weights_given_and_they_are_checked() -> None:
    weights = {"q": 2.0}
    wrapped = ResidualAction(ChainCartEnv(SHORT), plan_weights=weights)
    plain, softer, default = ChainCartEnv(SHORT), tracker(weights=weights), tracker()
    obs, _ = wrapped.reset(seed=1)
    plain_obs, _ = plain.reset(seed=1)
    differs = False
    for t in range(SHORT.max_episode_steps):
        starts = np.array([t == 0])
        command = softer.predict(plain_obs, episode_start=starts)[0]
        differs |= not np.array_equal(command, default.predict(plain_obs, episode_start=starts)[0])
        np.testing.assert_array_equal(obs[-1:], command)
        obs, _, terminated, truncated, _ = wrapped.step(np.zeros(1, dtype=np.float32))
        plain_obs, *_ = plain.step(command)
        if terminated or truncated:
            break
    assert differs  # the weights change the base
    for bad, message in (({"q": -2}, "weights.q = -2"), ({"qq": 1}, "qq"), ("q=2", "weights = 'q=2'")):
        with pytest.raises(InvalidInputError, match=message):
            ResidualAction(ChainCartEnv(SHORT), plan_weights=bad)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="plan_weights = .* start at their target: expected none"):
        ResidualAction(ChainCartEnv(ChainCartConfig(scene="inverted-2")), plan_weights=weights)
    setting = {"scale": 0.2, "config": SHORT.to_dict(), "plan_weights": weights}
    checked = checked_setting(setting)
    assert checked is not None and checked["plan_weights"]["q"] == 2.0 and len(checked["plan_weights"]) == 8
    assert checked_setting({**setting, "plan_weights": None}) == {"scale": 0.2, "config": SHORT.to_dict()}
    with pytest.raises(InvalidInputError, match="weights.q = -1"):
        checked_setting({**setting, "plan_weights": {"q": -1}})
    with pytest.raises(InvalidInputError, match=RESIDUAL_ATTRIBUTE):
        checked_setting({**setting, "base": "mpc"})


def test_the_residual_wrapper_comes_first_in_a_recipe_and_only_there() -> None:
    from chaincart_env.tools.compare.recipes import (
        ELAPSED_TIME_WRAPPER,
        HISTORY_WRAPPER,
        RESIDUAL_WRAPPER,
        _recipe,
        residual_setting as recipe_residual,
    )

    residual, history, timed = {RESIDUAL_WRAPPER: {"scale": 0.3}}, {HISTORY_WRAPPER: {"k": 1}}, {ELAPSED_TIME_WRAPPER: {}}
    recipe = _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_wrapper": [residual, history, timed]})
    assert (recipe.residual, recipe.history, recipe.elapsed_time) == ({"scale": 0.3}, 1, True)
    assert recipe_residual({RESIDUAL_WRAPPER: {}}) == {"scale": 0.2} and recipe_residual(None) is None
    weighted = recipe_residual({RESIDUAL_WRAPPER: {"plan_weights": {"q": 2}}})
    assert weighted is not None and weighted["plan_weights"]["q"] == 2.0 and weighted["scale"] == 0.2
    assert _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_wrapper": [history]}).residual is None
    for bad in ([history, residual], [residual, residual], {RESIDUAL_WRAPPER: {"scale": 0}},
                {RESIDUAL_WRAPPER: {"scale": 0.2, "k": 1}}, {RESIDUAL_WRAPPER: None},
                {RESIDUAL_WRAPPER: {"plan_weights": {"q": -2}}}):
        with pytest.raises(InvalidInputError, match=r"env_wrapper = .*: expected some of \["):
            _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_wrapper": bad})


def test_the_residual_controller_trains_only_where_it_has_a_recipe() -> None:
    import gymnasium

    from chaincart_env.tools.compare.recipes import recipe_for, training_conditions
    from chaincart_env.tools.controllers import NotApplicable

    recipe = recipe_for("swingup-2", "ppo-residual")
    assert recipe.source == "ppo.yml: ChainCart-swingup-2-residual-v0" and recipe.residual == {"scale": 0.2}
    assert set(training_conditions("ppo-residual", recipe)) == {"action_delay", "randomize"}  # no robust draws
    with pytest.raises(NotApplicable, match="ppo-residual has no recipe for spatial-inverted-2: .*exist for "
                                            "inverted-2, swingup-2, "):
        recipe_for("spatial-inverted-2", "ppo-residual")
    env = gymnasium.make("ChainCart-swingup-2-residual-v0")
    assert env.unwrapped.config == ChainCartConfig(scene="swingup-2")
    assert isinstance(ResidualAction(env).observation_space, type(env.observation_space))
    env.close()


def test_a_residual_agent_refuses_what_would_start_its_base_off_its_plan(tmp_path: Any) -> None:
    from chaincart_env.tools.compare.curriculum import PlanStarts
    from chaincart_env.tools.compare.imitation import Imitation
    from chaincart_env.tools.compare.training import train

    common = dict(timesteps=64, directory=tmp_path, eval_seeds=[0], eval_every=64, checkpoint_every=64, residual=0.2)
    for given, words in ((dict(imitation=Imitation()), "an imitation"), (dict(curriculum=PlanStarts()), "plan starts"),
                         (dict(mirror_weight=1.0), "the mirror loss")):
        with pytest.raises(InvalidInputError, match=f"residual scale 0.2 with {words}"):
            train(SHORT, **common, **given)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="residual scale = 5"):
        train(SHORT, **{**common, "residual": 5})  # type: ignore[arg-type]


def test_a_trained_residual_agent_keeps_its_base_through_saving_and_every_evaluation(tmp_path: Any) -> None:
    import torch

    from chaincart_env.residual import on_plain_env
    from chaincart_env.tools.compare.run_files import MODEL_FILE
    from chaincart_env.tools.compare.training import train

    result = train(SHORT, timesteps=128, num_envs=2, directory=tmp_path, eval_seeds=[0], eval_every=128,
                   checkpoint_every=128, progress_bar=False, hyperparameters={"n_steps": 64, "batch_size": 64},
                   history=1, elapsed_time=True, residual={"scale": 0.25, "plan_weights": {"q": 2}})
    setting = residual_setting(result.model)
    assert setting is not None and setting["plan_weights"]["q"] == 2.0
    assert setting == {"scale": 0.25, "config": SHORT.to_dict(), "plan_weights": setting["plan_weights"]}
    model = result.model
    with torch.no_grad():  # an agent that never corrects: the evaluation is the planner's controller
        model.policy.action_net.weight.zero_()
        model.policy.action_net.bias.zero_()
    model.save(tmp_path / MODEL_FILE)
    from stable_baselines3 import PPO

    loaded = PPO.load(tmp_path / MODEL_FILE, device="cpu")
    saved = residual_setting(loaded)  # through the zip's JSON: the same configuration
    assert saved is not None and saved["scale"] == 0.25 and ChainCartConfig(**saved["config"]) == SHORT
    assert saved["plan_weights"] == setting["plan_weights"]
    env = ChainCartEnv(SHORT)
    policy = on_plain_env(loaded, env.observation_space, env.action_space, SHORT.max_episode_steps)
    assert isinstance(policy, ResidualPolicy)
    base = tracker(weights={"q": 2})
    obs, _ = env.reset(seed=2)
    for t in range(SHORT.max_episode_steps):
        starts = np.array([t == 0])
        sent = policy.predict(obs[None], episode_start=starts)[0][0]
        np.testing.assert_array_equal(sent, base.predict(obs[None], episode_start=starts)[0][0])
        obs, *_ = env.step(sent)


TINY = [
    "--scene", "swingup-2", "--policies", "ppo-residual", "--timesteps", "256", "--num-envs", "2",
    "--eval-episodes", "2", "--set", "max_episode_steps=40", "--algo-kwarg", "n_steps=64", "--algo-kwarg",
    "batch_size=64", "--eval-every", "128", "--eval-starts", "2", "--checkpoint-every", "256", "--sweep",
    "delay=0,2", "--no-progress",
]  # fmt: skip


def test_a_tiny_residual_study_trains_without_the_scenes_methods_and_refuses_plan_starts(tmp_path: Any, capsys) -> None:
    import json

    from chaincart_env.__main__ import main

    assert main(["compare", *TINY, "--out", str(tmp_path / "run")]) == 0
    record = json.loads((tmp_path / "run" / "seed-0" / "run.json").read_text())
    assert record["residual"] == {"scale": 0.2} and record["curriculum"] is None and record["imitation"] is None
    assert record["training_reward"] is None and record["conditions"]["action_delay"] == [0, 3]
    with pytest.raises(SystemExit):
        main(["compare", *TINY, "--curriculum", "plan", "--out", str(tmp_path / "refused")])
    assert "residual scale 0.2 with plan starts" in capsys.readouterr().err


def test_the_leaderboard_reports_a_residual_agent_without_a_recipe_as_not_scored(tmp_path: Any) -> None:
    from chaincart_env.tools.leaderboard.run import LeaderboardSettings, _plan

    logged: list[str] = []
    scene = "spatial-inverted-2"
    plan = _plan(LeaderboardSettings(scenes=(scene,), controllers=("ppo-residual", "lqr")), tmp_path, logged.append, {})
    assert set(plan.skipped) == {(scene, "ppo-residual")}
    assert f"ChainCart-{scene}-residual-v0" in plan.skipped[(scene, "ppo-residual")]
    assert not plan.agents and not plan.training and f"{scene}/lqr" in plan.designs
    assert any("(not scored)" in line for line in logged)
