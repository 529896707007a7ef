"""Sweeps: every policy evaluated on the same seeded starts at each value of an axis.

An axis turns a value into a variant of the scene's configuration (a larger start
perturbation, a system that differs from the model, a noisier sensor, ...). For each
value the same seeds start the episodes of every policy, so the comparison is paired:
at one value, the policies face the same random directions; across values, the same
directions scaled (``start_noise``).

Each row of a sweep is one (axis, value, policy): the success rate with its 95% Wilson
interval, the mean return, the mean time to settle over the settled episodes and the
mean peak force.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.evaluation import Policy, rollout, settle_times
from chaincart_env.tools.compare.uncertainty import aggregate_over_seeds, wilson_interval

__all__ = [
    "DEFAULT_SWEEPS", "SWEEP_AXES", "SWEEP_COLUMNS", "SWEEP_SUMMARY_COLUMNS", "SweepAxis", "parse_sweep", "run_sweep", "summarize_sweep",
    "sweep_rows",
]


@dataclass(frozen=True)
class SweepAxis:
    """One axis: what it varies (for tables and plot labels) and how a value changes
    the configuration."""

    name: str
    label: str
    apply: Callable[[ChainCartConfig, float], ChainCartConfig]
    minimum: float = 0.0
    maximum: float = math.inf
    integer: bool = False


def _start_noise(config: ChainCartConfig, value: float) -> ChainCartConfig:
    return config.replace(start_noise=value)


def _mismatch(config: ChainCartConfig, value: float) -> ChainCartConfig:
    """The true cart mass, link masses and link lengths each drawn at every reset from
    their nominal value times U[1 - p, 1 + p] (per link, from the env's own stream)."""
    if value == 0:
        return config.replace(randomize=None)
    return config.replace(randomize={key: value for key in ("cart_mass", "link_masses", "link_lengths")})


def _obs_noise(config: ChainCartConfig, value: float) -> ChainCartConfig:
    return config.replace(obs_noise=value if value > 0 else None)


def _delay(config: ChainCartConfig, value: float) -> ChainCartConfig:
    if value != int(value):
        raise InvalidInputError(f"--sweep delay value {value!r}: expected a whole number of control periods")
    return config.replace(action_delay=int(value))


#: The axes ``compare --sweep AXIS=V1,V2,...`` accepts.
SWEEP_AXES: dict[str, SweepAxis] = {
    axis.name: axis
    for axis in (
        SweepAxis("start_noise", "start perturbation (half-width, rad and m)", _start_noise),
        SweepAxis("mismatch", "model mismatch p (masses, lengths x U[1-p, 1+p])", _mismatch, maximum=0.95),
        SweepAxis("obs_noise", "observation noise (std, state units)", _obs_noise),
        SweepAxis("delay", "control delay (control periods)", _delay, integer=True),
    )
}

#: The sweeps of a default run: start perturbations from inside the LQR's region of
#: attraction to well outside it, and true systems whose masses and lengths are up to
#: 40% off the model both controllers were designed or trained on.
DEFAULT_SWEEPS: dict[str, tuple[float, ...]] = {
    "start_noise": (0.05, 0.1, 0.2, 0.3, 0.5),
    "mismatch": (0.0, 0.2, 0.4),
}

#: Columns of ``sweeps.csv``.
SWEEP_COLUMNS = (
    "axis", "value", "policy", "episodes", "successes", "success_rate", "ci_low", "ci_high",
    "return_mean", "settled", "settle_time_mean", "peak_force_mean",
)


def parse_sweep(text: str) -> tuple[str, list[float]]:
    """``"AXIS=V1,V2,..."`` into the axis name and its values (checked)."""
    name, sep, values = text.partition("=")
    name = name.strip()
    if not sep or name not in SWEEP_AXES:
        raise InvalidInputError(
            f"--sweep {text!r}: expected AXIS=V1,V2,... with AXIS one of {sorted(SWEEP_AXES)}"
        )
    try:
        numbers = [float(v) for v in values.split(",") if v.strip()]
    except ValueError:
        raise InvalidInputError(f"--sweep {text!r}: the values must be numbers separated by commas") from None
    axis = SWEEP_AXES[name]
    if not numbers:
        raise InvalidInputError(f"--sweep {text!r}: expected at least one value")
    for value in numbers:
        if not math.isfinite(value) or not axis.minimum <= value <= axis.maximum:
            bound = f" and <= {axis.maximum}" if math.isfinite(axis.maximum) else ""
            raise InvalidInputError(f"--sweep {name} value {value!r}: expected a finite number >= {axis.minimum}{bound}")
        if axis.integer and value != int(value):
            raise InvalidInputError(f"--sweep {name} value {value!r}: expected a whole number")
    return name, numbers


def sweep_rows(axis: str, value: float, runs: Sequence[Any], tolerances: tuple[float, float]) -> list[dict[str, Any]]:
    """The :data:`SWEEP_COLUMNS` of each policy's rollouts at one value."""
    rows = []
    for run in runs:
        wins = int(run.success.sum())
        low, high = wilson_interval(wins, run.episodes)
        settle = settle_times(run, tolerances)
        peaks = np.array([np.max(run.force[i, : run.lengths[i]]) for i in range(run.episodes)])
        rows.append(dict(
            axis=axis, value=float(value), policy=run.policy, episodes=run.episodes, successes=wins,
            success_rate=wins / run.episodes, ci_low=low, ci_high=high,
            return_mean=float(run.returns.mean()), settled=int(np.isfinite(settle).sum()),
            settle_time_mean=float(np.nanmean(settle)) if np.isfinite(settle).any() else float("nan"),
            peak_force_mean=float(peaks.mean()),
        ))
    return rows


def run_sweep(
    policies: Sequence[tuple[str, Policy]],
    config: ChainCartConfig,
    axis: str,
    values: Sequence[float],
    seeds: Sequence[int],
) -> list[dict[str, Any]]:
    """Evaluates every ``(name, policy)`` at every value of ``axis`` on the same ``seeds``."""
    if axis not in SWEEP_AXES:
        raise InvalidInputError(f"sweep axis {axis!r}: expected one of {sorted(SWEEP_AXES)}")
    rows: list[dict[str, Any]] = []
    for value in values:
        variant = SWEEP_AXES[axis].apply(config, float(value))
        runs = [rollout(policy, name, variant, seeds) for name, policy in policies]
        rows.extend(sweep_rows(axis, value, runs, variant.success_tolerances))
    return rows


#: Columns of ``sweep_summary.csv``: one row per (axis, value, policy) over seeds.
SWEEP_SUMMARY_COLUMNS = (
    "axis", "value", "policy", "seeds", "episodes", "success_rate", "ci_low", "ci_high", "interval",
    "return_mean", "settle_time_mean", "peak_force_mean",
)


def summarize_sweep(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Aggregates :func:`run_sweep` rows of several training seeds (each row may carry a
    ``seed``; rows without one are a single evaluation, e.g. the LQR's). A policy
    measured on one seed keeps its Wilson interval over episodes; one measured on several
    gets the mean over seeds with the 95% bootstrap interval over seeds."""
    groups: dict[tuple[str, float, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["axis"], row["value"], row["policy"]), []).append(row)
    out = []
    for (axis, value, policy), members in groups.items():
        mean_of = lambda key: float(np.nanmean([m[key] for m in members]))  # noqa: E731
        if len(members) == 1:
            only = members[0]
            low, high, interval = only["ci_low"], only["ci_high"], "Wilson, over episodes"
        else:
            aggregate = aggregate_over_seeds([m["success_rate"] for m in members])
            low, high, interval = aggregate.ci_low, aggregate.ci_high, "bootstrap, over seeds"
        settles = [m["settle_time_mean"] for m in members if math.isfinite(m["settle_time_mean"])]
        out.append(dict(
            axis=axis, value=value, policy=policy, seeds=len(members),
            episodes=int(sum(m["episodes"] for m in members)), success_rate=mean_of("success_rate"),
            ci_low=float(low), ci_high=float(high), interval=interval, return_mean=mean_of("return_mean"),
            settle_time_mean=float(np.mean(settles)) if settles else float("nan"),
            peak_force_mean=mean_of("peak_force_mean"),
        ))
    return out
