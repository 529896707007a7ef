"""The main job: train every learned policy once per training seed, evaluate the agents
and the model-based controllers (on the main starts and over the sweeps), report;
resume an interrupted run; re-run the evaluation of a saved run.

A run directory holds ``config.json``, ``run.json`` (the settings, a ``status`` and
per-training-run progress), one folder per learned algorithm and training seed (the
agent, its best model by evaluation, logs, checkpoints: ``seed-<s>/`` when one
algorithm is learned, ``<algo>/seed-<s>/`` when several are; see
:mod:`~chaincart_env.tools.compare.layout`) and the study's tables and pictures
(:data:`chaincart_env.tools.compare.study.EVALUATION_FILES`).

``run.json``'s ``status`` is ``training``, ``evaluating``, ``done``, ``interrupted``
(Ctrl-C or SIGTERM: everything produced so far stays, and ``compare --resume RUN``
continues) or ``failed`` (with the error).
"""

from __future__ import annotations

import json
import platform
import signal
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Iterator, Mapping, Optional, Sequence

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.cell_runner import map_cells
from chaincart_env.tools.compare.imitation import SCENE_IMITATIONS, scene_imitation
from chaincart_env.tools.compare.layout import TrainingRun, training_runs
from chaincart_env.tools.compare.learning_curve import (
    EPISODES_FILE,
    LEARNING_CURVE_COLUMNS,
    learning_curve,
    read_learning_curve,
    read_training_episodes,
)  # fmt: skip
from chaincart_env.tools.compare.policy_sources import load_run
from chaincart_env.tools.compare.recipes import GENERIC, recipe_for, training_conditions
from chaincart_env.tools.compare.run_files import CONFIG_FILE, RUN_FILE, folder_contents, save_run, write_folder
from chaincart_env.tools.compare.shaping import Shaping, scene_shaping
from chaincart_env.tools.compare.study import (
    EVALUATION_FILES,
    StudyEvaluation,
    conditional_files_in,
    describe,
    evaluate_study,
    evaluate_study_at,
    lqr_baseline,
    model_based_sources,
    policy_label,
    run_label,
)  # fmt: skip
from chaincart_env.tools.compare.study_plots import plot_learning_curve
from chaincart_env.tools.compare.sweeps import DEFAULT_SWEEPS, SWEEP_AXES
from chaincart_env.tools.compare.tables import write_csv
from chaincart_env.tools.controllers import CONTROLLERS, LEARNED, parse_controllers

__all__ = [
    "DEFAULT_POLICIES", "DEFAULT_SWEEPS", "EVALUATION_FILES", "OUTPUT_FILES", "SEED_FILES", "TRAINERS", "SeedCell",
    "SeedTraining", "StudySettings", "cluster_address", "lqr_baseline", "policy_label", "resume_compare",
    "run_compare", "run_evaluate", "train_seed_cell",
]  # fmt: skip

#: The policies of a study unless told otherwise: PPO against the paper's LQR.
DEFAULT_POLICIES = ("ppo", "lqr")

#: The trainers of compare: stable-baselines3 on one machine, Ray RLlib on a cluster.
TRAINERS = ("sb3", "rllib")
#: What compare writes at the top of the run directory.
OUTPUT_FILES = EVALUATION_FILES + (CONFIG_FILE, RUN_FILE)
#: What each ``seed-<s>/`` folder holds after training with stable-baselines3.
SEED_FILES = (
    "model.zip", "best_model.zip", "config.json", "run.json", "training_episodes.csv", "evaluations.csv",
    "learning_curve.csv", "learning_curve.png",
)


