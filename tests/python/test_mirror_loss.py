"""The mirror loss beside PPO's: its mirror of an observation with history is the
model's (the mirrored episode's observations), it is the same raw or normalised, it
makes the policy act mirror-symmetrically, training with it is seeded, and its setting
is checked by name."""

from __future__ import annotations

import numpy as np
import pytest

from chaincart_env import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.history import VecHistoryObservation
from chaincart_env.sb3 import ChainCartVecEnv
from chaincart_env.symmetry import Mirror
from chaincart_env.tools.compare.mirror_loss import MirrorLoss, check_mirror_weight

ROLLOUT = {"n_steps": 32, "batch_size": 64, "n_epochs": 2, "policy_kwargs": "dict(net_arch=[32, 32])"}


@pytest.mark.parametrize("scene, history", [("swingup-2", 1), ("spatial-inverted-2", 2)])
def test_the_mirror_of_an_observation_with_history_is_the_mirrored_episodes(scene: str, history: int) -> None:
    config = ChainCartConfig(scene=scene, obs_dtype="float64", max_episode_steps=60, start_noise=0.0)
    mirror = Mirror(config)
    signs, action_signs = mirror.observation_signs(history), mirror.action_signs()
    n = config.n_links
    layout = 2 + 3 * n if config.planar else 4 + 6 * n  # the state layout the start option takes
    first = np.asarray(ChainCartVecEnv(1, config, seed=5).reset())[0][:layout]
    rng = np.random.default_rng(1)
    # A start off the symmetry plane and away from rest, so that nothing is mirror-symmetric by itself.
    start = model_state(config, first + 0.2 * rng.standard_normal(layout))
    one = VecHistoryObservation(ChainCartVecEnv(1, config.replace(start=list(start)), seed=5), history)
    other = VecHistoryObservation(
        ChainCartVecEnv(1, config.replace(start=list(mirror.state(start))), seed=5), history)
    obs, mirrored_obs = one.reset(), other.reset()
    assert not np.allclose(obs * signs, obs)
    for _ in range(40):
        assert np.allclose(mirrored_obs, obs * signs, rtol=0, atol=1e-9)
        action = rng.uniform(-1, 1, (1, *one.action_space.shape))
        obs, _, done, _ = one.step(action)
        mirrored_obs, _, mirrored_done, _ = other.step(action * action_signs)
        assert np.array_equal(done, mirrored_done)
    assert signs.shape == one.observation_space.shape and action_signs.shape == one.action_space.shape


def model_state(config: ChainCartConfig, state: np.ndarray) -> np.ndarray:
    """``state`` made a state of the model: unit link directions (the planar layout's
    ``(q.e1, q.e3)`` pairs, the spatial one's ``q`` triples) and, in space, angular
    velocities normal to their links."""
    n, state = config.n_links, state.copy()
    width, first = (2, 2) if config.planar else (3, 4)
    for i in range(n):
        link = slice(first + width * i, first + width * (i + 1))
        state[link] /= np.linalg.norm(state[link])
        if not config.planar:
            q, w = state[link], state[first + 3 * n + 3 * i: first + 3 * n + 3 * (i + 1)]
            w -= (w @ q) * q
    return state


def test_history_must_be_a_count() -> None:
    with pytest.raises(InvalidInputError, match="history = -1"):
        Mirror(ChainCartConfig(scene="swingup-2")).observation_signs(-1)


def _agent(config: ChainCartConfig, normalize=None, history=None, seed: int = 0):
    from chaincart_env.tools.compare.training import _new_agent

    return _new_agent("ppo", config, seed, 4, dict(ROLLOUT), normalize, history=history)


def _asymmetry(model, loss: MirrorLoss, observed: np.ndarray) -> float:
    import torch

    from chaincart_env.tools.compare.imitation import mean_action

    with torch.no_grad():
        mean = mean_action(model.policy, torch.as_tensor(observed, dtype=torch.float32)).numpy()
        mirrored = mean_action(model.policy, torch.as_tensor(loss.mirrored(model, observed), dtype=torch.float32))
    return float(((mirrored.numpy() - mean * loss.action_signs) ** 2).mean())


def test_normalised_observations_are_mirrored_raw() -> None:
    config = ChainCartConfig(scene="swingup-2")
    model = _agent(config, {"norm_obs": True, "norm_reward": False}, history=1)
    model.learn(ROLLOUT["n_steps"] * 4)  # statistics that are not symmetric
    statistics = model.get_vec_normalize_env()
    raw = np.asarray(model.rollout_buffer.observations).reshape(-1, model.observation_space.shape[0])
    raw = statistics.unnormalize_obs(raw)
    loss = MirrorLoss(config, 1.0, history=1)
    expected = statistics.normalize_obs(raw * Mirror(config).observation_signs(1))
    assert np.allclose(loss.mirrored(model, statistics.normalize_obs(raw)), expected, atol=1e-5)
    assert not np.allclose(expected, statistics.normalize_obs(raw) * loss.observation_signs, atol=1e-3)


