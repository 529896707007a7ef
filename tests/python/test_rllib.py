"""Ray RLlib on chaincart, on a local Ray cluster of 2 CPUs shared by every test of this
module: the native vector env in every runner, the env config passed through,
disjoint start seeds across runners, next-step autoreset enforced, the trained
module as a policy, and ``compare --trainer rllib`` on a tiny budget."""

from __future__ import annotations

import csv
import json
import os
import pathlib
import subprocess
import sys
from typing import Any, Iterator

import gymnasium as gym
import numpy as np
import pytest
import ray  # the rllib extra, installed by scripts/setup.sh
from gymnasium.vector import AutoresetMode
from ray.rllib.algorithms.appo import APPOConfig

from chaincart_env import ChainCartConfig, ChainCartEnv, ChainCartError, ChainCartVectorEnv, _core
from chaincart_env.__main__ import main
from chaincart_env.rllib import (
    ENV_NAME,
    RunnerStartSeeds,
    configure,
    make_runner_env,
    ppo_config,
    runner_start_seeds,
    start_seeds_of,
)
from chaincart_env.tools.bench.rllib_sampling import measure_sampling
from chaincart_env.tools.compare.cell_runner import ray_cluster
from chaincart_env.tools.compare.evaluation import METRIC_COLUMNS, evaluate_policies, evaluation_seeds
from chaincart_env.tools.compare.job import OUTPUT_FILES, lqr_baseline
from chaincart_env.tools.compare.learning_curve import TRAINING_EPISODE_COLUMNS
from chaincart_env.tools.compare.rllib_training import RLlibPolicy

ROOT = pathlib.Path(__file__).resolve().parents[2]
SEED = 5
RUNNERS = 2
ENVS_PER_RUNNER = 3
EPISODE_STEPS = 40
# A non-default scene and keywords, to see them arrive in the runners.
SCENE = dict(scene="inverted-1", start_noise=0.07, max_episode_steps=EPISODE_STEPS)
TINY_TRAINING = dict(train_batch_size_per_learner=120, minibatch_size=60, num_epochs=1)


def read_csv(path: pathlib.Path) -> tuple[list[str], list[dict[str, str]]]:
    with path.open(newline="") as file:
        reader = csv.DictReader(file)
        return list(reader.fieldnames or []), list(reader)


@pytest.fixture(scope="module")
def ray_session() -> Iterator[None]:
    # A new local cluster, even if this machine runs one started with `ray start`.
    ray.init(address="local", num_cpus=2, include_dashboard=False, logging_level="WARNING")
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def algo(ray_session: None) -> Iterator[Any]:
    """PPO trained for one iteration on 2 runners of 3 envs. Its runners reserve no
    CPU, so the compare run beside it gets the session's 2 CPUs for its own runners."""
    config = (
        ppo_config(**SCENE)
        .env_runners(num_env_runners=RUNNERS, num_envs_per_env_runner=ENVS_PER_RUNNER, num_cpus_per_env_runner=0)
        .learners(num_learners=0)
        .training(**TINY_TRAINING)
        .debugging(seed=SEED)
    )
    algorithm = config.build_algo()
    result = algorithm.train()
    assert result["num_env_steps_sampled_lifetime"] >= TINY_TRAINING["train_batch_size_per_learner"]
    yield algorithm
    algorithm.stop()


def test_every_runner_holds_the_native_vector_env_with_the_env_config(algo: Any) -> None:
    def describe(runner: Any) -> tuple[Any, ...]:
        env = runner.env.unwrapped
        threads = _core.num_threads()
        return type(env), env.num_envs, env.autoreset_mode, env.config, runner.config.gym_env_vectorize_mode, threads

    described = algo.env_runner_group.foreach_env_runner(describe, local_env_runner=False)
    assert len(described) == RUNNERS
    # The runners' Rust pool has the one CPU a runner gets (unless the user set its size).
    threads = int(os.environ.get("RAYON_NUM_THREADS", 1))
    for cls, num_envs, mode, config, vectorize, pool in described:
        assert cls is ChainCartVectorEnv and num_envs == ENVS_PER_RUNNER and pool == threads
        assert mode == AutoresetMode.NEXT_STEP and gym.VectorizeMode(vectorize) == gym.VectorizeMode.VECTOR_ENTRY_POINT
        assert config == ChainCartConfig(**SCENE)


def test_start_seeds_of_all_envs_in_the_cluster_are_distinct(algo: Any) -> None:
    seeds = algo.env_runner_group.foreach_env_runner(
        lambda runner: (runner.worker_index, start_seeds_of(runner)), local_env_runner=False
    )
    everything = [s for _, runner_seeds in seeds for s in runner_seeds]
    assert len(everything) == RUNNERS * ENVS_PER_RUNNER == len(set(everything))
    # The documented layout: runner w (reset by RLlib with seed + w) owns the block
    # [(seed + w) * n, (seed + w + 1) * n).
    for worker, runner_seeds in seeds:
        base = (SEED + worker) * ENVS_PER_RUNNER
        assert runner_seeds == list(range(base, base + ENVS_PER_RUNNER))