class StudySettings(dict):  # type: ignore[type-arg]
    """The settings of a run as saved in ``run.json`` (a plain dict with checks). Runs
    saved before several policies could be compared name one ``algo`` (compared with
    the LQR) and keep its ``timesteps``, ``num_envs`` and ``hyperparameters`` at the top
    level; they read the same through the methods below."""

    @classmethod
    def checked(cls, **settings: Any) -> "StudySettings":
        """The settings, each checked (policies, seeds, trainer, sweep axes, counts), or an
        error naming the bad one."""
        seeds = settings["seeds"]
        if not seeds or len(set(seeds)) != len(seeds) or any(
            isinstance(s, bool) or not isinstance(s, int) or s < 0 for s in seeds
        ):
            raise InvalidInputError(f"seeds = {seeds!r}: expected distinct integers >= 0, at least one")
        if settings["trainer"] not in TRAINERS:
            raise InvalidInputError(f"trainer = {settings['trainer']!r}: expected one of {list(TRAINERS)}")
        checked = cls(settings)
        if settings["trainer"] == "rllib" and checked.learned() not in ([], ["ppo"]):
            raise InvalidInputError(
                f"--trainer rllib with {', '.join(checked.learned())}: the RLlib trainer offers ppo only"
            )
        for axis in settings["sweeps"]:
            if axis not in SWEEP_AXES:
                raise InvalidInputError(f"sweep axis {axis!r}: expected one of {sorted(SWEEP_AXES)}")
        address = settings.get("address")
        if address is not None and (not isinstance(address, str) or not address.strip()):
            raise InvalidInputError(f"address = {address!r}: expected 'local', 'auto' or HOST:PORT of a Ray cluster")
        counts = [(key, settings[key]) for key in ("eval_every", "checkpoint_every", "eval_starts")]
        counts += [(f"{algo} timesteps", checked.training(algo)["timesteps"]) for algo in checked.learned()]
        counts += [(f"{algo} num_envs", checked.training(algo)["num_envs"]) for algo in checked.learned()]
        for key, value in counts:
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise InvalidInputError(f"{key} = {value!r}: expected an integer >= 1")
        return checked

    def policies(self) -> list[str]:
        """The compared controllers' names, as given."""
        return list(self.get("policies") or [self["algo"], "lqr"])

    def learned(self) -> list[str]:
        """The learned algorithms, in the order given."""
        return [name for name in self.policies() if name in LEARNED]

    def model_based(self) -> list[str]:
        """The model-based controllers, in the order given."""
        return [name for name in self.policies() if name not in LEARNED]

    def training(self, algo: str) -> dict[str, Any]:
        """How ``algo`` trains: ``timesteps``, ``num_envs``, ``hyperparameters`` (and
        ``normalize``, the recipe's ``VecNormalize`` keywords or ``None``)."""
        if "training" in self:
            return dict(self["training"][algo])
        return {key: self[key] for key in ("timesteps", "num_envs", "hyperparameters")}

    def runs(self) -> list[TrainingRun]:
        """Every training run of the study, algorithm by algorithm."""
        return training_runs(self.learned(), self["seeds"])


def _write_json(path: Path, data: dict[str, Any]) -> None:
    staging = path.with_suffix(".tmp")
    staging.write_text(json.dumps(data, indent=2, default=repr) + "\n")
    staging.replace(path)


def _set_status(out: Path, run: dict[str, Any], status: str, **extra: Any) -> None:
    run.update(status=status, **extra)
    _write_json(out / RUN_FILE, run)


