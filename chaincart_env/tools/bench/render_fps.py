"""Render section: frames per second of the software renderer (``_core.render_frame``)
for the paper's 5-link system in each view (the 3-D view at 480x480, the speed goal
of at least 2,000 frames/s on one core; the flat views at 480x240 and 960x480); plus the env-level report of
:func:`~chaincart_env.tools.bench.render_benchmark.render_benchmark`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from chaincart_env import _core
from chaincart_env.tools.bench.context import BenchContext
from chaincart_env.tools.bench.render_benchmark import render_benchmark
from chaincart_env.tools.bench.timing import rate

__all__ = ["render_section", "CASES", "GOAL_3D_FPS"]

#: (view, width, height) measured.
CASES = (("3d", 480, 480), ("3d", 960, 720), ("side", 480, 240), ("side+top", 480, 240), ("side+top", 960, 480))
#: Frames per second the 3-D view is to reach at 480x480 on one core for 5 links.
GOAL_3D_FPS = 2000


#: Seconds each env-level render measurement runs (``--quick``: a smoke run).
ENV_SECONDS, QUICK_ENV_SECONDS = 0.5, 0.02


def _renderer_report(ctx: BenchContext) -> None:
    result: Any = render_benchmark(seconds=QUICK_ENV_SECONDS if ctx.settings.quick else ENV_SECONDS)
    ctx.report.paragraph("`chaincart_env.tools.bench.render_benchmark.render_benchmark()`:")
    rows = [result] if isinstance(result, Mapping) else list(result) if isinstance(result, Sequence) else []
    if rows and all(isinstance(r, Mapping) for r in rows):
        keys = list(dict.fromkeys(k for r in rows for k in r))
        ctx.report.table(keys, [[_cell(r.get(k, "")) for k in keys] for r in rows], len(keys))
    else:
        ctx.report.paragraph(str(result))


def _cell(value: Any) -> str:
    return f"{value:.3g}" if isinstance(value, float) else str(value)


def render_section(ctx: BenchContext) -> None:
    """The render section: frames per second of the software renderer by frame size and view, then
    the env-level render benchmark."""
    ctx.report.heading("Render frames per second")
    state = _core.paper_initial_condition("paper-fig3")
    lengths = [0.1] * 5
    signs = [-1.0, -1.0, -1.0, 1.0, 1.0]
    # A tip trail of one second at 1 ms steps, every 20th kept: what an animation draws.
    trail = np.column_stack([0.2 * np.cos(np.linspace(0, 3, 50)), 0.2 * np.sin(np.linspace(0, 3, 50)), np.full(50, -0.3)])
    rows, fps = [], {}
    for view, width, height in CASES:
        def frame() -> np.ndarray:
            return _core.render_frame(lengths, state, [3.0, -1.0], target=signs, max_force=10.0, track_limit=10.0,
                                      width=width, height=height, view=view, trail=trail)  # fmt: skip

        r = rate(frame, ctx.settings.min_time, ctx.settings.repeats)
        fps[(view, width, height)] = r
        goal = f">= {GOAL_3D_FPS}: {'met' if r >= GOAL_3D_FPS else 'NOT met'}" if (view, width, height) == ("3d", 480, 480) else ""
        rows.append([view, f"{width}x{height}", f"{r:.0f}", f"{1e3 / r:.3f}", goal])
    ctx.results["render_fps"] = fps
    ctx.report.paragraph(
        "`_core.render_frame` from Python on one core (one call per frame, a fresh uint8 RGB array returned), "
        "the paper's 5-link chain at its Fig. 3 start with the target ghost, a force arrow and, in the 3-D "
        "view, a 50-point tip trail; the camera follows the cart (track 10 m)."
    )
    ctx.report.table(["view", "size (w x h)", "frames/s", "ms/frame", "goal"], rows, 2)
    _renderer_report(ctx)
