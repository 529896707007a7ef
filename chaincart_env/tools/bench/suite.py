"""The benchmark suite behind ``python -m chaincart_env bench``: the section registry
and the run (the settings and the context the sections write into are in
:mod:`chaincart_env.tools.bench.context`, which the sections import).

Each section is a function ``section(ctx)`` that measures, appends Markdown to
``ctx.report``, saves its PNG plots under ``ctx.settings.out_dir`` and leaves the
numbers other sections need (the targets summary, the Pareto plot) in ``ctx.results``.
Sections run in the order of :data:`SECTION_ORDER` whatever order they were asked in.
"""

from __future__ import annotations

import datetime
import os
import platform
import time
from pathlib import Path
from typing import Callable, Optional, Sequence

import gymnasium as gym
import numpy as np

from chaincart_env import _core
from chaincart_env.tools.bench.bench_report import Report
from chaincart_env.tools.bench.context import BenchContext, BenchSettings, mujoco_available

__all__ = ["SECTION_ORDER", "HAND_WRITTEN", "parse_sections", "run_suite", "performance_page", "hand_written_sections"]

#: Sections in the order they run (``--sections`` picks a subset).
SECTION_ORDER = (
    "throughput", "mujoco", "accuracy", "scaling", "render", "control", "rllib", "learners", "cells", "criterion",
    "targets",
)

#: The end of a level-2 heading of the performance page whose section is written by hand
#: (measurements the suite does not take): writing the page again keeps such sections.
HAND_WRITTEN = "(hand-written, not generated)"


def parse_sections(text: str) -> list[str]:
    """``"throughput,mujoco"`` (or ``"all"``) -> the sections in running order."""
    asked = [s.strip() for s in text.split(",") if s.strip()]
    if asked == ["all"]:
        return list(SECTION_ORDER)
    unknown = [s for s in asked if s not in SECTION_ORDER]
    if unknown or not asked:
        raise ValueError(f"sections {text!r}: expected a comma-separated subset of {', '.join(SECTION_ORDER)} or 'all'")
    return [s for s in SECTION_ORDER if s in asked]


def _machine_line(settings: BenchSettings) -> str:
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    versions = f"Python {platform.python_version()}, numpy {np.__version__}, gymnasium {gym.__version__}"
    if mujoco_available():
        import mujoco

        versions += f", mujoco {mujoco.__version__}"
    return (
        f"{datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}; {platform.machine()} "
        f"({platform.processor() or 'cpu'}), {os.cpu_count()} logical CPUs, rayon threads {_core.num_threads()}, "
        f"1-min load average at start {load:.2f}; {versions}. "
        f"Each number is the best of {settings.repeats} timed run(s) of >= {settings.min_time} s: "
        "on a loaded machine the least disturbed run is the best estimate, and still a lower bound."
    )


def _sections() -> dict[str, Callable[[BenchContext], None]]:
    # Imported here so that `--sections scaling` does not import SB3/torch, etc.
    from chaincart_env.tools.bench import (
        accuracy,
        control,
        criterion,
        envs,
        learners,
        mujoco_compare,
        render_fps,
        rllib_sampling,
        scaling,
        study_cells,
        targets,
    )  # fmt: skip

    return {
        "throughput": envs.throughput_section,
        "mujoco": mujoco_compare.mujoco_section,
        "accuracy": accuracy.accuracy_section,
        "scaling": scaling.scaling_section,
        "render": render_fps.render_section,
        "control": control.control_section,
        "rllib": rllib_sampling.rllib_section,
        "learners": learners.learners_section,
        "cells": study_cells.cells_section,
        "criterion": criterion.criterion_section,
        "targets": targets.targets_section,
    }


def run_suite(
    settings: BenchSettings,
    sections: Sequence[str],
    markdown_file: Optional[Path] = None,
    echo: bool = True,
    command: str = "python -m chaincart_env bench",
) -> BenchContext:
    """Runs ``sections``; prints their Markdown (and writes it to ``markdown_file`` as
    the performance page of the docs, see :func:`performance_page`)."""
    ctx = BenchContext(settings, Report(echo=echo))
    title = "chaincart benchmark" + (" (--quick: a smoke run, numbers are noisy)" if settings.quick else "")
    ctx.report.heading(title, depth=-1)
    ctx.report.paragraph(_machine_line(settings) + (f" {settings.note}" if settings.note else ""))
    registry = _sections()
    start, took = time.perf_counter(), []
    for name in sections:
        section_start = time.perf_counter()
        registry[name](ctx)
        took.append(f"{name} {time.perf_counter() - section_start:.0f} s")
    if ctx.plots:
        ctx.report.paragraph("Plots: " + ", ".join(f"`{p}`" for p in ctx.plots) + ".")
    ctx.report.paragraph(f"Benchmark wall time: {time.perf_counter() - start:.0f} s ({', '.join(took)}).")
    if markdown_file is not None:
        kept = hand_written_sections(markdown_file.read_text()) if markdown_file.exists() else ""
        markdown_file.parent.mkdir(parents=True, exist_ok=True)
        markdown_file.write_text(performance_page(ctx.report.text(), command, kept))
    return ctx


def performance_page(report: str, command: str, hand_written: str = "") -> str:
    """The report as the docs' performance page (``docs/performance.md``): the title
    becomes ``# Performance`` with a line saying how it was made; the other headings keep
    their level; the ``hand_written`` sections (see :func:`hand_written_sections`) follow."""
    lines = report.splitlines()
    out = ["# Performance", "", f"Generated by `{command}` (numbers from one run; rerun it to check them).", ""]
    out.extend(lines[1:])
    page = "\n".join(out).rstrip() + "\n"
    return page + ("\n" + hand_written.strip() + "\n" if hand_written.strip() else "")


def hand_written_sections(page: str) -> str:
    """The sections of ``page`` whose level-2 heading ends with :data:`HAND_WRITTEN`,
    each up to the next level-2 heading, in their order (headings inside code blocks
    do not count)."""
    kept: list[str] = []
    keeping = in_code = False
    for line in page.splitlines():
        if line.startswith("```"):
            in_code = not in_code
        elif not in_code and line.startswith("## "):
            keeping = line.rstrip().endswith(HAND_WRITTEN)
        if keeping:
            kept.append(line)
    return "\n".join(kept).strip()
