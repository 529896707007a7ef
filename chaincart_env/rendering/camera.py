"""The camera of the 3-D view (:class:`Camera`) and the tip's trail (:class:`TipTrail`).

The camera's defaults and range checks are the Rust renderer's
(``_core.CAMERA_DEFAULTS``, ``_core.check_camera``)."""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np
import numpy.typing as npt

from chaincart_env import _core
from chaincart_env.errors import InvalidInputError, InvalidTypeError

__all__ = ["Camera", "TipTrail", "TRAIL_POINTS", "trail_length"]

_DEFAULTS: dict[str, Any] = dict(_core.CAMERA_DEFAULTS)


@dataclass(frozen=True)
class Camera:
    """Where the 3-D view looks from. Angles in degrees.

    * ``azimuth``: the direction the camera looks from; at 0 it stands on the ``+e2``
      side looking along ``-e2`` (``e1`` to the right, as in the side view), at 90 on
      the ``+e1`` side.
    * ``elevation``: the viewpoint's angle above the horizontal plane, in [-90, 90]
      (90: straight down).
    * ``distance``: metres from the point looked at; ``None``: the nearest distance
      that keeps the chain's whole reach in the frame (and, for a fixed camera, the
      whole track).
    * ``fov``: vertical field of view, in [1, 120].
    * ``follow``: ``True`` follows the cart, ``False`` looks at the track's centre,
      ``None`` follows when the track is more than twice the chain's length.

    Bad values raise :class:`~chaincart_env.errors.InvalidInputError` (or
    ``InvalidTypeError``) naming the value and what is accepted.
    """

    azimuth: float = _DEFAULTS["azimuth"]
    elevation: float = _DEFAULTS["elevation"]
    distance: Optional[float] = _DEFAULTS["distance"]
    fov: float = _DEFAULTS["fov"]
    follow: Optional[bool] = _DEFAULTS["follow"]

    def __post_init__(self) -> None:
        for name in ("azimuth", "elevation", "distance", "fov"):
            value = getattr(self, name)
            if value is None and name == "distance":
                continue
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise InvalidTypeError(f"camera {name} = {value!r}: expected a number")
        if self.follow is not None and not isinstance(self.follow, (bool, np.bool_)):
            raise InvalidTypeError(f"camera follow = {self.follow!r}: expected True, False or None")
        checked = _core.check_camera(**self.as_kwargs())
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    def as_kwargs(self) -> dict[str, Any]:
        """The settings as keywords of ``_core.render_frame``."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for name in ("azimuth", "elevation", "distance", "fov"):
            if out[name] is not None:
                out[name] = float(out[name])
        if out["follow"] is not None:
            out["follow"] = bool(out["follow"])
        return out

    @classmethod
    def coerce(cls, value: "Camera | Mapping[str, Any] | None") -> "Camera":
        """A camera from ``None`` (the defaults), a mapping of some settings, or a camera."""
        if value is None:
            return cls()
        if isinstance(value, Camera):
            return value
        if isinstance(value, Mapping):
            unknown = sorted(set(value) - {f.name for f in dataclasses.fields(cls)})
            if unknown:
                raise InvalidInputError(
                    f"render_camera has unknown settings {unknown}: expected some of azimuth, elevation, distance, "
                    "fov, follow"
                )
            return cls(**value)
        raise InvalidTypeError(f"render_camera = {value!r}: expected a Camera, a dict of its settings, or None")


#: Most positions a trail keeps: longer trails (or shorter steps) keep every k-th step.
TRAIL_POINTS = 100


class TipTrail:
    """The recent positions of the chain's tip (model coordinates, ``e3`` along
    gravity), oldest first, for the 3-D view's trail: every ``every``-th position
    added, at most ``length`` of them, and the newest one."""

    def __init__(self, length: int, every: int = 1) -> None:
        self._points = np.zeros((max(length, 0), 3))
        self._every = max(1, every)
        self._head = np.zeros(3)
        self.clear()

    def clear(self) -> None:
        """Forget every position (a new episode starts a new trail)."""
        self._count = self._next = self._since = 0
        self._has_head = False

    def add(self, tip: npt.ArrayLike) -> None:
        """Record the tip's position after a step: kept if it is an ``every``-th one, else
        as the newest position until the next one comes."""
        if len(self._points) == 0:
            return
        if self._since % self._every == 0:
            self._points[self._next] = tip
            self._next = (self._next + 1) % len(self._points)
            self._count = min(self._count + 1, len(self._points))
            self._has_head = False
        else:
            self._head[:] = tip
            self._has_head = True
        self._since += 1

    def points(self) -> Optional[np.ndarray]:
        """The positions, oldest first (``None`` while fewer than two)."""
        kept = self._points[: self._count] if self._count < len(self._points) else np.roll(
            self._points, -self._next, axis=0)
        if self._has_head:
            kept = np.vstack([kept, self._head])
        return kept if len(kept) >= 2 else None


def trail_length(seconds: Any, dt: float) -> tuple[int, int]:
    """``(positions kept, steps between them)`` for a trail of ``seconds`` (a number
    >= 0; 0: none) at control period ``dt``: at most :data:`TRAIL_POINTS` positions."""
    expected = f"render_trail = {seconds!r}: expected a number of seconds >= 0 (0: no trail)"
    if isinstance(seconds, bool) or not isinstance(seconds, numbers.Real):
        raise InvalidTypeError(expected)
    length = float(seconds)
    if not (math.isfinite(length) and length >= 0):
        raise InvalidInputError(expected)
    if length == 0:
        return 0, 1
    steps = max(1, math.ceil(length / dt - 1e-9))
    every = max(1, math.ceil(steps / TRAIL_POINTS))
    return steps // every + 1, every
