"""Command line: ``python -m chaincart_env COMMAND [options]`` (``--help`` lists the commands)."""

from __future__ import annotations

import argparse
import sys
from typing import Optional, Sequence


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``python -m chaincart_env`` with every command."""
    from chaincart_env.cli_text import plain, scene_help

    parser = argparse.ArgumentParser(prog="python -m chaincart_env", description=plain(__doc__ or ""))
    commands = parser.add_subparsers(dest="command", required=True)

    demo = commands.add_parser("demo", help="roll out one episode of a scene and print a summary")
    demo.add_argument("--scene", default=None, help=scene_help())
    demo.add_argument(
        "--policy", choices=("lqr", "zero", "random"), default="lqr",
        help="lqr: the paper's LQR designed on the scene's model (default); zero: no force; random: uniform actions",
    )  # fmt: skip
    demo.add_argument("--seed", type=int, default=0, help="reset seed of the episode (and the random policy's) (default: 0)")
    demo.add_argument("--steps", type=int, default=None, help="at most this many steps (default: one episode)")

    bench = commands.add_parser(
        "bench", help="benchmark suite: throughput vs CartPole, MuJoCo, speed/accuracy, scaling, render (Markdown)"
    )
    from chaincart_env.tools.bench.bench_cli import add_bench_arguments

    add_bench_arguments(bench)

    soak = commands.add_parser("soak", help="millions of random vector-env steps; RSS at start and end")
    soak.add_argument("--steps", type=int, default=10_000_000, help="env-steps in total (default: 10 million)")
    soak.add_argument("--num-envs", type=int, default=1024, help="envs in the vector env (default: 1024)")
    soak.add_argument("--seed", type=int, default=0, help="reset seed of the vector env (default: 0)")
    soak.add_argument("--scene", default=None, help=scene_help())

    from chaincart_env.tools.analysis_cli import add_commands as add_analysis_commands

    add_analysis_commands(commands)  # figures, roa: each sets args.handler

    from chaincart_env.tools.compare.compare_cli import add_commands as add_compare_commands

    add_compare_commands(commands)  # compare, evaluate: each sets args.handler

    from chaincart_env.tools.leaderboard.leaderboard_cli import add_leaderboard_command

    add_leaderboard_command(commands)  # leaderboard: sets args.handler

    from chaincart_env.tools.animate import add_animate_command

    add_animate_command(commands)  # animate: sets args.handler

    from chaincart_env.tools.transitions import add_transitions_command

    add_transitions_command(commands)  # transitions: sets args.handler

    from chaincart_env.tools.export_agent import add_export_command

    add_export_command(commands)  # export-agent: sets args.handler

    from chaincart_env.tools.config_docs import add_docs_command

    add_docs_command(commands)  # docs: sets args.handler

    from chaincart_env.tools.curves import add_curves_command

    add_curves_command(commands)  # curves: sets args.handler
    return parser


def subcommand_parsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The parsers of ``parser``'s commands, by name."""
    (commands,) = (action for action in parser._actions if isinstance(action, argparse._SubParsersAction))
    return dict(commands.choices)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Runs the command line with ``argv`` (default: ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    from chaincart_env.errors import InvalidInputError, MissingExtraError
    from chaincart_env.extras import command_needs, require

    try:
        # A tool's command may say what it needs itself (``needs`` in its defaults).
        needs = getattr(args, "needs", None)
        require(args.command, needs(args) if needs is not None else command_needs(args.command, args))
    except MissingExtraError as error:
        print(f"{parser.prog} {args.command}: error: {error}", file=sys.stderr)
        return 1
    if getattr(args, "handler", None) is not None:
        return int(args.handler(args, parser))
    try:
        return _run_builtin(args, subcommand_parsers(parser)["bench"])
    except InvalidInputError as error:  # a bad scene, count, ...: one line, exit status 2
        print(f"{parser.prog} {args.command}: error: {error}", file=sys.stderr)
        return 2


def _run_builtin(args: argparse.Namespace, bench: argparse.ArgumentParser) -> int:
    from chaincart_env.errors import InvalidInputError

    if args.command in ("demo", "soak"):
        least = 0 if args.command == "demo" else 1
        for name in ("steps", "num_envs"):
            value = getattr(args, name, None)
            if value is not None and value < least:
                raise InvalidInputError(f"--{name.replace('_', '-')} {value}: expected an integer >= {least}")
    if args.command == "soak":
        from chaincart_env.tools.soak import main as soak_main

        return soak_main(args.steps, args.num_envs, args.seed, args.scene)
    if args.command == "demo":
        from chaincart_env.tools.demo import run_demo

        return run_demo(scene=args.scene, policy=args.policy, seed=args.seed, max_steps=args.steps)
    from chaincart_env.tools.bench.bench_cli import run_from_args

    return run_from_args(args, bench)


if __name__ == "__main__":
    sys.exit(main())
