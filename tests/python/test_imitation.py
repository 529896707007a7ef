"""The planner imitation that warm-starts PPO: its settings are checked, it fits the
planner's actions, it is seeded, and compare records and applies it per scene."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from chaincart_env import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.imitation import IMITATION_FILE, Imitation, scene_imitation

TINY = Imitation(demonstration_steps=40, noise=(0.0, 0.05), epochs=3, rounds=2, round_steps=30, round_epochs=2,
                 batch_size=256)


@pytest.mark.parametrize(
    "changes, named",
    [
        (dict(rounds=-1), "rounds = -1"),
        (dict(epochs=0), "epochs = 0"),
        (dict(demonstration_steps=2.5), "demonstration_steps = 2.5"),
        (dict(noise=()), "noise = ()"),
        (dict(noise=(0.1, 1.5)), "noise = (0.1, 1.5)"),
        (dict(learning_rate=0.0), "learning_rate = 0.0"),
        (dict(action_std=float("nan")), "action_std = nan"),
    ],
)
def test_bad_imitation_settings_are_named(changes, named) -> None:
    with pytest.raises(InvalidInputError, match=named.replace("(", r"\(").replace(")", r"\)")):
        Imitation(**changes)


def test_settings_round_trip_through_their_record() -> None:
    record = json.loads(json.dumps(TINY.record()))
    assert Imitation.from_record(record) == TINY


def test_only_ppo_and_a2c_imitate_and_only_on_the_scenes_that_ask() -> None:
    assert scene_imitation("transitions-2", "ppo") is not None
    assert scene_imitation("transitions-2", "sac") is None
    assert scene_imitation("swingup-2", "ppo") is not None  # its agent observes the elapsed time
    assert scene_imitation("swingup-3", "ppo") is None
    assert scene_imitation(None, "ppo") is None


def _agent(config: ChainCartConfig, seed: int = 0):
    from chaincart_env.tools.compare.training import _new_agent

    return _new_agent("ppo", config, seed, 4, {"n_steps": 32, "batch_size": 64, "policy_kwargs": "dict(net_arch=[32, 32])"},
                      {"norm_obs": True, "norm_reward": False})


def _flat_parameters(model) -> np.ndarray:
    return np.concatenate([p.detach().numpy().ravel() for p in model.policy.parameters()])


def test_imitation_fits_the_planner_is_seeded_and_sets_the_exploration(tmp_path) -> None:
    from chaincart_env.policies import TrajectoryPolicy
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.imitation import imitate

    config = ChainCartConfig(scene="transitions-2")
    venv = ChainCartVecEnv(4, config, seed=77)
    expert = TrajectoryPolicy.from_env(venv)
    observations = [venv.reset()]
    for _ in range(30):
        observations.append(venv.step(expert.predict(observations[-1])[0])[0])
    expert.reset()
    states = np.concatenate(observations)
    labels = expert.predict(states[:4])[0]  # the first step of each episode: a known label per state

    def error(model) -> float:
        normalized = model.get_vec_normalize_env().normalize_obs(states[:4])
        return float(np.mean((model.predict(normalized, deterministic=True)[0] - labels) ** 2))

    fitting = Imitation(**{**TINY.record(), "noise": TINY.noise, "epochs": 60, "batch_size": 64})
    models = []
    for run in range(2):
        model = _agent(config)
        before = error(model)
        (tmp_path / f"run{run}").mkdir()
        imitate(model, config, fitting, 0, tmp_path / f"run{run}")
        models.append(model)
    assert error(models[0]) < 0.5 * before
    assert np.array_equal(_flat_parameters(models[0]), _flat_parameters(models[1]))
    assert np.allclose(models[0].policy.log_std.detach().numpy(), math.log(TINY.action_std))
    with (tmp_path / "run0" / IMITATION_FILE).open(newline="") as file:
        rows = list(csv.DictReader(file))
    assert [int(r["round"]) for r in rows] == [0, 1, 2]
    assert int(rows[0]["samples"]) == 4 * TINY.demonstration_steps * len(TINY.noise)
    assert int(rows[2]["samples"]) == int(rows[0]["samples"]) + 2 * 4 * TINY.round_steps
    statistics = models[0].get_vec_normalize_env()
    assert statistics.obs_rms.count == int(rows[0]["samples"])  # the demonstrations' statistics


def test_imitation_refuses_an_algorithm_without_a_gaussian_actor(tmp_path) -> None:
    from chaincart_env.tools.compare.imitation import imitate
    from chaincart_env.tools.compare.training import _new_agent

    config = ChainCartConfig(scene="transitions-2")
    model = _new_agent("sac", config, 0, 1, {"learning_starts": 10, "buffer_size": 100}, None)
    with pytest.raises(InvalidInputError, match="Gaussian actor-critic"):
        imitate(model, config, TINY, 0, tmp_path)


def test_compare_records_the_scene_imitation_and_no_imitation_turns_it_off() -> None:
    from chaincart_env.tools.compare.job import _training_settings

    config = ChainCartConfig(scene="transitions-2")
    on = _training_settings(config, ["ppo", "sac"], "sb3", None, None, {}, {})
    assert Imitation.from_record(on["ppo"]["imitation"]) == scene_imitation("transitions-2", "ppo")
    assert on["sac"]["imitation"] is None
    off = _training_settings(config, ["ppo"], "sb3", None, None, {}, {}, imitation=False)
    assert off["ppo"]["imitation"] is None
    other = _training_settings(ChainCartConfig(scene="swingup-3"), ["ppo"], "sb3", None, None, {}, {})
    assert other["ppo"]["imitation"] is None
    swing_up = _training_settings(ChainCartConfig(scene="swingup-2"), ["ppo"], "sb3", None, None, {}, {})["ppo"]
    assert Imitation.from_record(swing_up["imitation"]) == scene_imitation("swingup-2", "ppo")
    assert swing_up["elapsed_time"] is True and swing_up["history"] == 1  # the copy needs the time


def test_training_with_an_imitation_evaluates_it_first(tmp_path) -> None:
    from chaincart_env.tools.compare.training import train

    config = ChainCartConfig(scene="transitions-2")
    result = train(config, timesteps=128, num_envs=4, directory=tmp_path, eval_seeds=[1_000_000, 1_000_001],
                   eval_every=128, checkpoint_every=128, progress_bar=False,
                   hyperparameters={"n_steps": 32, "batch_size": 64}, normalize={"norm_obs": True}, imitation=TINY)
    assert (tmp_path / IMITATION_FILE).is_file() and result.imitation["round"] == TINY.rounds
    with (tmp_path / "evaluations.csv").open(newline="") as file:
        assert float(next(csv.DictReader(file))["timesteps"]) == 0.0  # the imitation, before any training


def test_focus_rounds_draw_the_transitions_the_learner_misses_and_stop_when_none(tmp_path, monkeypatch) -> None:
    from chaincart_env.tools.compare import imitation as module

    config = ChainCartConfig(scene="transitions-2")
    solved = {config.pairs[0], config.pairs[5]}
    asked = []

    def pair_success(act, config, pair, starts, seed, extras=(0, False)):
        asked.append((pair, starts))
        return 1.0 if pair in solved else 0.0

    monkeypatch.setattr(module, "_pair_success", pair_success)
    focused = Imitation.from_record({**TINY.record(), "rounds": 1, "focus_rounds": 3, "focus_starts": 2})
    module.imitate(_agent(config), config, focused, 0, tmp_path)
    with (tmp_path / IMITATION_FILE).open(newline="") as file:
        drawn = [int(row["drawn_pairs"]) for row in csv.DictReader(file)]
    # The fit, one round on all 12, then focus rounds: the 10 missed, all 12, the 10 missed.
    assert drawn == [12, 12, 10, 12, 10]
    assert len(asked) == 2 * 12 and {starts for _, starts in asked} == {2}

    solved.update(config.pairs)  # the learner misses none: the focus rounds end at once
    module.imitate(_agent(config), config, focused, 0, tmp_path)
    with (tmp_path / IMITATION_FILE).open(newline="") as file:
        assert [int(row["drawn_pairs"]) for row in csv.DictReader(file)] == [12, 12]


def test_pair_success_counts_the_first_episode_of_each_start() -> None:
    from chaincart_env.policies import TrajectoryPolicy
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.imitation import _pair_success

    config = ChainCartConfig(scene="transitions-2")
    pair = ((-1, -1), (1, 1))
    expert = TrajectoryPolicy.from_env(ChainCartVecEnv(1, config.replace(transitions=[pair])))
    assert _pair_success(lambda obs, _: expert.predict(obs)[0], config, pair, 2, 5) == 1.0
    assert _pair_success(lambda obs, _: np.zeros((obs.shape[0], 1), np.float32), config, pair, 2, 5) == 0.0


def test_the_learner_observes_history_and_elapsed_time_as_the_agent_does(tmp_path) -> None:
    from chaincart_env.tools.compare.imitation import IMITATION_DATA_FILE, imitate
    from chaincart_env.tools.compare.training import _new_agent

    config = ChainCartConfig(scene="swingup-2")
    model = _new_agent("ppo", config, 0, 4, {"n_steps": 32, "batch_size": 64, "policy_kwargs": "dict(net_arch=[32, 32])"},
                       {"norm_obs": True, "norm_reward": False}, history=1, elapsed_time=True)
    plain, steps = config.obs_dim, TINY.demonstration_steps
    assert model.observation_space.shape == (plain + (plain + 1) + 1,)
    imitate(model, config, Imitation(**{**TINY.record(), "noise": TINY.noise, "anchor_weight": 1.0}), 0, tmp_path)
    seen = np.load(tmp_path / IMITATION_DATA_FILE)["observations"]
    assert seen.shape[1] == model.observation_space.shape[0]
    first = seen[: 4 * steps].reshape(steps, 4, -1)  # the first demonstration run, step by step
    np.testing.assert_allclose(first[:, :, -1], np.arange(steps)[:, None] / config.max_episode_steps * np.ones(4),
                               rtol=1e-6)
    np.testing.assert_array_equal(first[1:, :, plain : 2 * plain], first[:-1, :, :plain])  # the observation before


def test_the_imitation_plans_where_asked() -> None:
    assert Imitation(plan_from="equilibrium").plan_from == "equilibrium"
    with pytest.raises(InvalidInputError, match="plan_from = 'nowhere'"):
        Imitation(plan_from="nowhere")
