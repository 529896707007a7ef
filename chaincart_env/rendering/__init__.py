"""Seeing the chain: RGB frames drawn by the Rust rasteriser, tiles of several envs,
a live window for ``render_mode="human"``, and the render benchmark.

* :class:`ChainRenderer`: frames of one config's chain in its view (the lit 3-D
  view seen by a :class:`Camera`, or the flat side and top views): target, force
  arrow, track, the tip's trail (:class:`TipTrail`).
* :func:`tile_frames`: frames in a grid (vector envs).
* :class:`HumanWindow`, :class:`RenderUnavailable`: the human-mode window and why
  none can open (turned into a warning once per process: the env keeps working).
* :func:`render_benchmark` (imported on first use): frames per second by frame size.
"""

from __future__ import annotations

from typing import Any

from chaincart_env.rendering.camera import Camera, TipTrail
from chaincart_env.rendering.env_rendering import EnvRendering, check_shown_envs
from chaincart_env.rendering.frames import (
    DEFAULT_3D_FRAME_SIZE,
    DEFAULT_FRAME_SIZE,
    RENDER_MODES,
    RENDER_VIEWS,
    VECTOR_RENDER_MODES,
    ChainRenderer,
    check_frame_size,
    check_render_mode,
    default_frame_size,
    tile_frames,
    tile_grid,
)
from chaincart_env.rendering.window import HumanWindow, RenderUnavailable, check_display

__all__ = [
    "DEFAULT_3D_FRAME_SIZE",
    "DEFAULT_FRAME_SIZE",
    "RENDER_MODES",
    "RENDER_VIEWS",
    "VECTOR_RENDER_MODES",
    "Camera",
    "ChainRenderer",
    "EnvRendering",
    "HumanWindow",
    "RenderUnavailable",
    "check_display",
    "check_frame_size",
    "check_render_mode",
    "check_shown_envs",
    "default_frame_size",
    "render_benchmark",
    "tile_frames",
    "tile_grid",
    "TipTrail",
]


def __getattr__(name: str) -> Any:
    # The benchmark builds envs, and the env modules import this package.
    if name == "render_benchmark":
        from chaincart_env.rendering.benchmark import render_benchmark

        return render_benchmark
    raise AttributeError(f"module 'chaincart_env.rendering' has no attribute {name!r}")