@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM ends the run the way Ctrl-C does (``KeyboardInterrupt``)."""

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt(f"signal {signum}")

    try:
        previous = signal.signal(signal.SIGTERM, interrupt)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _set_torch_threads(threads: Optional[int]) -> None:
    if threads is not None:
        import torch

        torch.set_num_threads(threads)


def _train_seed(config: ChainCartConfig, out: Path, run: TrainingRun, settings: StudySettings, resume: bool) -> dict[str, Any]:
    """Trains one algorithm with one seed into its folder and saves it; returns its
    record for run.json."""
    directory = run.directory(out)
    directory.mkdir(parents=True, exist_ok=True)
    algo, seed, training = run.algo, run.seed, settings.training(run.algo)
    timesteps = training["timesteps"]
    if settings["trainer"] == "rllib":
        result, trained = _train_rllib(config, directory, seed, settings, resume)
    else:
        warm_start_from = training.get("warm_start")
        stage = training.get("first_stage")
        if stage is not None:
            from chaincart_env.tools.compare.stages import FIRST_STAGE_DIR, first_stage

            base = TrainingRun(stage["algo"], seed, run.shared)
            # The study's own agent of the base algorithm is the first stage (not so for a polish).
            reusable = base.directory(out) if stage["algo"] != algo and stage["algo"] in settings.learned() else None
            warm_start_from = str(first_stage(
                directory,
                lambda folder: _train_sb3(config, folder, stage["algo"], seed, stage, settings, resume,
                                          stage.get("warm_start")),
                existing=reusable, name=stage.get("folder", FIRST_STAGE_DIR),
            ))
        result, trained = _train_sb3(config, directory, algo, seed, training, settings, resume, warm_start_from)
    print(f"{policy_label(algo)} seed {seed}: trained in {result.wall_time_s:.1f} s ({result.episodes} training episodes)")
    info = dict(trainer=settings["trainer"], algo=algo, timesteps=timesteps, seed=seed,
                eval_seed=settings["eval_seed"], eval_episodes=settings["eval_episodes"],
                hyperparameters=result.hyperparameters, training_wall_time_s=round(result.wall_time_s, 2),
                training_episodes=result.episodes, **trained)
    save_run(directory, result.model, config, info)
    # Binned over the steps actually trained (SB3 rounds up to whole rollouts).
    curve = learning_curve(read_training_episodes(directory / EPISODES_FILE), info["timesteps_trained"])
    write_csv(directory / "learning_curve.csv", curve, LEARNING_CURVE_COLUMNS)
    return info


def _train_sb3(
    config: ChainCartConfig, directory: Path, algo: str, seed: int, training: Mapping[str, Any],
    settings: StudySettings, resume: bool, warm_start_from: Optional[str] = None,
) -> tuple[Any, dict[str, Any]]:
    """Trains ``algo`` with stable-baselines3 as ``training`` says into ``directory``
    (from the agent at ``warm_start_from`` if given); the result and its record."""
    from chaincart_env.tools.compare.training import train

    timesteps = training["timesteps"]
    eval_starts = list(range(settings["eval_seed"], settings["eval_seed"] + settings["eval_starts"]))
    print(f"training {policy_label(algo)} for {timesteps} timesteps on {training['num_envs']} envs, seed {seed} -> "
          f"{directory}")
    result = train(config, algo=algo, timesteps=timesteps, seed=seed, num_envs=training["num_envs"],
                   directory=directory, eval_seeds=eval_starts, eval_every=settings["eval_every"],
                   checkpoint_every=settings["checkpoint_every"], progress_bar=settings["progress_bar"],
                   hyperparameters=training["hyperparameters"], resume=resume,
                   normalize=training.get("normalize"), imitation=_imitation(training),
                   curriculum=_curriculum(training), training_reward=training.get("training_reward"),
                   history=training.get("history"), conditions=training.get("conditions"),
                   shaping=_shaping(training), mirror_weight=training.get("mirror_weight", 0.0),
                   warm_start_from=None if warm_start_from is None else Path(warm_start_from),
                   elapsed_time=training.get("elapsed_time", False), residual=training.get("residual"))
    trained = dict(timesteps_trained=int(result.model.num_timesteps), num_envs=training["num_envs"],
                   resumed_from=result.resumed_from, evaluations=result.evaluations,
                   normalize=training.get("normalize"), imitation=result.imitation,
                   curriculum=training.get("curriculum"), training_reward=training.get("training_reward"),
                   history=training.get("history"), conditions=training.get("conditions"),
                   shaping=_shaping(training).record(), mirror_weight=training.get("mirror_weight", 0.0),
                   warm_start_from=warm_start_from, elapsed_time=training.get("elapsed_time", False),
                   residual=training.get("residual"))
    return result, trained


def _shaping(training: Mapping[str, Any]) -> Shaping:
    """The shaping a run's settings record (an older run's: its off-track penalty alone)."""
    if "shaping" in training:
        return Shaping.from_record(training["shaping"])
    return Shaping(off_track_penalty=training.get("off_track_penalty", 0.0))


def _imitation(training: Mapping[str, Any]) -> Any:
    from chaincart_env.tools.compare.imitation import Imitation

    record = training.get("imitation")
    return None if record is None else Imitation.from_record(record)


def _curriculum(training: Mapping[str, Any]) -> Any:
    from chaincart_env.tools.compare.curriculum import PlanStarts

    record = training.get("curriculum")
    return None if record is None else PlanStarts.from_record(record)


def _chosen_curriculum(config: ChainCartConfig, trainer: str, curriculum: Any) -> Optional[dict[str, Any]]:
    """The curriculum record of the study's SB3 training: the scene's for ``"scene"``, none
    for ``None`` or ``"none"``, else ``curriculum`` (a ``PlanStarts``), checked against the
    scene and the trainer."""
    from chaincart_env.tools.compare.curriculum import PlanStarts, check_plan_scene, scene_curriculum

    if curriculum == "scene":
        chosen = scene_curriculum(config.scene) if trainer == "sb3" else None
        return None if chosen is None else chosen.record()
    if curriculum is None or curriculum == "none":
        return None
    if not isinstance(curriculum, PlanStarts):
        raise InvalidInputError(f"curriculum = {curriculum!r}: expected 'scene', 'none' or PlanStarts(...)")
    if trainer != "sb3":
        raise InvalidInputError(f"--curriculum {curriculum.name} with --trainer {trainer}: plan starts are built for "
                                "the sb3 trainer")
    check_plan_scene(config)
    return curriculum.record()


def _train_rllib(
    config: ChainCartConfig, directory: Path, seed: int, settings: StudySettings, resume: bool
) -> tuple[Any, dict[str, Any]]:
    """Trains PPO with Ray RLlib into ``directory``; returns the result and its record."""
    try:
        import ray.rllib  # noqa: F401
    except ImportError as error:
        raise InvalidInputError(
            f"--trainer rllib needs Ray RLlib ({error}): install the rllib extra, pip install 'chaincart-env[rllib]'"
        ) from None
    from chaincart_env.tools.compare.rllib_training import CHECKPOINT_DIR, train_rllib

    rllib, training = settings["rllib"], settings.training("ppo")
    runners, per_runner = rllib["num_env_runners"], rllib["envs_per_runner"]
    print(f"training PPO with RLlib for {training['timesteps']} timesteps on {runners} env runner(s) x "
          f"{per_runner} envs, seed {seed} -> {directory}")
    result = train_rllib(config, timesteps=training["timesteps"], seed=seed, num_env_runners=runners,
                         envs_per_runner=per_runner, address=cluster_address(settings), directory=directory,
                         checkpoint=directory / CHECKPOINT_DIR, checkpoint_every=settings["checkpoint_every"],
                         resume=resume, progress=settings["progress_bar"],
                         hyperparameters=training["hyperparameters"])
    info = dict(timesteps_trained=result.timesteps_trained, num_env_runners=runners, envs_per_runner=per_runner,
                num_envs=runners * per_runner, training_iterations=result.iterations, cluster=result.cluster,
                runner_nodes=result.runner_nodes, runner_restarts=result.runner_restarts,
                resumed_from=result.resumed_from)
    return result, info


def _training_notes(run: dict[str, Any]) -> list[str]:
    notes = []
    for info in run["seed_runs"].values():
        evaluations = info.get("evaluations") or {}
        best = evaluations.get("best")
        line = (f"{run_label(info)}, seed {info['seed']}: "
                f"{info['timesteps_trained']} timesteps in {info['training_wall_time_s']} s of training "
                f"({info['training_episodes']} training episodes)")
        if best:
            line += (f"; best deterministic evaluation at {int(best['timesteps'])} timesteps "
                     f"(success {best['success_rate']:.2f}, return {best['return_mean']:.1f}, "
                     f"{int(best['episodes'])} starts)")
        notes.append(line + ".")
    return notes


def cluster_address(settings: dict[str, Any]) -> Optional[str]:
    """The Ray cluster a run uses (``None``: none, or for RLlib a local one per seed);
    runs saved before the study could be distributed kept it with the RLlib settings."""
    return settings.get("address", settings.get("rllib", {}).get("address"))


def _study(config: ChainCartConfig, out: Path, run: dict[str, Any], resume: bool) -> StudyEvaluation:
    settings = StudySettings(run["settings"])
    address = cluster_address(settings)
    if address is None:
        return _train_and_evaluate(config, out, run, resume, distributed=False)
    from chaincart_env.tools.compare.cell_runner import ray_cluster

    runners = settings["rllib"]["num_env_runners"] if settings["trainer"] == "rllib" else 1
    with ray_cluster(address, max(1, runners)) as cluster:
        print(f"the study's training runs and evaluation cells run as Ray tasks on {cluster}")
        run["cluster"] = cluster
        return _train_and_evaluate(config, out, run, resume, distributed=True)


def _train_and_evaluate(
    config: ChainCartConfig, out: Path, run: dict[str, Any], resume: bool, distributed: bool
) -> StudyEvaluation:
    settings = StudySettings(run["settings"])
    pending = [r for r in settings.runs() if r.key not in run["seed_runs"]]  # others trained before
    if distributed and settings["trainer"] == "sb3":
        _train_runs_as_tasks(config, out, run, pending, resume)
    else:  # one after the other (RLlib spreads each seed's sampling over the cluster itself)
        for training in pending:
            _set_status(out, run, "training", training_seed=training.seed, training_algo=training.algo)
            run["seed_runs"][training.key] = _train_seed(config, out, training, settings, resume)
            _set_status(out, run, "training")
    _set_status(out, run, "evaluating")
    evaluation = evaluate_study(out, config, runs=settings.runs(), model_based=settings.model_based(),
                                eval_seed=settings["eval_seed"], eval_episodes=settings["eval_episodes"],
                                sweeps=settings["sweeps"], training_notes=_training_notes(run),
                                distributed=distributed, torch_threads=settings.get("torch_threads"))
    for training in settings.runs():
        directory = training.directory(out)
        curve_csv = directory / "learning_curve.csv"
        if curve_csv.is_file():
            plot_learning_curve(directory / "learning_curve.png", read_learning_curve(curve_csv),
                                policy_label(training.algo, settings["trainer"]), evaluation.baseline)
    return evaluation


@dataclass(frozen=True)
class SeedTraining:
    """What every training-seed task shares: the scene and the run's settings."""

    config: ChainCartConfig
    settings: StudySettings


