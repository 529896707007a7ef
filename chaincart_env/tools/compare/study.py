"""Evaluation of a study: every trained agent (the final and the best-by-evaluation
model of each learned algorithm and training seed), every shipped agent named
(``pretrained:<scene>/<name>``, weighed as a learned policy of one training seed) and
every model-based controller
(with the oracle LQR where the true system can differ from the model), on the main
evaluation starts and over every sweep axis, with the tables, pictures, ``report.md``
and ``summary.png``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence

from chaincart_env.config import ChainCartConfig
from chaincart_env.pretrained_agents import is_pretrained_slot, parse_pretrained_slot, pretrained
from chaincart_env.tools.compare.cell_runner import map_cells
from chaincart_env.tools.compare.curriculum import CURRICULUM_FILE, PlanStarts
from chaincart_env.tools.compare.evaluation import (
    EPISODE_COLUMNS,
    METRIC_COLUMNS,
    TRANSITION_COLUMNS,
    Rollouts,
    evaluation_seeds,
    rollout,
    tabulate,
    transition_table,
)
from chaincart_env.tools.compare.filmstrip import write_filmstrip
from chaincart_env.tools.compare.layout import TrainingRun, seed_directory
from chaincart_env.tools.compare.plan_bands import (
    BAND_COLUMNS,
    BANDS_FILE,
    band_cells,
    band_rows,
    evaluate_band_cell,
    widest_window,
)
from chaincart_env.tools.compare.policy_sources import PolicySource
from chaincart_env.tools.compare.run_files import EVALUATIONS_FILE, RUN_FILE, read_evaluations, read_json_object
from chaincart_env.tools.compare.study_plots import plot_errors, plot_evaluation_curves, plot_sweep
from chaincart_env.tools.compare.study_report import SUMMARY_FIGURE, seed_lines, write_report, write_summary_figure
from chaincart_env.tools.compare.sweeps import (
    SWEEP_AXES,
    SWEEP_COLUMNS,
    SWEEP_SUMMARY_COLUMNS,
    summarize_sweep,
    sweep_rows,
)
from chaincart_env.tools.compare.tables import write_csv, write_markdown
from chaincart_env.tools.compare.uncertainty import aggregate_over_seeds
from chaincart_env.tools.compare.verdict import Standing, main_setting_values, main_starts_rate, study_verdict
from chaincart_env.tools.controllers import build_model_based, label_of

__all__ = [
    "AGGREGATE_COLUMNS", "CONDITIONAL_EVALUATION_FILES", "EVALUATION_FILES", "TRAINING_EVALUATION_FILES",
    "TRANSITIONS_FILE", "EvaluationCell", "StudyEvaluation", "SweepPoint", "TrainedPolicy", "conditional_files_in",
    "describe", "evaluate_cell", "evaluate_study", "evaluate_study_at", "lqr_baseline", "model_based_sources",
    "plan_band_reaches", "policy_label", "pretrained_policies", "run_label", "seed_directory", "trained_name",
    "trained_policies",
]  # fmt: skip

#: What the evaluation of a study writes.
EVALUATION_FILES = (
    "comparison.csv", "comparison.md", "episodes.csv", "seeds.csv", "errors.png", "filmstrip.png",
    "sweeps.csv", "sweep_summary.csv", "evaluation_curve.png", "report.md", SUMMARY_FIGURE,
)
#: Success per (start, target) pair, written besides them on goal-conditioned scenes.
TRANSITIONS_FILE = "transitions.csv"
#: The tables only some studies write besides :data:`EVALUATION_FILES`.
CONDITIONAL_EVALUATION_FILES = (TRANSITIONS_FILE, BANDS_FILE)


def conditional_files_in(into: Path) -> tuple[str, ...]:
    """The files of :data:`CONDITIONAL_EVALUATION_FILES` an evaluation wrote into ``into``."""
    return tuple(name for name in CONDITIONAL_EVALUATION_FILES if (Path(into) / name).is_file())


#: The files of :data:`EVALUATION_FILES` that only a study with a learned policy writes.
TRAINING_EVALUATION_FILES = ("seeds.csv", "evaluation_curve.png")
#: Columns of ``seeds.csv``: each trained policy's numbers aggregated over training seeds.
AGGREGATE_COLUMNS = (
    "policy", "seeds", "success_mean", "success_ci_low", "success_ci_high", "return_mean", "return_ci_low",
    "return_ci_high",
)
#: The oracle LQR's name in the tables.
ORACLE = "LQR oracle"


def policy_label(algo: str, trainer: str = "sb3") -> str:
    """The trained policy's name in tables and plots: ``PPO``, ``PPO robust``, or
    ``PPO (RLlib)``."""
    return label_of(algo.lower()) + (" (RLlib)" if trainer == "rllib" else "")


def run_label(info: Mapping[str, Any]) -> str:
    """:func:`policy_label` of a training run's record (its ``run.json``)."""
    return policy_label(str(info["algo"]), str(info.get("trainer", "sb3")))


