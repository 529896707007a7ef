"""The transitions table: every move between two equilibria of an n-link chain, planned
(``ChainCart.plan``) and tracked (:class:`~chaincart_env.TrajectoryPolicy`) in the env
from seeded perturbed starts, with success held over the last seconds of the episode.

``python -m chaincart_env transitions [--links 2] [--spatial] [--max-force 20]
[--track-limit 2.4] [--duration D] [--hold 1] [--spare 1] [--seeds 3]
[--plan-from equilibrium|state] [--out DIR] [--figure]`` prints a Markdown table and
writes ``transitions_<n>.csv`` (and, with ``--figure``, a picture of the planned
swing-up ``swingup_<n>.png``).
"""

from __future__ import annotations

import argparse
import csv
import itertools
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

__all__ = ["TransitionRow", "add_transitions_command", "markdown_table", "transitions"]


@dataclass(frozen=True)
class TransitionRow:
    """One start-target pair: the plan and its tracking from seeded starts."""

    start: tuple[int, ...]
    target: tuple[int, ...]
    planned: bool
    plan_seconds: float
    iterations: int
    successes: int
    episodes: int
    #: Largest over the episodes of the first time after which the chain stays within
    #: the tolerances (NaN if an episode never settles).
    time_to_reach: float
    peak_force: float
    rms_force: float
    max_cart: float
    reason: str


def _episode(env: Any, policy: Any, seed: int, hold_steps: int, dt: float) -> tuple[bool, float, np.ndarray, float]:
    """Success held over the last ``hold_steps``, time to reach, applied forces, max |x|."""
    base = env.unwrapped
    obs, _ = env.reset(seed=seed)
    inside, forces, cart = [], [], 0.0
    start = True
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = policy.predict(obs, episode_start=np.array([start]))
        start = False
        forces.append(np.clip(np.asarray(action, dtype=np.float64), -1, 1) * base.config.max_force)
        obs, _, terminated, truncated, info = env.step(action)
        e_q, e_w = base.model.errors(base.model_state, base.config.target_signs)
        tol_q, tol_w = base.config.success_tolerances
        inside.append(e_q <= tol_q and e_w <= tol_w)
        cart = max(cart, float(np.abs(base.state[0:2]).max()))
    held = bool(not terminated and len(inside) >= hold_steps and all(inside[-hold_steps:]))
    outside = [k for k, ok in enumerate(inside) if not ok]
    reach = (outside[-1] + 2 if outside else 1) * dt if inside[-1] else float("nan")
    return held, reach, np.array(forces), cart


def transitions(
    n_links: int,
    planar: bool = True,
    max_force: float = 20.0,
    track_limit: float = 2.4,
    duration: Optional[float] = None,
    hold: float = 1.0,
    seeds: int = 3,
    start_noise: float = 0.05,
    pairs: Optional[Sequence[tuple[Sequence[int], Sequence[int]]]] = None,
    spare: float = 0.0,
    plan_from: str = "equilibrium",
) -> list[TransitionRow]:
    """Plans and tracks every ordered pair of distinct equilibria (or ``pairs``) on the
    default scene's physical system with ``n_links`` links; each episode lasts the plan
    plus ``spare`` plus ``hold`` seconds (the large-motion scenes leave 1 s spare after
    4 s plans of two links and 2 s after 7 s plans of three)
    and succeeds when the chain stays within the success tolerances over those last
    ``hold`` seconds. ``plan_from``: the tracking policy's (:class:`~chaincart_env.TrajectoryPolicy`),
    where each episode's plan starts."""
    from chaincart_env.config import ChainCartConfig
    from chaincart_env.env import ChainCartEnv
    from chaincart_env.policies import TrajectoryPolicy

    all_signs = [tuple(s) for s in itertools.product([1, -1], repeat=n_links)]
    todo = [(tuple(s), tuple(t)) for s, t in pairs] if pairs else [
        (s, t) for s in all_signs for t in all_signs if s != t
    ]
    plan_duration = 1.0 + n_links if duration is None else duration
    rows = []
    for start, target in todo:
        dt = 0.02
        steps = int(round(plan_duration / dt)) + int(round(spare / dt)) + int(round(hold / dt))
        env = ChainCartEnv(ChainCartConfig(
            n_links=n_links, planar=planar, start=tuple(map(float, start)), target=tuple(map(float, target)),
            max_force=max_force, track_limit=track_limit, max_episode_steps=steps, start_noise=start_noise,
        ))
        # A missed plan is tracked all the same (the episodes then fail): planning from each
        # episode's state may still find one where the plan from the equilibrium did not.
        policy = TrajectoryPolicy.from_env(env, duration=plan_duration, plan_from=plan_from, on_failure="track")
        began = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            plan = policy.plan(start, target)
        report = plan.report
        if not plan.converged and plan_from == "equilibrium":
            rows.append(TransitionRow(start, target, False, time.perf_counter() - began, 0, 0, seeds,
                                      float("nan"), float("nan"), float("nan"), float("nan"), str(report["reason"])))
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            results = [_episode(env, policy, seed, int(round(hold / dt)), dt) for seed in range(seeds)]
        forces = np.concatenate([r[2].reshape(-1) for r in results])
        rows.append(TransitionRow(
            start=start, target=target, planned=bool(plan.converged), plan_seconds=float(report["seconds"]),
            iterations=int(report["iterations"]), successes=sum(r[0] for r in results), episodes=seeds,
            time_to_reach=max(r[1] for r in results), peak_force=float(np.abs(forces).max()),
            rms_force=float(np.sqrt(np.mean(forces**2))), max_cart=max(r[3] for r in results),
            reason="" if plan.converged else str(report["reason"]),
        ))
    return rows