@dataclass(frozen=True)
class SeedCell:
    """One training run as a task: its folder's files so far (a checkpoint to resume
    from, when ``resume``)."""

    run: TrainingRun
    resume: bool
    files: dict[str, bytes]


def train_seed_cell(job: SeedTraining, cell: SeedCell) -> tuple[dict[str, Any], dict[str, bytes]]:
    """Trains one run in a scratch folder (of the machine the task runs on) exactly as
    the serial study does, and returns its run.json record and its folder's files."""
    with tempfile.TemporaryDirectory(prefix="chaincart-seed-") as scratch:
        directory = cell.run.directory(Path(scratch))
        write_folder(directory, cell.files)
        info = _train_seed(job.config, Path(scratch), cell.run, job.settings, cell.resume)
        return info, folder_contents(directory)


def _train_runs_as_tasks(
    config: ChainCartConfig, out: Path, run: dict[str, Any], runs: Sequence[TrainingRun], resume: bool
) -> None:
    """SB3 training runs as Ray tasks; each run's folder is written here as it finishes."""
    settings = StudySettings(run["settings"])
    job = SeedTraining(config, StudySettings({**settings, "progress_bar": False}))
    cells = [SeedCell(r, resume, folder_contents(r.directory(out)) if resume else {}) for r in runs]

    def save(index: int, result: tuple[dict[str, Any], dict[str, bytes]]) -> None:
        info, files = result
        write_folder(runs[index].directory(out), files)
        run["seed_runs"][runs[index].key] = info
        # In the order of the study's runs, as a serial study records them.
        run["seed_runs"] = {r.key: run["seed_runs"][r.key] for r in settings.runs() if r.key in run["seed_runs"]}
        _set_status(out, run, "training")

    _set_status(out, run, "training", training_seeds=[r.key for r in runs])
    map_cells(train_seed_cell, cells, shared=job, distributed=True, torch_threads=settings.get("torch_threads"),
              on_result=save)


