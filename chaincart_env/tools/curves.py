"""``python -m chaincart_env curves``: learning curves of training recipes, over seeds.

Each argument is a study written by ``compare`` (``LABEL=DIR``, or ``DIR`` labelled by
its folder name). Every learned algorithm of a study is one recipe; its training seeds
are read from ``run.json`` and their periodic deterministic evaluations from each
seed's ``evaluations.csv`` (a polished run's: its first stage's, then the polish's, one
curve). A folder of ``seed-<s>/`` training runs without a
``run.json`` (a leaderboard's ``agents/<scene>/<controller>/``) is one recipe too. The command writes, into ``--out``:

* ``learning-curves.png``: success and mean return of the deterministic policy against
  env steps and against wall time, the mean over seeds with its 95 % bootstrap
  interval (seeds evaluated at the same steps; the wall time of an evaluation is its
  mean over the seeds);
* ``learning-curves.md``: per recipe, the seeds, the first evaluation at which the mean
  success reached ``--goal``, for each seed the first step at or above it and whether
  its last five evaluations all were (steady), and the final success with its interval.

Wall times are those each run measured on its machine, under whatever load it had.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import platform
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from chaincart_env.errors import InvalidInputError

__all__ = ["RecipeCurves", "add_curves_command", "read_study_curves", "write_curves"]

#: Evaluations at the end of a run that must all reach the goal for it to count as steady.
STEADY_EVALUATIONS = 5
FIGURE_FILE, PAGE_FILE = "learning-curves.png", "learning-curves.md"


@dataclass(frozen=True)
class RecipeCurves:
    """One recipe's evaluations: ``steps`` (E,), and per seed (S, E) ``success``,
    ``returns`` and ``wall_time_s``, cut to the evaluations every seed reached."""

    label: str
    seeds: tuple[int, ...]
    steps: np.ndarray
    success: np.ndarray
    returns: np.ndarray
    wall_time_s: np.ndarray


def _runs(study: Path, run: dict[str, Any]) -> list[tuple[str, int, Path]]:
    from chaincart_env.tools.compare.layout import training_runs
    from chaincart_env.tools.controllers import LEARNED

    settings = run.get("settings", {})
    learned = [name for name in settings.get("policies", []) if name in LEARNED]
    return [(r.algo, r.seed, r.directory(study)) for r in training_runs(learned, settings.get("seeds", []))]


def _seed_folders(folder: Path) -> list[tuple[str, int, Path]]:
    """The ``seed-<s>/`` training runs in ``folder``, by seed (one recipe)."""
    found = []
    for path in folder.glob("seed-*") if folder.is_dir() else []:
        number = path.name[len("seed-"):]
        if path.is_dir() and number.isdigit():
            found.append((folder.name, int(number), path))
    return sorted(found, key=lambda run: run[1])


def _evaluations(directory: Path) -> list[dict[str, float]]:
    """The run's evaluations; for a polished run, its first stage's, then the polish's
    (steps and wall time counted on from where the first stage ended)."""
    from chaincart_env.tools.compare.run_files import EVALUATIONS_FILE, read_evaluations
    from chaincart_env.tools.compare.stages import POLISH_FIRST_STAGE_DIR

    path = directory / EVALUATIONS_FILE
    if not path.is_file():
        raise InvalidInputError(f"{path}: no such file; expected the evaluations of a training run of compare")
    rows = read_evaluations(path)
    first = directory / POLISH_FIRST_STAGE_DIR
    if not (first / EVALUATIONS_FILE).is_file():
        return rows
    before = read_evaluations(first / EVALUATIONS_FILE)
    steps, wall = _stage_end(first, before)
    return before + [{**row, "timesteps": row["timesteps"] + steps, "wall_time_s": row["wall_time_s"] + wall}
                     for row in rows]


def _stage_end(stage: Path, evaluations: list[dict[str, float]]) -> tuple[float, float]:
    """Where a first stage ended, in env steps and wall time: its last record (its last
    evaluation or its last training episode)."""
    from chaincart_env.tools.compare.learning_curve import EPISODES_FILE, read_training_episodes

    steps = max((row["timesteps"] for row in evaluations), default=0.0)
    wall = max((row["wall_time_s"] for row in evaluations), default=0.0)
    if (stage / EPISODES_FILE).is_file():
        episodes = read_training_episodes(stage / EPISODES_FILE)
        steps = max(steps, float(episodes["timesteps"].max(initial=0.0)))
        wall = max(wall, float(episodes["wall_time_s"].max(initial=0.0)))
    return steps, wall


def read_study_curves(study: Path, label: Optional[str] = None) -> list[RecipeCurves]:
    """The recipes of the compare study in ``study`` (one per learned algorithm),
    labelled ``label`` (the folder's name by default; the algorithm's label is added
    when the study trained several)."""
    from chaincart_env.tools.compare.run_files import RUN_FILE
    from chaincart_env.tools.controllers import label_of

    study = Path(study)
    if (study / RUN_FILE).is_file():
        runs = _runs(study, json.loads((study / RUN_FILE).read_text()))
    else:
        runs = _seed_folders(study)
        if not runs:
            raise InvalidInputError(f"{study}: no {RUN_FILE} and no seed-<s>/ folders; expected a study written by "
                                    "compare or a leaderboard's agents/<scene>/<controller>/")
    if not runs:
        raise InvalidInputError(f"{study}: no learned policy was trained; expected a study of ppo, sac, ...")
    algos = list(dict.fromkeys(algo for algo, _, _ in runs))
    out = []
    for algo in algos:
        seeds = [(seed, _evaluations(directory)) for a, seed, directory in runs if a == algo]
        length = min(len(rows) for _, rows in seeds)
        if length == 0:
            raise InvalidInputError(f"{study}: a training run of {algo} has no evaluation yet")
        steps = np.array([row["timesteps"] for row in seeds[0][1][:length]])
        for seed, rows in seeds:
            if not np.array_equal([row["timesteps"] for row in rows[:length]], steps):
                raise InvalidInputError(f"{study}: seed {seed} of {algo} was evaluated at other steps than seed "
                                        f"{seeds[0][0]}; expected one evaluation schedule")

        def column(key: str, rows_by_seed: list[tuple[int, list[dict[str, float]]]] = seeds) -> np.ndarray:
            return np.array([[row[key] for row in rows[:length]] for _, rows in rows_by_seed])

        name = label or study.name
        out.append(RecipeCurves(name if len(algos) == 1 else f"{name} {label_of(algo)}", tuple(s for s, _ in seeds),
                                steps, column("success_rate"), column("return_mean"), column("wall_time_s")))
    return out


def _band(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean over seeds (axis 0) and its 95 % bootstrap interval, per evaluation."""
    from chaincart_env.tools.compare.uncertainty import aggregate_over_seeds

    rows = [aggregate_over_seeds(values[:, j].tolist()) for j in range(values.shape[1])]
    mean = np.array([r.mean for r in rows])
    low = np.array([r.ci_low if math.isfinite(r.ci_low) else r.mean for r in rows])
    high = np.array([r.ci_high if math.isfinite(r.ci_high) else r.mean for r in rows])
    return mean, low, high


