"""Training recipes: the packaged RL Baselines3 Zoo files, read by ``compare`` and run by
the zoo itself."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

from chaincart_env.errors import InvalidInputError
from chaincart_env.registration import scene_env_id
from chaincart_env.tools.compare.recipes import (
    GENERIC,
    _recipe,
    conditions_setting,
    hyperparameter_file,
    load_recipes,
    recipe_for,
    sb3_keywords,
    training_conditions,
)


def test_every_packaged_recipe_names_a_registered_scene_and_builds_its_keywords():
    import gymnasium as gym

    for algo in ("ppo", "sac", "td3"):
        for env_id, recipe in load_recipes(algo).items():
            assert env_id in gym.registry, env_id
            assert recipe.num_envs >= 1 and recipe.timesteps >= 1
            assert "n_envs" not in recipe.hyperparameters and "policy" not in recipe.hyperparameters
            sb3_keywords(recipe.hyperparameters)


def test_the_file_entry_is_the_recipe_and_a_scene_without_one_is_generic():
    import yaml

    # An entry of the zoo's plain keywords and PPO's (no wrapper, no env keywords).
    entry = yaml.safe_load(hyperparameter_file("ppo").read_text())[scene_env_id("inverted-2-randomized")]
    recipe = recipe_for("inverted-2-randomized", "PPO")
    assert recipe.num_envs == entry["n_envs"] and recipe.timesteps == entry["n_timesteps"]
    assert recipe.hyperparameters == {k: v for k, v in entry.items() if k not in ("n_envs", "n_timesteps", "policy")}
    assert recipe_for("paper-fig1", "ppo") is GENERIC and recipe_for("inverted-2", "a2c") is GENERIC


def test_zoo_values_become_sb3_objects():
    import torch

    keywords = sb3_keywords({
        "learning_rate": "lin_3e-4", "policy_kwargs": "dict(net_arch=[64, 64], activation_fn=nn.Tanh, log_std_init=-1)",
        "train_freq": [1, "episode"], "gamma": 0.98,
    })
    assert keywords["learning_rate"](1.0) == pytest.approx(3e-4) and keywords["learning_rate"](0.5) == pytest.approx(1.5e-4)
    assert keywords["policy_kwargs"] == {"net_arch": [64, 64], "activation_fn": torch.nn.Tanh, "log_std_init": -1}
    assert keywords["train_freq"] == (1, "episode") and keywords["gamma"] == 0.98


@pytest.mark.parametrize(
    "entry, message",
    [
        ({"n_timesteps": 10, "frame_stack": 4}, "['frame_stack'] are zoo wrappers"),
        ({"n_timesteps": 10, "normalize": "dict(norm_obs=True, epsilon=1e-3)"}, "normalize keys ['epsilon'] are not supported"),
        ({"n_timesteps": 10, "normalize": "dict(norm_obs=__import__('os'))"}, "normalize = "),
        ({"n_timesteps": 10, "normalize": {"norm_obs": "yes"}}, "normalize norm_obs = 'yes': expected true or false"),
        ({"n_timesteps": 10, "policy": "CnnPolicy"}, "policy 'CnnPolicy'"),
        ({"n_envs": 4}, "number n_timesteps"),
        ({"n_timesteps": 10, "learning_rate": "exp_1e-3"}, "learning_rate = 'exp_1e-3'"),
        ({"n_timesteps": 10, "policy_kwargs": "dict(net_arch=__import__('os'))"}, "policy_kwargs"),
        ({"n_timesteps": 10, "policy_kwargs": "dict(activation_fn=nn.Softmax)"}, "policy_kwargs"),
        ({"n_timesteps": 10, "env_kwargs": {"action_delays": [0, 2]}}, "env_kwargs keys ['action_delays']: expected "
                                                                      "configuration keys"),
        ({"n_timesteps": 10, "env_kwargs": [["action_delay", 1]]}, "expected a mapping of configuration keys"),
        ({"n_timesteps": 10, "env_kwargs": {"_resolved": 1}}, "env_kwargs keys ['_resolved']: expected configuration"),
    ],
)
def test_a_bad_recipe_is_refused_with_its_place_and_value(entry, message):
    with pytest.raises(InvalidInputError, match=r"ppo.yml: ChainCart-x-v0: .*" + message.replace("[", r"\[").replace("]", r"\]").replace("(", r"\(")):
        _recipe("ppo", "ChainCart-x-v0", entry)


@pytest.mark.parametrize("env_id", ["ChainCart-inverted-2-v0", "ChainCart-swingup-2-robust-v0", "ChainCart-swingup-3-v0",
                                    "ChainCart-swingup-2-residual-v0", "ChainCart-inverted-2-residual-v0"])
def test_the_zoo_trains_a_packaged_recipe(env_id: str, tmp_path: pathlib.Path):
    # swingup-3's recipe normalises observations: the zoo builds its VecNormalize from
    # the same entry that compare reads. The robust swing-up's entry trains in the zoo on
    # its own registered variant (parameters, noise and delay drawn per episode), without
    # compare's nominal first stage, plan starts and training reward. The residual entries'
    # first wrapper puts the planner's controller (the swing-up) or the LQR (the inverted
    # pendulum) under the agent.
    hyperparams = pathlib.Path(str(hyperparameter_file("ppo")))
    command = [
        sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", env_id,
        "--gym-packages", "chaincart_env", "-conf", str(hyperparams), "-n", "2048", "--eval-freq", "-1",
        "-f", str(tmp_path / "logs"), "--seed", "0", "--device", "cpu",
    ]
    done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    saved = list((tmp_path / "logs" / "ppo").glob(f"{env_id}_*/{env_id}.zip"))
    assert saved, sorted(str(p) for p in (tmp_path / "logs").rglob("*"))[:20]
    normalized = list((tmp_path / "logs").rglob("vecnormalize.pkl"))
    assert bool(normalized) == (env_id == "ChainCart-swingup-3-v0"), normalized


def test_a_recipes_env_kwargs_are_its_training_conditions_over_the_variants():
    from chaincart_env.robust_training import ROBUST_CONDITIONS

    recipe = _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_kwargs": {"action_delay": (0, 2), "obs_noise": 0.02}})
    assert recipe.conditions == {"action_delay": [0, 2], "obs_noise": 0.02}  # as run.json records them
    assert "action_delay" not in recipe.hyperparameters
    assert training_conditions("ppo", recipe) == recipe.conditions
    robust = training_conditions("ppo-robust", recipe)
    assert robust["action_delay"] == [0, 2] and robust["obs_noise"] == 0.02  # the recipe's over the variant's
    assert robust["randomize"] == ROBUST_CONDITIONS["randomize"]
    assert training_conditions("ppo", _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10})) is None
    assert conditions_setting(None) == {}


def test_a_recipes_conditions_leave_what_the_study_sets_itself():
    from chaincart_env import ChainCartConfig

    recipe = _recipe("ppo", "ChainCart-x-v0", {"n_timesteps": 10, "env_kwargs": {"action_delay": [0, 1], "obs_noise": 0.02}})
    plain = ChainCartConfig(scene="swingup-2")
    assert training_conditions("ppo", recipe, plain) == recipe.conditions
    delayed = ChainCartConfig(scene="swingup-2", action_delay=(0, 2))  # the user's own delay stays
    assert training_conditions("ppo", recipe, delayed) == {"obs_noise": 0.02}
    both = ChainCartConfig(scene="swingup-2", action_delay=2, obs_noise=0.01)
    assert training_conditions("ppo", recipe, both) is None
