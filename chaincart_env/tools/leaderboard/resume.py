"""Picking up an interrupted leaderboard run: ``cells.csv`` grows by one row as each
cell finishes, and a run into the same directory reads back the rows of its cells
instead of evaluating them again.

A row is reused only if the run that wrote it evaluated cells the same way: the
settings a cell's numbers depend on (:func:`cell_settings`) are kept in
``leaderboard.json``, and a run whose settings differ stops with an error naming them
(``fresh=True``, ``--fresh`` on the command line, discards the old rows instead). The
scenes, controllers, seeds and axes may differ: rows are matched by their key (scene,
controller, seed, axis, value), and rows of cells the run does not have are dropped.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.leaderboard.cells import CELL_COLUMNS, Cell

__all__ = ["CellKey", "append_row", "cell_key", "cell_settings", "finished_cells", "row_key"]

#: A cell's identity: scene, controller, seed, axis, value.
CellKey = tuple[str, str, int, str, float]

#: How each column of ``cells.csv`` is read back (``repr`` of a float reads back exactly).
_COLUMN_TYPES: dict[str, Callable[[str], Any]] = {
    "scene": str, "controller": str, "axis": str, "value": float, "seed": int, "episodes": int, "successes": int,
    "success_rate": float, "peak_force_mean": float, "rms_force_mean": float, "us_per_step": float,
}  # fmt: skip


def cell_key(cell: Cell) -> CellKey:
    """The key of ``cell``."""
    return (cell.scene, cell.controller, cell.seed, cell.axis.name, float(cell.value))


def row_key(row: Mapping[str, Any]) -> CellKey:
    """The key of a row of ``cells.csv``."""
    return (row["scene"], row["controller"], int(row["seed"]), row["axis"], float(row["value"]))


def cell_settings(settings: Any) -> dict[str, Any]:
    """What a cell's numbers depend on besides its key, as JSON values."""
    record = dict(
        episodes_per_cell=settings.episodes_per_cell, training_timesteps=settings.training_timesteps,
        quick=settings.quick, wall_clock_budgets=settings.wall_clock, extra=settings.extra,
    )
    return json.loads(json.dumps(record, sort_keys=True, default=repr))


def _parsed(row: Mapping[str, Optional[str]]) -> Optional[dict[str, Any]]:
    """A row read back, or None for a row cut short (a run killed while writing it)."""
    try:
        return {column: _COLUMN_TYPES[column](str(row[column])) for column in CELL_COLUMNS if row[column] is not None}
    except (KeyError, ValueError):
        return None


def finished_cells(
    out: Path, settings: Any, fresh: bool, log: Callable[[str], None]
) -> dict[CellKey, dict[str, Any]]:
    """The rows of ``out/cells.csv`` that a run with ``settings`` can reuse, by key
    (none when ``fresh``: the file is removed, before the new settings are recorded,
    so that no later run takes its rows for theirs); an error when they were computed
    with other settings."""
    cells, record = Path(out) / "cells.csv", Path(out) / "leaderboard.json"
    if not cells.is_file():
        return {}
    if fresh or not record.is_file():
        if not fresh:
            log(f"leaderboard: {cells} has no leaderboard.json beside it; its cells are evaluated again")
        cells.unlink()
        return {}
    then = json.loads(record.read_text()).get("cell_settings")
    now = cell_settings(settings)
    if then != now:
        differ = sorted(k for k in set(now) | set(then or {}) if (then or {}).get(k, math.nan) != now.get(k))
        described = ", ".join(f"{k} = {(then or {}).get(k)!r} there, {now.get(k)!r} now" for k in differ)
        raise InvalidInputError(
            f"{out} holds cells evaluated with other settings ({described or 'not recorded'}): expected the same "
            "settings to resume; pass --fresh to evaluate every cell again, or choose another --out"
        )
    with cells.open(newline="") as file:
        rows = [_parsed(row) for row in csv.DictReader(file)]
    finished = {row_key(row): row for row in rows if row is not None and len(row) == len(CELL_COLUMNS)}
    if finished:
        log(f"leaderboard: {len(finished)} cells already evaluated in {cells} are read back")
    return finished


def append_row(path: Path, row: Mapping[str, Any]) -> None:
    """Adds one row to ``cells.csv`` (with its header if the file is new), written and
    closed at once so that an interrupted run keeps every finished cell."""
    new = not Path(path).is_file()
    with Path(path).open("a", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(CELL_COLUMNS))
        if new:
            writer.writeheader()
        writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items() if k in CELL_COLUMNS})
