"""Benchmark section ``rllib``: RLlib sampling throughput (env steps/s) of PPO's env
runners with the native vector env and with RLlib's default ``SyncVectorEnv``
wrapping, for 1 and 2 runners, and the share of a runner's sampling time spent in
the env's ``step`` (needs the ``rllib`` extra).

Each runner samples with the (untrained) PPO module exploring, as in training. The
env share is measured inside each runner: ``env.step`` as RLlib calls it (its info
wrapper included) is timed during ``sample()`` and divided by ``sample()``'s time;
the rest is RLlib's connectors, the module's forward pass and episode bookkeeping.
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass
from typing import Any

from chaincart_env.tools.bench.bench_report import fmt_rate
from chaincart_env.tools.bench.context import BenchContext

__all__ = ["MODES", "SamplingRate", "rllib_section", "measure_sampling", "timed_sample"]

#: RLlib's ``gym_env_vectorize_mode`` values compared, with their names in the table.
MODES = {"vector_entry_point": "native ChainCartVectorEnv", "sync": "SyncVectorEnv of ChainCartEnv (RLlib's default)"}

MISSING_NOTE = "Skipped: Ray RLlib is not installed (`pip install chaincart-env[rllib]`)."


def rllib_available() -> bool:
    """Whether Ray RLlib (the ``rllib`` extra) can be imported."""
    try:
        import ray.rllib  # noqa: F401
    except ImportError:
        return False
    return True


def timed_sample(env_runner: Any, timesteps: int) -> tuple[int, float, float]:
    """Runs in an env runner: one ``sample(num_timesteps=timesteps)`` with its env's
    ``step`` timed; returns (env steps, sample seconds, seconds in env.step)."""
    env = env_runner.env
    step = env.step
    in_env = 0.0

    def timed_step(actions: Any) -> Any:
        nonlocal in_env
        start = time.perf_counter()
        try:
            return step(actions)
        finally:
            in_env += time.perf_counter() - start

    env.step = timed_step  # the runner calls self.env.step: shadow it for this sample
    try:
        start = time.perf_counter()
        episodes = env_runner.sample(num_timesteps=timesteps)
        seconds = time.perf_counter() - start
    finally:
        del env.step
    return sum(len(episode) for episode in episodes), seconds, in_env


@dataclass(frozen=True)
class SamplingRate:
    """RLlib's sampling rate in one setting: env-steps/s overall and per runner, and the share of
    the runners' time spent in the env."""

    mode: str
    runners: int
    envs_per_runner: int
    steps_per_s: float
    runner_steps_per_s: float
    env_share: float


def measure_sampling(
    mode: str, runners: int, envs_per_runner: int, timesteps: int, repeats: int
) -> SamplingRate:
    """Builds PPO with ``runners`` runners of ``envs_per_runner`` envs in ``mode`` and
    times parallel ``sample()`` calls of ``timesteps`` steps per runner (best of
    ``repeats``, after one warm-up)."""
    from chaincart_env.rllib import ppo_config

    config = ppo_config().env_runners(
        num_env_runners=runners, num_envs_per_env_runner=envs_per_runner, gym_env_vectorize_mode=mode
    )
    algo = config.learners(num_learners=0).debugging(seed=0).build_algo()
    try:
        group = algo.env_runner_group
        assert group is not None  # built with remote runners
        group.foreach_env_runner(lambda r: timed_sample(r, timesteps // 4), local_env_runner=False)  # warm-up
        best: tuple[float, list[tuple[int, float, float]]] = (0.0, [])
        for _ in range(repeats):
            start = time.perf_counter()
            results = group.foreach_env_runner(lambda r: timed_sample(r, timesteps), local_env_runner=False)
            rate = sum(steps for steps, _, _ in results) / (time.perf_counter() - start)
            best = max(best, (rate, results), key=lambda pair: pair[0])
    finally:
        algo.stop()
    rate, results = best
    runner_rate = sum(steps / seconds for steps, seconds, _ in results) / len(results)
    share = sum(env for _, _, env in results) / sum(seconds for _, seconds, _ in results)
    return SamplingRate(mode, runners, envs_per_runner, rate, runner_rate, share)


def rllib_section(ctx: BenchContext) -> None:
    """The RLlib section: sampling rates with the native vector env and with Gymnasium's
    ``SyncVectorEnv`` (a note when RLlib is missing)."""
    ctx.report.heading("RLlib sampling: native vector env vs SyncVectorEnv")
    if not rllib_available():
        ctx.report.paragraph(MISSING_NOTE)
        return
    import ray

    quick = ctx.settings.quick
    timesteps, repeats = (256, 1) if quick else (4096, 3)
    # 1 and 2 runners of 8 envs; one runner of 64 envs shows how batching more envs
    # per forward pass shifts the share.
    cases = ((1, 8), (2, 8)) if quick else ((1, 8), (2, 8), (1, 64))
    owned = not ray.is_initialized()
    if owned:
        cpus = max(2, os.cpu_count() or 1)
        ray.init(address="local", num_cpus=cpus, include_dashboard=False, logging_level=logging.WARNING)
    try:
        rates = [measure_sampling(mode, runners, envs, timesteps, repeats) for mode in MODES for runners, envs in cases]
    finally:
        if owned:
            ray.shutdown()
    ctx.results["rllib"] = rates
    rows = [
        [MODES[r.mode], str(r.runners), str(r.envs_per_runner), fmt_rate(r.steps_per_s), fmt_rate(r.runner_steps_per_s),
         f"{r.env_share:.1%}"]
        for r in rates
    ]  # fmt: skip
    ctx.report.paragraph(
        f"PPO's env runners (Ray {ray.__version__}, default scene, the untrained module exploring), each "
        f"`sample()` of {timesteps} env steps per runner, runners sampling in parallel; best of {repeats}. "
        "Env share: the time in `env.step` (as RLlib calls it) over the runner's `sample()` time."
    )
    ctx.report.table(
        ["vector env", "runners", "envs per runner", "env steps/s (all runners)", "per runner", "env share"], rows,
        numeric_from=1,
    )
    native = [r.env_share for r in rates if r.mode == "vector_entry_point"]
    ctx.report.paragraph(
        f"With the native vector env the env takes {min(native):.1%}-{max(native):.1%} of a runner's sampling time: "
        "the rest is RLlib (connectors, the module's forward pass, episode bookkeeping), so a faster env barely "
        "moves RLlib's throughput; more runners (machines) do."
    )
