"""RGB frames of chain states: one env's picture (:class:`ChainRenderer`, drawn by the
Rust rasteriser ``chaincart_env._core.render_frame``: the 3-D view or the flat side
and top views) and a grid of several (:func:`tile_frames`)."""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any, Optional

import numpy as np
import numpy.typing as npt

from chaincart_env import _core
from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError, InvalidTypeError
from chaincart_env.rendering.camera import Camera, TipTrail, trail_length

__all__ = [
    "RENDER_MODES",
    "VECTOR_RENDER_MODES",
    "DEFAULT_FRAME_SIZE",
    "DEFAULT_3D_FRAME_SIZE",
    "RENDER_VIEWS",
    "default_frame_size",
    "MIN_FRAME_SIZE",
    "MAX_FRAME_SIZE",
    "ChainRenderer",
    "MAX_RENDER_FPS",
    "check_render_mode",
    "render_fps",
    "steps_per_frame",
    "check_frame_size",
    "tile_frames",
    "tile_grid",
]

#: The render modes every chaincart env accepts (besides ``None``).
RENDER_MODES = ("rgb_array", "human")
#: The native vector env's render modes: also ``rgb_array_list`` (every frame since
#: the last ``render()``), which single envs get from ``gymnasium.make``.
VECTOR_RENDER_MODES = ("rgb_array", "rgb_array_list", "human")
#: ``(width, height)`` of one env's frame of the flat views unless configured.
DEFAULT_FRAME_SIZE = (480, 240)
#: ``(width, height)`` of one env's frame of the 3-D view unless configured.
DEFAULT_3D_FRAME_SIZE = (480, 360)
#: The pictures a frame can show (the ``render_view`` key's values).
RENDER_VIEWS: tuple[str, ...] = tuple(_core.RENDER_VIEWS)
#: Bounds on either side of a frame, as the Rust renderer defines and enforces them.
MIN_FRAME_SIZE, MAX_FRAME_SIZE = _core.MIN_FRAME_SIZE, _core.MAX_FRAME_SIZE
#: Grey level of the lines between tiles (the frames' background is 250).
TILE_GAP_GREY = 120
#: Highest ``render_fps``: scenes whose control period is shorter (the paper's
#: scenes step at 1 ms or 0.1 ms) show one frame per several steps in human mode.
MAX_RENDER_FPS = 50


def render_fps(dt: float) -> int:
    """``metadata["render_fps"]`` of a scene with control period ``dt``: real time,
    ``round(1 / dt)``, capped at :data:`MAX_RENDER_FPS`."""
    return max(1, min(MAX_RENDER_FPS, round(1.0 / dt)))


def steps_per_frame(dt: float) -> int:
    """Env steps per frame at :func:`render_fps` for real-time playback (1 unless
    ``dt`` is shorter than ``1 / MAX_RENDER_FPS``)."""
    return max(1, round(1.0 / (dt * render_fps(dt))))


def check_render_mode(render_mode: Any, modes: Sequence[str] = RENDER_MODES) -> Optional[str]:
    """``render_mode`` itself if it is ``None`` or one of ``modes``."""
    if render_mode is None or (isinstance(render_mode, str) and render_mode in modes):
        return render_mode
    raise (InvalidInputError if isinstance(render_mode, str) else InvalidTypeError)(f"render_mode = {render_mode!r}: expected None or one of {list(modes)}")


def default_frame_size(view: str) -> tuple[int, int]:
    """``(width, height)`` of a frame of ``view`` unless configured: 480 x 360 for
    the 3-D view, 480 x 240 for the flat ones (whose side view is wide)."""
    return DEFAULT_3D_FRAME_SIZE if view == "3d" else DEFAULT_FRAME_SIZE


def check_frame_size(width: Any, height: Any, view: str = "side") -> tuple[int, int]:
    """``(width, height)`` as ints, each an integer in [16, 8192] pixels; ``None``
    takes the view's default (:func:`default_frame_size`)."""
    default = default_frame_size(view)
    width = default[0] if width is None else width
    height = default[1] if height is None else height
    for name, value in (("render_width", width), ("render_height", height)):
        wrong_type = isinstance(value, bool) or not isinstance(value, numbers.Integral)
        if wrong_type or not MIN_FRAME_SIZE <= int(value) <= MAX_FRAME_SIZE:
            raise (InvalidTypeError if wrong_type else InvalidInputError)(
                f"{name} = {value!r}: expected an integer number of pixels in [{MIN_FRAME_SIZE}, {MAX_FRAME_SIZE}]"
            )
    return int(width), int(height)


def _per_link(value: float | tuple[float, ...], n_links: int) -> list[float]:
    if isinstance(value, tuple):
        return [float(v) for v in value]
    return [float(value)] * n_links


