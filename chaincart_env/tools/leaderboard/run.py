"""Running a leaderboard: every controller on every scene, along every axis, for every
seed, into a run directory (``cells.csv``, the agents of the learned controllers, the
scores, ``leaderboard.md`` and one figure per scene).

A run can be repeated into the same directory: agents that were trained there are
reused, and so are the cells already evaluated there (``cells.csv`` grows by one row as
each cell finishes, so an interrupted run resumes where it stopped; see
:mod:`~chaincart_env.tools.leaderboard.resume` for when rows are reused).

The model-based controllers run with fixed iteration counts (no wall-clock limit on the
planner or on MPC's step, :func:`~chaincart_env.tools.leaderboard.contestants.fixed_iteration_options`),
so that a cell's numbers do not depend on the machine's load: two runs write the same
``cells.csv`` and ``scores.csv`` but for the measured compute time per step.
``wall_clock=True`` keeps the controllers' default time limits instead.

Its independent pieces, the agents to train (one per scene, learned controller and
seed) and then the cells, run one after the other in this process or, on a Ray
cluster (``address``), as Ray tasks (:func:`~chaincart_env.tools.compare.cell_runner.map_cells`),
with the same rows (but for the measured compute time per step).
"""

from __future__ import annotations

import json
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.cell_runner import map_cells, torch_threads
from chaincart_env.tools.compare.policy_sources import PolicySource
from chaincart_env.tools.compare.recipes import recipe_for
from chaincart_env.tools.compare.run_files import MODEL_FILE, folder_contents, write_folder
from chaincart_env.tools.compare.tables import write_csv
from chaincart_env.tools.controllers import LEARNED, NotApplicable
from chaincart_env.tools.leaderboard.axes import AXES, RobustnessAxis, axis_values
from chaincart_env.tools.leaderboard.cells import CELL_COLUMNS, Cell, cells_of, run_cell
from chaincart_env.tools.leaderboard.contestants import fixed_source, seeds_checked, train_agent
from chaincart_env.tools.leaderboard.resume import append_row, cell_key, cell_settings, finished_cells

__all__ = [
    "AgentTraining", "CellJob", "LeaderboardSettings", "QUICK_EPISODES", "QUICK_TIMESTEPS", "evaluate_cell_job",
    "run_leaderboard", "train_agent_cell",
]  # fmt: skip

#: Episodes per cell and training budget of learned agents in a quick run.
QUICK_EPISODES = 3
QUICK_TIMESTEPS = 2048
#: Episodes per cell of a full run: enough that a success fraction's 95 % interval is
#: at most about +-0.18 wide per cell and seed.
FULL_EPISODES = 30


@dataclass(frozen=True)
class LeaderboardSettings:
    """What a leaderboard run evaluates."""

    scenes: tuple[str, ...]
    controllers: tuple[str, ...]
    seeds: tuple[int, ...] = (0,)
    axes: tuple[RobustnessAxis, ...] = AXES
    quick: bool = False
    episodes: Optional[int] = None
    timesteps: Optional[int] = None
    progress_bar: bool = False
    extra: dict[str, Any] = field(default_factory=dict)
    #: Torch threads of training and evaluation (here and in every task).
    torch_threads: int = 1
    #: The planner and MPC stop at their wall-clock budgets too (their results then
    #: depend on the machine's load); default: iteration counts alone.
    wall_clock: bool = False

    @property
    def episodes_per_cell(self) -> int:
        """Episodes of every cell."""
        if self.episodes is not None:
            return self.episodes
        return QUICK_EPISODES if self.quick else FULL_EPISODES

    @property
    def training_timesteps(self) -> Optional[int]:
        """The learned agents' budget (None: each recipe's own)."""
        if self.timesteps is not None:
            return self.timesteps
        return QUICK_TIMESTEPS if self.quick else None

    def values(self) -> dict[str, Sequence[float]]:
        """The values evaluated on each axis."""
        return {axis.name: axis_values(axis, self.quick) for axis in self.axes}

    def describe(self) -> dict[str, Any]:
        """The settings as ``leaderboard.json`` records them."""
        return dict(
            scenes=list(self.scenes), controllers=list(self.controllers), seeds=list(self.seeds),
            axes={name: [v if math.isfinite(v) else "inf" for v in values] for name, values in self.values().items()},
            quick=self.quick, episodes_per_cell=self.episodes_per_cell, training_timesteps=self.training_timesteps,
            wall_clock_budgets=self.wall_clock, cell_settings=cell_settings(self),
        )