def first_reaching(steps: np.ndarray, values: np.ndarray, goal: float) -> Optional[float]:
    """The first step at which ``values`` reached ``goal``, or ``None``."""
    hits = np.flatnonzero(values >= goal)
    return float(steps[hits[0]]) if hits.size else None


def steady(values: np.ndarray, goal: float) -> bool:
    """Whether the last :data:`STEADY_EVALUATIONS` values all reached ``goal``."""
    return values.size >= STEADY_EVALUATIONS and bool(np.all(values[-STEADY_EVALUATIONS:] >= goal))


def _plot(path: Path, recipes: Sequence[RecipeCurves]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), dpi=100, constrained_layout=True)
    for recipe in recipes:
        wall = recipe.wall_time_s.mean(axis=0)
        for row, (values, name) in enumerate(((recipe.success, "success"), (recipe.returns, "mean return"))):
            mean, low, high = _band(values)
            for col, (x, xlabel) in enumerate(((recipe.steps, "env steps"), (wall, "wall time (s)"))):
                ax = axes[row, col]
                (line,) = ax.plot(x, mean, marker="o", markersize=3, label=f"{recipe.label} ({len(recipe.seeds)} seeds)")
                ax.fill_between(x, low, high, color=line.get_color(), alpha=0.2)
                ax.set_xlabel(xlabel)
                ax.set_ylabel(name)
    for ax in axes[0]:
        ax.set_ylim(-0.02, 1.02)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("deterministic evaluations during training: mean over seeds, 95 % bootstrap interval")
    fig.savefig(path)
    plt.close(fig)