def describe(config: ChainCartConfig) -> str:
    """One line saying what the scene is."""
    return (
        f"scene {config.scene}: {config.n_links} link(s), {'planar' if config.planar else 'spatial'}, "
        f"target {config.target_signs}, start {config.start!r} +- {config.start_noise}, dt {config.dt} s, "
        f"max_force {config.max_force} N, {config.max_episode_steps} steps"
    )


def lqr_baseline(config: ChainCartConfig, oracle: bool = False) -> Any:
    """The LQR baseline of ``config`` (``LQRPolicy.from_env``, designed on the nominal
    model; ``oracle=True``: per episode on the true parameters of the batch it is
    evaluated on); a scene it cannot serve (e.g. no force) is an InvalidInputError
    naming it."""
    return build_model_based("lqr", config, oracle=oracle)


def _has_parameter_gap(config: ChainCartConfig, sweeps: Mapping[str, Sequence[float]]) -> bool:
    return config.has_param_gap or any(v > 0 for v in sweeps.get("mismatch", ()))


@dataclass(frozen=True)
class TrainedPolicy:
    """One trained agent of a study: its label (shared by its seeds), seed and policy
    (``shipped``: a shipped agent, trained elsewhere with that seed)."""

    label: str
    seed: int
    source: PolicySource
    shipped: bool = False

    @property
    def name(self) -> str:
        """``"<label> (seed <seed>)"``, the policy's row in the tables."""
        return trained_name(self.label, self.seed)


def trained_name(label: str, seed: int) -> str:
    """A trained policy's row in the tables: ``"<label> (seed <seed>)"``."""
    return f"{label} (seed {seed})"


def trained_policies(out: Path, runs: Sequence[TrainingRun]) -> list[TrainedPolicy]:
    """The trained agents of ``runs``, algorithm by algorithm: the final model of each
    seed, then each seed's best model by training-time evaluation (where one was kept)."""
    policies: list[TrainedPolicy] = []
    for algo in dict.fromkeys(run.algo for run in runs):
        finals, bests = [], []
        for run in (r for r in runs if r.algo == algo):
            directory = run.directory(out)
            info = read_json_object(directory / RUN_FILE)
            label = run_label(info)
            finals.append(TrainedPolicy(label, run.seed, PolicySource.of_run(directory)))
            best = PolicySource.best_of_run(directory)
            if best is not None:
                bests.append(TrainedPolicy(f"{label} best", run.seed, best))
        policies += finals + bests
    return policies


def plan_band_reaches(
    out: Path, runs: Sequence[TrainingRun], trained: Sequence[TrainedPolicy]
) -> dict[str, tuple[float, float]]:
    """The ``trained`` policies (final and best, by name) of the runs that trained with a
    reverse curriculum: the widest window each run reached and its widening step."""
    names = {t.name for t in trained}
    reaches: dict[str, tuple[float, float]] = {}
    for run in runs:
        directory = run.directory(out)
        info = read_json_object(directory / RUN_FILE)
        record = info.get("curriculum")
        if not isinstance(record, dict) or record.get("kind") != "plan" or not record.get("reverse"):
            continue
        curriculum = PlanStarts.from_record(record)
        reach = (widest_window(directory / CURRICULUM_FILE, curriculum), curriculum.window)
        label = run_label(info)
        for name in (trained_name(label, run.seed), trained_name(f"{label} best", run.seed)):
            if name in names:  # the best only where the run kept one
                reaches[name] = reach
    return reaches


