"""Render section: frames per second of the software renderer (``_core.render_frame``)
at 480x240 and 960x480 for the paper's 5-link system, side view alone and with the top
view; plus the env-level report of :func:`~chaincart_env.tools.bench.render_benchmark.render_benchmark`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from chaincart_env import _core
from chaincart_env.tools.bench.render_benchmark import render_benchmark
from chaincart_env.tools.bench.context import BenchContext
from chaincart_env.tools.bench.timing import rate

__all__ = ["render_section", "SIZES"]

#: (width, height) in pixels.
SIZES = ((480, 240), (960, 480))


def _renderer_report(ctx: BenchContext) -> None:
    result: Any = render_benchmark()
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
    rows, fps = [], {}
    for width, height in SIZES:
        for top_view in (False, True):
            def frame() -> np.ndarray:
                return _core.render_frame(lengths, state, [3.0, -1.0], target=signs, max_force=10.0, track_limit=1.0,
                                          width=width, height=height, top_view=top_view)  # fmt: skip

            r = rate(frame, ctx.settings.min_time, ctx.settings.repeats)
            fps[(width, height, top_view)] = r
            rows.append([f"{width}x{height}", "side + top" if top_view else "side", f"{r:.0f}", f"{1e3 / r:.2f}"])
    ctx.results["render_fps"] = fps
    ctx.report.paragraph("`_core.render_frame` from Python (one call per frame, uint8 RGB array returned), paper Fig. 3 state.")
    ctx.report.table(["size (w x h)", "views", "frames/s", "ms/frame"], rows, 2)
    _renderer_report(ctx)
