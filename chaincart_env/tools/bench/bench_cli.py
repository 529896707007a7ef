"""Options of ``python -m chaincart_env bench`` and their handling."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from chaincart_env.tools.bench.context import BenchSettings
from chaincart_env.tools.bench.suite import SECTION_ORDER, parse_sections, run_suite

__all__ = ["add_bench_arguments", "run_from_args"]


def _int_list(name: str, text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(s) for s in text.split(",") if s.strip())
    except ValueError:
        values = ()
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"{name} {text!r}: expected comma-separated integers >= 1, e.g. 1,16,256")
    return values


def add_bench_arguments(bench: argparse.ArgumentParser) -> None:
    """Adds the options of the ``bench`` command to its parser."""
    bench.add_argument("--quick", action="store_true", help="short timings and fewer points (a smoke run, noisy numbers)")
    bench.add_argument("--sections", default="all",
                       help=f"comma-separated subset of {','.join(SECTION_ORDER)} (default: all)")  # fmt: skip
    bench.add_argument("--sizes", default="1,16,256,4096", type=lambda s: _int_list("--sizes", s),
                       help="vector sizes N (default: 1,16,256,4096)")  # fmt: skip
    bench.add_argument("--links", default="1,2,5,10", type=lambda s: _int_list("--links", s),
                       help="numbers of links n for the throughput section (default: 1,2,5,10)")  # fmt: skip
    bench.add_argument("--out", type=Path, default=None, help="directory for the PNG plots (default: no plots)")
    bench.add_argument("--markdown", type=Path, default=None, help="also write the report as the docs' performance page (docs/performance.md) to this file")
    bench.add_argument("--note", default="", help="free text added to the machine line (e.g. the load during the run)")


def run_from_args(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """Runs the ``bench`` command with parsed ``args``; returns the exit status."""
    try:
        sections = parse_sections(args.sections)
    except ValueError as exc:
        parser.error(str(exc))
    settings = BenchSettings(quick=args.quick, sizes=args.sizes, links=args.links, out_dir=args.out, note=args.note)
    command = "python -m chaincart_env " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    run_suite(settings, sections, args.markdown, command=command)
    return 0