def pretrained_policies(config: ChainCartConfig, names: Sequence[str]) -> list[TrainedPolicy]:
    """The shipped agents among ``names`` (``pretrained:<scene>/<name>``), each loaded
    once here and checked against ``config``'s spaces (another scene with the same
    spaces is a warning)."""
    policies = []
    for name in (n for n in names if is_pretrained_slot(n)):
        agent = pretrained(*parse_pretrained_slot(name, "--policies"))
        agent.check_config(config)
        seed = agent.record.get("training", {}).get("seed")
        policies.append(TrainedPolicy(agent.label, int(seed or 0), PolicySource.pretrained(agent.scene, agent.name),
                                      shipped=True))
    return policies


def model_based_sources(
    config: ChainCartConfig, controllers: Sequence[str], sweeps: Mapping[str, Sequence[float]]
) -> dict[str, PolicySource]:
    """The model-based controllers of a study by their name in the tables, each built
    once here so that one that cannot serve the scene fails before anything runs; with
    the LQR, the oracle LQR where the true system can differ from the model. Shipped
    agents among ``controllers`` are checked here too, but are not among the sources
    (:func:`pretrained_policies` has them)."""
    pretrained_policies(config, controllers)
    sources: dict[str, PolicySource] = {}
    for name in (n for n in controllers if not is_pretrained_slot(n)):
        build_model_based(name, config)
        sources[label_of(name)] = PolicySource.model_based(name, config)
    if "lqr" in controllers and _has_parameter_gap(config, sweeps):
        sources[ORACLE] = PolicySource.lqr(config, oracle=True)
    return sources


def _aggregate_rows(summaries: Sequence[dict[str, Any]], trained: Sequence[TrainedPolicy]) -> list[dict[str, Any]]:
    by_name = {s["policy"]: s for s in summaries}
    rows = []
    for label in dict.fromkeys(t.label for t in trained):
        mine = [by_name[t.name] for t in trained if t.label == label]
        success = aggregate_over_seeds([s["success_rate"] for s in mine])
        returns = aggregate_over_seeds([s["return_mean"] for s in mine])
        rows.append(dict(
            policy=label, seeds=success.seeds, success_mean=success.mean, success_ci_low=success.ci_low,
            success_ci_high=success.ci_high, return_mean=returns.mean, return_ci_low=returns.ci_low,
            return_ci_high=returns.ci_high,
        ))
    return rows


@dataclass(frozen=True)
class EvaluationCell:
    """One policy (by its name in the tables) on one scene variant, from the study's
    seeded starts: an independent piece of the evaluation."""

    policy: str
    config: ChainCartConfig
    seeds: tuple[int, ...]


def evaluate_cell(sources: Mapping[str, PolicySource], cell: EvaluationCell) -> Rollouts:
    """The rollouts of one :class:`EvaluationCell` (``sources``: the policies by name)."""
    return rollout(sources[cell.policy].load(), cell.policy, cell.config, cell.seeds)


@dataclass(frozen=True)
class SweepPoint:
    """One value of a sweep axis and the scene variant it makes."""

    axis: str
    value: float
    config: ChainCartConfig


def _sweep_points(config: ChainCartConfig, sweeps: Mapping[str, Sequence[float]]) -> list[SweepPoint]:
    return [
        SweepPoint(axis, value, SWEEP_AXES[axis].apply(config, float(value)))
        for axis, values in sweeps.items() for value in values
    ]


def _sweep_rows(
    points: Sequence[SweepPoint], runs: Sequence[Rollouts], trained: Sequence[TrainedPolicy]
) -> list[dict[str, Any]]:
    """The rows of every sweep point (``runs``: every policy at each point in turn),
    trained policies labelled by their label and seed."""
    per_point = len(runs) // max(1, len(points))
    owner = {t.name: t for t in trained}
    rows: list[dict[str, Any]] = []
    for k, point in enumerate(points):
        rows.extend(sweep_rows(point.axis, point.value, runs[k * per_point:(k + 1) * per_point],
                               point.config.success_tolerances))
    for row in rows:
        if row["policy"] in owner:
            row["seed"], row["policy"] = owner[row["policy"]].seed, owner[row["policy"]].label
    return rows


