"""Command line of the control-theory tools: ``figures`` (the paper's Figs. 1-3 as
PNG panels with a summary table) and ``roa`` (the LQR baseline's region of attraction).
Registered as subcommands of ``python -m chaincart_env``; matplotlib loads only when a
command runs.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from chaincart_env.cli_text import scene_help

__all__ = ["add_commands"]

_ROA_SIZES = "0.025,0.05,0.1,0.2,0.3,0.4,0.6,0.8,1.0"


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected an integer >= 1") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value}: expected an integer >= 1")
    return value


def _sizes(text: str) -> list[float]:
    sizes = []
    for part in (p.strip() for p in text.split(",")):
        try:
            size = float(part)
        except ValueError:
            raise argparse.ArgumentTypeError(f"start noise {part!r}: expected a number >= 0") from None
        if not (math.isfinite(size) and size >= 0):
            raise argparse.ArgumentTypeError(f"start noise {part!r}: expected a finite number >= 0")
        sizes.append(size)
    return sizes


def _figures(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from chaincart_env.tools.figures import run_figures

    figures = (1, 2, 3) if args.figure == "all" else (int(args.figure),)
    run_figures(args.out, figures)
    return 0


def _roa(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from chaincart_env.errors import InvalidInputError
    from chaincart_env.tools.roa_cli import run_roa

    try:
        run_roa(args.out, scene=args.scene, sizes=args.sizes, starts=args.starts, seed=args.seed, start=args.start)
    except InvalidInputError as error:  # a bad scene or start: one line, exit status 2
        print(f"{parser.prog} roa: error: {error}", file=sys.stderr)
        return 2
    return 0


def add_commands(commands: Any) -> None:
    """Adds ``figures`` and ``roa`` to an argparse subparsers object."""
    figures = commands.add_parser(
        "figures", help="the paper's Figs. 1-3 (PNG panels) and their numbers (peak force, settle time, ...)"
    )
    figures.add_argument("--out", type=Path, default=Path("figures"), help="output folder (default: figures)")
    figures.add_argument("--figure", choices=("1", "2", "3", "all"), default="all", help="which figure (default: all)")
    figures.set_defaults(handler=_figures)

    roa = commands.add_parser(
        "roa", help="fraction of random starts the LQR baseline stabilises vs start noise (table, CSV, PNG)"
    )
    roa.add_argument("--scene", default=None, help=scene_help())
    roa.add_argument("--sizes", type=_sizes, default=_sizes(_ROA_SIZES),
                     help=f"comma-separated start noises (default: {_ROA_SIZES})")  # fmt: skip
    roa.add_argument("--starts", type=_positive_int, default=200, help="seeded starts per noise (default: 200)")
    roa.add_argument("--seed", type=int, default=0, help="start i is seeded seed + i (default: 0)")
    roa.add_argument("--start", default=None,
                     help="override the scene's start (e.g. 'target' for perturbations of the target)")  # fmt: skip
    roa.add_argument("--out", type=Path, default=Path("roa"), help="output folder (default: roa)")
    roa.set_defaults(handler=_roa)