def _run(config: ChainCartConfig, out: Path, run: dict[str, Any], resume: bool) -> list[dict[str, Any]]:
    _set_torch_threads(run["settings"].get("torch_threads"))
    start = time.perf_counter()
    print(describe(config))
    try:
        with _sigterm_as_interrupt():
            summaries = _study(config, out, run, resume).summaries
    except KeyboardInterrupt:
        _set_status(out, run, "interrupted", resume_with=f"python -m chaincart_env compare --resume {out}")
        print(f"interrupted: what was produced is in {out}; continue with `compare --resume {out}`")
        raise
    except Exception as error:
        _set_status(out, run, "failed", error=f"{type(error).__name__}: {error}")
        raise
    total = time.perf_counter() - start
    run["wall_time_s"] = round(run.get("wall_time_s", 0.0) + total, 2)
    _set_status(out, run, "done")
    folders = " and a folder per training run" if StudySettings(run["settings"]).learned() else ""
    written = OUTPUT_FILES + conditional_files_in(out)
    print(f"wall time {total:.1f} s; wrote {', '.join(written)}{folders} in {out}")
    return summaries


def _training_settings(
    config: ChainCartConfig, learned: Sequence[str], trainer: str, timesteps: Optional[int], num_envs: Optional[int],
    hyperparameters: Mapping[str, Any], algo_hyperparameters: Mapping[str, Mapping[str, Any]],
    imitation: Any = True, curriculum: Any = "scene", training_reward: Optional[str] = "scene",
    history: Optional[int] = None, shaping: Optional[Mapping[str, Optional[float]]] = None,
    warm_start_from: Optional[Path] = None, polish: Any = None, mirror_weight: float = 0.0,
) -> dict[str, dict[str, Any]]:
    """How each learned algorithm trains: its recipe for the scene (SB3's defaults
    without one, and with RLlib), then the budget, envs and keywords given for every
    algorithm, then those given for it alone; with ``imitation``, the scene's imitation
    of the planner first (SB3 only; ``None`` where the scene has none), ``True`` as the
    scene has it or a mapping of :class:`~chaincart_env.tools.compare.imitation.Imitation`
    fields changed (e.g. ``{"critic_warmup": 500_000}``); ``curriculum``: see
    :func:`_chosen_curriculum`; ``polish`` (``timesteps`` and an optional
    ``learning_rate``, or ``"scene"``): a second stage of each nominal algorithm
    (:func:`~chaincart_env.tools.compare.stages.chosen_polish`, ``polish_stage``);
    ``mirror_weight``: the mirror loss beside PPO's (SB3 PPO agents only)."""
    unknown = sorted(set(algo_hyperparameters) - set(learned))
    if unknown:
        raise InvalidInputError(
            f"keywords for {', '.join(unknown)}: expected a learned algorithm of the study, one of {list(learned)}"
        )
    out = {}
    chosen_curriculum = _chosen_curriculum(config, trainer, curriculum) if learned else None
    # What a residual agent takes: only what was given, none of the scene's defaults.
    given_curriculum = chosen_curriculum if curriculum != "scene" else None
    given_reward = training_reward if training_reward != "scene" else None
    if training_reward == "scene":
        from chaincart_env.tools.compare.curriculum import scene_training_reward

        training_reward = scene_training_reward(config.scene) if trainer == "sb3" else None
    if training_reward is not None and learned:
        if trainer != "sb3":
            raise InvalidInputError(f"--training-reward {training_reward} with --trainer {trainer}: expected the sb3 "
                                    "trainer")
        from chaincart_env.tools.compare.training import training_config

        training_config(config, training_reward)  # an unknown reward fails before training
    given_shaping = Shaping().with_overrides(**(shaping or {}))
    if given_shaping and trainer != "sb3" and learned:
        raise InvalidInputError(f"{' '.join(given_shaping.given())} with --trainer {trainer}: expected the sb3 trainer")
    chosen_shaping = scene_shaping(config.scene).with_overrides(**(shaping or {})) if trainer == "sb3" else Shaping()
    if chosen_shaping.follows_plan and learned:
        from chaincart_env.tools.compare.curriculum import check_plan_scene

        check_plan_scene(config)  # a scene without one plan fails before training
    if warm_start_from is not None and learned:
        if trainer != "sb3":
            raise InvalidInputError(f"--warm-start with --trainer {trainer}: expected the sb3 trainer")
        from chaincart_env.tools.compare.warm_start import agent_file

        warm_start_from = agent_file(Path(warm_start_from)).resolve()  # a missing agent fails before training
    from chaincart_env.tools.compare.mirror_loss import MIRROR_ALGOS, check_mirror_weight

    mirror_weight = check_mirror_weight(mirror_weight)
    if learned and mirror_weight:
        refused = [algo for algo in learned if trainer != "sb3" or CONTROLLERS[algo].recipe_algorithm not in MIRROR_ALGOS]
        if refused:
            raise InvalidInputError(f"--mirror-weight {mirror_weight} for {', '.join(refused)} with --trainer "
                                    f"{trainer}: expected agents of {list(MIRROR_ALGOS)} trained with sb3")
    if history is not None and trainer != "sb3" and learned:
        raise InvalidInputError(f"--history {history} with --trainer {trainer}: expected the sb3 trainer")
    from chaincart_env.tools.compare.stages import chosen_polish

    scene_default = polish == "scene"
    polish = chosen_polish(config.scene, polish, timesteps)
    if polish is not None and trainer != "sb3" and learned:
        if not scene_default:
            raise InvalidInputError(f"--polish with --trainer {trainer}: expected the sb3 trainer")
        polish = None  # a scene's polish is a setting of SB3 training

    def one(algo: str) -> dict[str, Any]:
        recipe = recipe_for(config.scene, algo) if trainer == "sb3" else GENERIC
        conditions = training_conditions(algo, recipe, config)
        if conditions is not None and trainer != "sb3":
            raise InvalidInputError(f"{algo} with --trainer {trainer}: expected the sb3 trainer")
        keywords = {**recipe.hyperparameters, **hyperparameters, **algo_hyperparameters.get(algo, {})}
        if trainer == "sb3":
            from chaincart_env.tools.compare.training import check_keywords

            check_keywords(algo, keywords)
        seen = recipe.history if history is None else history
        # The imitation's learner observes what the agent does (history, elapsed time).
        warm_start = scene_imitation(config.scene, algo) if imitation and trainer == "sb3" else None
        if warm_start is not None and isinstance(imitation, Mapping):
            warm_start = replace(warm_start, **imitation)
        scene_methods = CONTROLLERS[algo].takes_scene_methods
        starts = chosen_curriculum if scene_methods else given_curriculum
        for key, option in (("freeze_statistics", "--curriculum-freeze-statistics"),
                            ("spread_floor", "--curriculum-spread-floor")):
            if starts is not None and starts.get(key) and recipe.normalize is None:
                raise InvalidInputError(f"{option} for {algo}, whose recipe ({recipe.source}) does not normalise "
                                        "observations: expected a recipe with normalize")
        return dict(timesteps=recipe.timesteps if timesteps is None else timesteps,
                    num_envs=recipe.num_envs if num_envs is None else num_envs,
                    hyperparameters=keywords, recipe=recipe.source, normalize=recipe.normalize,
                    imitation=None if warm_start is None else warm_start.record(),
                    curriculum=starts,
                    training_reward=training_reward if scene_methods else given_reward, history=seen,
                    conditions=conditions, elapsed_time=recipe.elapsed_time, residual=recipe.residual,
                    shaping=(chosen_shaping if scene_methods else given_shaping).record(),
                    mirror_weight=float(mirror_weight),
                    warm_start=None if warm_start_from is None else str(warm_start_from))

    for algo in learned:
        out[algo] = one(algo)
    if isinstance(imitation, Mapping) and imitation and not any(out[algo]["imitation"] for algo in out):
        given_options = ", ".join(f"{key} = {value!r}" for key, value in imitation.items())
        raise InvalidInputError(
            f"{given_options}: settings of an imitation, expected a PPO agent of a scene whose recipe imitates the "
            f"planner first ({', '.join(SCENE_IMITATIONS)})"
        )
    for algo in learned:
        base = CONTROLLERS[algo].recipe_algorithm
        if CONTROLLERS[algo].fine_tunes and warm_start_from is None:  # its algorithm's nominal agent first
            out[algo]["first_stage"] = {**one(base), "algo": base}
        elif polish is not None and base == algo:  # a variant is a fine-tuning or a residual already
            from chaincart_env.tools.compare.stages import polish_stage

            out[algo] = polish_stage(algo, out[algo], polish["timesteps"], polish.get("learning_rate"))
    return out


