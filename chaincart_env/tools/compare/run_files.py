"""The files that make a trained run re-evaluable: ``model.zip`` (SB3) or
``rllib_checkpoint/`` (RLlib, written by its trainer), ``config.json`` (the env
config's keywords) and ``run.json`` (trainer, algorithm, budget, seeds, evaluation
settings, hyperparameters, timings)."""

from __future__ import annotations

import csv
import json
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError

__all__ = [
    "BEST_MODEL_FILE", "CHECKPOINT_DIR", "CONFIG_FILE", "EVALUATIONS_FILE", "EVALUATION_COLUMNS", "MODEL_FILE", "RUN_FILE",
    "SavedRun", "folder_contents", "read_evaluations", "read_json_object", "replace_directory", "save_run",
    "settled_directory", "truncate_csv", "write_folder",
]  # fmt: skip

MODEL_FILE = "model.zip"
CONFIG_FILE = "config.json"
RUN_FILE = "run.json"
#: The folder of an RLlib run's checkpoint.
CHECKPOINT_DIR = "rllib_checkpoint"


@dataclass(frozen=True)
class SavedRun:
    #: An SB3 model, or an RLlibPolicy for runs of ``--trainer rllib``.
    """A run directory written by ``compare``: its model, config, ``run.json`` info and where it
    is."""

    model: Any
    config: ChainCartConfig
    info: dict[str, Any]
    directory: Path


def _rllib(info: dict[str, Any]) -> bool:
    return info.get("trainer") == "rllib"


def save_run(directory: Path, model: Any, config: ChainCartConfig, info: dict[str, Any]) -> None:
    """Writes the run's files (an RLlib run's checkpoint is already there; an SB3 model's
    normalisation statistics go beside it)."""
    directory = Path(directory)
    if not _rllib(info):
        from chaincart_env.tools.compare.normalization import save_agent

        save_agent(model, directory / MODEL_FILE)
    (directory / CONFIG_FILE).write_text(json.dumps(config.to_dict(), indent=2) + "\n")
    (directory / RUN_FILE).write_text(json.dumps(info, indent=2, default=repr) + "\n")


def read_json_object(path: Path) -> dict[str, Any]:
    """A run's JSON file (``run.json``, ``config.json``), which must exist and hold an object."""
    if not path.is_file():
        raise InvalidInputError(f"{path} does not exist: expected the {path.name} that compare writes beside the model")
    data = json.loads(path.read_text())
    if not isinstance(data, dict):
        raise InvalidInputError(f"{path} holds {type(data).__name__}: expected a JSON object")
    return data


#: The training-time evaluation log and the best model it keeps (see
#: :mod:`chaincart_env.tools.compare.periodic_eval`).
EVALUATIONS_FILE = "evaluations.csv"
BEST_MODEL_FILE = "best_model.zip"
#: Columns of ``evaluations.csv``.
EVALUATION_COLUMNS = (
    "timesteps", "wall_time_s", "episodes", "success_rate", "ci_low", "ci_high", "return_mean", "return_std",
)


def read_evaluations(path: Path) -> list[dict[str, float]]:
    """The rows of an ``evaluations.csv`` as numbers."""
    with Path(path).open(newline="") as file:
        return [{key: float(value) for key, value in row.items()} for row in csv.DictReader(file)]


def replace_directory(staging: Path, final: Path) -> None:
    """Swaps the finished folder ``staging`` in as ``final`` (the previous ``final``
    stays whole until the new one is in place; :func:`settled_directory` finds it
    after an interruption between the two renames), e.g. a checkpoint written by parts."""
    old = final.with_name(final.name + ".old")
    shutil.rmtree(old, ignore_errors=True)
    if final.exists():
        final.rename(old)
    staging.rename(final)
    shutil.rmtree(old, ignore_errors=True)


def folder_contents(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` by its path relative to it (empty if it is missing):
    a run folder as data, to send from one machine to another."""
    folder = Path(folder)
    if not folder.is_dir():
        return {}
    return {path.relative_to(folder).as_posix(): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


def write_folder(folder: Path, contents: dict[str, bytes]) -> None:
    """Writes :func:`folder_contents` back under ``folder`` (replacing files of the same name)."""
    for name, data in contents.items():
        path = Path(folder) / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)


def truncate_csv(path: Path, rows: int) -> None:
    """Keeps the header and the first ``rows`` data rows of a CSV file."""
    lines = Path(path).read_text().splitlines(keepends=True)
    Path(path).write_text("".join(lines[: rows + 1]))


def settled_directory(final: Path) -> Path:
    """``final`` as :func:`replace_directory` leaves it, also when it was interrupted
    after moving the previous version aside and before moving the new one in (the
    previous one is then put back)."""
    old = final.with_name(final.name + ".old")
    if not final.exists() and old.is_dir():
        old.rename(final)
    return final
