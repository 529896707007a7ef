"""A filmstrip PNG: one row of frames per policy, at the same times of the same
seeded start, drawn by the core's renderer (``_core.render_frame``) in the 3-D view
with a camera that follows the cart, so that the chain fills most of each frame.

The frames are spread over what happens, not over the clock: frame k is at the first
step by which the shown episodes have made, on average, ``k / (frames - 1)`` of
:data:`MOTION_SHOWN` of their motion (the path their link directions travel; the
camera follows the cart, so the cart's own travel shows little). So the frames crowd
where the chain moves fast (a stabilised start's first second, a swing-up's swing)
and the last shows where it came to rest. A stabilised start settles within seconds
and holds still for the rest of the episode, a swing-up holds the target after its
swing: frames evenly spaced over the whole episode would show that stillness, one
identical frame after another."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from PIL import Image, ImageDraw

from chaincart_env import _core
from chaincart_env.config import ChainCartConfig
from chaincart_env.tools.compare.evaluation import Rollouts

__all__ = [
    "DEFAULT_FRAMES", "FRAME_SIZE", "LABEL_HEIGHT", "MOTION_SHOWN", "filmstrip", "filmstrip_size", "frame_steps",
    "motion", "write_filmstrip",
]  # fmt: skip

#: (width, height) of one frame in pixels: upright, like the chain it shows.
FRAME_SIZE = (240, 300)
#: Frames per policy unless asked otherwise.
DEFAULT_FRAMES = 6
#: Height of the caption band above each frame.
LABEL_HEIGHT = 18
#: The share of the episodes' motion the frames span (the rest is the slowest settling).
MOTION_SHOWN = 0.99


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


def motion(states: np.ndarray) -> np.ndarray:
    """The path travelled by the link directions of a spatial state sequence up to each
    state: shape ``(len(states),)``, 0 at the start."""
    states = np.asarray(states, dtype=np.float64)
    n = (states.shape[1] - 4) // 6
    steps = np.linalg.norm(np.diff(states[:, 4 : 4 + 3 * n], axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def frame_steps(runs: Sequence[Rollouts], frames: int = DEFAULT_FRAMES) -> np.ndarray:
    """The steps shown (module docstring): increasing, from 0; evenly spaced over the
    longest episode where no episode moves at all."""
    longest = max(int(run.lengths[0]) for run in runs)
    progress = np.zeros(longest + 1)
    moved = False
    for run in runs:
        path = motion(run.first_states[: int(run.lengths[0]) + 1])
        share = path / path[-1] if path[-1] > 0.0 else np.ones_like(path)
        moved |= bool(path[-1] > 0.0)
        # An episode that ended earlier has made all its motion.
        progress += np.concatenate([share, np.ones(longest + 1 - share.size)]) / len(runs)
    if not moved:
        return np.linspace(0, longest, frames).round().astype(int)
    steps = np.searchsorted(progress, np.linspace(0.0, MOTION_SHOWN, frames))
    for k in range(1, frames):  # one step at least between frames
        steps[k] = max(steps[k], steps[k - 1] + 1)
    return np.minimum(steps, longest).astype(int)


def filmstrip(runs: Sequence[Rollouts], config: ChainCartConfig, frames: int = DEFAULT_FRAMES) -> np.ndarray:
    """uint8 image (H, W, 3): row r shows ``runs[r]``'s first episode at the same
    ``frames`` steps (:func:`frame_steps`; an episode that ended earlier shows its last
    state)."""
    steps = frame_steps(runs, frames)
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
