"""What keeps an imitation while PPO trains on: the critic's warm-up freezes exactly
the actor for exactly its steps, the anchor pulls the policy toward the planner's
labels, both are seeded and resumable, and compare's options are checked by name."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from chaincart_env import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.anchoring import CriticWarmup, ImitationAnchor
from chaincart_env.tools.compare.imitation import IMITATION_DATA_FILE, Imitation, mean_action
from chaincart_env.tools.compare.policy_losses import actor_parameters, minibatches_per_update

TINY = Imitation(demonstration_steps=40, noise=(0.0, 0.05), epochs=3, rounds=1, round_steps=30, round_epochs=2,
                 batch_size=256)
ROLLOUT = {"n_steps": 32, "batch_size": 64, "n_epochs": 2, "policy_kwargs": "dict(net_arch=[32, 32])"}
CONFIG = ChainCartConfig(scene="transitions-2")


def _agent(seed: int = 0):
    from chaincart_env.tools.compare.training import _new_agent

    return _new_agent("ppo", CONFIG, seed, 4, dict(ROLLOUT), {"norm_obs": True, "norm_reward": False})


def _actor_and_critic(model) -> tuple[np.ndarray, np.ndarray]:
    actor = {id(p) for p in actor_parameters(model.policy)}
    flat = [(id(p) in actor, p.detach().numpy().ravel().copy()) for p in model.policy.parameters()]
    return (np.concatenate([v for is_actor, v in flat if is_actor]),
            np.concatenate([v for is_actor, v in flat if not is_actor]))


@pytest.mark.parametrize(
    "changes, named",
    [
        (dict(critic_warmup=-1), "critic_warmup = -1"),
        (dict(critic_warmup=1.5), "critic_warmup = 1.5"),
        (dict(anchor_weight=-0.5), "anchor_weight = -0.5"),
        (dict(anchor_weight=float("inf")), "anchor_weight = inf"),
        (dict(anchor_weight=True), "anchor_weight = True"),
    ],
)
def test_bad_anchoring_settings_are_named(changes, named) -> None:
    with pytest.raises(InvalidInputError, match=named):
        Imitation(**changes)


def test_an_older_record_without_anchoring_reads_as_none() -> None:
    record = json.loads(json.dumps(TINY.record()))
    del record["critic_warmup"], record["anchor_weight"]
    read = Imitation.from_record(record)
    assert (read.critic_warmup, read.anchor_weight) == (0, 0.0)


def test_the_actor_is_every_parameter_but_the_value_function() -> None:
    policy = _agent().policy
    actor = {id(p) for p in actor_parameters(policy)}
    critic = {id(p) for module in (policy.mlp_extractor.value_net, policy.value_net) for p in module.parameters()}
    assert actor.isdisjoint(critic)
    assert actor | critic == {id(p) for p in policy.parameters()}
    assert id(policy.log_std) in actor


def test_the_critic_warmup_trains_only_the_value_function_for_its_steps() -> None:
    model = _agent()
    rollout = ROLLOUT["n_steps"] * 4
    actor0, critic0 = _actor_and_critic(model)
    model.learn(total_timesteps=2 * rollout, callback=[CriticWarmup(2 * rollout)])
    actor1, critic1 = _actor_and_critic(model)
    assert np.array_equal(actor1, actor0)  # two updates, the actor frozen in both
    assert not np.allclose(critic1, critic0)
    assert all(p.requires_grad for p in model.policy.parameters())  # freed at the end
    warm = CriticWarmup(3 * rollout)
    model.learn(total_timesteps=2 * rollout, callback=[warm], reset_num_timesteps=False)
    # The run counts its earlier steps: the update after step 3 x rollout is free.
    assert not np.array_equal(_actor_and_critic(model)[0], actor1)
    assert not warm.frozen


def _anchored(tmp_path, weight: float, seed: int = 0):
    import torch

    from chaincart_env.tools.compare.imitation import imitate

    torch.manual_seed(seed)
    model = _agent(seed)
    imitate(model, CONFIG, Imitation(**{**TINY.record(), "noise": TINY.noise, "anchor_weight": weight}), seed,
            tmp_path)
    return model


def _imitation_error(model, tmp_path) -> float:
    import torch

    with np.load(tmp_path / IMITATION_DATA_FILE) as data:
        observed = model.get_vec_normalize_env().normalize_obs(data["observations"])
        with torch.no_grad():
            mean = mean_action(model.policy, torch.as_tensor(observed, dtype=torch.float32))
        return float(((mean.numpy() - data["labels"]) ** 2).mean())


def test_the_imitation_keeps_its_data_only_for_an_anchor(tmp_path) -> None:
    (tmp_path / "plain").mkdir()
    _anchored(tmp_path / "plain", 0.0)
    assert not (tmp_path / "plain" / IMITATION_DATA_FILE).exists()
    model = _anchored(tmp_path, 1.0)
    with np.load(tmp_path / IMITATION_DATA_FILE) as data:
        with (tmp_path / "imitation.csv").open(newline="") as file:
            samples = int(list(csv.DictReader(file))[-1]["samples"])
        assert data["observations"].shape[0] == data["labels"].shape[0] == samples
        assert data["observations"].shape[1:] == model.observation_space.shape
        assert data["labels"].shape[1:] == model.action_space.shape and np.all(np.abs(data["labels"]) <= 1.0)


def test_the_anchor_steps_the_policy_toward_the_labels_as_often_as_an_update(tmp_path) -> None:
    import torch

    model = _anchored(tmp_path, 1.0)
    with torch.no_grad():  # the policy moved away from its imitation
        for p in model.policy.action_net.parameters():
            p.add_(0.3 * torch.randn_like(p))
    before = _imitation_error(model, tmp_path)
    from stable_baselines3.common.logger import configure

    model.set_logger(configure(None, []))  # as learn() sets one
    anchor = ImitationAnchor(tmp_path, 1.0)
    anchor.init_callback(model)
    steps = []
    original = model.policy.optimizer.step
    model.policy.optimizer.step = lambda *a, **k: (steps.append(1), original(*a, **k))[1]
    anchor.on_rollout_end()
    assert len(steps) == minibatches_per_update(model) == ROLLOUT["n_epochs"] * math.ceil(
        ROLLOUT["n_steps"] * 4 / ROLLOUT["batch_size"])
    assert _imitation_error(model, tmp_path) < before
    assert math.isfinite(anchor.last_loss)


def test_the_anchor_waits_for_the_critic_warmup(tmp_path) -> None:
    model = _anchored(tmp_path, 1.0)
    warm, anchor = CriticWarmup(10**6), ImitationAnchor(tmp_path, 1.0)
    actor0 = _actor_and_critic(model)[0]
    model.learn(total_timesteps=ROLLOUT["n_steps"] * 4, callback=[warm, anchor])
    assert np.array_equal(_actor_and_critic(model)[0], actor0)
    assert math.isnan(anchor.last_loss)


def test_an_anchored_training_keeps_the_imitations_observation_statistics(tmp_path, monkeypatch) -> None:
    from chaincart_env.tools.compare import training as module

    seen = {}
    imitate = module.imitate

    def imitate_and_note(model, *args):
        out = imitate(model, *args)
        statistics = model.get_vec_normalize_env().obs_rms
        seen["after"] = (statistics.mean.copy(), statistics.var.copy(), statistics.count)
        return out

    monkeypatch.setattr(module, "imitate", imitate_and_note)
    for weight, kept in ((0.5, True), (0.0, False)):
        imitation = Imitation(**{**TINY.record(), "noise": TINY.noise, "anchor_weight": weight})
        result = module.train(CONFIG, timesteps=256, num_envs=4, directory=tmp_path / str(weight),
                              eval_seeds=[1_000_000], eval_every=10**6, checkpoint_every=10**6, progress_bar=False,
                              hyperparameters=dict(ROLLOUT), normalize={"norm_obs": True, "norm_reward": False},
                              imitation=imitation)
        statistics = result.model.get_vec_normalize_env().obs_rms
        mean, var, count = seen["after"]
        assert (np.array_equal(statistics.mean, mean) and np.array_equal(statistics.var, var)
                and statistics.count == count) is kept


def test_an_anchored_training_is_seeded(tmp_path) -> None:
    from chaincart_env.tools.compare.training import train

    kept = Imitation(**{**TINY.record(), "noise": TINY.noise, "critic_warmup": 128, "anchor_weight": 0.5})
    parameters = []
    for run in ("a", "b"):
        result = train(CONFIG, timesteps=384, num_envs=4, directory=tmp_path / run, eval_seeds=[1_000_000],
                       eval_every=10**6, checkpoint_every=10**6, progress_bar=False, hyperparameters=dict(ROLLOUT),
                       normalize={"norm_obs": True, "norm_reward": False}, imitation=kept)
        parameters.append(np.concatenate([p.detach().numpy().ravel() for p in result.model.policy.parameters()]))
    assert np.array_equal(parameters[0], parameters[1])


def test_compare_changes_the_scene_imitation_and_refuses_anchoring_without_one() -> None:
    from chaincart_env.tools.compare.job import _training_settings

    kept = _training_settings(CONFIG, ["ppo"], "sb3", None, None, {}, {},
                              imitation={"critic_warmup": 100_000, "anchor_weight": 2.0})
    record = Imitation.from_record(kept["ppo"]["imitation"])
    assert (record.critic_warmup, record.anchor_weight, record.focus_rounds) == (100_000, 2.0, 8)
    scene = Imitation.from_record(_training_settings(CONFIG, ["ppo"], "sb3", None, None, {}, {})["ppo"]["imitation"])
    assert (scene.critic_warmup, scene.anchor_weight, scene.action_std) == (500_000, 10.0, 0.03)
    with pytest.raises(InvalidInputError, match="critic_warmup = 1000.*transitions-2"):
        _training_settings(ChainCartConfig(scene="swingup-3"), ["ppo"], "sb3", None, None, {}, {},
                           imitation={"critic_warmup": 1000})
    with pytest.raises(InvalidInputError, match="anchor_weight = -1"):
        _training_settings(CONFIG, ["ppo"], "sb3", None, None, {}, {}, imitation={"anchor_weight": -1.0})


def test_the_command_line_reads_the_anchoring_options(capsys) -> None:
    from chaincart_env.__main__ import main

    with pytest.raises(SystemExit):
        main(["compare", "--scene", "transitions-2", "--no-imitation", "--critic-warmup", "1000", "--out", "/nonexistent"])
    assert "--critic-warmup and --imitation-weight keep an imitation" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["compare", "--scene", "swingup-3", "--policies", "ppo", "--imitation-weight", "1", "--out",
              "/nonexistent"])
    assert "anchor_weight = 1.0" in capsys.readouterr().err
