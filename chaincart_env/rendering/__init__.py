"""Seeing the chain: RGB frames drawn by the Rust rasteriser, tiles of several envs,
a live window for ``render_mode="human"``, and the render benchmark.

* :class:`ChainRenderer`: frames of one config's chain (side view, top view for
  spatial scenes, target, force arrow, track).
* :func:`tile_frames`: frames in a grid (vector envs).
* :class:`HumanWindow`, :class:`RenderUnavailable`: the human-mode window and why
  none can open (turned into a warning once per process: the env keeps working).
* :func:`render_benchmark` (imported on first use): frames per second by frame size.
"""

from __future__ import annotations

from typing import Any

from chaincart_env.rendering.env_rendering import EnvRendering, check_shown_envs
from chaincart_env.rendering.frames import (
    DEFAULT_FRAME_SIZE,
    RENDER_MODES,
    VECTOR_RENDER_MODES,
    ChainRenderer,
    check_frame_size,
    check_render_mode,
    tile_frames,
    tile_grid,
)
from chaincart_env.rendering.window import HumanWindow, RenderUnavailable, check_display

__all__ = [
    "DEFAULT_FRAME_SIZE",
    "RENDER_MODES",
    "VECTOR_RENDER_MODES",
    "ChainRenderer",
    "EnvRendering",
    "HumanWindow",
    "RenderUnavailable",
    "check_display",
    "check_frame_size",
    "check_render_mode",
    "check_shown_envs",
    "render_benchmark",
    "tile_frames",
    "tile_grid",
]


def __getattr__(name: str) -> Any:
    # The benchmark builds envs, and the env modules import this package.
    if name == "render_benchmark":
        from chaincart_env.rendering.benchmark import render_benchmark

        return render_benchmark
    raise AttributeError(f"module 'chaincart_env.rendering' has no attribute {name!r}")
