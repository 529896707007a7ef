"""Warm starts: a new agent takes a saved agent's weights (exactly), a run records where
it started from, and an agent that does not fit is refused with the reason."""

from __future__ import annotations

import json
import pathlib

import pytest
import torch
from stable_baselines3 import PPO

from chaincart_env import ChainCartConfig, ChainCartVecEnv
from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.history import VecHistoryObservation
from chaincart_env.tools.compare.warm_start import agent_file, warm_start

CONFIG = ChainCartConfig(scene="inverted-1", max_episode_steps=40)


def _agent(seed: int, history: int | None = None) -> PPO:
    envs = ChainCartVecEnv(2, CONFIG, seed=seed)
    return PPO("MlpPolicy", envs if history is None else VecHistoryObservation(envs, history), seed=seed,
               n_steps=64, batch_size=64, device="cpu")


def _weights(model: PPO) -> dict[str, torch.Tensor]:
    return {k: v.clone() for k, v in model.policy.state_dict().items()}


def test_a_new_agent_takes_the_saved_weights_exactly(tmp_path: pathlib.Path):
    source = _agent(1)
    source.learn(128)
    source.save(tmp_path / "model.zip")
    target = _agent(2)
    assert any(not torch.equal(a, b) for a, b in zip(_weights(source).values(), _weights(target).values()))
    assert warm_start(target, tmp_path) == tmp_path / "model.zip"  # a folder: its model file
    assert all(torch.equal(a, b) for a, b in zip(_weights(source).values(), _weights(target).values()))


def test_an_agent_of_other_spaces_or_no_agent_is_refused(tmp_path: pathlib.Path):
    _agent(1, history=2).save(tmp_path / "model.zip")
    with pytest.raises(InvalidInputError, match=r"warm start .*model.zip: .*expected an agent of the same algorithm"):
        warm_start(_agent(2), tmp_path / "model.zip")
    with pytest.raises(InvalidInputError, match=r"warm start .*nowhere.zip: no such file"):
        agent_file(tmp_path / "nowhere.zip")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InvalidInputError, match=r"warm start .*empty: a folder without best_model.zip or model.zip"):
        agent_file(tmp_path / "empty")


TINY = [
    "--scene", "inverted-1", "--timesteps", "128", "--num-envs", "2", "--eval-episodes", "2", "--eval-seed", "7",
    "--set", "max_episode_steps=40", "--algo-kwarg", "n_steps=64", "--algo-kwarg", "batch_size=64",
    "--eval-every", "64", "--eval-starts", "2", "--checkpoint-every", "128", "--sweep", "start_noise=0.05",
    "--no-progress", "--policies", "ppo",
]  # fmt: skip


def test_a_warm_started_run_records_its_source_and_starts_from_it(tmp_path: pathlib.Path):
    assert main(["compare", *TINY, "--out", str(tmp_path / "first")]) == 0
    source = tmp_path / "first" / "seed-0"
    assert main(["compare", *TINY, "--warm-start", str(source), "--out", str(tmp_path / "second")]) == 0
    run = json.loads((tmp_path / "second" / "run.json").read_text())
    assert run["settings"]["training"]["ppo"]["warm_start"] == str((source / "best_model.zip").resolve())
    # The step-0 evaluation of the second run scores the first run's best model.
    first = (source / "evaluations.csv").read_text().splitlines()
    second = (tmp_path / "second" / "seed-0" / "evaluations.csv").read_text().splitlines()
    best_return = max(float(row.split(",")[6]) for row in first[1:])
    assert float(second[1].split(",")[6]) == pytest.approx(best_return)