def test_the_loss_makes_the_policy_act_mirror_symmetrically() -> None:
    from stable_baselines3.common.logger import configure

    config = ChainCartConfig(scene="swingup-2")
    model = _agent(config, {"norm_obs": True, "norm_reward": False})
    model.learn(ROLLOUT["n_steps"] * 4)
    model.set_logger(configure(None, []))
    loss = MirrorLoss(config, 1.0)
    loss.init_callback(model)
    observed = np.asarray(model.rollout_buffer.observations).reshape(-1, model.observation_space.shape[0])
    before = _asymmetry(model, loss, observed)
    for _ in range(10):
        loss.on_rollout_end()
    assert _asymmetry(model, loss, observed) < 0.2 * before
    assert np.isfinite(loss.last_loss)


def test_a_training_with_the_mirror_loss_is_seeded_and_recorded(tmp_path) -> None:
    from chaincart_env.tools.compare.training import train

    config = ChainCartConfig(scene="swingup-2", max_episode_steps=40)
    parameters = []
    for run in ("a", "b"):
        result = train(config, timesteps=256, num_envs=4, directory=tmp_path / run, eval_seeds=[1_000_000],
                       eval_every=10**6, checkpoint_every=10**6, progress_bar=False, hyperparameters=dict(ROLLOUT),
                       history=1, mirror_weight=0.5)
        parameters.append(np.concatenate([p.detach().numpy().ravel() for p in result.model.policy.parameters()]))
    assert np.array_equal(parameters[0], parameters[1])
    plain = train(config, timesteps=256, num_envs=4, directory=tmp_path / "plain", eval_seeds=[1_000_000],
                  eval_every=10**6, checkpoint_every=10**6, progress_bar=False, hyperparameters=dict(ROLLOUT),
                  history=1)
    assert not np.array_equal(
        parameters[0], np.concatenate([p.detach().numpy().ravel() for p in plain.model.policy.parameters()]))


def test_an_agent_observing_history_and_time_trains_mirrored_and_is_evaluated_as_it_acts(tmp_path) -> None:
    from chaincart_env.tools.compare.training import train

    config = ChainCartConfig(scene="swingup-2", max_episode_steps=40)
    result = train(config, timesteps=256, num_envs=4, directory=tmp_path, eval_seeds=[1_000_000, 1_000_001],
                   eval_every=128, checkpoint_every=10**6, progress_bar=False, hyperparameters=dict(ROLLOUT),
                   history=1, elapsed_time=True, mirror_weight=0.5)
    assert result.model.observation_space.shape == (config.obs_dim * 2 + 1 + 1,)
    assert len(result.evaluations) >= 2  # the periodic evaluations ran the agent on plain envs
    loss = MirrorLoss(config, 1.0, history=1, elapsed_time=True)
    assert loss.observation_signs.shape == result.model.observation_space.shape and loss.observation_signs[-1] == 1.0


@pytest.mark.parametrize("weight", [-1.0, float("nan"), float("inf"), True, "1"])
def test_bad_mirror_weights_are_named(weight) -> None:
    with pytest.raises(InvalidInputError, match="mirror weight = "):
        check_mirror_weight(weight)


def test_compare_records_the_mirror_weight_and_refuses_it_where_it_cannot_serve(tmp_path) -> None:
    from chaincart_env.tools.compare.job import _training_settings
    from chaincart_env.tools.compare.training import train

    config = ChainCartConfig(scene="swingup-2")
    chosen = _training_settings(config, ["ppo", "ppo-robust"], "sb3", None, None, {}, {}, mirror_weight=0.5)
    assert chosen["ppo"]["mirror_weight"] == 0.5 and chosen["ppo-robust"]["first_stage"]["mirror_weight"] == 0.5
    assert _training_settings(config, ["ppo"], "sb3", None, None, {}, {})["ppo"]["mirror_weight"] == 0.0
    with pytest.raises(InvalidInputError, match="--mirror-weight 0.5 for sac"):
        _training_settings(config, ["ppo", "sac"], "sb3", None, None, {}, {}, mirror_weight=0.5)
    with pytest.raises(InvalidInputError, match="--mirror-weight 0.5 for ppo with --trainer rllib"):
        _training_settings(config, ["ppo"], "rllib", None, None, {}, {}, mirror_weight=0.5)
    with pytest.raises(InvalidInputError, match="mirror weight 1.0 with sac"):
        train(config, algo="sac", timesteps=10, num_envs=1, directory=tmp_path, eval_seeds=[0], eval_every=10,
              checkpoint_every=10, progress_bar=False, mirror_weight=1.0)


def test_the_command_line_reads_the_mirror_weight(capsys) -> None:
    from chaincart_env.__main__ import main

    with pytest.raises(SystemExit):
        main(["compare", "--scene", "swingup-2", "--policies", "ppo,sac", "--mirror-weight", "1", "--out",
              "/nonexistent"])
    assert "--mirror-weight 1.0 for sac" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["compare", "--mirror-weight", "-2", "--out", "/nonexistent"])
    assert "mirror weight = -2.0" in capsys.readouterr().err
