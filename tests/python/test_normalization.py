"""Observation normalisation of a training recipe (the zoo's ``normalize``): the recipe's
forms, training on ``VecNormalize``, the statistics saved beside each model file, loaded
runs acting on normalised observations, and resuming bit for bit."""

from __future__ import annotations

import json
import pathlib
import shutil

import numpy as np
import pytest

from chaincart_env import ChainCartConfig
from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.recipes import TrainingRecipe, _recipe, normalize_setting

OBS_ONLY = {"norm_obs": True, "norm_reward": False}
TINY_PPO = {"n_steps": 64, "batch_size": 64}


@pytest.mark.parametrize(
    "value, keywords",
    [
        (True, {}),
        (False, None),
        ("dict(norm_obs=True, norm_reward=False)", OBS_ONLY),
        ({"norm_obs": True, "norm_reward": False, "clip_obs": 5.0}, {**OBS_ONLY, "clip_obs": 5.0}),
    ],
)
def test_the_zoo_forms_of_normalize_parse(value, keywords):
    assert normalize_setting(value) == keywords
    recipe = _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "normalize": value, **TINY_PPO})
    assert recipe.normalize == keywords and recipe.hyperparameters == TINY_PPO


def test_an_unsupported_normalize_setting_is_a_clear_error():
    with pytest.raises(InvalidInputError, match=r"normalize keys \['gamma', 'norm_obs_keys'\] are not supported"):
        normalize_setting("dict(norm_obs=True, gamma=0.9, norm_obs_keys=['a'])")
    with pytest.raises(InvalidInputError, match=r"normalize clip_obs = -1: expected a number > 0"):
        normalize_setting({"clip_obs": -1})
    with pytest.raises(InvalidInputError, match=r"normalize = 'VecNormalize\(\)': expected true, false or dict"):
        normalize_setting("VecNormalize()")