def _standings(
    trained: Sequence[TrainedPolicy], model_based: Sequence[str], summaries: Sequence[dict[str, Any]],
    aggregates: Sequence[dict[str, Any]],
) -> tuple[list[Standing], list[Standing]]:
    """The learned policies (their final models, over seeds) and the model-based
    controllers (the oracle apart) as the verdict weighs them."""
    by_name = {s["policy"]: s for s in summaries}
    learned = []
    for aggregate in aggregates:
        if aggregate["policy"].endswith(" best"):
            continue
        first_seed = next(t for t in trained if t.label == aggregate["policy"])
        rate = main_starts_rate(by_name[first_seed.name], aggregate)
        learned.append(Standing(aggregate["policy"], int(aggregate["seeds"]), rate, aggregate["return_mean"]))
    designed = [
        Standing(name, 0, main_starts_rate(by_name[name]), by_name[name]["return_mean"])
        for name in model_based if name != ORACLE
    ]
    return learned, designed


def _evaluation_curves(out: Path, runs: Sequence[TrainingRun]) -> dict[str, dict[str, Sequence[dict[str, Any]]]]:
    """The training-time evaluations of every run that logged them, by trained policy's
    label and then by seed."""
    curves: dict[str, dict[str, Sequence[dict[str, Any]]]] = {}
    for run in runs:
        log = run.directory(out) / EVALUATIONS_FILE
        if log.is_file():
            info = read_json_object(run.directory(out) / RUN_FILE)
            label = run_label(info)
            curves.setdefault(label, {})[str(run.seed)] = read_evaluations(log)
    return curves


@dataclass(frozen=True)
class StudyEvaluation:
    """What :func:`evaluate_study` found: the summaries of the main comparison (one per
    policy and seed) and, when the verdict's baseline is model-based, its summary."""

    summaries: list[dict[str, Any]]
    baseline: Optional[dict[str, Any]]


def _title(contenders: Sequence[str], baseline: str) -> str:
    against = "the paper's LQR" if baseline == "LQR" else baseline
    return f"{' and '.join(contenders)} vs {against}" if contenders else baseline


def evaluate_study_at(address: Optional[str], out: Path, config: ChainCartConfig, *,
                      torch_threads: Optional[int] = None, **options: Any) -> StudyEvaluation:
    """:func:`evaluate_study` here (``address`` None) or with its cells as Ray tasks on the
    cluster at ``address``."""
    if address is None:
        return evaluate_study(out, config, **options)
    from chaincart_env.tools.compare.cell_runner import ray_cluster

    with ray_cluster(address, 1) as cluster:
        print(f"the evaluation cells run as Ray tasks on {cluster}")
        return evaluate_study(out, config, distributed=True, torch_threads=torch_threads, **options)


