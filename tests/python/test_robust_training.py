"""Robust agents: the robust variant of every scene (its Gymnasium id and its draws), the
``ppo-robust`` controller's recipe and training conditions, and a tiny robust run that
trains on the variant and is evaluated on the scene."""

from __future__ import annotations

import json
import pathlib

import gymnasium as gym
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv
from chaincart_env.__main__ import main
from chaincart_env.config import SCENES
from chaincart_env.errors import InvalidInputError
from chaincart_env.registration import scene_env_id
from chaincart_env.robust_training import ROBUST_CONDITIONS, ROBUST_VARIANT, robust_config
from chaincart_env.tools.compare.recipes import (
    ELAPSED_TIME_WRAPPER,
    GENERIC,
    HISTORY_WRAPPER,
    _recipe,
    history_setting,
    recipe_for,
    training_conditions,
)


def test_every_scene_has_a_robust_id_with_the_scene_and_the_draws():
    for scene in SCENES:
        env_id = scene_env_id(scene, ROBUST_VARIANT)
        assert env_id == f"ChainCart-{scene}-robust-v0"
        spec = gym.spec(env_id)
        assert spec.max_episode_steps == gym.spec(scene_env_id(scene)).max_episode_steps
    env = gym.make(scene_env_id("swingup-2", ROBUST_VARIANT))
    assert env.unwrapped.config == robust_config(ChainCartConfig(scene="swingup-2"))
    assert env.unwrapped.config.action_delay == (0, 1) and env.unwrapped.config.obs_noise == [0.01]
    env.close()


def test_the_robust_draws_change_from_episode_to_episode_and_repeat_under_a_seed():
    def first_observations(seed: int) -> list[list[float]]:
        env = ChainCartEnv(robust_config(ChainCartConfig(scene="swingup-2")))
        observations = [env.reset(seed=seed)[0].tolist()]
        observations += [env.reset()[0].tolist() for _ in range(3)]
        env.close()
        return observations

    drawn = first_observations(5)
    assert drawn == first_observations(5)
    assert len({tuple(o) for o in drawn}) == len(drawn)  # sensor noise drawn afresh


def test_only_the_robust_controller_has_training_conditions():
    assert training_conditions("ppo") is None and training_conditions("sac") is None
    conditions = training_conditions("ppo-robust")
    assert conditions == json.loads(json.dumps(ROBUST_CONDITIONS))
    conditions["obs_noise"] = 1.0  # a copy: the shipped conditions stay as they are
    assert training_conditions("PPO-robust")["obs_noise"] == ROBUST_CONDITIONS["obs_noise"]


def test_the_robust_recipe_is_its_own_entry_with_history_or_else_the_scenes():
    robust = recipe_for("swingup-2", "ppo-robust")
    assert robust.source == "ppo.yml: ChainCart-swingup-2-robust-v0"
    assert recipe_for("swingup-2", "ppo").history == robust.history == 1  # a warm start needs the same inputs
    inverted = recipe_for("inverted-2", "ppo-robust")
    assert inverted.source == "ppo.yml: ChainCart-inverted-2-robust-v0"
    assert recipe_for("inverted-2", "ppo").history == inverted.history == 1
    assert recipe_for("inverted-2-randomized", "ppo").history is None
    assert recipe_for("inverted-1", "ppo-robust") is GENERIC  # no entry for the variant nor the scene
    assert recipe_for("spatial-inverted-2", "ppo-robust") is recipe_for("spatial-inverted-2", "ppo")


def test_the_elapsed_time_wrapper_is_read_after_the_history_only():
    history, timed = {HISTORY_WRAPPER: {"k": 2}}, {ELAPSED_TIME_WRAPPER: {}}
    recipe = _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_wrapper": [history, timed]})
    assert (recipe.history, recipe.elapsed_time) == (2, True)
    recipe = _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_wrapper": [timed]})
    assert (recipe.history, recipe.elapsed_time) == (None, True)
    assert _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10}).elapsed_time is False
    for bad in ([timed, history], [timed, timed], {ELAPSED_TIME_WRAPPER: {"horizon": 5}}, {ELAPSED_TIME_WRAPPER: None}):
        with pytest.raises(InvalidInputError, match=r"env_wrapper = .*: expected some of \["):
            _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_wrapper": bad})