@pytest.fixture(scope="module")
def normalized_run(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    import chaincart_env.tools.compare.job as job

    out = tmp_path_factory.mktemp("normalized")
    recipe = TrainingRecipe(2, 256, dict(TINY_PPO), "test recipe", dict(OBS_ONLY))
    patch = pytest.MonkeyPatch()
    patch.setattr(job, "recipe_for", lambda scene, algo: recipe)
    try:
        assert main(["compare", "--set", "max_episode_steps=40", "--eval-episodes", "2", "--eval-every", "128",
                     "--eval-starts", "2", "--checkpoint-every", "128", "--sweep", "start_noise=0.05",
                     "--no-progress", "--torch-threads", "1", "--out", str(out)]) == 0
    finally:
        patch.undo()
    return out


def test_a_normalized_recipe_saves_its_statistics_and_records_them(normalized_run: pathlib.Path):
    seed = normalized_run / "seed-0"
    for name in ("vecnormalize.pkl", "best_vecnormalize.pkl", "checkpoints/best_vecnormalize.pkl"):
        assert (seed / name).is_file(), name
    assert json.loads((seed / "run.json").read_text())["normalize"] == OBS_ONLY
    assert json.loads((normalized_run / "run.json").read_text())["settings"]["training"]["ppo"]["normalize"] == OBS_ONLY


def test_a_loaded_normalized_run_acts_on_observations_normalized_with_the_saved_statistics(
    normalized_run: pathlib.Path,
):
    from stable_baselines3 import PPO

    from chaincart_env.tools.compare.normalization import NormalizedPolicy, read_statistics
    from chaincart_env.tools.compare.policy_sources import PolicySource, load_run

    seed = normalized_run / "seed-0"
    saved = load_run(seed)
    assert isinstance(saved.model, NormalizedPolicy)
    bare = PPO.load(seed / "model.zip", device="cpu")
    statistics = read_statistics((seed / "vecnormalize.pkl").read_bytes())
    assert statistics.obs_rms.count > 256 and not np.allclose(statistics.obs_rms.var, 1.0)
    batch = saved.config.make_batch(4, "same_step")
    obs = batch.reset([1, 2, 3, 4], None)
    by_hand = np.clip((obs - statistics.obs_rms.mean) / np.sqrt(statistics.obs_rms.var + statistics.epsilon),
                      -statistics.clip_obs, statistics.clip_obs).astype(np.float32)
    action = saved.model.predict(obs, deterministic=True)[0]
    np.testing.assert_array_equal(action, bare.predict(by_hand, deterministic=True)[0])
    assert not np.array_equal(action, bare.predict(obs, deterministic=True)[0])
    before = statistics.obs_rms.mean.copy()
    saved.model.predict(obs, deterministic=True)
    np.testing.assert_array_equal(saved.model.statistics.obs_rms.mean, before)  # frozen
    for source in (PolicySource.of_run(seed), PolicySource.best_of_run(seed)):
        policy = source.load()
        assert isinstance(policy, NormalizedPolicy)
    np.testing.assert_array_equal(PolicySource.of_run(seed).load().predict(obs, deterministic=True)[0], action)


def test_a_run_without_statistics_loads_the_bare_model(normalized_run: pathlib.Path, tmp_path: pathlib.Path):
    from stable_baselines3 import PPO

    from chaincart_env.tools.compare.policy_sources import PolicySource, load_run

    copy = tmp_path / "seed-0"
    shutil.copytree(normalized_run / "seed-0", copy)
    (copy / "vecnormalize.pkl").unlink()
    assert isinstance(load_run(copy).model, PPO) and isinstance(PolicySource.of_run(copy).load(), PPO)


def test_a_normalized_run_resumes_to_the_uninterrupted_result(tmp_path: pathlib.Path):
    """Reward normalisation too, so that the discounted returns must survive the checkpoint."""
    import torch

    from chaincart_env.tools.compare.training import train

    config = ChainCartConfig(max_episode_steps=40)
    options = dict(algo="ppo", timesteps=384, seed=3, num_envs=2, eval_seeds=[5, 6], eval_every=128,
                   checkpoint_every=256, progress_bar=False, hyperparameters=TINY_PPO,
                   normalize={"norm_obs": True, "norm_reward": True})
    whole = tmp_path / "whole"
    first = train(config, directory=whole, **options)
    broken = tmp_path / "broken"  # as the run stood when interrupted after its checkpoint at 256 steps
    shutil.copytree(whole, broken)
    resumed = train(config, directory=broken, resume=True, **options)
    assert resumed.resumed_from == 256 and resumed.model.num_timesteps == first.model.num_timesteps == 384
    for a, b in zip(first.model.policy.state_dict().values(), resumed.model.policy.state_dict().values()):
        assert torch.equal(a, b)
    stats = [model.get_vec_normalize_env() for model in (first.model, resumed.model)]
    np.testing.assert_array_equal(stats[0].obs_rms.mean, stats[1].obs_rms.mean)
    np.testing.assert_array_equal(stats[0].ret_rms.var, stats[1].ret_rms.var)
    np.testing.assert_array_equal(stats[0].returns, stats[1].returns)
    for name in ("training_episodes.csv", "evaluations.csv"):
        untimed = [[cell for i, cell in enumerate(line.split(",")) if i != 1]
                   for line in (broken / name).read_text().splitlines()]
        assert untimed == [[cell for i, cell in enumerate(line.split(",")) if i != 1]
                           for line in (whole / name).read_text().splitlines()], name


def test_evaluate_and_animate_use_the_saved_statistics(normalized_run: pathlib.Path, tmp_path: pathlib.Path):
    from chaincart_env.tools.animate import load_sb3_model
    from chaincart_env.tools.compare.normalization import NormalizedPolicy

    seed = normalized_run / "seed-0"
    assert isinstance(load_sb3_model(seed), NormalizedPolicy)
    assert main(["evaluate", str(seed), "--out", str(tmp_path / "again")]) == 0
    # The study's own evaluation used the same statistics: the re-evaluation agrees with it.
    rows = lambda path: [r for r in path.read_text().splitlines() if r.startswith("PPO")]  # noqa: E731
    again = rows(tmp_path / "again" / "comparison.csv")
    assert again and set(again) <= set(rows(normalized_run / "comparison.csv"))


def test_the_leaderboard_trains_a_normalized_recipe_and_scores_it_normalized(tmp_path: pathlib.Path):
    import chaincart_env.tools.compare.recipes as recipes
    from chaincart_env.tools.compare.normalization import NormalizedPolicy
    from chaincart_env.tools.compare.policy_sources import PolicySource
    from chaincart_env.tools.leaderboard.contestants import train_agent

    recipe = TrainingRecipe(2, 128, dict(TINY_PPO), "test recipe", dict(OBS_ONLY))
    patch = pytest.MonkeyPatch()
    patch.setattr(recipes, "recipe_for", lambda scene, algo: recipe)
    try:
        train_agent("ppo", ChainCartConfig(max_episode_steps=20), 0, tmp_path)
    finally:
        patch.undo()
    assert (tmp_path / "vecnormalize.pkl").is_file()
    assert isinstance(PolicySource.sb3(tmp_path / "model.zip", "ppo").load(), NormalizedPolicy)


def test_the_leaderboard_scores_the_best_evaluated_model_not_the_last(tmp_path: pathlib.Path):
    """Every evaluation ties here, so the earliest (before any update) is the best: the
    agent the leaderboard keeps must be that one, with its statistics, not the last."""
    from stable_baselines3 import PPO

    import chaincart_env.tools.compare.periodic_eval as periodic_eval
    import chaincart_env.tools.compare.recipes as recipes
    from chaincart_env.tools.leaderboard.contestants import train_agent

    recipe = TrainingRecipe(2, 256, dict(TINY_PPO), "test recipe", dict(OBS_ONLY))
    patch = pytest.MonkeyPatch()
    patch.setattr(recipes, "recipe_for", lambda scene, algo: recipe)
    patch.setattr(periodic_eval, "_score", lambda row: (0.0, 0.0))
    try:
        train_agent("ppo", ChainCartConfig(max_episode_steps=20), 0, tmp_path)
    finally:
        patch.undo()
    kept = PPO.load(tmp_path / "model.zip", device="cpu")
    assert kept.num_timesteps == 0
    assert (tmp_path / "model.zip").read_bytes() == (tmp_path / "best_model.zip").read_bytes()
    assert (tmp_path / "vecnormalize.pkl").read_bytes() == (tmp_path / "best_vecnormalize.pkl").read_bytes()
    assert len((tmp_path / "evaluations.csv").read_text().splitlines()) > 2  # header, first, later ones