def run_compare(
    config: ChainCartConfig,
    *,
    out: Path,
    policies: Optional[Sequence[str]] = None,
    algo: str = "ppo",
    timesteps: Optional[int] = None,
    seeds: Sequence[int] = (0,),
    num_envs: Optional[int] = None,
    eval_episodes: int = 50,
    eval_seed: int = 1_000_000,
    sweeps: Optional[Mapping[str, Sequence[float]]] = None,
    eval_every: int = 20_000,
    eval_starts: int = 20,
    checkpoint_every: int = 50_000,
    progress_bar: bool = True,
    torch_threads: Optional[int] = None,
    hyperparameters: Optional[Mapping[str, Any]] = None,
    algo_hyperparameters: Optional[Mapping[str, Mapping[str, Any]]] = None,
    trainer: str = "sb3",
    rllib: Optional[dict[str, Any]] = None,
    address: Optional[str] = None,
    imitation: Any = True,
    curriculum: Any = "scene",
    training_reward: Optional[str] = "scene",
    history: Optional[int] = None,
    shaping: Optional[Mapping[str, Optional[float]]] = None,
    warm_start_from: Optional[Path] = None,
    polish: Any = "scene",
    mirror_weight: float = 0.0,
) -> list[dict[str, Any]]:
    """Trains every learned policy of ``policies`` (names of
    :data:`~chaincart_env.tools.controllers.CONTROLLERS`, e.g. ``["ppo", "sac", "lqr",
    "mpc"]``; default ``[algo, "lqr"]``) on ``config`` once per training seed, evaluates
    every agent and every model-based controller on ``eval_episodes`` seeded starts and
    over ``sweeps`` (default :data:`DEFAULT_SWEEPS`), and writes the study into ``out``;
    returns the main comparison's summaries.

    Each learned algorithm trains with the scene's recipe
    (:func:`~chaincart_env.tools.compare.recipes.recipe_for`); ``timesteps``,
    ``num_envs`` and ``hyperparameters`` override it for every algorithm,
    ``algo_hyperparameters`` (``{"sac": {"learning_starts": 100}}``) for one.
    ``trainer="rllib"`` trains PPO with Ray RLlib (``rllib = {"num_env_runners": ...,
    "envs_per_runner": ...}``). ``address``: a Ray cluster (``"local"``: a new one on
    this machine) on which the study's independent pieces (SB3 training runs,
    evaluation cells) run as Ray tasks, with the same results as without it; RLlib's
    env runners run there too. ``imitation=False`` trains from scratch where the scene's
    PPO recipe starts from an imitation of the planner
    (:data:`~chaincart_env.tools.compare.imitation.SCENE_IMITATIONS`); a mapping changes
    fields of that imitation (``{"critic_warmup": 500_000, "anchor_weight": 1.0}``: how
    the training keeps it, :mod:`~chaincart_env.tools.compare.anchoring`). ``curriculum``: where
    the SB3 training episodes start: ``"scene"`` (the scene's curriculum,
    :data:`~chaincart_env.tools.compare.curriculum.SCENE_CURRICULA`, none on most scenes),
    ``None`` (the scene's starts only) or a
    :class:`~chaincart_env.tools.compare.curriculum.PlanStarts` (a share of them along the
    planner's plan). ``training_reward``: the SB3 training envs reward with it (``"exp"``
    or ``"tolerance"``) instead of the scene's; ``"scene"`` (the default): the scene's
    training reward (:data:`~chaincart_env.tools.compare.curriculum.SCENE_TRAINING_REWARDS`),
    its own reward on most scenes. ``shaping``: terms of the SB3 training reward's shaping
    (:class:`~chaincart_env.tools.compare.shaping.Shaping`'s fields, e.g.
    ``{"off_track_penalty": 10.0, "plan_bonus": 0.3}``) on top of the scene's
    (:data:`~chaincart_env.tools.compare.shaping.SCENE_SHAPING`); a term given ``None`` keeps the scene's.
    ``warm_start_from``: every learned agent starts from the weights of the agent saved
    there (a model file or a training run's folder; same algorithm and spaces).
    ``polish``: ``{"timesteps": steps}`` (and optionally ``"learning_rate"``): each
    nominal learned agent then trains ``steps`` more from its best model at a tenth of
    its learning rate (:func:`~chaincart_env.tools.compare.stages.polish_stage`);
    ``"scene"`` (the default): the scene's polish
    (:data:`~chaincart_env.tools.compare.stages.SCENE_POLISH`, none on most scenes) when
    ``timesteps`` is the recipe's;
    ``None``: none. ``mirror_weight``: the weight of a mirror-symmetry loss beside PPO's
    (:mod:`~chaincart_env.tools.compare.mirror_loss`; SB3 PPO agents), 0 for none.
    Every evaluation keeps the scene."""
    from chaincart_env.tools.compare.evaluation import evaluation_seeds

    names = parse_controllers(",".join(policies) if policies is not None else f"{algo},lqr")
    learned = [name for name in names if name in LEARNED]
    runners = {"num_env_runners": 2, "envs_per_runner": 4, **(rllib or {})}
    given = runners.pop("address", None)  # where it was before the study could be distributed
    chosen_sweeps = {k: list(v) for k, v in (DEFAULT_SWEEPS if sweeps is None else sweeps).items()}
    settings = StudySettings.checked(
        policies=names, seeds=list(seeds), eval_episodes=eval_episodes, eval_seed=eval_seed, sweeps=chosen_sweeps,
        eval_every=eval_every, eval_starts=eval_starts, checkpoint_every=checkpoint_every, progress_bar=progress_bar,
        torch_threads=torch_threads, trainer=trainer, rllib=runners, address=given if address is None else address,
        training=_training_settings(config, learned, trainer, timesteps, num_envs, dict(hyperparameters or {}),
                                    dict(algo_hyperparameters or {}), imitation, curriculum, training_reward,
                                    history, shaping, warm_start_from, polish, mirror_weight),
    )
    evaluation_seeds(eval_seed, eval_episodes)  # bad evaluation settings fail before training
    model_based_sources(config, settings.model_based(), chosen_sweeps)  # so does a controller that cannot serve
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / CONFIG_FILE).write_text(json.dumps(config.to_dict(), indent=2) + "\n")
    run = dict(
        status="training", settings=settings, seed_runs={},
        machine=f"{platform.machine()}, {platform.python_implementation()} {platform.python_version()}",
    )
    return _run(config, out, run, resume=False)