def _signs(s: tuple[int, ...]) -> str:
    return "(" + ",".join("+" if v > 0 else "-" for v in s) + ")"


def markdown_table(rows: Sequence[TransitionRow]) -> str:
    """The rows as a Markdown table (signs: + hanging link, - upright link)."""
    lines = [
        "| start | target | planned | success | time to reach (s) | peak force (N) | RMS force (N) | max abs(x) (m) | planning (s) | iterations |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {_signs(r.start)} | {_signs(r.target)} | {'yes' if r.planned else 'no'} | "
            f"{r.successes}/{r.episodes} | {r.time_to_reach:.2f} | {r.peak_force:.1f} | {r.rms_force:.1f} | "
            f"{r.max_cart:.2f} | {r.plan_seconds:.2f} | {r.iterations} |"
        )
    return "\n".join(lines)


def swingup_figure(n_links: int, path: Path, max_force: float = 20.0, duration: Optional[float] = None) -> Path:
    """A picture of the planned swing-up of the planar n-link chain: the chain every
    0.2 s (later instants darker) over the cart's path, and the force."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from chaincart_env.model import ChainCart

    model = ChainCart(n_links, 1.0, 0.1, 0.5, planar=True)
    plan = model.plan("hanging", "inverted", max_force=max_force, duration=duration)
    states, times = plan.states, plan.times
    fig, (ax, axf) = plt.subplots(2, 1, figsize=(7, 5), gridspec_kw={"height_ratios": [3, 1]})
    every = max(1, int(round(0.2 / plan.dt)))
    for k in range(0, len(times), every):
        y = states[k]
        x = y[0]
        q = y[2 : 2 + 2 * n_links].reshape(n_links, 2)
        # Heights up: e3 points down, so the height of a mass is -l * (q . e3).
        points = np.vstack([[x, 0.0], [x, 0.0] + np.cumsum(0.5 * np.column_stack([q[:, 0], -q[:, 1]]), axis=0)])
        shade = 0.15 + 0.85 * k / (len(times) - 1)
        ax.plot(points[:, 0], points[:, 1], "-o", color=(0.1, 0.2, 0.6, shade), markersize=2, linewidth=1)
    ax.plot(states[:, 0], np.zeros_like(times), color="0.5", linewidth=0.8)
    ax.set_aspect("equal")
    ax.set_xlabel("e1 (m)")
    ax.set_ylabel("height (m)")
    ax.set_title(f"planned swing-up, {n_links} links ({plan.report['seconds']:.2f} s to plan)")
    axf.step(times[:-1], plan.forces[:, 0], where="post", linewidth=1)
    axf.set_xlabel("t (s)")
    axf.set_ylabel("force (N)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def add_transitions_command(commands: Any) -> None:
    """Registers ``transitions`` as a subcommand."""
    p = commands.add_parser("transitions", help="plan and track every transition between equilibria (Markdown)")
    p.add_argument("--links", type=int, default=2, help="number of links (default: 2)")
    p.add_argument("--spatial", action="store_true", help="spherical joints (default: planar)")
    p.add_argument("--max-force", type=float, default=20.0, help="force limit per cart axis, N (default: 20)")
    p.add_argument("--track-limit", type=float, default=2.4, help="largest cart offset from the centre before the episode ends, m (default: 2.4)")
    p.add_argument("--duration", type=float, default=None, help="plan length, s (default: 1 + links)")
    p.add_argument("--hold", type=float, default=1.0, help="seconds the target must be held at the end")
    p.add_argument("--spare", type=float, default=0.0,
                   help="seconds between the plan's end and the hold (the large-motion scenes leave 1 with "
                   "two links, 2 with three; default: 0)")
    p.add_argument("--plan-from", choices=["equilibrium", "state"], default="equilibrium",
                   help="where each episode's plan starts: the start equilibrium (one plan per transition) "
                   "or the episode's first observed state (one plan per episode)")
    p.add_argument("--seeds", type=int, default=3, help="perturbed starts per transition")
    p.add_argument("--out", type=Path, default=None, help="directory for the CSV (and the figure)")
    p.add_argument("--figure", action="store_true", help="also draw the planned swing-up")
    p.set_defaults(handler=_run)


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from chaincart_env.errors import InvalidInputError

    try:
        rows = transitions(
            args.links, not args.spatial, args.max_force, args.track_limit, args.duration, args.hold, args.seeds,
            spare=args.spare, plan_from=args.plan_from,
        )
    except InvalidInputError as error:
        print(f"{parser.prog} transitions: error: {error}")
        return 2
    print(markdown_table(rows))
    ok = sum(r.successes == r.episodes for r in rows)
    print(f"\n{ok}/{len(rows)} transitions succeed from every start")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        with open(args.out / f"transitions_{args.links}.csv", "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(TransitionRow.__dataclass_fields__)
            for r in rows:
                writer.writerow([getattr(r, name) for name in TransitionRow.__dataclass_fields__])
        if args.figure:
            print(swingup_figure(args.links, args.out / f"swingup_{args.links}.png"))
    return 0 if ok == len(rows) else 1