def evaluate_study(
    out: Path,
    config: ChainCartConfig,
    *,
    runs: Sequence[TrainingRun],
    model_based: Sequence[str],
    eval_seed: int,
    eval_episodes: int,
    sweeps: Mapping[str, Sequence[float]],
    into: Optional[Path] = None,
    training_notes: Sequence[str] = (),
    distributed: bool = False,
    torch_threads: Optional[int] = None,
) -> StudyEvaluation:
    """Evaluates the study in ``out`` (the agents of its training ``runs`` and the
    ``model_based`` controllers and shipped agents, by name) and writes :data:`EVALUATION_FILES` into
    ``into`` (default ``out``; :data:`TRAINING_EVALUATION_FILES` only with a trained
    agent). The main comparison has one summary per trained policy and seed, then one
    per model-based controller, then the oracle LQR where the true system can differ
    from the model. Every policy on every scene variant is one :class:`EvaluationCell`;
    ``distributed``: the cells run as Ray tasks on the connected cluster
    (:func:`~chaincart_env.tools.compare.cell_runner.map_cells`), with the same results."""
    into = Path(out) if into is None else Path(into)
    into.mkdir(parents=True, exist_ok=True)
    starts = tuple(evaluation_seeds(eval_seed, eval_episodes))
    designed = model_based_sources(config, model_based, sweeps)  # a controller that cannot serve fails here
    trained = trained_policies(out, runs) + pretrained_policies(config, model_based)
    sources = {**{t.name: t.source for t in trained}, **designed}
    points = _sweep_points(config, sweeps)
    cells = [EvaluationCell(name, variant, starts) for variant in [config] + [p.config for p in points]
             for name in sources]
    all_runs = map_cells(evaluate_cell, cells, shared=sources, distributed=distributed, torch_threads=torch_threads)
    runs_here = all_runs[: len(sources)]
    episodes, summaries = tabulate(runs_here, config.success_tolerances)
    write_csv(into / "comparison.csv", summaries, METRIC_COLUMNS)
    write_csv(into / "episodes.csv", episodes, EPISODE_COLUMNS)
    # Goal-conditioned scenes draw a pair per episode: success per pair too.
    transitions = transition_table(runs_here) if config.goal_conditioned else []
    if transitions:
        write_csv(into / TRANSITIONS_FILE, transitions, TRANSITION_COLUMNS)
    aggregates = _aggregate_rows(summaries, trained)
    if trained:
        write_csv(into / "seeds.csv", aggregates, AGGREGATE_COLUMNS)
    # Agents of a reverse curriculum: how far back along the plan they swing up from.
    bands = band_cells(config, plan_band_reaches(out, runs, trained), eval_seed)
    plan_bands = band_rows(bands, map_cells(evaluate_band_cell, bands, shared=sources, distributed=distributed,
                                            torch_threads=torch_threads)) if bands else []
    if plan_bands:
        write_csv(into / BANDS_FILE, plan_bands, BAND_COLUMNS)

    rows = _sweep_rows(points, all_runs[len(sources):], trained)
    summaries_by_axis: dict[str, tuple[str, Sequence[dict[str, Any]]]] = {}
    for axis in sweeps:
        summary = summarize_sweep([row for row in rows if row["axis"] == axis])
        summaries_by_axis[axis] = (SWEEP_AXES[axis].label, summary)
        plot_sweep(into / f"sweep_{axis}.png", summary, SWEEP_AXES[axis].label)
    write_csv(into / "sweeps.csv", rows, ("seed",) + SWEEP_COLUMNS)
    write_csv(into / "sweep_summary.csv", [r for _, rows in summaries_by_axis.values() for r in rows],
              SWEEP_SUMMARY_COLUMNS)

    learned, model = _standings(trained, list(designed), summaries, aggregates)
    verdict = study_verdict(learned, model, summaries_by_axis, eval_episodes, main_setting_values(config, sweeps))
    title = _title(verdict.contenders, verdict.baseline.label)
    tol_q, tol_w = config.success_tolerances
    notes = [
        describe(config),
        f"{eval_episodes} evaluation episodes, seeds {starts[0]}..{starts[-1]}, deterministic actions; "
        "mean ± std over episodes.",
        f"Success: the episode reaches the time limit with e_q <= {tol_q} and e_w <= {tol_w}. Time to settle: the "
        "first time after which e_q and e_w stay within these tolerances to the end (successful episodes only).",
    ]
    print(write_markdown(into / "comparison.md", title, summaries, notes))
    # One start, one row per policy: the first seed's final agent of each learned policy, each design.
    first_seed = runs[0].seed if runs else None
    shown = [t.name for t in trained if not t.label.endswith(" best") and (t.seed == first_seed or t.shipped)]
    shown += [name for name in designed if name != ORACLE]
    first_runs = [run for run in runs_here if run.policy in shown]
    plot_errors(into / "errors.png", first_runs, config.success_tolerances)
    write_filmstrip(into / "filmstrip.png", first_runs, config)

    curves = _evaluation_curves(out, runs)
    by_name = {s["policy"]: s for s in summaries}
    references = [by_name[name] for name in designed if name != ORACLE]
    if trained:  # (an RLlib run logs no evaluations during training: the baselines alone)
        plot_evaluation_curves(into / "evaluation_curve.png", curves, references)
    write_summary_figure(into / SUMMARY_FIGURE, curves=curves, baselines=references, sweeps=summaries_by_axis,
                         errors=first_runs, tolerances=config.success_tolerances, filmstrip=into / "filmstrip.png")
    print("\n".join(["", "Verdict:", *verdict.lines]))
    write_report(
        into, title=title, verdict=verdict.lines,
        setup=notes + seed_lines(aggregates), comparison=summaries,
        sweeps=summaries_by_axis, training=training_notes, transitions=transitions, plan_bands=plan_bands,
        pictures=[(SUMMARY_FIGURE, "summary"), ("evaluation_curve.png", "deterministic evaluation during training"),
                  *[(f"sweep_{axis}.png", f"success vs {SWEEP_AXES[axis].label}") for axis in sweeps],
                  ("errors.png", "e_q(t) and e_w(t) from the first start"),
                  ("filmstrip.png", "the first start, one row per policy")],
    )
    baseline = verdict.baseline
    return StudyEvaluation(summaries, by_name.get(baseline.label) if baseline.seeds == 0 else None)
