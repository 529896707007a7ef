"""Reusable matplotlib panels for trajectories of the chain on a cart.

Every function takes plain NumPy arrays and draws on a matplotlib ``Axes`` (a fresh
one from :func:`new_axes` when ``ax`` is None), returning that ``Axes``; nothing here
touches ``pyplot`` or selects a backend, so the panels work in scripts (Agg), in
notebooks and inside other figures alike. Save with ``ax.figure.savefig(path)``.

Conventions follow the paper: e3 points along gravity, so panels drawn in a vertical
plane put e3 *downwards* (a hanging chain hangs down on the page).

Needs the ``plot`` extra (matplotlib).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Optional, cast

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.figure import Figure

__all__ = [
    "new_axes",
    "panel_figure",
    "plot_cart_position",
    "plot_components",
    "plot_errors",
    "plot_tip_path",
    "plot_tip_path_3d",
    "plot_energies",
    "plot_force",
    "plot_success_curve",
    "save_panel",
]

_AXIS_NAMES = ("e1", "e2", "e3")


def new_axes(projection: Optional[str] = None, figsize: tuple[float, float] = (5.0, 3.6)) -> Axes:
    """One ``Axes`` on a new stand-alone ``Figure`` (``projection="3d"`` for 3-D)."""
    fig = Figure(figsize=figsize, layout="constrained")
    return fig.add_subplot(projection=projection)


def save_panel(ax: Axes, path: Any, dpi: int = 120) -> None:
    """Saves the whole figure ``ax`` is drawn on (its root figure) as ``path``."""
    figure = ax.figure
    root = cast(Figure, getattr(figure, "figure", figure) or figure)  # a SubFigure's root
    root.savefig(path, dpi=dpi)


def panel_figure(
    projections: Sequence[Optional[str]], ncols: int = 2, panel_size: tuple[float, float] = (5.0, 3.6)
) -> tuple[Figure, list[Axes]]:
    """A ``Figure`` with one panel per entry of ``projections`` (None or ``"3d"``) on a
    grid of ``ncols`` columns, as in the paper's four-panel figures."""
    nrows = -(-len(projections) // ncols)
    fig = Figure(figsize=(panel_size[0] * ncols, panel_size[1] * nrows), layout="constrained")
    axes = [fig.add_subplot(nrows, ncols, k + 1, projection=p) for k, p in enumerate(projections)]
    return fig, axes


def _axes(ax: Optional[Axes], projection: Optional[str] = None) -> Axes:
    return new_axes(projection) if ax is None else ax


def _columns(values: npt.ArrayLike, name: str, length: int) -> np.ndarray:
    """``values`` as a 2-D array with one row per time sample."""
    v = np.asarray(values, dtype=np.float64)
    v = v[:, None] if v.ndim == 1 else v
    if v.ndim != 2 or v.shape[0] != length:
        raise ValueError(f"{name} has shape {np.shape(values)}: expected ({length},) or ({length}, k) like t")
    return v


def plot_components(
    t: npt.ArrayLike,
    values: npt.ArrayLike,
    labels: Sequence[str],
    *,
    ylabel: str = "",
    title: str = "",
    ax: Optional[Axes] = None,
    **line_kwargs: Any,
) -> Axes:
    """One line per column of ``values`` (shape ``(T,)`` or ``(T, k)``) against time."""
    t = np.asarray(t, dtype=np.float64)
    v = _columns(values, "values", t.shape[0])
    if len(labels) != v.shape[1]:
        raise ValueError(f"{len(labels)} labels for {v.shape[1]} columns: expected one label per column")
    ax = _axes(ax)
    for column, label in zip(v.T, labels):
        ax.plot(t, column, label=label, **line_kwargs)
    ax.set_xlabel("t (s)")
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_cart_position(t: npt.ArrayLike, x: npt.ArrayLike, *, ax: Optional[Axes] = None) -> Axes:
    """Cart position components ``x . e1`` (and ``x . e2`` for a spatial cart), ``x`` of
    shape ``(T, 2)`` or ``(T,)``."""
    cols = _columns(x, "x", np.shape(t)[0]).shape[1]
    labels = [f"x . {name}" for name in _AXIS_NAMES[:cols]]
    return plot_components(t, x, labels, ylabel="cart position (m)", title="Cart position x", ax=ax)


def plot_errors(
    t: npt.ArrayLike,
    e_q: npt.ArrayLike,
    e_w: npt.ArrayLike,
    *,
    tolerance: Optional[float] = None,
    log: bool = True,
    ax: Optional[Axes] = None,
) -> Axes:
    """The paper's errors ``e_q = sum |q_i - s_i e3|`` and ``e_w = sum |w_i|`` against
    time, on a log scale by default (exponential convergence is then a straight line),
    with an optional dashed ``tolerance`` line."""
    ax = plot_components(
        t, np.column_stack([e_q, e_w]), ["e_q", "e_w (rad/s)"], ylabel="error", title="Errors e_q, e_w", ax=ax
    )
    if log:
        ax.set_yscale("log")
    if tolerance is not None:
        ax.axhline(tolerance, color="0.4", linestyle="--", linewidth=0.8, label=f"{tolerance:g}")
        ax.legend(loc="best", fontsize="small")
    return ax


def plot_tip_path(
    tip: npt.ArrayLike,
    *,
    plane: tuple[int, int] = (0, 2),
    title: str = "Tip path relative to the cart",
    ax: Optional[Axes] = None,
) -> Axes:
    """The path of a point (e.g. the tip ``sum_i l_i q_i``, shape ``(T, 3)``) projected
    on the plane of two axes (default e1-e3), equal scales, start and end marked. A
    vertical axis (e3) is drawn pointing down, along gravity."""
    p = np.asarray(tip, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"tip has shape {p.shape}: expected (T, 3)")
    a, b = plane
    if not (a in (0, 1, 2) and b in (0, 1, 2) and a != b):
        raise ValueError(f"plane = {plane!r}: expected two different axis indices in 0, 1, 2")
    ax = _axes(ax)
    ax.plot(p[:, a], p[:, b], linewidth=0.6)
    ax.plot(p[0, a], p[0, b], "o", color="tab:green", label="start")
    ax.plot(p[-1, a], p[-1, b], "s", color="tab:red", label="end")
    ax.set_xlabel(f"{_AXIS_NAMES[a]} (m)")
    ax.set_ylabel(f"{_AXIS_NAMES[b]} (m)")
    ax.set_aspect("equal", adjustable="datalim")
    if b == 2:
        ax.invert_yaxis()
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_tip_path_3d(
    tip: npt.ArrayLike, *, title: str = "Tip path relative to the cart", ax: Optional[Axes] = None
) -> Axes:
    """The path of a point (shape ``(T, 3)``) in 3-D, e3 pointing down; ``ax`` must be a
    3-D axes (``new_axes("3d")``)."""
    p = np.asarray(tip, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"tip has shape {p.shape}: expected (T, 3)")
    ax = _axes(ax, "3d")
    if getattr(ax, "name", "") != "3d":
        raise ValueError("plot_tip_path_3d needs a 3-D axes: expected new_axes('3d') or projection='3d'")
    ax.plot(p[:, 0], p[:, 1], p[:, 2], linewidth=0.6)
    ax.scatter(*p[0], color="tab:green", label="start")
    ax.scatter(*p[-1], color="tab:red", marker="s", label="end")
    ax.set_xlabel("e1 (m)")
    ax.set_ylabel("e2 (m)")
    axes3d = cast(Any, ax)  # an mpl_toolkits Axes3D
    axes3d.set_zlabel("e3 (m)")
    axes3d.invert_zaxis()
    ax.set_title(title)
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_energies(
    t: npt.ArrayLike,
    kinetic: npt.ArrayLike,
    potential: npt.ArrayLike,
    *,
    kinetic_links: Optional[npt.ArrayLike] = None,
    total: bool = True,
    ax: Optional[Axes] = None,
) -> Axes:
    """Kinetic energy T, potential energy V, optionally the links' part ``T_q`` (paper
    eq. T2, dotted) and the total ``T + V``."""
    t = np.asarray(t, dtype=np.float64)
    kin = np.asarray(kinetic, dtype=np.float64)
    pot = np.asarray(potential, dtype=np.float64)
    ax = _axes(ax)
    ax.plot(t, kin, label="T", linewidth=0.8)
    if kinetic_links is not None:
        ax.plot(t, np.asarray(kinetic_links, dtype=np.float64), ":", color="tab:red", label="T_q", linewidth=0.8)
    ax.plot(t, pot, label="V", linewidth=0.8)
    if total:
        ax.plot(t, kin + pot, color="k", label="T + V", linewidth=0.8)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("energy (J)")
    ax.set_title("Kinetic and potential energy")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_force(
    t: npt.ArrayLike, force: npt.ArrayLike, *, max_force: Optional[float] = None, ax: Optional[Axes] = None
) -> Axes:
    """Control force components (shape ``(T, 2)`` or ``(T,)``; a zero-order hold is
    drawn as steps), with the force limit as dashed lines if given."""
    t = np.asarray(t, dtype=np.float64)
    f = _columns(force, "force", t.shape[0])
    labels = [f"u . {name}" for name in _AXIS_NAMES[: f.shape[1]]]
    ax = plot_components(t, f, labels, ylabel="force (N)", title="Control force u", ax=ax, drawstyle="steps-post")
    if max_force is not None and max_force > 0:
        for sign in (-1, 1):
            ax.axhline(sign * max_force, color="0.4", linestyle="--", linewidth=0.8)
    return ax


def plot_success_curve(
    sizes: npt.ArrayLike,
    success: npt.ArrayLike,
    *,
    low: Optional[npt.ArrayLike] = None,
    high: Optional[npt.ArrayLike] = None,
    label: str = "",
    log_x: bool = False,
    ax: Optional[Axes] = None,
) -> Axes:
    """Fraction of stabilised starts against the perturbation size, with an optional
    confidence band ``[low, high]``; call again on the same ``ax`` to overlay another
    controller (e.g. an RL agent against the LQR baseline)."""
    x = np.asarray(sizes, dtype=np.float64)
    y = np.asarray(success, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(f"sizes {x.shape} and success {y.shape}: expected two 1-D arrays of one length")
    ax = _axes(ax)
    (line,) = ax.plot(x, y, "o-", label=label or None)
    if low is not None and high is not None:
        ax.fill_between(x, np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64),
                        color=line.get_color(), alpha=0.2)  # fmt: skip
    if log_x:
        ax.set_xscale("log")
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("start noise (half-width of the uniform perturbation)")
    ax.set_ylabel("fraction stabilised")
    ax.set_title("Region of attraction")
    ax.grid(True, alpha=0.3)
    if label:
        ax.legend(loc="best", fontsize="small")
    return ax
