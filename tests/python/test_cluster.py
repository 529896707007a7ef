"""Ray past one machine, on a local multi-node cluster: Ray's own
``ray.cluster_utils.Cluster`` with a head and a worker node (separate raylets of one CPU
each on this machine), shared by the tests of this module. RLlib's env runners placed on
both nodes by ``compare --trainer rllib``; training going on when a runner's process or
a whole node is lost (and the samples lost, counted); a driver killed mid-run and its
run resumed from the checkpoint (what is restored, compared with the checkpoint); the
study's pieces as Ray tasks (each task recorded as it runs) giving the serial run's
tables, and the leaderboard's agents and cells, as tasks too, giving the serial run's
rows.

The cluster keeps its files (and the address file Ray leaves for ``ray.init("auto")``)
in a folder of its own, ignores ``RAY_ADDRESS`` and never joins a cluster already
running on the machine; every process it starts is stopped at the end, also on failure.
"""

from __future__ import annotations

import copy
import csv
import io
import json
import os
import pathlib
import pickle
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import uuid
import zipfile
from collections import Counter
from functools import partial
from typing import Any, Iterator

import numpy as np
import pytest
import ray  # the rllib extra, installed by scripts/setup.sh
import torch
from gymnasium.vector import VectorEnv, VectorWrapper
from ray.cluster_utils import Cluster
from ray.rllib.core import (
    COMPONENT_ENV_RUNNER,
    COMPONENT_ENV_TO_MODULE_CONNECTOR,
    COMPONENT_MODULE_TO_ENV_CONNECTOR,
    COMPONENT_RL_MODULE,
)

from chaincart_env.__main__ import main
from chaincart_env.rllib import make_runner_env, ppo_config, register, start_seeds_of
from chaincart_env.tools.compare import cell_runner as study_cells, rllib_training
from chaincart_env.tools.compare.cell_runner import map_cells
from chaincart_env.tools.compare.job import OUTPUT_FILES
from chaincart_env.tools.compare.run_files import settled_directory

ROOT = pathlib.Path(__file__).resolve().parents[2]
EPISODE_STEPS = 40
RLLIB_TINY = [
    "--num-env-runners", "2", "--envs-per-runner", "2", "--eval-episodes", "3", "--eval-seed", "7",
    "--set", f"max_episode_steps={EPISODE_STEPS}", "--no-progress", "--algo-kwarg", "train_batch_size_per_learner=100",
    "--algo-kwarg", "minibatch_size=50", "--algo-kwarg", "num_epochs=1", "--sweep", "start_noise=0.05",
]  # fmt: skip
SB3_TINY = [
    "--timesteps", "256", "--num-envs", "2", "--eval-episodes", "3", "--eval-seed", "7",
    "--set", f"max_episode_steps={EPISODE_STEPS}", "--algo-kwarg", "n_steps=64", "--algo-kwarg", "batch_size=64",
    "--eval-every", "128", "--eval-starts", "2", "--checkpoint-every", "128", "--sweep", "start_noise=0.05,0.5",
    "--seeds", "3,4", "--no-progress",
]  # fmt: skip
#: The tables of a study, equal byte for byte between a serial and a distributed run.
TABLES = ("comparison.csv", "episodes.csv", "seeds.csv", "sweeps.csv", "sweep_summary.csv")

# The runners unpickle this module's env creator by value (it is not importable there).
ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])


@pytest.fixture(scope="module")
def cluster() -> Iterator[Cluster]:
    """A head and one worker node of 1 CPU each, stopped (every process) at the end."""
    scratch = tempfile.mkdtemp(prefix="ccray-", dir="/tmp")  # short: Ray's socket paths live under it
    with pytest.MonkeyPatch.context() as patch:
        patch.delenv("RAY_ADDRESS", raising=False)
        patch.setenv("RAY_TMPDIR", scratch)
        nodes = Cluster(initialize_head=False)
        try:
            nodes.add_node(num_cpus=1, include_dashboard=False)
            nodes.add_node(num_cpus=1)
            nodes.wait_for_nodes()
            yield nodes
        finally:
            if ray.is_initialized():
                ray.shutdown()
            nodes.shutdown()
            shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture
