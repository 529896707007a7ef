"""compare --history K: the agents train and are evaluated on observations carrying the
last K observations and actions, and a saved agent evaluates with the same history."""

from __future__ import annotations

import csv
import pathlib

import numpy as np
import pytest

from chaincart_env import ChainCartEnv, HistoryObservation
from chaincart_env.__main__ import main
from chaincart_env.tools.compare.evaluation import rollout

HISTORY = 2
# Seconds of work: 2 envs, PPO rollouts of 64 steps, 40-step episodes, 3 evaluation starts.
TINY = [
    "--scene", "inverted-1", "--timesteps", "128", "--num-envs", "2", "--eval-episodes", "3", "--eval-seed", "7",
    "--set", "max_episode_steps=40", "--set", "action_delay=0,2", "--algo-kwarg", "n_steps=64", "--algo-kwarg", "batch_size=64",
    "--eval-every", "64", "--eval-starts", "2", "--checkpoint-every", "128", "--sweep", "start_noise=0.05",
    "--no-progress",
]  # fmt: skip


def _rows(path: pathlib.Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


def test_a_history_run_trains_and_its_saved_agent_evaluates_with_the_same_history(tmp_path: pathlib.Path) -> None:
    from chaincart_env.tools.compare.policy_sources import load_run

    out = tmp_path / "run"
    assert main(["compare", *TINY, "--history", str(HISTORY), "--out", str(out)]) == 0
    saved = load_run(out / "seed-0")
    assert saved.config.action_delay == (0, 2)  # a delay drawn per episode, kept in the run's files
    env = ChainCartEnv(saved.config)
    obs_dim, action_dim = env.observation_space.shape[0], env.action_space.shape[0]
    assert saved.model.observation_space.shape == (obs_dim + HISTORY * (obs_dim + action_dim),)
    # Evaluating the saved run again gives the comparison the run wrote.
    assert main(["evaluate", str(out), "--out", str(tmp_path / "again")]) == 0
    assert _rows(tmp_path / "again" / "comparison.csv") == _rows(out / "comparison.csv")
    # The evaluation acts as the agent would in a plain loop over the wrapped env.
    seed = 123
    batch = rollout(saved.model, "PPO", saved.config, [seed])
    wrapped = HistoryObservation(ChainCartEnv(saved.config), HISTORY)
    obs, _ = wrapped.reset(seed=seed)
    total, steps, done = 0.0, 0, False
    while not done:
        action, _ = saved.model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, _ = wrapped.step(action)
        total, steps, done = total + float(reward), steps + 1, terminated or truncated
    assert int(batch.lengths[0]) == steps
    assert float(batch.returns[0]) == pytest.approx(total, rel=1e-6)


def test_a_bad_history_is_a_clear_error(tmp_path: pathlib.Path, capsys) -> None:
    for bad in ("0", "two"):
        with pytest.raises(SystemExit):
            main(["compare", *TINY, "--history", bad, "--out", str(tmp_path)])
        assert f"history = {bad if bad == '0' else repr(bad)}: expected an integer >= 1" in capsys.readouterr().err
    assert not np.any([p.name == "seed-0" for p in tmp_path.iterdir()])
