"""Seeing the chain: RGB frames drawn by the Rust rasteriser, tiles of several envs,
and a live window for ``render_mode="human"``. (The render benchmark is a tool:
:mod:`chaincart_env.tools.bench.render_benchmark`.)

* :class:`ChainRenderer`: frames of one config's chain in its view (the lit 3-D
  view seen by a :class:`Camera`, or the flat side and top views): target, force
  arrow, track, the tip's trail (:class:`TipTrail`).
* :func:`tile_frames`: frames in a grid (vector envs).
* :class:`HumanWindow`, :class:`RenderUnavailable`: the human-mode window and why
  none can open (turned into a warning once per process: the env keeps working).
"""

from __future__ import annotations

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
    "tile_frames",
    "tile_grid",
    "TipTrail",
]
