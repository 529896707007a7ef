"""The paper's figures (``python -m chaincart_env figures``): one episode of each
``paper-figK`` scene, drawn panel by panel with :mod:`chaincart_env.tools.plots` and
summarised (peak force, settle time, final errors, energy drift). Needs the ``plot``
extra (matplotlib)."""

from chaincart_env.tools.figures.episodes import (
    Trajectory,
    link_directions,
    link_kinetic_energy,
    paper_errors,
    rollout,
    settle_time,
    tip_positions,
)
from chaincart_env.tools.figures.paper import (
    FIGURES,
    SETTLE_TOLERANCE,
    FigureSummary,
    draw_figure,
    run_figures,
    simulate_figure,
    summarize,
    summary_table,
)

__all__ = [
    "FIGURES",
    "SETTLE_TOLERANCE",
    "FigureSummary",
    "Trajectory",
    "draw_figure",
    "link_directions",
    "link_kinetic_energy",
    "paper_errors",
    "rollout",
    "run_figures",
    "settle_time",
    "simulate_figure",
    "summarize",
    "summary_table",
    "tip_positions",
]
