"""The rendering part of an env: render mode, frame size and camera, the forces last
applied (each frame shows them), the tips' trails and, in human mode, the window.
Shared by the single env, the native vector env and the SB3 VecEnv."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Optional, cast

import numpy as np
import numpy.typing as npt

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError, InvalidTypeError
from chaincart_env.rendering.frames import (
    RENDER_MODES,
    ChainRenderer,
    check_render_mode,
    render_fps,
    steps_per_frame,
    tile_frames,
)
from chaincart_env.rendering.window import HumanWindow

__all__ = ["EnvRendering", "check_shown_envs"]


def check_shown_envs(render_envs: Any, num_envs: int) -> int:
    """How many envs a vector env draws: ``render_envs`` (an integer in [1,
    num_envs]) or, for ``None``, ``min(num_envs, 4)``."""
    if render_envs is None:
        return min(num_envs, 4)
    wrong_type = isinstance(render_envs, bool) or not isinstance(render_envs, (int, np.integer))
    if wrong_type or not 1 <= render_envs <= num_envs:
        raise (InvalidTypeError if wrong_type else InvalidInputError)(f"render_envs = {render_envs!r}: expected an integer in [1, num_envs = {num_envs}]")
    return int(render_envs)


class EnvRendering:
    """Frames of the first ``shown`` envs of a batch, each with the force its env last
    applied and, with ``trail`` seconds > 0, its tip's recent path (both remembered
    for the first ``tracked`` envs, default ``shown``), seen by ``camera`` in the 3-D
    view.
    ``render(states)`` returns the frame (``tiled=False``, one env) or the grid of
    frames (:func:`tile_frames`) in ``rgb_array`` mode, shows it in ``human`` mode, and
    does nothing without a render mode. ``fps`` is the config's :func:`render_fps`;
    human mode shows every :func:`steps_per_frame`-th step (real time)."""

    def __init__(
        self,
        render_mode: Optional[str],
        config: ChainCartConfig,
        width: Optional[int],
        height: Optional[int],
        *,
        shown: int = 1,
        tiled: bool = False,
        tracked: Optional[int] = None,
        modes: Sequence[str] = RENDER_MODES,
        camera: Any = None,
        trail: float = 0.0,
        targets: Optional[Callable[[], np.ndarray]] = None,
    ) -> None:
        self.mode = check_render_mode(render_mode, modes)
        # Goal-conditioned envs: each env's episode target for its ghost (one row per env).
        self._targets = targets
        # Validates the size, camera and trail in every mode.
        self.renderer = ChainRenderer(config, width, height, camera, trail)
        self.shown = shown
        self.tiled = tiled
        # Forces are remembered only where frames are drawn from them.
        rows = shown if tracked is None or self.mode is None else max(tracked, shown)
        self.forces = np.zeros((rows, config.force_dim))
        # Trails only where frames are drawn and a trail is asked for.
        keeps_trails = self.mode is not None and self.renderer.trail_length > 0
        self.trails = [self.renderer.new_trail() for _ in range(rows)] if keeps_trails else []
        self._max_force = float(config.max_force)
        self.fps = render_fps(config.dt)
        self._stride = steps_per_frame(config.dt)
        self._steps = 0
        title = f"chaincart: {config.scene}" + (f" ({shown} envs)" if tiled else "")
        self.window = HumanWindow(self.fps, title) if self.mode == "human" else None

    @property
    def frame_shape(self) -> tuple[int, int, int]:
        """Shape of one env's frame, ``(height, width, 3)``."""
        return (self.renderer.height, self.renderer.width, 3)

    def record_forces(self, actions: npt.ArrayLike, fresh: Optional[np.ndarray] = None) -> None:
        """Remembers the forces (N) of normalised ``actions`` (one row per env, already
        accepted by the core), clipped as the core clips them; envs flagged ``fresh``
        (reset by this step, so their action was not applied) show none."""
        if self.mode is None:
            return
        tracked = len(self.forces)
        a = np.asarray(actions, dtype=np.float64).reshape(-1, self.forces.shape[1])[:tracked]
        self.forces[:] = np.clip(a, -1.0, 1.0) * self._max_force
        if fresh is not None:
            self.forces[np.asarray(fresh[:tracked], dtype=bool)] = 0.0

    def record_tips(self, states: Callable[[], np.ndarray], fresh: Optional[np.ndarray] = None) -> None:
        """Adds each tracked env's tip to its trail, reading ``states()`` (the batch's
        states) only when trails are kept; envs flagged ``fresh`` (just reset) start
        a new trail."""
        if not self.trails:
            return
        y = states()
        for i, trail in enumerate(self.trails):
            if fresh is not None and fresh[i]:
                trail.clear()
            trail.add(self.renderer.tip(y[i]))

    def human_frame_due(self, reset: bool = False) -> bool:
        """Whether human mode shows a frame now: after every reset and every
        ``steps_per_frame``-th step since."""
        if self.mode != "human":
            return False
        self._steps = 0 if reset else self._steps + 1
        return self._steps % self._stride == 0

    def clear_forces(self, mask: Optional[np.ndarray] = None) -> None:
        """No force and no trail shown for the envs in ``mask`` (all envs: ``None``),
        after a reset."""
        if mask is None:
            self.forces[:] = 0.0
        else:
            self.forces[np.asarray(mask[: len(self.forces)], dtype=bool)] = 0.0
        for i, trail in enumerate(self.trails):
            if mask is None or mask[i]:
                trail.clear()

    def frames(self, states: Sequence[np.ndarray] | np.ndarray, first: int = 0) -> list[np.ndarray]:
        """Frames of the states (model layout) of envs ``first, first + 1, ...``, each
        with its env's last force."""
        if first + len(states) > len(self.forces):
            raise InvalidInputError(
                f"states of envs {first}..{first + len(states) - 1} to draw: forces are tracked for "
                f"envs 0..{len(self.forces) - 1} only"
            )
        trails = cast(Sequence[Any], self.trails[first:] if self.trails else [None] * len(states))
        targets = cast(Sequence[Any], self._targets()[first:] if self._targets is not None else [None] * len(states))
        return [
            self.renderer.frame(y, f, t, g) for y, f, t, g in zip(states, self.forces[first:], trails, targets)
        ]

    def image(self, states: Sequence[np.ndarray] | np.ndarray) -> np.ndarray:
        """The frame of the first env (``tiled=False``) or the grid of the first
        ``shown`` envs' frames."""
        frames = self.frames(states[: self.shown])
        return tile_frames(frames) if self.tiled else frames[0]

    def render(self, states: Sequence[np.ndarray] | np.ndarray) -> Optional[np.ndarray]:
        """What ``render()`` returns for ``states``: the frame (or tiled frames), ``None``
        without a render mode or in human mode (which shows it in the window)."""
        if self.mode is None:
            return None
        image = self.image(states)
        if self.window is not None:
            self.window.show(image)
            return None
        return image

    def close(self) -> None:
        """Closes the human-mode window, if one is open."""
        if self.window is not None:
            self.window.close()