def test_a_runner_env_starts_each_env_from_its_own_seed() -> None:
    env = make_runner_env({**ChainCartConfig(**SCENE).to_dict(), "num_envs": 3})
    assert isinstance(env, RunnerStartSeeds) and isinstance(env.unwrapped, ChainCartVectorEnv)
    obs, _ = env.reset(seed=7)
    assert env.start_seeds == runner_start_seeds(7, 3) == [21, 22, 23]
    for i, seed in enumerate(env.start_seeds):
        single, _ = ChainCartEnv(**SCENE).reset(seed=seed)
        np.testing.assert_array_equal(obs[i], single)
    # RLlib's sync mode gets one plain env.
    assert type(make_runner_env(dict(SCENE))) is ChainCartEnv
    with pytest.raises(ChainCartError, match="2\\*\\*64"):
        runner_start_seeds(2**63, 4)


@pytest.mark.parametrize("mode", ["same_step", "disabled", AutoresetMode.SAME_STEP])
def test_an_autoreset_mode_rllib_cannot_use_is_an_error_naming_it(mode: Any) -> None:
    name = mode if isinstance(mode, str) else "SameStep"
    with pytest.raises(ChainCartError, match=f"autoreset_mode = .*{name}.*next_step"):
        ppo_config(autoreset_mode=mode)
    with pytest.raises(ChainCartError, match=f"autoreset_mode = .*{name}"):
        ppo_config({"scene": "inverted-1", "autoreset_mode": mode})
    # The runners' creator checks it too (a config assembled by hand).
    with pytest.raises(ChainCartError, match=f"autoreset_mode = .*{name}"):
        make_runner_env({"autoreset_mode": mode, "num_envs": 2})
    assert ppo_config(autoreset_mode="next_step").env_config["autoreset_mode"] == "next_step"


def test_configure_sets_up_any_algorithm_config() -> None:
    appo = configure(APPOConfig(), ChainCartConfig(scene="inverted-1"), start_noise=0.07, render_mode="rgb_array")
    assert appo.env == ENV_NAME
    assert gym.VectorizeMode(appo.gym_env_vectorize_mode) == gym.VectorizeMode.VECTOR_ENTRY_POINT
    keys = ChainCartConfig().to_dict().keys()
    passed = ChainCartConfig(**{key: appo.env_config[key] for key in keys})
    assert passed == ChainCartConfig(scene="inverted-1", start_noise=0.07)
    assert appo.env_config["render_mode"] == "rgb_array"
    with pytest.raises(ChainCartError, match="n_links"):
        ppo_config(n_links=0)


def test_configure_states_the_fault_tolerance_settings() -> None:
    # Set otherwise first, so the values read back are the ones configure put there.
    other = dict(restart_failed_env_runners=False, max_num_env_runner_restarts=3, restart_failed_sub_environments=True)
    for algo_config in (configure(APPOConfig().fault_tolerance(**other)), ppo_config()):
        # A lost runner is restarted whole (with its worker index), up to 1000 times;
        # an error inside one env fails the runner rather than rebuilding that env.
        assert algo_config.restart_failed_env_runners is True
        assert algo_config.max_num_env_runner_restarts == 1000
        assert algo_config.restart_failed_sub_environments is False


def test_the_saved_module_acts_as_the_runners_do(algo: Any, tmp_path: pathlib.Path) -> None:
    algo.save_to_path(str(tmp_path))
    policy = RLlibPolicy.load(tmp_path)
    episodes = algo.env_runner_group.foreach_env_runner(
        lambda runner: runner.sample(num_timesteps=30, explore=False, force_reset=True),
        remote_worker_ids=[1],
        local_env_runner=False,
    )[0]
    checked = 0
    for episode in episodes:
        observations, actions = episode.get_observations()[:-1], episode.get_actions()
        if len(actions) == 0:
            continue
        predicted, _ = policy.predict(observations, deterministic=True)
        # The runner sends the module's action clipped to the bounds [-1, 1].
        np.testing.assert_allclose(predicted, np.clip(actions, -1.0, 1.0), atol=1e-6)
        checked += len(actions)
        one, _ = policy.predict(observations[0], deterministic=True)
        np.testing.assert_allclose(one, predicted[0], atol=1e-6)
    assert checked >= 30


def test_too_few_cpus_in_the_cluster_is_an_error(ray_session: None) -> None:
    with pytest.raises(ChainCartError, match="has 2 CPUs: expected at least 3"):
        with ray_cluster(None, 3):
            pass
    assert ray.is_initialized()  # the caller's session is left alone