class ChainRenderer:
    """Frames of one config's chain, ``(height, width, 3)`` uint8 arrays, in the
    config's view (``config.view``: ``render_view``, or by default ``"3d"`` for
    spatial chains and ``"side"`` for planar ones).

    The 3-D view (:class:`Camera` settings ``camera``): a lit perspective picture of
    the cart (blue box) and the chain (grey rods, orange masses) over a floor with a
    grid, each body casting a shadow on the floor; the track with its end stops at
    ``+-track_limit``; the target equilibrium as a faint ghost from the cart; the
    force as a red arrow (``max_force`` is 60% of the chain's length); and, with
    ``trail`` seconds > 0, the tip's recent path (positions fed by :meth:`observe`).

    The flat views: a side view, e1 to the right and gravity down, with the cart on
    its track (a track much longer than the chain scrolls with the cart), the links
    (black) and their point masses (orange), the target drawn faintly and the force
    arrow; a top view (e1 right, e2 up, centred on the cart), where the horizontal
    force shows in both components; or both side by side (``"side+top"``).
    """

    def __init__(
        self,
        config: ChainCartConfig,
        width: Optional[int] = None,
        height: Optional[int] = None,
        camera: "Camera | dict[str, Any] | None" = None,
        trail: float = 0.0,
    ) -> None:
        self.view = config.view
        self.width, self.height = check_frame_size(width, height, self.view)
        self.camera = Camera.coerce(camera)
        self.planar = config.planar
        self.force_dim = config.force_dim
        self._model = config.make_model()
        self._lengths = _per_link(config.link_lengths, config.n_links)
        self._target = [float(s) for s in config.target_signs]
        self._max_force = float(config.max_force)
        self._track_limit = float(config.track_limit)
        self._trail_length, self._trail_every = trail_length(trail, config.dt)

    @property
    def trail_length(self) -> int:
        """Tip positions a trail keeps (0: no trail), one every ``trail_every`` steps."""
        return self._trail_length

    @property
    def trail_every(self) -> int:
        """Steps between the positions a trail keeps."""
        return self._trail_every

    def new_trail(self) -> TipTrail:
        """An empty trail of this renderer's length."""
        return TipTrail(self._trail_length, self._trail_every)

    def spatial(self, state: npt.ArrayLike) -> np.ndarray:
        """``state`` (the model's layout) as a spatial state."""
        y = np.asarray(state, dtype=np.float64)
        return self._model.to_spatial(y) if self.planar else y

    def tip(self, state: npt.ArrayLike) -> np.ndarray:
        """The tip's position (model coordinates) in ``state``."""
        y = self.spatial(state)
        n = len(self._lengths)
        q = y[4 : 4 + 3 * n].reshape(n, 3)
        return np.array([y[0], y[1], 0.0]) + np.asarray(self._lengths) @ q

    def frame(
        self,
        state: npt.ArrayLike,
        force: Optional[npt.ArrayLike] = None,
        trail: Optional[TipTrail] = None,
        target: Optional[Sequence[float]] = None,
    ) -> np.ndarray:
        """The frame of ``state`` (the model's layout: planar states are planar) with
        ``force`` (N, ``force_dim`` numbers; ``None``: no force) as an arrow, the
        ``trail``'s positions (3-D view) and the ghost of ``target`` (signs; ``None``:
        the config's target). Any state draws, however far off-screen, huge or NaN its
        entries."""
        return _core.render_frame(
            self._lengths,
            self.spatial(state),
            self._force_2d(force),
            target=self._target if target is None else [float(s) for s in target],
            max_force=self._max_force,
            track_limit=self._track_limit,
            width=self.width,
            height=self.height,
            view=self.view,
            planar=self.planar,
            trail=None if trail is None else trail.points(),
            **self.camera.as_kwargs(),
        )

    def _force_2d(self, force: Optional[npt.ArrayLike]) -> list[float]:
        if force is None:
            return [0.0, 0.0]
        f = np.asarray(force, dtype=np.float64).reshape(-1)
        if f.shape != (self.force_dim,):
            raise InvalidInputError(f"force has shape {f.shape}: expected ({self.force_dim},)")
        if not np.all(np.isfinite(f)):
            raise InvalidInputError(f"force = {f.tolist()}: expected finite numbers")
        return [float(f[0]), float(f[1]) if self.force_dim == 2 else 0.0]


def tile_grid(count: int) -> tuple[int, int]:
    """``(rows, columns)`` of the most nearly square grid holding ``count`` tiles,
    filled row by row (columns >= rows)."""
    if count < 1:
        raise InvalidInputError(f"count = {count}: expected at least one tile")
    columns = math.ceil(math.sqrt(count))
    return math.ceil(count / columns), columns


def tile_frames(frames: Sequence[np.ndarray], gap: int = 2) -> np.ndarray:
    """Frames of equal size in a grid (:func:`tile_grid`), row by row, with ``gap``
    grey pixels between tiles; empty cells stay grey. Shape ``(rows * h + (rows - 1) *
    gap, columns * w + (columns - 1) * gap, 3)``."""
    if len(frames) == 0:
        raise InvalidInputError("tile_frames got no frames: expected at least one")
    h, w, _ = frames[0].shape
    for k, f in enumerate(frames):
        if f.shape != (h, w, 3):
            raise InvalidInputError(f"frame {k} has shape {f.shape}: expected {(h, w, 3)} like frame 0")
    rows, columns = tile_grid(len(frames))
    out = np.full((rows * h + (rows - 1) * gap, columns * w + (columns - 1) * gap, 3), TILE_GAP_GREY, dtype=np.uint8)
    for k, f in enumerate(frames):
        r, c = divmod(k, columns)
        out[r * (h + gap) : r * (h + gap) + h, c * (w + gap) : c * (w + gap) + w] = f
    return out
