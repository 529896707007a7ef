"""A curriculum's spread floor: each observation component is divided by at least a share
of its spread along the plan. The floor is checked, computed from the plan's own
observations, applied wherever the agent's statistics normalise (training, a saved agent,
an exported one), and a warm start across floors is refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from chaincart_env import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.curriculum import PlanStarts, plan_observations, plan_states

SWINGUP = ChainCartConfig(scene="swingup-2")
TINY = {"n_steps": 32, "batch_size": 64, "policy_kwargs": "dict(net_arch=[16])"}
NORMALIZE = {"norm_obs": True, "norm_reward": False}


@pytest.fixture(scope="module")
def states() -> np.ndarray:
    return plan_states(SWINGUP)


@pytest.mark.parametrize("floor", [-0.1, 1.5, float("nan"), True, "tenth"])
def test_a_bad_spread_floor_is_named(floor) -> None:
    with pytest.raises(InvalidInputError, match=r"plan-start spread_floor = .*expected a number in \[0, 1\]"):
        PlanStarts(spread_floor=floor)


def test_the_setting_round_trips_through_its_record_and_older_records_have_none() -> None:
    floored = PlanStarts(1.0, reverse=True, spread_floor=0.1)
    assert PlanStarts.from_record(json.loads(json.dumps(floored.record()))) == floored
    older = {key: value for key, value in floored.record().items() if key != "spread_floor"}
    assert PlanStarts.from_record(older).spread_floor == 0.0


def test_the_plan_observations_are_what_the_env_observes_there_without_noise(states) -> None:
    from chaincart_env.sb3 import ChainCartVecEnv

    noisy = SWINGUP.replace(obs_noise=0.3)
    observations = plan_observations(noisy, states)
    assert observations.shape == (len(states), SWINGUP.obs_dim)
    env = ChainCartVecEnv(1, SWINGUP, seed=4)
    env.reset()
    for row in (0, len(states) // 2, len(states) - 1):
        env.env_method("set_state", states[row], indices=0)
        np.testing.assert_array_equal(observations[row], env._batch.observations()[0])
    np.testing.assert_array_equal(observations, plan_observations(noisy, states))  # no noise drawn
    assert np.all(observations.std(axis=0) > 0.1)  # every component moves along a swing-up


def _floored(floor: np.ndarray, var: np.ndarray, clip: float = 10.0):
    import gymnasium
    from stable_baselines3.common.vec_env import DummyVecEnv

    from chaincart_env.tools.compare.normalization import FlooredVecNormalize

    envs = DummyVecEnv([lambda: gymnasium.make("ChainCart-swingup-2-v0")])
    statistics = FlooredVecNormalize(envs, floor, norm_obs=True, norm_reward=False, clip_obs=clip)
    rms = statistics.obs_rms
    rms.mean, rms.var = np.linspace(-1.0, 1.0, var.size), var
    return statistics


def test_observations_are_divided_by_the_larger_of_the_spread_and_its_floor() -> None:
    from chaincart_env.tools.compare.normalization import observation_variance

    var = np.array([1e-6, 1e-6, 4.0, 4.0, 1e-6, 0.25, 0.25, 0.25])
    floor = np.array([0.01, 0.0, 1.0, 9.0, 0.04, 0.0, 1.0, 0.25])
    statistics = _floored(floor, var, clip=1e9)
    observation = statistics.obs_rms.mean + np.full(8, 0.6)
    spread = np.sqrt(np.maximum(var, floor) + statistics.epsilon)
    np.testing.assert_allclose(statistics.normalize_obs(observation[None])[0], 0.6 / spread, rtol=1e-6)  # float32
    # A component below its floor reads smaller than SB3's VecNormalize would make it, one above it alike.
    assert statistics.normalize_obs(observation[None])[0][0] == pytest.approx(6.0, rel=1e-3)
    assert statistics.normalize_obs(observation[None])[0][1] == pytest.approx(0.6 / np.sqrt(1e-6 + 1e-8), rel=1e-6)
    np.testing.assert_allclose(statistics.unnormalize_obs(statistics.normalize_obs(observation[None])),
                               observation[None], rtol=1e-6)
    np.testing.assert_array_equal(observation_variance(statistics), np.maximum(var, floor))


@pytest.mark.parametrize("floor", [np.zeros(3), np.full(8, -1.0), np.full(8, np.inf)])
def test_a_bad_variance_floor_is_named(floor) -> None:
    with pytest.raises(InvalidInputError, match="variance floor of shape .*expected finite values >= 0"):
        _floored(floor, np.ones(8))


def _train(directory, spread_floor: float, **extra):
    from chaincart_env.tools.compare.training import train

    curriculum = PlanStarts(1.0, reverse=True, window=0.02, spread_floor=spread_floor)  # starts near the top
    # Episodes end at the fall, so that the starts near the top keep the counted spread small.
    return train(SWINGUP.replace(fall_limit=0.3), timesteps=128, num_envs=2, seed=5, directory=directory,
                 eval_seeds=[1_000_000], eval_every=10_000, checkpoint_every=10_000, progress_bar=False,
                 hyperparameters=TINY, normalize=NORMALIZE, curriculum=curriculum, **extra)


def test_a_floored_run_is_seeded(tmp_path) -> None:
    first, second = (_train(tmp_path / name, 0.1).model for name in ("first", "second"))
    np.testing.assert_array_equal(first.get_vec_normalize_env().variance_floor,
                                  second.get_vec_normalize_env().variance_floor)
    np.testing.assert_array_equal(first.get_vec_normalize_env().obs_rms.var, second.get_vec_normalize_env().obs_rms.var)
    for (name, weights), (_, again) in zip(first.policy.state_dict().items(), second.policy.state_dict().items()):
        assert (weights == again).all(), name


def test_a_run_divides_by_the_share_of_the_plans_spread_and_its_saved_agent_too(states, tmp_path) -> None:
    from chaincart_env.tools.compare.normalization import FlooredVecNormalize, load_statistics, save_agent

    result = _train(tmp_path / "floored", 0.1, history=1)
    statistics = result.model.get_vec_normalize_env()
    assert isinstance(statistics, FlooredVecNormalize)
    size = SWINGUP.obs_dim
    expected = (0.1 * plan_observations(SWINGUP, states).std(axis=0)) ** 2
    np.testing.assert_allclose(statistics.variance_floor[:size], expected, rtol=1e-12)
    # The history the agent also observes keeps its counted spread.
    assert statistics.variance_floor.shape == statistics.observation_space.shape
    assert statistics.observation_space.shape[0] > size and not statistics.variance_floor[size:].any()
    # Near the top of a short training, some component's counted spread lies below its floor.
    assert np.any(statistics.obs_rms.var[:size] < statistics.variance_floor[:size])
    save_agent(result.model, tmp_path / "agent.zip")
    saved = load_statistics(tmp_path / "agent.zip")
    probe = np.random.default_rng(0).normal(0.0, 2.0, (5, statistics.observation_space.shape[0]))
    np.testing.assert_array_equal(saved.normalize_obs(probe), statistics.normalize_obs(probe))
    without = _train(tmp_path / "plain", 0.0).model.get_vec_normalize_env()
    assert type(without).__name__ == "VecNormalize"  # no floor asked, SB3's own


def test_a_floor_needs_a_recipe_that_normalises(tmp_path) -> None:
    from chaincart_env.tools.compare.training import train

    with pytest.raises(InvalidInputError, match="flooring the observation spread with ppo's recipe, which does not"):
        train(SWINGUP, timesteps=64, num_envs=2, seed=5, directory=tmp_path, eval_seeds=[1_000_000],
              eval_every=64, checkpoint_every=10_000, progress_bar=False,
              curriculum=PlanStarts(1.0, spread_floor=0.1))


def test_an_exported_agent_normalises_as_the_floored_statistics_do(tmp_path) -> None:
    from stable_baselines3 import PPO

    from chaincart_env.pretrained_agents import PretrainedPolicy
    from chaincart_env.tools.compare.normalization import read_statistics
    from chaincart_env.tools.export_agent import agent_record

    var = np.full(8, 1e-4)
    statistics = _floored(np.full(8, 0.09), var)
    model = PPO("MlpPolicy", statistics.venv, seed=0, device="cpu", policy_kwargs=dict(net_arch=[8]))
    statistics.save(str(tmp_path / "vecnormalize.pkl"))  # exported as export-agent reads it: without envs
    loaded = read_statistics((tmp_path / "vecnormalize.pkl").read_bytes())
    record, arrays = agent_record(model, loaded, SWINGUP, "test")
    agent = PretrainedPolicy(json.loads(json.dumps(record)), arrays)
    observations = np.random.default_rng(2).normal(0.0, 0.5, (20, 8))
    np.testing.assert_allclose(agent.normalize(observations), statistics.normalize_obs(observations), rtol=1e-6)


def test_a_warm_start_across_floors_is_refused(tmp_path) -> None:
    first = _train(tmp_path / "floored", 0.1)
    from chaincart_env.tools.compare.normalization import save_agent

    save_agent(first.model, tmp_path / "floored.zip")
    with pytest.raises(InvalidInputError, match="spread floor \\(set\\) differs from the new agent's \\(none\\)"):
        _train(tmp_path / "plain", 0.0, warm_start_from=tmp_path / "floored.zip")
    with pytest.raises(InvalidInputError, match="spread floor \\(set\\) differs from the new agent's \\(set\\)"):
        _train(tmp_path / "other", 0.2, warm_start_from=tmp_path / "floored.zip")
    _train(tmp_path / "same", 0.1, warm_start_from=tmp_path / "floored.zip")  # the same floor warm-starts
