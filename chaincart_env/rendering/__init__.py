"""Seeing the chain: RGB frames drawn by the Rust rasteriser, tiles of several envs,
and a live window for ``render_mode="human"``. (The render benchmark is a tool:
:mod:`chaincart_env.tools.bench.render_benchmark`.)

* :class:`ChainRenderer`: frames of one config's chain (side view, top view for
  spatial scenes, target, force arrow, track).
* :func:`tile_frames`: frames in a grid (vector envs).
* :class:`HumanWindow`, :class:`RenderUnavailable`: the human-mode window and why
  none can open (turned into a warning once per process: the env keeps working).
"""

from __future__ import annotations

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
    "tile_frames",
    "tile_grid",
]
