"""The main job's answer in plain words: what was measured, and at which settings each
learned policy or the best model-based controller succeeded more often.

The *baseline* is the best model-based controller of the study: the highest success
rate averaged over the evaluation starts and every sweep value (then the higher mean
return on the starts; then the first named), the oracle LQR excluded (it reads the true
parameters, which a deployed controller cannot). Each learned policy (its final models)
is weighed against it. A study without a learned policy weighs the other model-based
controllers against the best one; one without a model-based controller, the other
learned policies against the best learned one.

A sweep value that leaves the scene as it is (no mismatch; the scene's own start
perturbation) is the setting of the evaluation starts again, on the same episodes: the
verdict shows it on its axis's line but counts each distinct setting once.

A side is *ahead* at a setting when the 95% interval of its success rate lies wholly
above the other's; where the intervals overlap the two *tie* (the data cannot tell
them apart). The interval of a policy measured on one training seed (and of the LQR)
is the Wilson interval over its episodes; over several seeds, the bootstrap interval
over seeds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from chaincart_env.config import ChainCartConfig
from chaincart_env.tools.compare.uncertainty import wilson_interval

__all__ = [
    "Rate", "Standing", "Verdict", "compare_rates", "main_setting_values", "main_starts_rate", "study_verdict",
    "verdict_lines",
]

#: Sweep values by axis that are the evaluation starts' own setting.
Nominal = Mapping[str, Sequence[float]]


@dataclass(frozen=True)
class Rate:
    """A success rate and its 95% interval."""

    value: float
    low: float
    high: float


@dataclass(frozen=True)
class Standing:
    """One policy as the verdict weighs it: its label, its training seeds (0: designed,
    not trained), its success rate on the evaluation starts and its mean return there."""

    label: str
    seeds: int
    main: Rate
    returns: float


def compare_rates(agent: Rate, baseline: Rate) -> str:
    """``"agent"``, ``"baseline"`` (that side is ahead) or ``"tie"``."""
    if agent.low > baseline.high:
        return "agent"
    if baseline.low > agent.high:
        return "baseline"
    return "tie"


def main_starts_rate(summary: dict[str, Any], aggregate: dict[str, Any] | None = None) -> Rate:
    """The success rate on the evaluation starts: over several training seeds the
    aggregate's bootstrap interval, else the Wilson interval over the episodes."""
    if aggregate is not None and aggregate["seeds"] > 1 and math.isfinite(aggregate["success_ci_low"]):
        return Rate(aggregate["success_mean"], aggregate["success_ci_low"], aggregate["success_ci_high"])
    episodes = int(summary["episodes"])
    low, high = wilson_interval(round(summary["success_rate"] * episodes), episodes)
    return Rate(summary["success_rate"], low, high)


def main_setting_values(config: ChainCartConfig, sweeps: Mapping[str, Sequence[float]]) -> dict[str, list[float]]:
    """The values of each sweep axis that leave ``config`` as it is: the setting of the
    evaluation starts, measured again on the same episodes."""
    from chaincart_env.tools.compare.sweeps import SWEEP_AXES

    return {
        axis: [value for value in values if SWEEP_AXES[axis].apply(config, float(value)) == config]
        for axis, values in sweeps.items()
    }


def _values_text(values: Sequence[float], nominal: Sequence[float] = ()) -> str:
    return ", ".join(f"{v:g}" + (" (the evaluation starts' setting)" if v in nominal else "") for v in values)


def _axis_line(
    label: str, rows: Sequence[dict[str, Any]], agent: str, baseline: str, nominal: Sequence[float] = ()
) -> tuple[str, dict[str, int]]:
    """One sweep axis: where each side is ahead and where they tie; the counts leave out
    the ``nominal`` values (the evaluation starts' setting, counted there)."""
    outcome: dict[str, list[float]] = {"agent": [], "baseline": [], "tie": []}
    higher: dict[str, list[float]] = {"agent": [], "baseline": []}  # ties whose rates still differ
    for value in sorted({r["value"] for r in rows}):
        mine = {r["policy"]: r for r in rows if r["value"] == value}
        rates = [Rate(mine[p]["success_rate"], mine[p]["ci_low"], mine[p]["ci_high"]) for p in (agent, baseline)]
        side = compare_rates(*rates)
        outcome[side].append(value)
        if side == "tie" and rates[0].value != rates[1].value:
            higher["agent" if rates[0].value > rates[1].value else "baseline"].append(value)
    names = (("agent", agent), ("baseline", baseline))
    parts = [f"{name} ahead at {_values_text(outcome[side], nominal)}" for side, name in names if outcome[side]]
    if outcome["tie"]:
        within = [f"{name} at {_values_text(higher[side])}" for side, name in names if higher[side]]
        parts.append(f"tied at {_values_text(outcome['tie'], nominal)}"
                     + (f" (higher rate within the intervals: {', '.join(within)})" if within else ""))  # fmt: skip
    counts = {side: sum(1 for v in values if v not in nominal) for side, values in outcome.items()}
    return f"* {label}: {'; '.join(parts)}.", counts


