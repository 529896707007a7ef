"""The paper's three numerical examples (Figs. 1-3): simulate, summarise, draw.

* Fig. 1: uncontrolled motion of the 5-link system from IC1, a 1 degree perturbation of
  the folded equilibrium s = (-1, 1, -1, 1, -1), over 10 s (scene ``paper-fig1``):
  cart position; third components of q_3, q_4, q_5; the tip path sum_i l_i q_i in the
  e1-e3 plane; kinetic energy T, the links' part T_q (eq. T2) and potential energy V.
* Fig. 2: the LQR feedback of eq. (u) stabilising the hanging equilibrium from IC1
  (scene ``paper-fig2``, 10 s): cart position, e_q and e_w, the tip path relative to
  the cart, the control force.
* Fig. 3: the same for s = (-1, -1, -1, 1, 1) from the Fig. 3 initial condition
  (scene ``paper-fig3``, 12 s: with the paper's weights the slowest closed-loop poles
  are -0.77 +- 0.56i and e_q, e_w fall below 1e-3 only after ~11.3 s).

Each figure is one episode of its scene through the Gymnasium env (the LQR baseline
:class:`chaincart_env.LQRPolicy` for Figs. 2 and 3), so figures and env agree.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np
from matplotlib.axes import Axes

from chaincart_env.config import ChainCartConfig
from chaincart_env.policies.lqr import LQRPolicy
from chaincart_env.tools import plots
from chaincart_env.tools.figures.episodes import (
    Trajectory,
    link_directions,
    link_kinetic_energy,
    paper_errors,
    rollout,
    settle_time,
    tip_positions,
)

__all__ = ["FIGURES", "SETTLE_TOLERANCE", "FigureSummary", "simulate_figure", "summarize", "draw_figure", "run_figures"]

#: The figures and their scenes.
FIGURES: dict[int, str] = {1: "paper-fig1", 2: "paper-fig2", 3: "paper-fig3"}

#: "Settled": e_q and e_w both below this from then on (the paper's plots reach it).
SETTLE_TOLERANCE = 1e-3

#: Lines are drawn from at most this many samples (summaries use every sample).
_MAX_DRAWN_SAMPLES = 20_000


@dataclass(frozen=True)
class FigureSummary:
    """The numbers behind a figure. ``settle_time``: first time from which e_q and e_w
    stay below :data:`SETTLE_TOLERANCE` (None: never). ``energy_drift``: for the
    uncontrolled Fig. 1, ``max_t |E(t) - E(0)|`` relative to the peak kinetic energy
    (the potential's zero is arbitrary, the energy that sloshes between the links is
    not). ``out_of_plane``: ``max |q_i . e2|`` over the run."""

    figure: int
    scene: str
    duration: float
    peak_force: float
    settle_time: Optional[float]
    final_e_q: float
    final_e_w: float
    final_cart_distance: float
    energy_drift: Optional[float]
    out_of_plane: float
    is_success: bool


def _check_figure(figure: int) -> str:
    if figure not in FIGURES:
        raise ValueError(f"figure = {figure!r}: expected one of {sorted(FIGURES)}")
    return FIGURES[figure]


def simulate_figure(figure: int) -> Trajectory:
    """One episode of the figure's scene (LQR baseline for Figs. 2 and 3)."""
    config = ChainCartConfig(scene=_check_figure(figure))
    policy = None if figure == 1 else LQRPolicy.from_model(config.make_model(), config.target_signs, config.max_force)
    return rollout(config, policy)


def _relative_energy_drift(traj: Trajectory) -> float:
    model = traj.model
    energy = np.array([model.energy(y) for y in traj.states])
    kinetic = np.array([model.kinetic_energy(y) for y in traj.states])
    return float(np.max(np.abs(energy - energy[0])) / np.max(kinetic))


def summarize(figure: int, traj: Trajectory) -> FigureSummary:
    """The figure's numbers from its trajectory."""
    e_q, e_w = paper_errors(traj.states, traj.target)
    q, _ = link_directions(traj.states, traj.config.n_links)
    forces = np.linalg.norm(traj.forces, axis=1)
    return FigureSummary(
        figure=figure,
        scene=traj.config.scene,
        duration=float(traj.times[-1]),
        peak_force=float(forces.max()) if forces.size else 0.0,
        settle_time=settle_time(traj.times, e_q, e_w, SETTLE_TOLERANCE),
        final_e_q=float(e_q[-1]),
        final_e_w=float(e_w[-1]),
        final_cart_distance=float(np.linalg.norm(traj.states[-1, :2])),
        energy_drift=_relative_energy_drift(traj) if traj.config.max_force == 0 else None,
        out_of_plane=float(np.max(np.abs(q[:, :, 1]))),
        is_success=bool(traj.info.get("is_success", False)),
    )


