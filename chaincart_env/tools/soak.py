"""Soak run: millions of vector-env steps with random actions, checking that memory
stays constant (resident set size before and after) and nothing goes non-finite.

``python -m chaincart_env soak [--steps 10000000] [--num-envs 1024] [--scene S]``
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from chaincart_env.vector import ChainCartVectorEnv

__all__ = ["SoakReport", "resident_set_size", "soak"]


def resident_set_size() -> int:
    """This process's resident set size in bytes (Linux /proc; 0 where unavailable)."""
    try:
        with open("/proc/self/statm") as f:
            pages = int(f.read().split()[1])
    except (OSError, ValueError, IndexError):
        return 0
    import os

    return pages * os.sysconf("SC_PAGE_SIZE")


@dataclass
class SoakReport:
    """What a soak run measured: env-steps, wall time, resident memory at start and end, episodes
    ended and numerical failures."""

    env_steps: int
    seconds: float
    rss_start: int
    rss_end: int
    episodes_ended: int
    numerical_failures: int

    @property
    def rss_growth(self) -> int:
        """Resident memory growth over the run, bytes."""
        return self.rss_end - self.rss_start

    def markdown(self) -> str:
        """The report as a one-row Markdown table."""
        mib = 1024 * 1024
        return (
            "| env-steps | wall time (s) | env-steps/s | RSS at start (MiB) | RSS at end (MiB) | growth (MiB) "
            "| episodes ended | numerical failures |\n|---|---|---|---|---|---|---|---|\n"
            f"| {self.env_steps:,} | {self.seconds:.1f} | {self.env_steps / self.seconds:,.0f} "
            f"| {self.rss_start / mib:.1f} | {self.rss_end / mib:.1f} | {self.rss_growth / mib:+.2f} "
            f"| {self.episodes_ended:,} | {self.numerical_failures:,} |"
        )


def soak(steps: int, num_envs: int = 1024, seed: int = 0, warmup: int = 1000, **config: Any) -> SoakReport:
    """Steps a vector env ``steps`` env-steps in total (rounded up to whole batches)
    with uniform random actions; RSS is taken after ``warmup`` batch steps, when every
    buffer has been allocated, and again at the end."""
    if steps <= 0 or num_envs <= 0:
        raise ValueError(f"steps = {steps}, num_envs = {num_envs}: expected both > 0")
    env = ChainCartVectorEnv(num_envs=num_envs, **config)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    # One preallocated action buffer refilled in place: the loop itself allocates
    # nothing that grows.
    actions = np.empty((num_envs, *(env.single_action_space.shape or ())), dtype=np.float32)
    ended = failures = 0

    def run(batches: int) -> None:
        nonlocal ended, failures
        for _ in range(batches):
            rng.random(out=actions, dtype=np.float32)
            np.multiply(actions, 2.0, out=actions)
            np.subtract(actions, 1.0, out=actions)
            obs, _, terminated, truncated, info = env.step(actions)
            done = terminated | truncated
            if done.any():
                ended += int(done.sum())
                if "numerical_failure" in info:
                    failures += int(np.sum(info["numerical_failure"] & info["_numerical_failure"]))
                if not np.all(np.isfinite(obs)):
                    raise AssertionError("non-finite observation during the soak")

    run(warmup)
    rss_start = resident_set_size()
    batches = -(-steps // num_envs)
    start = time.perf_counter()
    run(batches)
    seconds = time.perf_counter() - start
    return SoakReport(batches * num_envs, seconds, rss_start, resident_set_size(), ended, failures)


def main(steps: int, num_envs: int, seed: int, scene: Optional[str]) -> int:
    """Runs the ``soak`` command: prints the report; returns 0."""
    config: dict[str, Any] = {} if scene is None else {"scene": scene}
    report = soak(steps, num_envs, seed, **config)
    print(report.markdown())
    return 0