def test_the_history_wrapper_is_read_and_every_other_wrapper_refused():
    assert history_setting(None) is None
    assert history_setting([{HISTORY_WRAPPER: {"k": 3}}]) == 3 and history_setting({HISTORY_WRAPPER: {"k": 1}}) == 1
    for bad in ("gymnasium.wrappers.FrameStackObservation", [{HISTORY_WRAPPER: {"k": 0}}], {HISTORY_WRAPPER: {"k": True}},
                [{HISTORY_WRAPPER: {"k": 2}}, {HISTORY_WRAPPER: {"k": 2}}], {"my.Wrapper": {"k": 2}},
                {HISTORY_WRAPPER: {"k": 2, "n": 1}}):
        with pytest.raises(InvalidInputError, match=r"ppo.yml: ChainCart-x-v0: env_wrapper = .*: expected some of \["):
            _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_wrapper": bad})


TINY = [
    "--scene", "inverted-1", "--timesteps", "128", "--num-envs", "2", "--eval-episodes", "3", "--eval-seed", "7",
    "--set", "max_episode_steps=40", "--algo-kwarg", "n_steps=64", "--algo-kwarg", "batch_size=64",
    "--eval-every", "64", "--eval-starts", "2", "--checkpoint-every", "128", "--sweep", "start_noise=0.05",
    "--no-progress",
]  # fmt: skip


def _record_training_configs(monkeypatch) -> list:
    from chaincart_env.tools.compare import training

    trained_on: list = []
    new_agent = training._new_agent
    monkeypatch.setattr(training, "_new_agent", lambda algo, config, *rest: (trained_on.append(config),
                                                                             new_agent(algo, config, *rest))[1])
    return trained_on


def test_a_robust_run_fine_tunes_the_nominal_agent_on_the_draws_and_is_evaluated_on_the_scene(
    tmp_path: pathlib.Path, monkeypatch
):
    from chaincart_env.tools.compare import periodic_eval
    from chaincart_env.tools.compare.policy_sources import load_run

    trained_on = _record_training_configs(monkeypatch)
    judged_on: list = []
    evaluation = periodic_eval.PeriodicEvaluation
    monkeypatch.setattr(periodic_eval, "PeriodicEvaluation", lambda config, *rest, **kw: (judged_on.append(config),
                                                                                          evaluation(config, *rest, **kw))[1])
    out = tmp_path / "run"
    assert main(["compare", *TINY, "--policies", "ppo,ppo-robust", "--history", "2", "--out", str(out)]) == 0
    run = json.loads((out / "run.json").read_text())
    scene = ChainCartConfig(scene="inverted-1", max_episode_steps=40)
    robust = run["settings"]["training"]["ppo-robust"]
    assert robust["conditions"] == training_conditions("ppo-robust") and robust["first_stage"]["conditions"] is None
    assert robust["first_stage"]["algo"] == "ppo" and robust["first_stage"]["history"] == 2
    assert run["settings"]["training"]["ppo"]["conditions"] is None
    # PPO trains on the scene; ppo-robust starts from that agent (no second nominal stage) and trains on the draws.
    assert trained_on == [scene, robust_config(scene)]
    assert run["seed_runs"]["ppo-robust/0"]["warm_start_from"] == str(out / "ppo" / "seed-0")
    saved = load_run(out / "ppo-robust" / "seed-0")
    assert saved.config == scene  # evaluated on the scene
    # The periodic evaluations that choose each best model: PPO's on the scene, ppo-robust's on the draws.
    assert judged_on == [scene, robust_config(scene)]
    rows = (out / "comparison.csv").read_text()
    assert "\nPPO robust (seed 0)," in rows and "\nPPO (seed 0)," in rows


def test_a_robust_run_alone_trains_its_own_nominal_stage_first(tmp_path: pathlib.Path, monkeypatch):
    trained_on = _record_training_configs(monkeypatch)
    out = tmp_path / "run"
    assert main(["compare", *TINY, "--policies", "ppo-robust", "--out", str(out)]) == 0
    scene = ChainCartConfig(scene="inverted-1", max_episode_steps=40)
    assert trained_on == [scene, robust_config(scene)]
    stage = out / "seed-0" / "nominal-stage"
    assert (stage / "stage-finished").is_file() and (stage / "best_model.zip").is_file()
    run = json.loads((out / "run.json").read_text())
    assert run["seed_runs"]["0"]["warm_start_from"] == str(stage)


def test_robust_training_with_rllib_is_refused(tmp_path: pathlib.Path, capsys):
    with pytest.raises(SystemExit):
        main(["compare", *TINY, "--policies", "ppo-robust", "--trainer", "rllib", "--out", str(tmp_path)])
    assert "ppo-robust with --trainer rllib: expected the sb3 trainer" in capsys.readouterr().err