# -- drawing -----------------------------------------------------------------------

Panel = tuple[str, Optional[str], Callable[[Axes], Axes]]


def _panels(figure: int, traj: Trajectory) -> list[Panel]:
    """``(file stem, projection, draw(ax))`` for each of the figure's four panels."""
    stride = max(1, len(traj.times) // _MAX_DRAWN_SAMPLES)
    t = traj.times[::stride]
    states = traj.states[::stride]
    config = traj.config
    tip = tip_positions(states, config.make_model().link_lengths)
    cart: Panel = ("a_cart_position", None, lambda ax: plots.plot_cart_position(t, states[:, :2], ax=ax))
    if figure == 1:
        model = traj.model
        q, _ = link_directions(states, config.n_links)
        heights = q[:, 2:5, 2]
        kinetic = np.array([model.kinetic_energy(y) for y in states])
        potential = np.array([model.potential_energy(y) for y in states])
        links = link_kinetic_energy(states, model.link_masses, model.link_lengths)
        return [
            cart,
            ("b_link_directions", None, lambda ax: plots.plot_components(
                t, heights, ["q_3 . e3", "q_4 . e3", "q_5 . e3"], ylabel="third component",
                title="Third components of q_3, q_4, q_5", ax=ax)),
            ("c_tip_path", None, lambda ax: plots.plot_tip_path(tip, plane=(0, 2), ax=ax)),
            ("d_energy", None, lambda ax: plots.plot_energies(t, kinetic, potential, kinetic_links=links, ax=ax)),
        ]  # fmt: skip
    e_q, e_w = paper_errors(states, traj.target)
    force_stride = max(1, len(traj.forces) // _MAX_DRAWN_SAMPLES)
    force_t = traj.times[:-1][::force_stride]
    force = traj.forces[::force_stride]
    return [
        cart,
        ("b_errors", None, lambda ax: plots.plot_errors(t, e_q, e_w, tolerance=SETTLE_TOLERANCE, ax=ax)),
        ("c_tip_path", "3d", lambda ax: plots.plot_tip_path_3d(tip, ax=ax)),
        ("d_force", None, lambda ax: plots.plot_force(force_t, force, max_force=config.max_force, ax=ax)),
    ]


def draw_figure(figure: int, traj: Trajectory, out_dir: Path) -> list[Path]:
    """Writes ``fig{K}_{panel}.png`` for each panel and ``fig{K}.png`` with all four;
    returns the paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    panels = _panels(figure, traj)
    written = []
    for stem, projection, draw in panels:
        ax = draw(plots.new_axes(projection))
        path = out_dir / f"fig{figure}{stem}.png"
        plots.save_panel(ax, path)
        written.append(path)
    overview, axes = plots.panel_figure([projection for _, projection, _ in panels])
    for (_, _, draw), ax in zip(panels, axes):
        draw(ax)
    overview.suptitle(_TITLES[figure])
    path = out_dir / f"fig{figure}.png"
    overview.savefig(path, dpi=100)
    written.append(path)
    return written


_TITLES = {
    1: "Fig. 1: uncontrolled response from a perturbed folded equilibrium",
    2: "Fig. 2: LQR stabilisation of the hanging equilibrium",
    3: "Fig. 3: LQR stabilisation of s = (-1, -1, -1, 1, 1)",
}


def _fmt(value: Optional[float], spec: str) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else format(value, spec)


def summary_table(summaries: Sequence[FigureSummary]) -> str:
    """The summaries as a Markdown table."""
    lines = [
        "| figure | scene | duration (s) | peak force (N) | settle time (s) | final e_q | final e_w "
        "| final abs(x) (m) | energy drift | max abs(q_i . e2) | is_success |",
        "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for s in summaries:
        lines.append(
            f"| {s.figure} | {s.scene} | {s.duration:g} | {s.peak_force:.2f} | {_fmt(s.settle_time, '.3f')} "
            f"| {s.final_e_q:.3e} | {s.final_e_w:.3e} | {s.final_cart_distance:.3e} "
            f"| {_fmt(s.energy_drift, '.2e')} | {s.out_of_plane:.1e} | {s.is_success} |"
        )
    return "\n".join(lines)


def run_figures(out_dir: Path, figures: Sequence[int] = (1, 2, 3)) -> list[FigureSummary]:
    """The ``figures`` command: simulate, draw and summarise each figure; prints the
    summary table and the files written."""
    summaries = []
    for figure in figures:
        traj = simulate_figure(figure)
        summary = summarize(figure, traj)
        summaries.append(summary)
        for path in draw_figure(figure, traj, Path(out_dir)):
            print(f"wrote {path}")
    print()
    print(summary_table(summaries))
    return summaries


def summary_dict(summary: FigureSummary) -> dict[str, object]:
    """A summary as plain values (for JSON)."""
    return asdict(summary)
