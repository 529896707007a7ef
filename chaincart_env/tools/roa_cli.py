"""The ``roa`` command: the region of attraction of the LQR baseline
(:func:`chaincart_env.roa.region_of_attraction`) as a printed Markdown table, a CSV and
a PNG (overlay another controller's curve with
:func:`chaincart_env.tools.plots.plot_success_curve`). Needs the ``plot`` extra for the
PNG.
"""

from __future__ import annotations

import csv
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any, Optional, Sequence

from chaincart_env.config import ChainCartConfig
from chaincart_env.roa import DEFAULT_SIZES, RoaPoint, region_of_attraction

__all__ = ["roa_table", "write_csv", "plot_roa", "run_roa"]


def roa_table(points: Sequence[RoaPoint]) -> str:
    """The curve as a Markdown table."""
    lines = [
        "| start noise | starts | stabilised | 95% interval | out of track | numerical failure | unsettled |",
        "|---:|---:|---:|---|---:|---:|---:|",
    ]
    for p in points:
        lines.append(
            f"| {p.start_noise:g} | {p.starts} | {p.success:.3f} | [{p.ci_low:.3f}, {p.ci_high:.3f}] "
            f"| {p.out_of_track:.3f} | {p.numerical_failure:.3f} | {p.unsettled:.3f} |"
        )
    return "\n".join(lines)


def write_csv(points: Sequence[RoaPoint], path: Path) -> None:
    """The curve as CSV, one row per start noise, columns the :class:`RoaPoint` fields."""
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=[field.name for field in fields(RoaPoint)])
        writer.writeheader()
        for p in points:
            writer.writerow(asdict(p))


def plot_roa(points: Sequence[RoaPoint], path: Path, label: str = "LQR baseline") -> None:
    """The curve with its 95% band as a PNG."""
    from chaincart_env.tools import plots

    ax = plots.new_axes(figsize=(6.0, 4.0))
    plots.plot_success_curve(
        [p.start_noise for p in points],
        [p.success for p in points],
        low=[p.ci_low for p in points],
        high=[p.ci_high for p in points],
        label=label,
        ax=ax,
    )
    ax.set_title(f"Region of attraction: {points[0].scene}, {points[0].starts} starts per noise")
    plots.save_panel(ax, path)


def run_roa(
    out_dir: Path,
    scene: Optional[str] = None,
    sizes: Sequence[float] = DEFAULT_SIZES,
    starts: int = 200,
    seed: int = 0,
    start: Optional[str] = None,
) -> list[RoaPoint]:
    """The ``roa`` command: the curve as a printed Markdown table, ``roa_{scene}.csv``
    and ``roa_{scene}.png`` in ``out_dir``."""
    overrides: dict[str, Any] = {} if start is None else {"start": start}
    points = region_of_attraction(scene, sizes, starts, seed, **overrides)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    name = points[0].scene
    config = ChainCartConfig(scene=name, **overrides)
    print(
        f"LQR baseline on {name}: start {config.start!r} + uniform noise, {starts} starts per noise "
        f"(seeds {seed}..{seed + starts - 1}), {config.max_episode_steps} steps of {config.dt} s, "
        f"success = is_success at the time limit (e_q <= {config.success_tolerances[0]}, "
        f"e_w <= {config.success_tolerances[1]})"
    )
    print()
    print(roa_table(points))
    csv_path, png_path = out_dir / f"roa_{name}.csv", out_dir / f"roa_{name}.png"
    write_csv(points, csv_path)
    plot_roa(points, png_path)
    print()
    print(f"wrote {csv_path}")
    print(f"wrote {png_path}")
    return points
