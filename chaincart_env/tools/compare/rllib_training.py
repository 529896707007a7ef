"""Training PPO with Ray RLlib (``compare --trainer rllib``): the native vector env in
every env runner of a local or existing Ray cluster (:mod:`chaincart_env.rllib`), a
CSV log of every training episode like the SB3 trainer's, and the trained RLModule
as a policy with SB3's ``predict`` for the shared evaluation.

Episode timesteps in the log are the env steps sampled by the end of the training
iteration in which the episode ended (RLlib samples a whole train batch per
iteration), so the learning curve has the resolution of one iteration.
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Mapping, Optional

import numpy as np

from chaincart_env._core import ChainCartError
from chaincart_env.config import ChainCartConfig
from chaincart_env.tools.compare.cell_runner import ray_cluster
from chaincart_env.tools.compare.learning_curve import (
    EPISODES_FILE,
    TRAINING_EPISODE_COLUMNS,
    episode_ends,
    episode_log_columns,
    episode_row,
)
from chaincart_env.tools.compare.run_files import CHECKPOINT_DIR, replace_directory, settled_directory, truncate_csv

__all__ = [
    "CHECKPOINT_DIR",
    "MODULE_PATH",
    "RESUME_DIR",
    "RLlibPolicy",
    "RLlibTrainingResult",
    "TrainingProgress",
    "restore_training",
    "save_training",
    "record_episode",
    "take_episode_records",
    "train_rllib",
]

#: The folder (beside ``run.json``) holding the RLlib checkpoint of the trained
#: algorithm (``Algorithm.from_checkpoint`` resumes it).
#: Where the trained RLModule (the policy evaluated) lies inside the checkpoint.
MODULE_PATH = ("learner_group", "learner", "rl_module", "default_policy")

# Where the episode-end callback keeps a runner's finished episodes until the driver
# takes them after each training iteration.
_RECORDS = "_chaincart_episode_records"


class RLlibPolicy:
    """A trained RLlib ``RLModule`` acting like an SB3 policy: ``predict(obs)``
    returns the actions an env runner would send to the env (the mean action when
    deterministic, else a sample; unsquashed to the action bounds as RLlib does)."""

    def __init__(self, module: Any) -> None:
        self.module = module

    @classmethod
    def load(cls, checkpoint: Path) -> "RLlibPolicy":
        """The policy in an algorithm checkpoint written by ``compare --trainer rllib``."""
        path = Path(checkpoint).resolve().joinpath(*MODULE_PATH)
        if not path.is_dir():
            raise ChainCartError(f"{path} does not exist: expected the RLModule inside an RLlib checkpoint")
        return cls.from_module(path)

    @classmethod
    def from_module(cls, module: Path) -> "RLlibPolicy":
        """The policy of an RLModule saved in the folder ``module``."""
        from ray.rllib.core.rl_module.rl_module import RLModule

        return cls(RLModule.from_checkpoint(str(Path(module).resolve())))

    def predict(
        self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = False
    ) -> tuple[np.ndarray, None]:
        """The module's actions for ``observation`` (its mean when ``deterministic``), like SB3's
        ``predict``."""
        import torch
        from ray.rllib.core.columns import Columns
        from ray.rllib.utils.spaces.space_utils import unsquash_action

        single = np.ndim(observation) == 1
        batch = np.array(observation, dtype=np.float32, ndmin=2)  # a writable copy for torch
        with torch.no_grad():
            out = self.module.forward_inference({Columns.OBS: torch.from_numpy(batch)})
            dist = self.module.get_inference_action_dist_cls().from_logits(out[Columns.ACTION_DIST_INPUTS])
            if deterministic:
                dist = dist.to_deterministic()
            actions = dist.sample().numpy()
        actions = unsquash_action(actions, self.module.action_space)
        return (actions[0] if single else actions), None


def record_episode(*, episode: Any, env_runner: Any, prev_episode_chunks: Any = (), **_: Any) -> None:
    """RLlib ``on_episode_end`` callback (runs in the runners): keeps the episode's
    return, length and how it ended on the runner for :func:`take_episode_records`."""
    chunks = [*(prev_episode_chunks or ()), episode]
    info = episode.get_infos(-1)
    record = (
        float(sum(chunk.get_return() for chunk in chunks)),
        int(sum(len(chunk) for chunk in chunks)),
        episode_ends(info),
    )
    if not hasattr(env_runner, _RECORDS):
        setattr(env_runner, _RECORDS, [])
    getattr(env_runner, _RECORDS).append(record)


def take_episode_records(env_runner: Any) -> list[tuple[float, int, tuple[int, ...]]]:
    """The episodes a runner finished since the last call (run via ``foreach_env_runner``)."""
    records = getattr(env_runner, _RECORDS, [])
    setattr(env_runner, _RECORDS, [])
    return records


@dataclass(frozen=True)
class RLlibTrainingResult:
    """What an RLlib training run returns: the policy, wall time, episodes, hyperparameters,
    timesteps and iterations."""

    model: RLlibPolicy
    wall_time_s: float
    episodes: int
    hyperparameters: dict[str, Any]
    timesteps_trained: int
    iterations: int
    cluster: str
    #: The Ray node id of each env runner at the end of training.
    runner_nodes: list[str] = field(default_factory=list)
    #: Env runners RLlib brought back into service after a failure.
    runner_restarts: int = 0
    #: Env steps of the checkpoint the run continued from (0: a fresh start).
    resumed_from: int = 0


def _ppo(config: ChainCartConfig, seed: int, num_env_runners: int, envs_per_runner: int,
         hyperparameters: Mapping[str, Any]) -> tuple[Any, dict[str, Any]]:
    from chaincart_env.rllib import PPO_TRAINING, ppo_config

    ppo = ppo_config(config)
    ppo.env_runners(num_env_runners=num_env_runners, num_envs_per_env_runner=envs_per_runner)
    ppo.learners(num_learners=0)  # the learner runs in the driver, next to the evaluation
    ppo.debugging(seed=seed)
    ppo.callbacks(on_episode_end=record_episode)
    try:
        ppo.training(**hyperparameters)
        ppo.validate()  # RLlib's own checks, before any cluster starts
    except (TypeError, ValueError) as error:  # an unknown keyword, an inconsistent setting
        raise ChainCartError(f"RLlib PPO keywords {dict(hyperparameters)}: {error}") from None
    return ppo, {**PPO_TRAINING, **hyperparameters}


def train_rllib(
    config: ChainCartConfig,
    *,
    timesteps: int,
    seed: int = 0,
    num_env_runners: int = 2,
    envs_per_runner: int = 4,
    address: Optional[str] = None,
    directory: Path,
    checkpoint: Path,
    checkpoint_every: Optional[int] = None,
    resume: bool = False,
    progress: bool = True,
    hyperparameters: Optional[Mapping[str, Any]] = None,
) -> RLlibTrainingResult:
    """Trains RLlib PPO until at least ``timesteps`` env steps were sampled, on
    ``num_env_runners`` runners of ``envs_per_runner`` native envs each (runner ``w``'s
    env ``i`` starts stream ``(seed + w) * envs_per_runner + i``), logs the training
    episodes to ``directory/training_episodes.csv``, saves the algorithm into
    ``checkpoint`` and returns the policy loaded back from it (what ``evaluate`` loads).

    Every ``checkpoint_every`` env steps (after the iteration that passes a multiple)
    the algorithm is saved into ``directory/checkpoints`` (:func:`save_training`);
    ``resume=True`` continues from there (:func:`restore_training`, which says what is
    restored) when it exists, else starts afresh."""
    if isinstance(timesteps, bool) or not isinstance(timesteps, int) or timesteps < 1:
        raise ChainCartError(f"timesteps = {timesteps!r}: expected an integer >= 1")
    ppo, settings = _ppo(config, seed, num_env_runners, envs_per_runner, dict(hyperparameters or {}))
    directory = Path(directory)
    with ray_cluster(address, num_env_runners) as cluster:
        if progress:
            print(f"RLlib on {cluster}")
        algo = ppo.build_algo()
        try:
            start = TrainingProgress()
            if resume and (settled_directory(directory / RESUME_DIR) / _STATE).is_file():
                start = restore_training(algo, directory)
                print(f"resumed from the checkpoint at {start.steps} env steps (iteration {start.iterations})")
            done = _train_loop(algo, timesteps, num_env_runners, directory, progress, checkpoint_every, start)
            nodes = algo.env_runner_group.foreach_env_runner(_node_of, local_env_runner=num_env_runners == 0)
            restarts = int(algo.env_runner_group.num_remote_worker_restarts())
            algo.save_to_path(str(Path(checkpoint).resolve()))
        finally:
            algo.stop()
    policy = RLlibPolicy.load(checkpoint)
    return RLlibTrainingResult(policy, done.wall_time_s, done.episodes, settings, done.steps, done.iterations, cluster,
                               runner_nodes=list(nodes), runner_restarts=restarts, resumed_from=start.steps)


def _node_of(env_runner: Any) -> str:
    """The id of the Ray node a runner runs on (run via ``foreach_env_runner``)."""
    import ray

    return str(ray.get_runtime_context().get_node_id())


@dataclass(frozen=True)
class TrainingProgress:
    """Where an RLlib training run stands: env steps sampled, iterations, training
    episodes logged and wall time spent (over all its sessions)."""

    steps: int = 0
    iterations: int = 0
    episodes: int = 0
    wall_time_s: float = 0.0


#: The folder of a run (beside its log) that holds its periodic checkpoint.
RESUME_DIR = "checkpoints"
_ALGORITHM, _STATE = "algorithm", "state.json"


def save_training(algo: Any, directory: Path, progress: TrainingProgress) -> None:
    """Saves the algorithm (RLlib's checkpoint: the learner's RLModule and optimizer
    states, the env runners' connector states and weights, the metrics with the
    lifetime step counters, the iteration count) and ``progress`` into
    ``directory/checkpoints``, swapped in whole."""
    staging = directory / (RESUME_DIR + ".tmp")
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    algo.save_to_path(str((staging / _ALGORITHM).resolve()))
    (staging / _STATE).write_text(json.dumps(asdict(progress), indent=2) + "\n")
    replace_directory(staging, directory / RESUME_DIR)


def restore_training(algo: Any, directory: Path) -> TrainingProgress:
    """Puts ``algo`` (built from the run's settings) back where ``directory``'s
    checkpoint left it, cuts the episode log back to it, and returns the progress saved
    with it.

    Restored exactly: the policy and value networks and the optimizer's state (so the
    next update starts from the same parameters and Adam moments), the weights every
    env runner acts with, the connector states (empty: RLlib's default connector
    pipelines, used here, keep none), the lifetime counters (env steps sampled, hence
    the budget still to go) and the iteration count; the episode log and the wall time
    continue from the checkpoint.

    Not restored: the envs' episodes in progress and their random streams (the
    runners are new processes: runner ``w``'s env ``i`` starts its stream
    ``(seed + w) * n + i`` again from its first episode), and the random state of the
    runners' exploration and of the learner's minibatch shuffling (seeded again from
    the run's seed). A resumed run therefore samples other episodes than the
    uninterrupted run would have after the checkpoint: it is reproducible, but not
    equal to the uninterrupted run bit for bit (an SB3 run is)."""
    checkpoint = Path(directory) / RESUME_DIR
    progress = TrainingProgress(**json.loads((checkpoint / _STATE).read_text()))
    algo.restore_from_path(str((checkpoint / _ALGORITHM).resolve()))
    # RLlib (2.60) sends the restored weights to the remote runners without waiting
    # for them, and the runners were seen sampling with their initial weights after a
    # restore: send them again, and wait until every runner has them.
    algo.env_runner_group.sync_weights(
        from_worker_or_learner_group=algo.learner_group, inference_only=True, timeout_seconds=_SYNC_TIMEOUT_S
    )
    truncate_csv(Path(directory) / EPISODES_FILE, progress.episodes)
    return progress


#: How long a restore waits for the runners to take the restored weights.
_SYNC_TIMEOUT_S = 300.0


def _train_loop(
    algo: Any,
    timesteps: int,
    num_env_runners: int,
    directory: Path,
    progress: bool,
    checkpoint_every: Optional[int],
    start: TrainingProgress,
) -> TrainingProgress:
    """Trains from ``start`` until ``timesteps`` env steps were sampled, checkpointing
    every ``checkpoint_every`` env steps; returns where it ended."""
    from ray.rllib.utils.metrics import NUM_ENV_STEPS_SAMPLED_LIFETIME

    steps, iterations, episodes = start.steps, start.iterations, start.episodes
    clock = time.perf_counter() - start.wall_time_s
    every = checkpoint_every or math.inf
    next_checkpoint = (steps // every + 1) * every
    resumed = start != TrainingProgress()
    log = directory / EPISODES_FILE
    columns = episode_log_columns(log) if resumed and log.is_file() else TRAINING_EPISODE_COLUMNS
    with log.open("a" if resumed else "w", newline="") as file:
        writer = csv.writer(file)
        if not resumed:
            writer.writerow(columns)
        while steps < timesteps:
            result = algo.train()
            iterations += 1
            steps = int(result[NUM_ENV_STEPS_SAMPLED_LIFETIME])
            elapsed = time.perf_counter() - clock
            batches = algo.env_runner_group.foreach_env_runner(
                take_episode_records, local_env_runner=num_env_runners == 0
            )
            returns = []
            for record in (r for batch in batches for r in batch):
                episodes += 1
                returns.append(record[0])
                writer.writerow(episode_row(columns, [steps, f"{elapsed:.3f}", episodes, repr(record[0]), record[1]],
                                            record[2]))
            file.flush()
            if progress:
                mean = f"{np.mean(returns):.1f}" if returns else "-"
                print(f"iteration {iterations}: {steps} env steps, {len(returns)} episodes, mean return {mean}, "
                      f"{elapsed:.1f} s")
            if next_checkpoint <= steps < timesteps:
                save_training(algo, directory, TrainingProgress(steps, iterations, episodes, elapsed))
                next_checkpoint = (steps // every + 1) * every
    return TrainingProgress(steps, iterations, episodes, time.perf_counter() - clock)
