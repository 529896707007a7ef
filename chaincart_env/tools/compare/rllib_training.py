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
import logging
import os
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Mapping, Optional

import numpy as np

from chaincart_env._core import ChainCartError
from chaincart_env.tools.compare.learning_curve import TRAINING_EPISODE_COLUMNS
from chaincart_env.config import ChainCartConfig

__all__ = [
    "CHECKPOINT_DIR",
    "MODULE_PATH",
    "RLlibPolicy",
    "RLlibTrainingResult",
    "ray_cluster",
    "record_episode",
    "take_episode_records",
    "train_rllib",
]

#: The folder (beside ``run.json``) holding the RLlib checkpoint of the trained
#: algorithm (``Algorithm.from_checkpoint`` resumes it).
CHECKPOINT_DIR = "rllib_checkpoint"
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
        from ray.rllib.core.rl_module.rl_module import RLModule

        path = Path(checkpoint).resolve().joinpath(*MODULE_PATH)
        if not path.is_dir():
            raise ChainCartError(f"{path} does not exist: expected the RLModule inside an RLlib checkpoint")
        return cls(RLModule.from_checkpoint(str(path)))

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
        int(bool(info.get("is_success", False))),
        int(bool(info.get("out_of_track", False))),
        int(bool(info.get("numerical_failure", False))),
    )
    if not hasattr(env_runner, _RECORDS):
        setattr(env_runner, _RECORDS, [])
    getattr(env_runner, _RECORDS).append(record)


def take_episode_records(env_runner: Any) -> list[tuple[float, int, int, int, int]]:
    """The episodes a runner finished since the last call (run via ``foreach_env_runner``)."""
    records = getattr(env_runner, _RECORDS, [])
    setattr(env_runner, _RECORDS, [])
    return records


@contextmanager
def ray_cluster(address: Optional[str], cpus_needed: int) -> Iterator[str]:
    """Connects to the cluster at ``address`` (``"auto"``: the one this machine is part
    of), or starts a new local one (even beside a running ``ray start`` cluster) with
    at least ``cpus_needed`` CPUs, and shuts it down afterwards; a Ray session already
    started by the caller is used as it is. Yields a description of the cluster; too
    few CPUs is a ChainCartError."""
    import ray

    owned = not ray.is_initialized()
    if owned:
        if address is None:
            ray.init(address="local", num_cpus=max(os.cpu_count() or 1, cpus_needed), include_dashboard=False,
                     logging_level=logging.WARNING)
        else:
            ray.init(address=address, logging_level=logging.WARNING)
    try:
        cpus = int(ray.cluster_resources().get("CPU", 0))
        nodes = sum(1 for node in ray.nodes() if node.get("Alive"))
        local = owned and address is None
        where = "a local Ray cluster" if local else f"the Ray cluster at {address or 'this session'}"
        if cpus < cpus_needed:
            raise ChainCartError(
                f"{where} has {cpus} CPUs: expected at least {cpus_needed} (one per env runner); "
                "add machines with `ray start --address=...` or ask for fewer --num-env-runners"
            )
        yield f"{where}: {nodes} node(s), {cpus} CPUs"
    finally:
        if owned:
            ray.shutdown()


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
    episodes_csv: Path,
    checkpoint: Path,
    progress: bool = True,
    hyperparameters: Optional[Mapping[str, Any]] = None,
) -> RLlibTrainingResult:
    """Trains RLlib PPO until at least ``timesteps`` env steps were sampled, on
    ``num_env_runners`` runners of ``envs_per_runner`` native envs each (runner ``w``'s
    env ``i`` starts stream ``(seed + w) * envs_per_runner + i``), and logs the training
    episodes to ``episodes_csv``; saves the algorithm into ``checkpoint`` and returns
    the policy loaded back from it (what ``evaluate`` will load)."""
    if isinstance(timesteps, bool) or not isinstance(timesteps, int) or timesteps < 1:
        raise ChainCartError(f"timesteps = {timesteps!r}: expected an integer >= 1")
    ppo, settings = _ppo(config, seed, num_env_runners, envs_per_runner, dict(hyperparameters or {}))
    with ray_cluster(address, num_env_runners) as cluster:
        if progress:
            print(f"RLlib on {cluster}")
        algo = ppo.build_algo()
        try:
            steps, iterations, episodes, wall = _train_loop(algo, timesteps, num_env_runners, episodes_csv, progress)
            algo.save_to_path(str(Path(checkpoint).resolve()))
        finally:
            algo.stop()
    policy = RLlibPolicy.load(checkpoint)
    return RLlibTrainingResult(policy, wall, episodes, settings, steps, iterations, cluster)


def _train_loop(
    algo: Any, timesteps: int, num_env_runners: int, episodes_csv: Path, progress: bool
) -> tuple[int, int, int, float]:
    """Trains until ``timesteps`` env steps were sampled; returns the steps, iterations,
    episodes and wall time."""
    from ray.rllib.utils.metrics import NUM_ENV_STEPS_SAMPLED_LIFETIME

    steps = iterations = episodes = 0
    start = time.perf_counter()
    with Path(episodes_csv).open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(TRAINING_EPISODE_COLUMNS)
        while steps < timesteps:
            result = algo.train()
            iterations += 1
            steps = int(result[NUM_ENV_STEPS_SAMPLED_LIFETIME])
            elapsed = time.perf_counter() - start
            batches = algo.env_runner_group.foreach_env_runner(
                take_episode_records, local_env_runner=num_env_runners == 0
            )
            returns = []
            for record in (r for batch in batches for r in batch):
                episodes += 1
                returns.append(record[0])
                writer.writerow([steps, f"{elapsed:.3f}", episodes, repr(record[0]), *record[1:]])
            file.flush()
            if progress:
                mean = f"{np.mean(returns):.1f}" if returns else "-"
                print(f"iteration {iterations}: {steps} env steps, {len(returns)} episodes, mean return {mean}, "
                      f"{elapsed:.1f} s")
    return steps, iterations, episodes, time.perf_counter() - start
