"""A polish: the run's agent trained on from its best model at a tenth of its learning
rate, as a second stage of the same run (compare --polish)."""

from __future__ import annotations

import csv
import json
import math
import pathlib

import pytest

from chaincart_env import ChainCartConfig
from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.job import _training_settings
from chaincart_env.tools.compare.stages import POLISH_FIRST_STAGE_DIR, polish_stage

TINY = [
    "--scene", "inverted-1", "--timesteps", "128", "--num-envs", "2", "--eval-episodes", "2", "--eval-seed", "7",
    "--set", "max_episode_steps=40", "--algo-kwarg", "n_steps=64", "--algo-kwarg", "batch_size=64",
    "--eval-every", "64", "--eval-starts", "2", "--checkpoint-every", "128", "--sweep", "start_noise=0.05",
    "--no-progress", "--policies", "ppo", "--torch-threads", "1",
]  # fmt: skip


def _evaluations(folder: pathlib.Path) -> list[dict[str, str]]:
    with (folder / "evaluations.csv").open(newline="") as file:
        return list(csv.DictReader(file))


def test_a_polished_run_fine_tunes_its_first_stages_best_model_at_a_tenth_of_the_rate(tmp_path: pathlib.Path):
    out = tmp_path / "study"
    args = [*TINY, "--algo-kwarg", "learning_rate=0.002", "--polish", "192", "--out", str(out)]
    assert main(["compare", *args]) == 0
    seed_run, first = out / "seed-0", out / "seed-0" / POLISH_FIRST_STAGE_DIR
    assert (first / "best_model.zip").is_file() and (first / "stage-finished").is_file()
    training = json.loads((out / "run.json").read_text())["settings"]["training"]["ppo"]
    assert training["timesteps"] == 192 and training["polish"] == {"timesteps": 192, "learning_rate": 0.0002}
    assert training["hyperparameters"]["learning_rate"] == 0.0002 and training["imitation"] is None
    assert training["first_stage"]["hyperparameters"]["learning_rate"] == 0.002
    assert training["first_stage"]["timesteps"] == 128
    record = json.loads((seed_run / "run.json").read_text())
    assert pathlib.Path(record["warm_start_from"]).resolve() == first.resolve()
    assert record["hyperparameters"]["learning_rate"] == 0.0002
    # Each stage trains its own budget; the second starts by scoring the first's best model.
    first_rows, polish_rows = _evaluations(first), _evaluations(seed_run)
    assert float(first_rows[-1]["timesteps"]) >= 128 and float(polish_rows[-1]["timesteps"]) >= 192
    assert float(polish_rows[0]["timesteps"]) == 0
    best_return = max(float(row["return_mean"]) for row in first_rows)
    assert float(polish_rows[0]["return_mean"]) == pytest.approx(best_return)


def test_the_polish_rate_is_a_tenth_of_the_runs_or_of_sb3s_default():
    main_stage = {"timesteps": 100, "hyperparameters": {"n_steps": 64}, "imitation": {"rounds": 3}}
    stage = polish_stage("ppo", main_stage, 50)
    assert stage["hyperparameters"] == {"n_steps": 64, "learning_rate": pytest.approx(3e-5)}  # SB3's PPO: 3e-4
    assert stage["imitation"] is None and stage["first_stage"]["imitation"] == {"rounds": 3}
    assert stage["first_stage"]["timesteps"] == 100 and stage["first_stage"]["algo"] == "ppo"
    assert polish_stage("sac", main_stage, 50, learning_rate=0.5)["hyperparameters"]["learning_rate"] == 0.5
    decaying = {"hyperparameters": {"learning_rate": "lin_1e-3"}}  # the zoo's linear decay from 1e-3
    assert polish_stage("ppo", decaying, 50)["hyperparameters"]["learning_rate"] == pytest.approx(1e-4)


@pytest.mark.parametrize(
    "steps, rate, hyperparameters, message",
    [
        (0, None, {}, r"polish = 0: expected a whole number of steps >= 1"),
        (1.5, None, {}, r"polish = 1.5: expected a whole number"),
        (10, None, {"learning_rate": "lin_fast"}, r"learning_rate = 'lin_fast': expected a constant rate"),
        (10, -1e-4, {}, r"polish learning rate = -0.0001: expected a finite number > 0"),
        (10, math.inf, {}, r"polish learning rate = inf: expected a finite number > 0"),
    ],
)
def test_bad_polish_settings_are_refused_by_name(steps, rate, hyperparameters, message):
    with pytest.raises(InvalidInputError, match=message):
        polish_stage("ppo", {"hyperparameters": hyperparameters}, steps, rate)


def test_a_variant_is_not_polished_and_rllib_refuses_a_polish():
    config = ChainCartConfig(scene="inverted-2")
    training = _training_settings(config, ["ppo", "ppo-robust"], "sb3", None, None, {}, {},
                                  polish={"timesteps": 1000})  # fmt: skip
    assert training["ppo"]["polish"]["timesteps"] == 1000 and training["ppo"]["first_stage"]["algo"] == "ppo"
    assert "polish" not in training["ppo-robust"] and training["ppo-robust"]["first_stage"]["algo"] == "ppo"
    with pytest.raises(InvalidInputError, match=r"--polish with --trainer rllib: expected the sb3 trainer"):
        _training_settings(config, ["ppo"], "rllib", None, None, {}, {}, polish={"timesteps": 1000})


