"""Region of attraction of the LQR baseline (or any policy): the fraction of random
starts it stabilises, as a function of the perturbation size.

For each start noise (the config's ``start_noise``: uniform noise of that half-width
on every local coordinate of the start, see :class:`chaincart_env.ChainCartEnv`),
``starts`` seeded episodes run side by side in the native vector env
(:class:`chaincart_env.ChainCartVectorEnv`), the policy evaluated on the whole batch
at once. A start counts as stabilised when its episode ends with the env's
``is_success``: at the time limit, not terminated, within the success tolerances.
Every noise level uses the same seeds, so its starts are the same random directions
scaled by the noise: the curve compares like with like.

This is the yardstick an RL agent is compared against. The ``roa`` command
(:mod:`chaincart_env.tools.roa_cli`) prints the curve as a table and writes it as CSV and
a PNG.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional, Sequence

import numpy as np

from chaincart_env.config import DEFAULT_SCENE, ChainCartConfig
from chaincart_env.policies.lqr import LQRPolicy
from chaincart_env.vector import ChainCartVectorEnv

__all__ = ["DEFAULT_SIZES", "RoaPoint", "region_of_attraction", "success_fractions", "wilson_interval"]

#: Default perturbation sizes (start noise half-widths).
DEFAULT_SIZES = (0.025, 0.05, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0)

#: z of the two-sided 95% interval.
_Z95 = 1.959963984540054


@dataclass(frozen=True)
class RoaPoint:
    """Outcome of ``starts`` episodes at one start noise: the fraction stabilised (with
    its 95% Wilson interval) and how the others ended."""

    scene: str
    start_noise: float
    starts: int
    success: float
    ci_low: float
    ci_high: float
    out_of_track: float
    numerical_failure: float
    unsettled: float


def wilson_interval(successes: int, trials: int) -> tuple[float, float]:
    """The 95% Wilson score interval of a binomial proportion."""
    if trials <= 0:
        raise ValueError(f"trials = {trials}: expected at least one trial")
    p = successes / trials
    z2 = _Z95**2 / trials
    centre = (p + z2 / 2) / (1 + z2)
    half = _Z95 * math.sqrt(p * (1 - p) / trials + z2 / (4 * trials)) / (1 + z2)
    return max(0.0, centre - half), min(1.0, centre + half)


def _episode_outcomes(env: ChainCartVectorEnv, policy: Any, seed: int) -> dict[str, np.ndarray]:
    """Runs every env of ``env`` to the end of its first episode; returns the
    episode-end flags per env (later episodes started by the autoreset are ignored)."""
    n = env.num_envs
    done = np.zeros(n, dtype=bool)
    outcome = {key: np.zeros(n, dtype=bool) for key in ("is_success", "out_of_track", "numerical_failure")}
    obs, _ = env.reset(seed=seed)
    while not done.all():
        obs, _, _, _, info = env.step(policy.predict(obs)[0])
        if "_is_success" not in info:
            continue
        new = info["_is_success"] & ~done
        for key, flags in outcome.items():
            flags[new] = info[key][new]
        done |= new
    return outcome


def success_fractions(
    config: ChainCartConfig, starts: int, seed: int = 0, policy: Optional[Any] = None
) -> RoaPoint:
    """One point of the curve: ``starts`` episodes of ``config`` (env i seeded
    ``seed + i``) with ``policy`` (default: the LQR baseline of the config)."""
    if isinstance(starts, bool) or not isinstance(starts, (int, np.integer)) or starts < 1:
        raise ValueError(f"starts = {starts!r}: expected an integer >= 1")
    env = ChainCartVectorEnv(int(starts), config)
    policy = LQRPolicy.from_env(env) if policy is None else policy
    outcome = _episode_outcomes(env, policy, seed)
    env.close()
    wins = int(outcome["is_success"].sum())
    low, high = wilson_interval(wins, int(starts))
    failed = outcome["out_of_track"] | outcome["numerical_failure"]
    return RoaPoint(
        scene=config.scene,
        start_noise=config.start_noise,
        starts=int(starts),
        success=wins / starts,
        ci_low=low,
        ci_high=high,
        out_of_track=float(outcome["out_of_track"].mean()),
        numerical_failure=float(outcome["numerical_failure"].mean()),
        unsettled=float((~outcome["is_success"] & ~failed).mean()),
    )


def region_of_attraction(
    scene: Optional[str] = None,
    sizes: Sequence[float] = DEFAULT_SIZES,
    starts: int = 200,
    seed: int = 0,
    policy: Optional[Any] = None,
    **config_overrides: Any,
) -> list[RoaPoint]:
    """The success curve of ``policy`` (default: the LQR baseline) on ``scene`` (default:
    the default scene; ``config_overrides`` are further config keywords) for each start
    noise in ``sizes``."""
    if len(sizes) == 0:
        raise ValueError("sizes is empty: expected at least one start noise")
    for size in sizes:
        if not (isinstance(size, (int, float, np.floating)) and math.isfinite(size) and size >= 0):
            raise ValueError(f"start noise {size!r}: expected a finite number >= 0")
    base = ChainCartConfig(scene=scene or DEFAULT_SCENE, **config_overrides)
    return [success_fractions(base.replace(start_noise=float(size)), starts, seed, policy) for size in sizes]
