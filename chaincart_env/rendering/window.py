"""``render_mode="human"``: frames shown live in a matplotlib window (the ``plot``
extra), paced to the env's ``render_fps``. Where no window can open (no display, no
interactive backend, no matplotlib) the env warns once, with the reason, and keeps
working without showing anything, as Gymnasium's own envs do on headless machines."""

from __future__ import annotations

import os
import sys
import time
from typing import Any, Optional

import numpy as np
from gymnasium import logger

from chaincart_env.errors import ChainCartError

__all__ = ["RenderUnavailable", "HumanWindow", "check_display"]

#: Interactive matplotlib backends tried, in order, when the current one cannot show
#: windows (matplotlib settles on Agg in a process that started without a display).
_INTERACTIVE_BACKENDS = ("macosx", "qtagg", "gtk4agg", "gtk3agg", "tkagg", "wxagg")

_HEADLESS_HINT = (
    "use render_mode='rgb_array' instead (for instance `python -m chaincart_env animate --out run.gif` "
    "writes an animation)"
)


class RenderUnavailable(ChainCartError, RuntimeError):
    """No window can open here (a ``ChainCartError`` and a ``RuntimeError``). Human
    mode turns it into a warning; :func:`check_display` raises it."""


_warned_headless = False


def _warn_headless(reason: str) -> None:
    """Warns, once per process, that human-mode frames are not shown."""
    global _warned_headless
    if not _warned_headless:
        _warned_headless = True
        logger.warn(f"{reason}; human-mode frames are not shown (the env keeps working)")


def check_display() -> None:
    """Raises :class:`RenderUnavailable` on a Unix desktop-less machine: neither
    ``DISPLAY`` (X11) nor ``WAYLAND_DISPLAY`` is set. macOS and Windows always have
    one."""
    if sys.platform in ("darwin", "win32", "cygwin"):
        return
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise RenderUnavailable(
            "render_mode='human' needs a display, but neither DISPLAY nor WAYLAND_DISPLAY is set "
            f"(a headless machine?): {_HEADLESS_HINT}"
        )


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise RenderUnavailable(
            "render_mode='human' draws with matplotlib: pip install 'chaincart-env[plot]'"
        ) from e
    return plt


def _interactive_backends() -> set[str]:
    try:
        from matplotlib.backends import BackendFilter, backend_registry

        return {b.lower() for b in backend_registry.list_builtin(BackendFilter.INTERACTIVE)}
    except ImportError:  # matplotlib < 3.9
        from matplotlib import rcsetup

        return {b.lower() for b in getattr(rcsetup, "interactive_bk")}


def _use_interactive_backend(plt: Any) -> str:
    """The name of an interactive backend now in use, switching to one if needed."""
    import matplotlib

    interactive = _interactive_backends()
    if matplotlib.get_backend().lower() in interactive:
        return matplotlib.get_backend()
    failures = []
    for name in _INTERACTIVE_BACKENDS:
        try:
            plt.switch_backend(name)
            return name
        except Exception as e:  # ImportError, or the toolkit failing to start
            failures.append(f"{name}: {type(e).__name__}: {str(e)[:80]}")
    raise RenderUnavailable(
        f"render_mode='human' needs an interactive matplotlib backend, but the current one is "
        f"{matplotlib.get_backend()!r} and none of {list(_INTERACTIVE_BACKENDS)} loads ({'; '.join(failures)}): "
        f"install tkinter or PyQt, or {_HEADLESS_HINT}"
    )


class HumanWindow:
    """One live window showing RGB frames at most ``fps`` times a second; the figure
    opens with the first frame. Where no window can open, a warning (once per process)
    says why and frames are dropped, as they are once the user closes the window.
    Pickling or copying drops the figure: a copy opens its own window."""

    def __init__(self, fps: float, title: str = "chaincart") -> None:
        self.fps = float(fps)
        self.title = title
        self._figure: Any = None
        self._image: Any = None
        self._closed_by_user = False
        self._next_due = 0.0
        #: Why no window can open here (``None``: it can).
        self.unavailable: Optional[str] = None
        try:
            check_display()
            _use_interactive_backend(_pyplot())
        except RenderUnavailable as e:
            self._give_up(str(e))

    def _give_up(self, reason: str) -> None:
        self.unavailable = reason
        self._figure = self._image = None
        _warn_headless(reason)

    @property
    def is_open(self) -> bool:
        """Whether the window is still open (the user may have closed it)."""
        return self._figure is not None and _pyplot().fignum_exists(self._figure.number)

    def show(self, frame: np.ndarray) -> None:
        """Shows ``frame`` (uint8 H x W x 3), waiting until its time slot comes."""
        if self._closed_by_user or self.unavailable is not None:
            return
        plt = _pyplot()
        if self._figure is None:
            if not self._open(plt, frame):
                return
        elif not self.is_open:
            self._closed_by_user = True
            self._figure = self._image = None
            return
        else:
            self._image.set_data(frame)
            self._image.set_extent((-0.5, frame.shape[1] - 0.5, frame.shape[0] - 0.5, -0.5))
            self._figure.canvas.draw_idle()
        now = time.perf_counter()
        # A timeout of 0 would run the GUI loop forever in some backends (Tk).
        self._figure.canvas.start_event_loop(max(self._next_due - now, 1e-3))
        self._next_due = max(now, self._next_due) + 1.0 / self.fps

    def _open(self, plt: Any, frame: np.ndarray) -> bool:
        h, w, _ = frame.shape
        dpi = 100.0
        try:
            figure = plt.figure(figsize=(w / dpi, h / dpi), dpi=dpi)
            figure.canvas.manager.set_window_title(self.title)
            axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
            axes.set_axis_off()
            self._image = axes.imshow(frame, interpolation="nearest")
            plt.show(block=False)
        except Exception as e:  # e.g. Tk's TclError: no display name / couldn't connect
            self._give_up(f"render_mode='human' could not open a window ({e}): {_HEADLESS_HINT}")
            return False
        self._figure = figure
        self._next_due = time.perf_counter()
        return True

    def close(self) -> None:
        """Closes the window (a no-op when none is open)."""
        if self._figure is not None:
            _pyplot().close(self._figure)
        self._figure = self._image = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state.update(_figure=None, _image=None)
        return state