def _checked(settings: LeaderboardSettings) -> None:
    seeds_checked(settings.seeds)
    if not settings.scenes or not settings.controllers:
        raise InvalidInputError("a leaderboard needs at least one scene and one controller")
    episodes = settings.episodes_per_cell
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise InvalidInputError(f"episodes = {episodes!r}: expected an integer >= 1")
    budget = settings.training_timesteps
    if budget is not None and (isinstance(budget, bool) or not isinstance(budget, int) or budget < 1):
        raise InvalidInputError(f"timesteps = {budget!r}: expected an integer >= 1")
    threads = settings.torch_threads
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise InvalidInputError(f"torch threads = {threads!r}: expected an integer >= 1")


def agent_directory(out: Path, scene: str, name: str, seed: int) -> Path:
    """Where the agent of learned controller ``name`` on ``scene`` with seed ``seed`` lives."""
    return Path(out) / "agents" / scene / name / f"seed-{seed}"


@dataclass(frozen=True)
class AgentTraining:
    """One agent to train, as a task: its scene, controller, seed, budget and the files
    of its folder so far (a checkpoint of an interrupted run)."""

    config: ChainCartConfig
    name: str
    seed: int
    timesteps: Optional[int]
    tiny: bool
    files: dict[str, bytes]


def train_agent_cell(_: None, job: AgentTraining) -> dict[str, bytes]:
    """Trains one agent in a scratch folder (of the machine the task runs on) exactly as
    a serial run does, and returns the folder's files."""
    with tempfile.TemporaryDirectory(prefix="chaincart-agent-") as scratch:
        write_folder(Path(scratch), job.files)
        train_agent(job.name, job.config, job.seed, Path(scratch), timesteps=job.timesteps, tiny=job.tiny)
        return folder_contents(Path(scratch))


@dataclass(frozen=True)
class CellJob:
    """One cell to evaluate: the cell, its scene's configuration and the key of its
    policy's source."""

    cell: Cell
    config: ChainCartConfig
    source: str


def evaluate_cell_job(sources: Mapping[str, PolicySource], job: CellJob) -> dict[str, Any]:
    """The row of one cell (``sources``: the policies by key, loaded once per process)."""
    return run_cell(job.cell, job.config, sources[job.source].load())


def _train_agents(
    jobs: Sequence[tuple[Path, AgentTraining]], settings: LeaderboardSettings, distributed: bool,
    log: Callable[[str], None],
) -> None:
    """Trains the agents not trained yet: here, into their folders, or as Ray tasks
    whose folders are written here as each finishes."""
    if not distributed:
        for directory, job in jobs:
            log(f"leaderboard: training {job.name} on {job.config.scene}, seed {job.seed}")
            train_agent(job.name, job.config, job.seed, directory, timesteps=job.timesteps,
                        progress_bar=settings.progress_bar, tiny=job.tiny)
        return

    def save(index: int, files: dict[str, bytes]) -> None:
        directory, job = jobs[index]
        write_folder(directory, files)
        log(f"leaderboard: trained {job.name} on {job.config.scene}, seed {job.seed}")

    map_cells(train_agent_cell, [job for _, job in jobs], distributed=True, torch_threads=settings.torch_threads,
              on_result=save)


@dataclass
class _Plan:
    """Every cell of a run in table order, the sources of the model-based controllers,
    the learned agents' model files (by source key), the agents still to train and the
    controllers that cannot serve a scene (with the reason)."""

    jobs: list[CellJob] = field(default_factory=list)
    designs: dict[str, Any] = field(default_factory=dict)
    agents: dict[str, tuple[str, Path]] = field(default_factory=dict)
    training: list[tuple[Path, AgentTraining]] = field(default_factory=list)
    skipped: dict[tuple[str, str], str] = field(default_factory=dict)

    def sources(self) -> dict[str, Any]:
        """Every policy by key, the agents read from their model files (trained by now,
        but for agents whose cells were all read back: those have none, and need none)."""
        agents = {key: PolicySource.sb3(path, name) for key, (name, path) in self.agents.items() if path.is_file()}
        return {**self.designs, **agents}