def test_compare_with_rllib_writes_its_tables_reproducibly_and_evaluate_reruns_them(
    ray_session: None, tmp_path: pathlib.Path
) -> None:
    out = tmp_path / "run"
    args = [
        "compare", "--trainer", "rllib", "--num-env-runners", "2", "--envs-per-runner", "2", "--timesteps", "200",
        "--eval-episodes", "3", "--eval-seed", "7", "--set", f"max_episode_steps={EPISODE_STEPS}", "--no-progress",
        "--algo-kwarg", "train_batch_size_per_learner=100", "--algo-kwarg", "minibatch_size=50",
        "--algo-kwarg", "num_epochs=1", "--sweep", "start_noise=0.05", "--out", str(out),
    ]  # fmt: skip
    assert main(args) == 0
    for name in OUTPUT_FILES:
        assert (out / name).exists(), name
    for name in ("rllib_checkpoint", "run.json", "config.json", "training_episodes.csv", "learning_curve.csv"):
        assert (out / "seed-0" / name).exists(), name
    columns, rows = read_csv(out / "comparison.csv")
    assert columns == list(METRIC_COLUMNS)
    assert [row["policy"] for row in rows] == ["PPO (RLlib) (seed 0)", "LQR"]
    # The LQR row is the one any trainer's study gets on these seeds.
    config = ChainCartConfig(max_episode_steps=EPISODE_STEPS)
    _, _, (lqr,) = evaluate_policies([("LQR", lqr_baseline(config))], config, evaluation_seeds(7, 3))
    assert rows[1]["return_mean"] == repr(lqr["return_mean"]) and rows[1]["success_rate"] == repr(lqr["success_rate"])

    columns, train = read_csv(out / "seed-0" / "training_episodes.csv")
    assert columns == list(TRAINING_EPISODE_COLUMNS) and train
    assert all(1 <= int(r["length"]) <= EPISODE_STEPS and 0.0 < float(r["return"]) <= EPISODE_STEPS for r in train)
    steps = [int(r["timesteps"]) for r in train]
    assert steps == sorted(steps) and 200 <= steps[-1] <= 300
    run = json.loads((out / "seed-0" / "run.json").read_text())
    assert run["trainer"] == "rllib" and run["num_env_runners"] == 2 and run["num_envs"] == 4
    assert run["hyperparameters"]["train_batch_size_per_learner"] == 100 and run["timesteps_trained"] >= 200

    # Seeded: a second run trains and evaluates the same, bit for bit (wall times aside).
    assert main([*args[:-1], str(tmp_path / "rerun")]) == 0
    assert (tmp_path / "rerun" / "comparison.csv").read_text() == (out / "comparison.csv").read_text()
    _, train_again = read_csv(tmp_path / "rerun" / "seed-0" / "training_episodes.csv")
    assert [{**r, "wall_time_s": ""} for r in train_again] == [{**r, "wall_time_s": ""} for r in train]

    assert main(["evaluate", str(out), "--out", str(tmp_path / "again")]) == 0
    assert main(["evaluate", str(out / "seed-0" / "rllib_checkpoint"), "--out", str(tmp_path / "again2")]) == 0
    for again in ("again", "again2"):
        for name in ("comparison.csv", "episodes.csv"):
            assert (tmp_path / again / name).read_text() == (out / name).read_text(), name


def test_bench_times_sampling_of_rllibs_sync_wrapping_of_the_single_env(ray_session: None) -> None:
    rate = measure_sampling("sync", runners=1, envs_per_runner=2, timesteps=64, repeats=1)
    assert rate.steps_per_s > 0 and rate.runner_steps_per_s > 0
    assert 0.0 < rate.env_share < 1.0


def test_compare_with_rllib_offers_ppo_only(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["compare", "--trainer", "rllib", "--algo", "sac", "--out", str(tmp_path)])
    assert "--trainer rllib with sac: the RLlib trainer offers ppo only" in capsys.readouterr().err


@pytest.mark.parametrize(
    "kwarg, message",
    [("no_such_setting=1", "no_such_setting"), ("minibatch_size=100000", "minibatch_size")],
)
def test_compare_with_rllib_rejects_bad_ppo_settings_before_training(
    kwarg: str, message: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        main(["compare", "--trainer", "rllib", "--algo-kwarg", kwarg, "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert "RLlib PPO keywords" in err and message in err
    assert not (tmp_path / "training_episodes.csv").exists()


def test_compare_with_rllib_without_ray_says_which_extra_to_install(tmp_path: pathlib.Path) -> None:
    code = (
        "import sys; sys.modules['ray'] = None\n"
        "from chaincart_env.__main__ import main\n"
        f"main(['compare', '--trainer', 'rllib', '--out', {str(tmp_path)!r}])\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "chaincart-env[rllib]" in done.stderr, done.stderr


def test_the_rllib_trainer_and_evaluation_import_without_stable_baselines3() -> None:
    code = (
        "import sys; sys.modules['stable_baselines3'] = None\n"
        "import chaincart_env.tools.compare.job, chaincart_env.tools.compare.run_files, chaincart_env.tools.compare.rllib_training\n"
        "import chaincart_env.rllib\n"
        "try:\n    import stable_baselines3\nexcept ImportError:\n    print('blocked')\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "blocked"