def resume_compare(out: Path, address: Optional[str] = None) -> list[dict[str, Any]]:
    """Continues the run in ``out`` where it stopped: seeds already trained are kept, an
    interrupted seed continues from its last checkpoint (an SB3 seed ending as it would
    have without the interruption; an RLlib seed as described in
    :func:`~chaincart_env.tools.compare.rllib_training.train_rllib`), the rest train, then the
    study is evaluated. ``address`` replaces the run's Ray cluster (e.g. a new one)."""
    out = Path(out)
    if not (out / RUN_FILE).is_file() or not (out / CONFIG_FILE).is_file():
        raise InvalidInputError(f"--resume {out}: expected a run directory of compare (with {RUN_FILE} and {CONFIG_FILE})")
    run = json.loads((out / RUN_FILE).read_text())
    if "settings" not in run or "seed_runs" not in run:
        raise InvalidInputError(f"--resume {out}: {RUN_FILE} is not that of a compare study")
    config = ChainCartConfig(**json.loads((out / CONFIG_FILE).read_text()))
    if address is not None:
        run["settings"]["address"] = address
    print(f"resuming {out} (status {run.get('status')!r}, runs trained: {sorted(run['seed_runs']) or 'none'})")
    return _run(config, out, run, resume=True)


def _study_directory(seed_folder: Path) -> Optional[Path]:
    """The run directory a training run's folder belongs to (``seed-<s>/`` or
    ``<algo>/seed-<s>/`` in it), if any."""
    for candidate in (seed_folder.parent, seed_folder.parent.parent):
        if (candidate / RUN_FILE).is_file() and "settings" in json.loads((candidate / RUN_FILE).read_text()):
            return candidate
    return None