def test_a_polish_rate_without_a_polish_is_an_error(capsys: pytest.CaptureFixture[str], tmp_path: pathlib.Path):
    with pytest.raises(SystemExit):
        main(["compare", *TINY, "--polish-learning-rate", "1e-4", "--out", str(tmp_path)])
    assert "--polish-learning-rate 0.0001: expected --polish STEPS with it" in capsys.readouterr().err


def test_the_double_swing_ups_are_polished_by_default_and_polish_0_turns_it_off():
    from chaincart_env.tools.compare.curriculum import scene_curriculum, scene_training_reward
    from chaincart_env.tools.compare.recipes import recipe_for
    from chaincart_env.tools.compare.shaping import scene_shaping
    from chaincart_env.tools.compare.stages import SCENE_POLISH

    spatial, planar = ChainCartConfig(scene="spatial-swingup-2"), ChainCartConfig(scene="swingup-2")
    recipe = recipe_for("spatial-swingup-2", "ppo")
    assert (recipe.num_envs, recipe.timesteps) == (64, 4_000_000) and recipe.hyperparameters["learning_rate"] == 1e-3
    # The planar swing-up's plan starts, exp reward and plan bonus.
    assert scene_curriculum("spatial-swingup-2") == scene_curriculum("swingup-2")
    assert scene_training_reward("spatial-swingup-2") == "exp"
    assert scene_shaping("spatial-swingup-2") == scene_shaping("swingup-2")

    training = _training_settings(spatial, ["ppo"], "sb3", None, None, {}, {}, polish="scene")["ppo"]
    steps = SCENE_POLISH["spatial-swingup-2"]
    assert training["polish"] == {"timesteps": steps, "learning_rate": pytest.approx(1e-4)}
    assert training["timesteps"] == steps and training["first_stage"]["timesteps"] == 4_000_000
    assert training["first_stage"]["curriculum"] == training["curriculum"] is not None
    for off in (None, {"timesteps": 0}):
        assert "polish" not in _training_settings(spatial, ["ppo"], "sb3", None, None, {}, {}, polish=off)["ppo"]
    # A budget of the run's own comes without the scene's polish, unless one is asked for.
    assert "polish" not in _training_settings(spatial, ["ppo"], "sb3", 1000, None, {}, {}, polish="scene")["ppo"]
    asked = _training_settings(spatial, ["ppo"], "sb3", 1000, None, {}, {}, polish={"timesteps": 10})["ppo"]
    assert asked["polish"]["timesteps"] == 10 and asked["first_stage"]["timesteps"] == 1000
    # The planar swing-up: a tenth of the start of its recipe's lin_1e-3 schedule.
    planar_training = _training_settings(planar, ["ppo"], "sb3", None, None, {}, {}, polish="scene")["ppo"]
    assert planar_training["polish"] == {"timesteps": SCENE_POLISH["swingup-2"], "learning_rate": pytest.approx(1e-4)}
    assert planar_training["first_stage"]["timesteps"] == recipe_for("swingup-2", "ppo").timesteps
    # Elsewhere no polish unless asked; the scene's default never stops RLlib.
    inverted = ChainCartConfig(scene="inverted-2")
    assert "polish" not in _training_settings(inverted, ["ppo"], "sb3", None, None, {}, {}, polish="scene")["ppo"]
    assert "polish" not in _training_settings(spatial, ["ppo"], "rllib", None, None, {}, {}, polish="scene")["ppo"]


def test_the_leaderboard_polishes_an_agent_where_the_scene_does(tmp_path: pathlib.Path, monkeypatch):
    from stable_baselines3 import PPO

    import chaincart_env.tools.compare.recipes as recipes
    from chaincart_env.tools.compare import stages
    from chaincart_env.tools.compare.recipes import TrainingRecipe
    from chaincart_env.tools.leaderboard.contestants import train_agent

    config = ChainCartConfig(scene="inverted-1", max_episode_steps=20)
    recipe = TrainingRecipe(2, 128, {"n_steps": 64, "batch_size": 64, "learning_rate": 0.002}, "test recipe")
    monkeypatch.setattr(recipes, "recipe_for", lambda scene, algo: recipe)
    monkeypatch.setitem(stages.SCENE_POLISH, "inverted-1", 192)
    train_agent("ppo", config, 0, tmp_path / "polished")
    first = tmp_path / "polished" / POLISH_FIRST_STAGE_DIR
    assert (first / "model.zip").is_file() and (first / "stage-finished").is_file()
    assert PPO.load(first / "model.zip", device="cpu").learning_rate == 0.002
    kept = PPO.load(tmp_path / "polished" / "model.zip", device="cpu")
    assert kept.learning_rate == pytest.approx(0.0002)
    assert float(_evaluations(tmp_path / "polished")[-1]["timesteps"]) >= 192
    # A budget of its own, or a tiny run, is not polished.
    train_agent("ppo", config, 0, tmp_path / "own", timesteps=128)
    assert not (tmp_path / "own" / POLISH_FIRST_STAGE_DIR).exists()
    assert PPO.load(tmp_path / "own" / "model.zip", device="cpu").learning_rate == 0.002