def verdict_lines(
    *,
    agent: str,
    seeds: int,
    baseline: str,
    episodes: int,
    main: tuple[Rate, Rate],
    returns: tuple[float, float],
    sweeps: dict[str, tuple[str, Sequence[dict[str, Any]]]],
    nominal: Nominal | None = None,
) -> list[str]:
    """The verdict of ``agent`` against ``baseline``: a headline naming who succeeded
    more often over every distinct setting, one line for the evaluation starts and one
    per sweep axis, and how to read it. ``seeds``: the agent's training seeds (0: not
    trained); ``nominal``: the values of each axis that are the evaluation starts'
    setting (:func:`main_setting_values`), shown on their axis but counted once."""
    counts = {"agent": 0, "baseline": 0, "tie": 0}
    side = compare_rates(*main)
    counts[side] += 1
    lines = [
        f"* On the {episodes} evaluation starts: {agent} succeeded in {main[0].value:.0%} "
        f"[{main[0].low:.2f}, {main[0].high:.2f}] of episodes, {baseline} in {main[1].value:.0%} "
        f"[{main[1].low:.2f}, {main[1].high:.2f}]"
        + {"agent": f": {agent} ahead", "baseline": f": {baseline} ahead", "tie": ": tied"}[side]
        + f"; mean return {returns[0]:.1f} against {returns[1]:.1f}.",
    ]
    for axis, (label, rows) in sweeps.items():
        line, outcome = _axis_line(label, rows, agent, baseline, (nominal or {}).get(axis, ()))
        lines.append(line)
        for key, count in outcome.items():
            counts[key] += count
    total = sum(counts.values())
    if counts["agent"] and not counts["baseline"]:
        headline = f"{agent} succeeded more often than {baseline}"
    elif counts["baseline"] and not counts["agent"]:
        headline = f"{baseline} succeeded more often than {agent}"
    elif counts["agent"] or counts["baseline"]:
        headline = f"each side is ahead somewhere: {agent} and {baseline} split"
    else:
        headline = f"{agent} and {baseline} cannot be told apart on these episodes"
    seed_text = f"{seeds} training seed{'s' if seeds != 1 else ''}" if seeds else "model-based"
    head = (
        f"**{headline}**: {agent} ({seed_text}) against {baseline}, success rates at {total} distinct "
        f"setting{'s' if total != 1 else ''}: "
        f"{agent} ahead at {counts['agent']}, {baseline} ahead at {counts['baseline']}, tied at {counts['tie']}."
    )
    reading = (
        "Ahead: the 95% interval of its success rate lies wholly above the other's; tied: the intervals overlap. "
        + {0: "Neither is trained: the intervals are over episodes.",
           1: "With one training seed the intervals are over episodes only: how much another seed would differ is "
              "not measured (`--seeds 0,1,2`)."}.get(seeds, "Intervals of the agent: bootstrap over seeds.")
    )
    return [head, "", *lines, "", reading]


def _overall(standing: Standing, sweeps: dict[str, tuple[str, Sequence[dict[str, Any]]]]) -> tuple[float, float]:
    """What ranks the candidates for the baseline: the success rate averaged over the
    evaluation starts and every sweep value, then the mean return on the starts."""
    rates = [standing.main.value] + [
        r["success_rate"] for _, rows in sweeps.values() for r in rows if r["policy"] == standing.label
    ]
    return (sum(rates) / len(rates), standing.returns)


@dataclass(frozen=True)
class Verdict:
    """A study's verdict: its lines of Markdown, the baseline and the policies weighed
    against it (labels)."""

    lines: list[str]
    baseline: Standing
    contenders: list[str]


def study_verdict(
    learned: Sequence[Standing],
    model_based: Sequence[Standing],
    sweeps: dict[str, tuple[str, Sequence[dict[str, Any]]]],
    episodes: int,
    nominal: Nominal | None = None,
) -> Verdict:
    """The verdict of a study (module docstring): one block of :func:`verdict_lines`
    per policy weighed against the baseline (``nominal``: as there)."""
    pool = list(model_based) or list(learned)
    if not pool:
        raise ValueError("a verdict needs at least one policy")
    baseline = max(pool, key=lambda standing: _overall(standing, sweeps))
    if model_based:
        contenders = list(learned) or [s for s in model_based if s is not baseline]
    else:
        contenders = [s for s in learned if s is not baseline]
    lines: list[str] = []
    if len(pool) > 1:
        kind = "model-based controller" if model_based else "learned policy"
        lines += [f"Baseline: {baseline.label}, the best {kind} of this study (highest success rate averaged over the "
                  "evaluation starts and every sweep value).", ""]
    for contender in contenders:
        if lines and lines[-1] != "":
            lines.append("")
        lines += verdict_lines(
            agent=contender.label, seeds=contender.seeds, baseline=baseline.label, episodes=episodes,
            main=(contender.main, baseline.main), returns=(contender.returns, baseline.returns), sweeps=sweeps,
            nominal=nominal,
        )
    if not contenders:
        rate = baseline.main
        lines.append(
            f"**Only {baseline.label} was evaluated**: it succeeded in {rate.value:.0%} [{rate.low:.2f}, "
            f"{rate.high:.2f}] of the {episodes} evaluation starts (mean return {baseline.returns:.1f}); nothing to "
            "weigh it against."
        )
    return Verdict(lines, baseline, [c.label for c in contenders])