def _plan(settings: LeaderboardSettings, out: Path, log: Callable[[str], None],
          finished: Mapping[Any, dict[str, Any]]) -> _Plan:
    """The run's plan; a learned agent is trained only where one of its cells is still to
    evaluate (a run whose cells are all read back, as from a published run's
    ``cells.csv``, trains nothing)."""
    plan = _Plan()
    for scene in settings.scenes:
        config = ChainCartConfig(scene=scene, **settings.extra)
        for name in settings.controllers:
            try:
                if name not in LEARNED:  # one design (or shipped agent) per scene, whatever the seed
                    plan.designs[f"{scene}/{name}"] = fixed_source(name, config, settings.wall_clock)
                else:  # a learned agent without a recipe for the scene (a residual agent's)
                    recipe_for(scene, name)
            except NotApplicable as reason:
                plan.skipped[(scene, name)] = str(reason)
                log(f"leaderboard: {reason} (not scored)")
                continue
            for seed in settings.seeds:
                key = f"{scene}/{name}"
                cells = cells_of(scene, name, settings.axes, settings.values(), seed, settings.episodes_per_cell)
                if name in LEARNED:
                    directory = agent_directory(out, scene, name, seed)
                    key = f"{key}/seed-{seed}"
                    plan.agents[key] = (name, directory / MODEL_FILE)
                    pending = any(cell_key(cell) not in finished for cell in cells)
                    if pending and not (directory / MODEL_FILE).is_file():
                        plan.training.append((directory, AgentTraining(
                            config, name, seed, settings.training_timesteps, settings.quick, folder_contents(directory))))
                plan.jobs += [CellJob(cell, config, key) for cell in cells]
    return plan


def _evaluate(
    plan: _Plan, finished: Mapping[Any, dict[str, Any]], settings: LeaderboardSettings, out: Path,
    log: Callable[[str], None], distributed: bool,
) -> list[dict[str, Any]]:
    """Every cell's row in table order: read back where ``finished`` has it, else
    evaluated and appended to ``cells.csv`` as it finishes."""
    keys = [cell_key(job.cell) for job in plan.jobs]
    rows: list[Optional[dict[str, Any]]] = [finished.get(key) for key in keys]
    write_csv(out / "cells.csv", [row for row in rows if row is not None], CELL_COLUMNS)
    pending = [i for i, row in enumerate(rows) if row is None]
    log(f"leaderboard: evaluating {len(pending)} of {len(plan.jobs)} cells" + (" as Ray tasks" if distributed else ""))

    def save(index: int, row: dict[str, Any]) -> None:
        rows[pending[index]] = row
        append_row(out / "cells.csv", row)

    map_cells(evaluate_cell_job, [plan.jobs[i] for i in pending], shared=plan.sources(), distributed=distributed,
              torch_threads=settings.torch_threads, on_result=save)
    return [row for row in rows if row is not None]


def _run(
    settings: LeaderboardSettings, out: Path, report: Optional[Path], log: Callable[[str], None], distributed: bool,
    finished: Mapping[Any, dict[str, Any]],
) -> list[dict[str, Any]]:
    from chaincart_env.tools.leaderboard.leaderboard_report import write_report

    plan = _plan(settings, out, log, finished)
    _train_agents(plan.training, settings, distributed, log)
    rows = _evaluate(plan, finished, settings, out, log, distributed)
    write_csv(out / "cells.csv", rows, CELL_COLUMNS)
    write_report(rows, settings, out, report or out / "leaderboard.md", plan.skipped)
    return rows


def run_leaderboard(
    settings: LeaderboardSettings, out: Path, report: Optional[Path] = None,
    log: Callable[[str], None] = print, address: Optional[str] = None, fresh: bool = False,
) -> list[dict[str, Any]]:
    """Runs every cell of ``settings`` into ``out`` and writes the report (to ``report``,
    default ``out/leaderboard.md``); returns the rows of ``cells.csv``. ``address``: a
    Ray cluster (``"local"``: a new one on this machine) on which the agents train and
    the cells run as Ray tasks, with the same rows. Cells already evaluated in ``out``
    with the same settings are read back, not evaluated again (other settings: an
    InvalidInputError; ``fresh``: every cell evaluated again)."""
    _checked(settings)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    finished = finished_cells(out, settings, fresh, log)
    record = out / "leaderboard.json"
    record.write_text(json.dumps(settings.describe(), indent=2) + "\n")
    with torch_threads(settings.torch_threads):  # as in every task, so that both ways give the same agents
        if address is None:
            return _run(settings, out, report, log, distributed=False, finished=finished)
        from chaincart_env.tools.compare.cell_runner import ray_cluster

        with ray_cluster(address, 1) as cluster:
            log(f"leaderboard: the agents and cells run as Ray tasks on {cluster}")
            record.write_text(json.dumps({**settings.describe(), "cluster": cluster}, indent=2) + "\n")
            return _run(settings, out, report, log, distributed=True, finished=finished)
