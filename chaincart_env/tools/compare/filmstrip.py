"""A filmstrip PNG: one row of frames per policy, at the same times of the same
seeded start, drawn by the core's renderer (``_core.render_frame``) in the 3-D view
with a camera that follows the cart, so that the chain fills most of each frame."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from PIL import Image, ImageDraw

from chaincart_env import _core
from chaincart_env.tools.compare.evaluation import Rollouts
from chaincart_env.config import ChainCartConfig

__all__ = ["DEFAULT_FRAMES", "FRAME_SIZE", "LABEL_HEIGHT", "filmstrip", "filmstrip_size", "write_filmstrip"]

#: (width, height) of one frame in pixels: upright, like the chain it shows.
FRAME_SIZE = (240, 300)
#: Frames per policy unless asked otherwise.
DEFAULT_FRAMES = 6
#: Height of the caption band above each frame.
LABEL_HEIGHT = 18


def filmstrip_size(policies: int, frames: int) -> tuple[int, int]:
    """(width, height) in pixels of a filmstrip."""
    return frames * FRAME_SIZE[0], policies * (FRAME_SIZE[1] + LABEL_HEIGHT)


def _frame(config: ChainCartConfig, state: np.ndarray, force: np.ndarray) -> np.ndarray:
    return _core.render_frame(
        list(config.make_model().link_lengths), state, list(force),
        target=list(config.target_signs), max_force=max(config.max_force, 1e-9),
        track_limit=config.track_limit, width=FRAME_SIZE[0], height=FRAME_SIZE[1], view="3d",
        planar=config.planar, follow=True,
    )


def filmstrip(runs: Sequence[Rollouts], config: ChainCartConfig, frames: int = DEFAULT_FRAMES) -> np.ndarray:
    """uint8 image (H, W, 3): row r shows ``runs[r]``'s first episode at ``frames``
    evenly spaced steps of the longest of these episodes (an episode that ended
    earlier shows its last state)."""
    longest = max(int(run.lengths[0]) for run in runs)
    steps = np.linspace(0, longest, frames).round().astype(int)
    width, height = filmstrip_size(len(runs), frames)
    image = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(image)
    for r, run in enumerate(runs):
        top = r * (FRAME_SIZE[1] + LABEL_HEIGHT)
        for c, step in enumerate(steps):
            k = min(int(step), run.first_states.shape[0] - 1)
            force = run.first_forces[k] if k < run.first_forces.shape[0] else np.zeros(2)
            frame = _frame(config, run.first_states[k], force)
            image.paste(Image.fromarray(frame), (c * FRAME_SIZE[0], top + LABEL_HEIGHT))
            draw.text((c * FRAME_SIZE[0] + 4, top + 3), f"{run.policy}  t = {k * run.dt:.2f} s", fill="black")
    return np.asarray(image)


def write_filmstrip(
    path: Path, runs: Sequence[Rollouts], config: ChainCartConfig, frames: int = DEFAULT_FRAMES
) -> None:
    """Writes :func:`filmstrip` as a PNG."""
    Image.fromarray(filmstrip(runs, config, frames)).save(path)