def connected(cluster: Cluster) -> Iterator[Cluster]:
    """This process as a driver of the cluster, for one test."""
    ray.init(address=cluster.address, logging_level="WARNING")
    try:
        yield cluster
    finally:
        ray.shutdown()


def node_ids(cluster: Cluster) -> list[str]:
    return sorted(node.node_id for node in cluster.list_all_nodes())


def read_csv(path: pathlib.Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


def without_wall_time(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    return [{**row, "wall_time_s": ""} for row in rows]


# -- multi-node placement ---------------------------------------------------------------


def test_compare_with_rllib_places_env_runners_on_both_nodes(cluster: Cluster, tmp_path: pathlib.Path) -> None:
    out = tmp_path / "run"
    args = ["compare", "--trainer", "rllib", "--address", cluster.address, "--timesteps", "200", *RLLIB_TINY]
    assert main([*args, "--out", str(out)]) == 0
    run = json.loads((out / "seed-0" / "run.json").read_text())
    # Two runners of one CPU each on two nodes of one CPU each: one on each node.
    assert sorted(run["runner_nodes"]) == node_ids(cluster)
    assert run["runner_restarts"] == 0  # no runner was lost
    assert run["cluster"].endswith("2 node(s), 2 CPUs") and run["timesteps_trained"] >= 200
    for name in OUTPUT_FILES:
        assert (out / name).exists(), name
    assert [row["policy"] for row in read_csv(out / "comparison.csv")] == ["PPO (RLlib) (seed 0)", "LQR"]
    assert json.loads((out / "run.json").read_text())["cluster"].endswith("2 node(s), 2 CPUs")


def node_of_cell(shared: int, cell: int) -> tuple[int, str]:
    time.sleep(1.0)  # long enough for both cells to start before either ends
    return shared * cell, ray.get_runtime_context().get_node_id()


def test_cells_run_as_tasks_on_both_nodes_with_the_serial_results(connected: Cluster) -> None:
    finished: list[int] = []
    results = map_cells(node_of_cell, [3, 5], shared=2, distributed=True, on_result=lambda i, _: finished.append(i))
    assert [value for value, _ in results] == [6, 10] and sorted(finished) == [0, 1]
    assert sorted(node for _, node in results) == node_ids(connected)
    assert [value for value, _ in map_cells(node_of_cell, [3, 5], shared=2)] == [6, 10]


# -- lost workers -----------------------------------------------------------------------


class CountedSteps(VectorWrapper):
    """A runner's env that appends, after every vector step, how many env steps it took
    so far, as RLlib counts them (an env in its next-step autoreset step is not counted),
    to a file named by its process (one line per vector step). The first runner process
    on the node ``die_on`` to reach its vector step ``die_at`` kills itself (SIGKILL),
    leaving its process id in the file ``killed``."""

    def __init__(self, env: VectorEnv, folder: str, die_at: int, die_on: str) -> None:
        super().__init__(env)
        self.folder, self.die_at = pathlib.Path(folder), die_at
        self.doomed = ray.get_runtime_context().get_node_id() == die_on
        self.vector_steps = self.counted = 0
        self.resetting = np.zeros(self.num_envs, dtype=bool)

    def reset(self, **kwargs: Any) -> Any:
        self.resetting[:] = False
        return self.env.reset(**kwargs)

    def step(self, actions: Any) -> Any:
        self.vector_steps += 1
        if self.doomed and self.vector_steps == self.die_at:
            try:
                marker = os.open(self.folder / "killed", os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                pass  # it was restarted
            else:
                os.write(marker, str(os.getpid()).encode())
                os.close(marker)
                os.kill(os.getpid(), signal.SIGKILL)
        out = self.env.step(actions)
        self.counted += int((~self.resetting).sum())
        self.resetting = out[2] | out[3]
        with (self.folder / f"steps-{os.getpid()}").open("a") as log:
            log.write(f"{self.counted}\n")
        return out


def counted_runner_env(env_config: Any, folder: str, die_at: int, die_on: str) -> VectorEnv:
    return CountedSteps(make_runner_env(env_config), folder, die_at, die_on)


def describe_runner(runner: Any) -> tuple[int, int, str, list[int]]:
    return runner.worker_index, os.getpid(), ray.get_runtime_context().get_node_id(), start_seeds_of(runner)


def train_until(algo: Any, healthy: int, restarts: int, lifetimes: list[int], limit: int = 60) -> None:
    """Trains until ``healthy`` runners serve and RLlib counted ``restarts`` restarts,
    recording the env steps sampled after every iteration."""
    for _ in range(limit):
        result = algo.train()
        lifetimes.append(int(result["num_env_steps_sampled_lifetime"]))
        group = algo.env_runner_group
        if group.num_healthy_remote_workers() == healthy and group.num_remote_worker_restarts() == restarts:
            return
    raise AssertionError(f"not {healthy} healthy runners and {restarts} restarts after {limit} iterations")


def test_training_goes_on_when_a_runner_or_a_node_is_lost(connected: Cluster, tmp_path: pathlib.Path) -> None:
    seed, envs, batch = 3, 2, 200  # each runner samples 100 env steps (50 vector steps) per iteration
    head = connected.head_node.node_id
    register("chaincart-counted", partial(counted_runner_env, folder=str(tmp_path), die_at=76, die_on=head))
    config = (
        ppo_config(scene="inverted-1", max_episode_steps=EPISODE_STEPS)
        .environment("chaincart-counted")
        .env_runners(num_env_runners=2, num_envs_per_env_runner=envs)
        .learners(num_learners=0)
        .training(train_batch_size_per_learner=batch, minibatch_size=100, num_epochs=1)
        .debugging(seed=seed)
    )
    algo = config.build_algo()
    try:
        group = algo.env_runner_group
        first = {w: (pid, node) for w, pid, node, _ in group.foreach_env_runner(describe_runner, local_env_runner=False)}
        assert sorted(node for _, node in first.values()) == node_ids(connected)
        lifetimes: list[int] = []
        # The runner on the head node kills itself in the middle of the second iteration's sampling.
        train_until(algo, healthy=1, restarts=0, lifetimes=lifetimes)
        train_until(algo, healthy=2, restarts=1, lifetimes=lifetimes)
        # Then the worker node goes, with the runner on it; a new node comes later.
        worker_node = next(iter(connected.worker_nodes))
        on_worker = next(w for w, (_, node) in first.items() if node == worker_node.node_id)
        connected.remove_node(worker_node)
        train_until(algo, healthy=1, restarts=1, lifetimes=lifetimes)
        for _ in range(2):  # training goes on with one runner while no CPU is free for the other
            lifetimes.append(int(algo.train()["num_env_steps_sampled_lifetime"]))
        new_node = connected.add_node(num_cpus=1)
        train_until(algo, healthy=2, restarts=2, lifetimes=lifetimes)
        runners = {w: (pid, node, seeds) for w, pid, node, seeds in group.foreach_env_runner(
            describe_runner, local_env_runner=False)}
    finally:
        algo.stop()

    assert all(b > a for a, b in zip(lifetimes, lifetimes[1:])), lifetimes  # every iteration trained
    # The restarted runners are new processes with their worker index, re-seeded into
    # their own blocks [(seed + w) n, (seed + w + 1) n), distinct across the cluster.
    assert sorted(runners) == [1, 2]
    for w, (pid, node, seeds) in runners.items():
        assert pid != first[w][0] and seeds == [(seed + w) * envs + i for i in range(envs)]
    assert runners[on_worker][1] == new_node.node_id
    # Samples lost: every env step the runners took, minus those that reached the learner.
    counts = {int(path.name.split("-")[1]): [int(n) for n in path.read_text().split()]
              for path in tmp_path.glob("steps-*")}  # fmt: skip
    stepped = sum(life[-1] for life in counts.values())
    lost = stepped - lifetimes[-1]
    killed = int((tmp_path / "killed").read_text())
    assert killed == next(pid for pid, node in first.values() if node == head)
    # The killed runner died after 75 vector steps, in its second sample(): a sample()
    # ends at the vector step at which the runner has counted its share of the batch,
    # 100 env steps. What it had counted in the unfinished sample (at most 25 vector
    # steps of 2 envs, fewer by the envs in an autoreset step) never reached the learner,
    # and that is all that was lost: the node went between iterations, with nothing in flight.
    life = counts[killed]
    first_sample_end = next(i for i, n in enumerate(life) if n >= batch // 2)
    in_flight = life[-1] - life[first_sample_end]
    print(f"samples lost: {lost} env steps (runner killed mid-sample: {in_flight}), of {stepped} taken")
    assert len(life) == 75 and 0 < in_flight <= 25 * envs
    assert lost == in_flight


# -- driver kill, then resume -----------------------------------------------------------


def checkpoint_steps(state: pathlib.Path) -> int:
    """The env steps of the checkpoint whose ``state.json`` is ``state`` (-1: none now,
    e.g. between the two renames of a checkpoint swap)."""
    try:
        return int(json.loads(state.read_text())["steps"])
    except FileNotFoundError:
        return -1


def wait_for_checkpoint(state: pathlib.Path, process: subprocess.Popen[bytes], steps: int, log: pathlib.Path) -> None:
    deadline = time.monotonic() + 300
    while checkpoint_steps(state) < steps:
        assert process.poll() is None, f"compare ended ({process.returncode}) before a checkpoint: {log.read_text()}"
        assert time.monotonic() < deadline, f"no checkpoint at {steps} env steps in 300 s: {log.read_text()}"
        time.sleep(0.2)


def equal_trees(a: Any, b: Any) -> bool:
    """Nested dicts/lists of arrays, tensors and scalars, equal exactly."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(equal_trees(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(equal_trees(x, y) for x, y in zip(a, b))
    if isinstance(a, (torch.Tensor, np.ndarray)) or isinstance(b, (torch.Tensor, np.ndarray)):
        x, y = (v.detach().numpy() if isinstance(v, torch.Tensor) else np.asarray(v) for v in (a, b))
        return x.dtype == y.dtype and np.array_equal(x, y)
    return bool(a == b)


CONNECTORS = (COMPONENT_ENV_TO_MODULE_CONNECTOR, COMPONENT_MODULE_TO_ENV_CONNECTOR)


def connector_states(runner: Any) -> dict[str, Any]:
    """A runner's connector states (run via ``foreach_env_runner``)."""
    state = runner.get_state(not_components=COMPONENT_RL_MODULE)
    return {name: state[name] for name in CONNECTORS}


def test_a_killed_driver_resumes_from_its_rllib_checkpoint(
    cluster: Cluster, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out, log = tmp_path / "run", tmp_path / "driver.log"
    args = ["compare", "--trainer", "rllib", "--address", cluster.address, "--timesteps", "1500",
            "--checkpoint-every", "200", *RLLIB_TINY, "--out", str(out)]  # fmt: skip
    with log.open("wb") as output:
        driver = subprocess.Popen([sys.executable, "-m", "chaincart_env", *args], cwd=tmp_path, stdout=output,
                                  stderr=subprocess.STDOUT, start_new_session=True)  # fmt: skip
        try:
            wait_for_checkpoint(out / "seed-0" / "checkpoints" / "state.json", driver, 400, log)
            os.killpg(driver.pid, signal.SIGKILL)
        finally:
            if driver.poll() is None:
                os.killpg(driver.pid, signal.SIGKILL)
            driver.wait(timeout=60)
    seed_dir = out / "seed-0"
    assert json.loads((out / "run.json").read_text())["status"] == "training"  # no chance to say more
    # The checkpoint as resume finds it, also if the kill came between the swap's renames.
    checkpoint = settled_directory(seed_dir / rllib_training.RESUME_DIR)
    state = json.loads((checkpoint / "state.json").read_text())
    logged = read_csv(seed_dir / "training_episodes.csv")
    assert len(logged) >= state["episodes"] > 0

    saved = checkpoint / "algorithm"
    learner_file = saved / "learner_group" / "learner"
    saved_module = pickle.loads((learner_file / "rl_module" / "default_policy" / "module_state.pkl").read_bytes())
    saved_optimizer = pickle.loads((learner_file / "state.pkl").read_bytes())["optimizer"]
    saved_connectors = {name: pickle.loads((saved / COMPONENT_ENV_RUNNER / name / "state.pkl").read_bytes())
                        for name in CONNECTORS}  # fmt: skip
    restored: dict[str, Any] = {}

    def restore_and_look(algo: Any, directory: pathlib.Path) -> Any:
        progress = real_restore(algo, directory)
        learner = algo.learner_group._learner
        restored.update(  # copies: training goes on from here
            module=copy.deepcopy(learner.module["default_policy"].state_dict()),
            optimizer=copy.deepcopy(learner.get_state(components="optimizer")["optimizer"]),
            runners=algo.env_runner_group.foreach_env_runner(lambda r: r.module.state_dict(), local_env_runner=False),
            connectors=algo.env_runner_group.foreach_env_runner(connector_states, local_env_runner=True),
            iteration=algo.iteration,
            steps=algo.metrics.peek(("env_runners", "num_env_steps_sampled_lifetime")),
            log_rows=len(read_csv(directory / "training_episodes.csv")),
        )
        return progress

    real_restore = rllib_training.restore_training
    monkeypatch.setattr(rllib_training, "restore_training", restore_and_look)
    assert main(["compare", "--resume", str(out)]) == 0

    # Restored exactly: the networks, the optimizer, the runners' weights, the connector
    # states, the counters; the episode log cut back to the checkpoint.
    assert equal_trees({k: v.numpy() for k, v in restored["module"].items()}, dict(saved_module))
    assert equal_trees(restored["optimizer"], saved_optimizer)
    assert len(restored["runners"]) == 2
    for weights in restored["runners"]:
        assert weights.keys() <= saved_module.keys()
        assert all(np.array_equal(weights[k].numpy(), saved_module[k]) for k in weights)
    # The connector states of the local runner and both remote ones are the checkpoint's:
    # empty, as RLlib's default connector pipelines (what compare uses) keep no state.
    assert saved_connectors == {name: {} for name in CONNECTORS}
    assert len(restored["connectors"]) == 3
    assert all(equal_trees(states, saved_connectors) for states in restored["connectors"])
    assert (restored["iteration"], restored["steps"], restored["log_rows"]) == (
        state["iterations"], state["steps"], state["episodes"])  # fmt: skip

    run = json.loads((seed_dir / "run.json").read_text())
    assert run["resumed_from"] == state["steps"] and run["timesteps_trained"] >= 1500
    assert json.loads((out / "run.json").read_text())["status"] == "done"
    for name in OUTPUT_FILES:
        assert (out / name).exists(), name
    rows = read_csv(seed_dir / "training_episodes.csv")
    assert len(rows) > state["episodes"]
    assert rows[: state["episodes"]] == logged[: state["episodes"]]  # the log up to the checkpoint, kept
    assert [int(r["episode"]) for r in rows] == list(range(1, len(rows) + 1))
    assert all(int(r["timesteps"]) > state["steps"] for r in rows[state["episodes"]:])
    # The wall time continues from the checkpoint's, in the log and in run.json.
    wall = [float(r["wall_time_s"]) for r in rows]
    assert wall == sorted(wall) and all(w > state["wall_time_s"] for w in wall[state["episodes"]:])
    assert run["training_wall_time_s"] > state["wall_time_s"]


# -- the study spread over the cluster --------------------------------------------------


def record_tasks(monkeypatch: pytest.MonkeyPatch, folder: pathlib.Path) -> None:
    """From now on each cell that ``map_cells`` runs as a Ray task leaves a record in
    ``folder`` (every node of the test cluster is this machine): the cell's function,
    and the process, node and Ray task it ran in. A serial run leaves none."""
    folder.mkdir()
    real = study_cells._run_cell

    def run_cell(function: Any, shared: Any, cell: Any, torch_threads: Any) -> Any:
        context = ray.get_runtime_context()
        record = dict(function=function.__name__, pid=os.getpid(), node=context.get_node_id(),
                      task=context.get_task_id())  # fmt: skip
        (folder / f"{uuid.uuid4().hex}.json").write_text(json.dumps(record))
        return real(function, shared, cell, torch_threads)

    monkeypatch.setattr(study_cells, "_run_cell", run_cell)


def tasks_run(folder: pathlib.Path, cluster: Cluster) -> Counter[str]:
    """How many cells of each function ran as Ray tasks (records of :func:`record_tasks`),
    each checked to have run in a Ray task, in a worker process of the cluster."""
    records = [json.loads(path.read_text()) for path in folder.glob("*.json")]
    nodes = node_ids(cluster)
    for record in records:
        assert record["task"] and record["pid"] != os.getpid() and record["node"] in nodes, record
    return Counter(record["function"] for record in records)


def zip_member(path: pathlib.Path, name: str) -> bytes:
    with zipfile.ZipFile(io.BytesIO(path.read_bytes())) as archive:
        return archive.read(name)


def test_a_study_on_the_cluster_gives_the_serial_tables(
    cluster: Cluster, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    serial, spread = tmp_path / "serial", tmp_path / "spread"
    record_tasks(monkeypatch, tmp_path / "tasks")
    assert main(["compare", *SB3_TINY, "--out", str(serial)]) == 0
    assert tasks_run(tmp_path / "tasks", cluster) == Counter()
    assert main(["compare", *SB3_TINY, "--address", cluster.address, "--out", str(spread)]) == 0
    # Every seed trained, and every policy evaluated on the scene and each of the 2 sweep
    # values, in a task of the cluster.
    policies = len(read_csv(serial / "comparison.csv"))
    assert tasks_run(tmp_path / "tasks", cluster) == Counter(train_seed_cell=2, evaluate_cell=3 * policies)
    for name in TABLES:
        assert (spread / name).read_bytes() == (serial / name).read_bytes(), name
    for seed in (3, 4):
        here, there = serial / f"seed-{seed}", spread / f"seed-{seed}"
        for name in ("training_episodes.csv", "evaluations.csv"):
            assert without_wall_time(read_csv(there / name)) == without_wall_time(read_csv(here / name)), name
        for member in ("policy.pth", "policy.optimizer.pth"):  # trained to the same bits
            assert zip_member(there / "model.zip", member) == zip_member(here / "model.zip", member)
        assert (there / "checkpoints" / "state.json").is_file()  # the task's folder came back whole
    run = json.loads((spread / "run.json").read_text())
    assert run["settings"]["address"] == cluster.address and run["cluster"].endswith("2 node(s), 2 CPUs")
    assert list(run["seed_runs"]) == ["3", "4"]
    # evaluate on the cluster too: the same tables again, from the same cells as tasks.
    record_tasks(monkeypatch, tmp_path / "evaluate-tasks")
    assert main(["evaluate", str(spread), "--address", cluster.address, "--out", str(tmp_path / "again")]) == 0
    assert tasks_run(tmp_path / "evaluate-tasks", cluster) == Counter(evaluate_cell=3 * policies)
    for name in TABLES:
        assert (tmp_path / "again" / name).read_bytes() == (serial / name).read_bytes(), name


def test_a_leaderboard_on_the_cluster_gives_the_serial_cells(
    cluster: Cluster, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    serial, spread = tmp_path / "serial", tmp_path / "spread"
    argv = ["leaderboard", "--scenes", "inverted-1", "--policies", "lqr,ppo", "--quick", "--axes", "mismatch,delay",
            "--episodes", "2", "--seeds", "0,1", "--no-progress"]  # fmt: skip
    record_tasks(monkeypatch, tmp_path / "tasks")
    assert main([*argv, "--out", str(serial)]) == 0
    assert tasks_run(tmp_path / "tasks", cluster) == Counter()
    assert main([*argv, "--address", cluster.address, "--out", str(spread)]) == 0
    # Both PPO agents trained, and every cell (a row of cells.csv) evaluated, in a task.
    assert tasks_run(tmp_path / "tasks", cluster) == Counter(train_agent_cell=2, evaluate_cell_job=2 * 2 * 2 * 2)
    # The same rows but for the measured compute time.
    untimed = lambda rows: [{**row, "us_per_step": ""} for row in rows]  # noqa: E731
    rows = read_csv(spread / "cells.csv")
    assert untimed(rows) == untimed(read_csv(serial / "cells.csv")) and len(rows) == 2 * 2 * 2 * 2
    assert all(float(row["us_per_step"]) > 0 for row in rows)
    assert json.loads((spread / "leaderboard.json").read_text())["cluster"].endswith("2 node(s), 2 CPUs")
    assert "cluster" not in json.loads((serial / "leaderboard.json").read_text())
    for seed in (0, 1):  # each agent trained as a task, to the same bits, its folder back whole
        here, there = (run / "agents" / "inverted-1" / "ppo" / f"seed-{seed}" for run in (serial, spread))
        for member in ("policy.pth", "policy.optimizer.pth"):
            assert zip_member(there / "model.zip", member) == zip_member(here / "model.zip", member)
        assert (there / "checkpoints" / "state.json").is_file()
        assert without_wall_time(read_csv(there / "evaluations.csv")) == without_wall_time(read_csv(here / "evaluations.csv"))