def run_evaluate(
    path: Path,
    *,
    out: Optional[Path] = None,
    eval_episodes: Optional[int] = None,
    eval_seed: Optional[int] = None,
    torch_threads: Optional[int] = None,
    address: Optional[str] = None,
) -> list[dict[str, Any]]:
    """Re-runs the evaluation of a saved run (same starts and sweeps unless told
    otherwise) into ``out`` (default ``<run>/evaluation``): a whole study directory, or
    one training run's folder or model file (then that agent alone against the study's
    model-based controllers, on the evaluation starts). ``address``: the evaluation
    cells run as Ray tasks on that cluster."""
    _set_torch_threads(torch_threads)
    path = Path(path)
    if (path / RUN_FILE).is_file() and "settings" in json.loads((path / RUN_FILE).read_text()):
        run = json.loads((path / RUN_FILE).read_text())
        settings, directory, home = StudySettings(run["settings"]), path, path
        config = ChainCartConfig(**json.loads((path / CONFIG_FILE).read_text()))
        runs = [r for r in settings.runs() if r.key in run["seed_runs"]]
        if settings.learned() and not runs:
            raise InvalidInputError(f"{path} has no trained seed yet (status {run.get('status')!r}): nothing to evaluate")
        sweeps = settings["sweeps"]
    else:
        saved = load_run(path)  # a seed folder, model.zip or RLlib checkpoint
        study = _study_directory(saved.directory)
        if study is None:
            raise InvalidInputError(f"{path}: expected a seed-<s> folder of a compare run, or the run directory")
        settings = StudySettings(json.loads((study / RUN_FILE).read_text())["settings"])
        one = TrainingRun(str(saved.info["algo"]), int(saved.info["seed"]), shared=len(settings.learned()) > 1)
        if one.directory(study) != saved.directory:
            raise InvalidInputError(f"{path}: expected a seed-<s> folder of a compare run, or the run directory")
        directory, config, home, runs, sweeps = study, saved.config, saved.directory, [one], {}
    into = home / "evaluation" if out is None else Path(out)
    episodes = int(settings.get("eval_episodes", 50)) if eval_episodes is None else eval_episodes
    first = int(settings.get("eval_seed", 1_000_000)) if eval_seed is None else eval_seed
    print(describe(config))
    print(f"evaluating {directory} -> {into}")
    options = dict(runs=runs, model_based=settings.model_based(), eval_seed=first, eval_episodes=episodes,
                   sweeps=sweeps, into=into)
    evaluation = evaluate_study_at(address, directory, config, torch_threads=torch_threads, **options)
    print(f"wrote {', '.join(EVALUATION_FILES + conditional_files_in(into))} in {into}")
    return evaluation.summaries
