"""``python -m chaincart_env leaderboard``: the robustness leaderboard of a set of
controllers on a set of scenes."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from chaincart_env.errors import ChainCartError, InvalidInputError

__all__ = ["add_leaderboard_command", "leaderboard_needs"]


def _seeds(text: str) -> list[int]:
    try:
        return [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected integers separated by commas") from None


def _positive(what: str) -> Any:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = 0
        if value < 1:
            raise argparse.ArgumentTypeError(f"{what} = {text!r}: expected an integer >= 1")
        return value

    return parse


def _scenes(text: str) -> list[str]:
    from chaincart_env.config import SCENES

    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in SCENES]
    if unknown or not names:
        raise argparse.ArgumentTypeError(f"{text!r}: expected scene names among {sorted(SCENES)}")
    return names


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from chaincart_env.tools.controllers import parse_controllers
    from chaincart_env.tools.leaderboard.axes import parse_axes
    from chaincart_env.tools.leaderboard.run import LeaderboardSettings, run_leaderboard

    try:
        settings = LeaderboardSettings(
            scenes=tuple(args.scenes), controllers=tuple(parse_controllers(args.policies)), seeds=tuple(args.seeds),
            axes=parse_axes(args.axes), quick=args.quick, episodes=args.episodes, timesteps=args.timesteps,
            progress_bar=not args.no_progress, torch_threads=args.torch_threads, wall_clock=args.wall_clock_budgets,
        )
        run_leaderboard(settings, args.out, args.report, address=args.address, fresh=args.fresh)
    except (ChainCartError, InvalidInputError) as error:
        parser.error(str(error))
    print(f"leaderboard: wrote {Path(args.report or Path(args.out) / 'leaderboard.md')}")
    return 0


def leaderboard_needs(args: Any) -> dict[str, tuple[str, ...]]:
    """The extras a leaderboard run needs: plotting always, SB3 for learned controllers,
    Ray for a cluster."""
    from chaincart_env.tools.controllers import LEARNED

    needs: dict[str, tuple[str, ...]] = {"plot": ("matplotlib", "scipy")}
    names = {name.strip().lower() for name in str(args.policies).split(",")}
    if names & set(LEARNED):
        needs["sb3"] = ("stable_baselines3", "yaml")
    if getattr(args, "address", None) is not None:
        needs["rllib"] = ("ray",)
    return needs


def add_leaderboard_command(commands: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    """Adds ``leaderboard`` to a subcommand set (its handler runs it)."""
    from chaincart_env.tools.controllers import CONTROLLERS
    from chaincart_env.tools.leaderboard.axes import AXIS_NAMES

    parser = commands.add_parser(
        "leaderboard", help="robustness leaderboard: success of every controller along robustness axes",
        description="Evaluate controllers (model-based and learned) on scenes along robustness axes (model "
        "mismatch, observation noise, force noise, control delay, force-rate limit, start perturbation), score "
        "them and write tables, figures and a Markdown report.",
    )
    parser.add_argument("--scenes", type=_scenes, required=True, help="scene names, separated by commas")
    parser.add_argument("--policies", required=True,
                        help=f"controllers, separated by commas, among: {', '.join(CONTROLLERS)} (the names the "
                        "main job's compare --policies takes), or pretrained:<scene>/<name>: a shipped agent, scored "
                        "as it is on the scenes with its spaces")
    parser.add_argument("--out", type=Path, required=True, help="run directory (agents, cells.csv, scores.csv, report)")
    parser.add_argument("--seeds", type=_seeds, default=[0],
                        help="seeds: training seeds of learned controllers and blocks of evaluation starts (default: 0)")
    parser.add_argument("--axes", default=None, help=f"axes, separated by commas (default: all: {', '.join(AXIS_NAMES)})")
    parser.add_argument("--quick", action="store_true",
                        help="a tiny run: two values per axis, 3 episodes per cell, learned agents trained 2048 steps")
    parser.add_argument("--episodes", type=int, default=None, help="episodes per cell and seed (default: 30; quick: 3)")
    parser.add_argument("--timesteps", type=int, default=None,
                        help="training budget of learned controllers (default: each recipe's; quick: 2048)")
    parser.add_argument("--report", type=Path, default=None,
                        help="where to write the Markdown report (default: OUT/leaderboard.md); figures go beside it")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar while training")
    parser.add_argument("--torch-threads", type=_positive("torch-threads"), default=1,
                        help="torch threads of training and evaluation (default 1: fastest for these small networks "
                        "on a shared machine)")
    parser.add_argument("--fresh", action="store_true",
                        help="evaluate every cell again (default: the cells already in OUT/cells.csv, evaluated with "
                        "the same settings, are read back: an interrupted run resumes; other settings are an error)")
    parser.add_argument("--wall-clock-budgets", action="store_true",
                        help="let the planner and MPC stop at their wall-clock budgets (30 s per plan, 2 ms per MPC "
                        "step) as well as their iteration counts; their results then depend on the machine's load "
                        "(default: iteration counts alone, the same results on any machine)")
    parser.add_argument("--address", default=None,
                        help="Ray cluster ('auto': the one this machine joined with `ray start`, HOST:PORT of its "
                        "head, or 'local' for a new one here) on which the agents train and the cells run as Ray "
                        "tasks, with the same results (default: everything in this process)")
    parser.set_defaults(handler=_run, needs=leaderboard_needs)