def _steps_text(step: Optional[float]) -> str:
    if step is None:
        return "never"
    return f"{step / 1e6:.2f}M" if step >= 1e6 else f"{step / 1e3:.0f}k" if step >= 1e3 else f"{step:.0f}"


def _page(recipes: Sequence[RecipeCurves], goal: float, command: str, note: str = "") -> str:
    lines = [
        "# Learning curves",
        "",
        f"Generated {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC on {platform.machine()} "
        f"by `{command}`. Wall times are those each run measured, under its machine's load.",
        "",
        *([note, ""] if note else []),
        f"![learning curves]({FIGURE_FILE})",
        "",
        f"| recipe | seeds | mean success first >= {goal:g} | per seed: first >= {goal:g} (steady: last "
        f"{STEADY_EVALUATIONS} all >= {goal:g}) | final success, mean [95 % CI] | final wall time (s) |",
        "|---|---:|---:|---|---:|---:|",
    ]
    from chaincart_env.tools.compare.uncertainty import aggregate_over_seeds

    for recipe in recipes:
        mean = recipe.success.mean(axis=0)
        first = first_reaching(recipe.steps, mean, goal)
        wall = recipe.wall_time_s.mean(axis=0)
        at = "never" if first is None else f"{_steps_text(first)} ({wall[int(np.argmax(recipe.steps == first))]:.0f} s)"
        per_seed = ", ".join(
            f"{seed}: {_steps_text(first_reaching(recipe.steps, values, goal))}"
            f"{' steady' if steady(values, goal) else ''}" for seed, values in zip(recipe.seeds, recipe.success)
        )
        final = aggregate_over_seeds(recipe.success[:, -1].tolist()).describe(2)
        lines.append(f"| {recipe.label} | {len(recipe.seeds)} | {at} | {per_seed} | {final} | {wall[-1]:.0f} |")
    return "\n".join(lines) + "\n"


def write_curves(studies: Sequence[tuple[Optional[str], Path]], out: Path, goal: float = 0.9,
                 command: str = "python -m chaincart_env curves", note: str = "") -> list[RecipeCurves]:
    """Reads every study (``(label or None, folder)``) and writes the figure and the
    page (with ``note`` under its first line) into ``out``; returns the recipes read."""
    if not 0 < goal <= 1:
        raise InvalidInputError(f"goal = {goal!r}: expected a success rate in (0, 1]")
    recipes = [recipe for label, study in studies for recipe in read_study_curves(study, label)]
    labels = [recipe.label for recipe in recipes]
    repeated = sorted({label for label in labels if labels.count(label) > 1})
    if repeated:
        raise InvalidInputError(f"recipes labelled {repeated} more than once: expected distinct labels (LABEL=DIR)")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    _plot(out / FIGURE_FILE, recipes)
    (out / PAGE_FILE).write_text(_page(recipes, goal, command, note))
    return recipes


def _study_argument(text: str) -> tuple[Optional[str], Path]:
    label, sep, folder = text.partition("=")
    return (label.strip(), Path(folder)) if sep and label.strip() else (None, Path(text))


def add_curves_command(commands: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    """Adds ``curves`` to a subcommand set (its handler runs it)."""
    from chaincart_env.cli_text import plain

    parser = commands.add_parser("curves", help="learning curves of compare studies, over seeds, into a figure and a page",
                                 description=plain(__doc__ or ""), formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("studies", nargs="+", type=_study_argument, metavar="[LABEL=]DIR",
                        help="compare output folders, each optionally labelled")
    parser.add_argument("--out", type=Path, required=True, help="where learning-curves.png and .md go")
    parser.add_argument("--goal", type=float, default=0.9, help="the success rate the page times (default 0.9)")
    parser.add_argument("--note", default="", help="a paragraph for the page: where the runs came from")

    def run(args: argparse.Namespace, _top: Any = None) -> int:
        import shlex

        given = ["curves", *(str(d) if label is None else f"{label}={d}" for label, d in args.studies),
                 "--out", str(args.out), *(["--goal", f"{args.goal:g}"] if args.goal != 0.9 else [])]
        command = "python -m chaincart_env " + shlex.join(given)
        try:
            recipes = write_curves(args.studies, args.out, args.goal, command, args.note)
        except InvalidInputError as error:
            parser.error(str(error))
        print(f"{len(recipes)} recipe(s); wrote {args.out / FIGURE_FILE} and {args.out / PAGE_FILE}")
        return 0

    parser.set_defaults(handler=run, needs=lambda args: {"plot": ("matplotlib",)})
