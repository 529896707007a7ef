"""Training an SB3 agent on the native ``ChainCartVecEnv``, with a CSV log of every
training episode (return, length, success, how it ended) and a progress bar."""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence, TextIO

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecMonitor

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.sb3 import ChainCartVecEnv
from chaincart_env.tools.compare.algorithms import algorithm_class
from chaincart_env.tools.compare.curriculum import PlanStarts, plan_states
from chaincart_env.tools.compare.imitation import Imitation, imitate
from chaincart_env.tools.compare.learning_curve import (
    EPISODES_FILE,
    TRAINING_EPISODE_COLUMNS,
    episode_ends,
    episode_row,
)
from chaincart_env.tools.compare.plan_start_envs import CURRICULUM_FILE, PlanStartEnvs, write_curriculum_log
from chaincart_env.tools.compare.shaping import Shaping
from chaincart_env.tools.controllers import label_of

__all__ = [
    "check_keywords",
    "steps_trained",
    "TRAINING_EPISODE_COLUMNS",
    "EpisodeCsvLogger",
    "TrainingResult",
    "quiet_logger",
    "train",
]


class EpisodeCsvLogger(BaseCallback):
    """Writes one CSV row per finished training episode (read from ``VecMonitor``'s
    ``episode`` info and the env's episode-end keys)."""

    def __init__(self, path: Path, append: bool = False) -> None:
        super().__init__()
        self.path = Path(path)
        self.append = append and self.path.is_file()
        self.episodes = 0
        self._file: Optional[TextIO] = None
        self._writer: Any = None
        self._columns: tuple[str, ...] = TRAINING_EPISODE_COLUMNS
        self._start = 0.0

    def _on_training_start(self) -> None:
        self._start = time.perf_counter()
        if self.append:  # a resumed run: continue the episode count and the clock
            with self.path.open(newline="") as file:
                reader = csv.DictReader(file)
                rows = list(reader)
            self.episodes = len(rows)
            self._start -= float(rows[-1]["wall_time_s"]) if rows else 0.0
            # Appended in the columns the log began with (one begun before a column existed goes on without it).
            self._columns = tuple(reader.fieldnames or TRAINING_EPISODE_COLUMNS)
            self._file = self.path.open("a", newline="")
            self._writer = csv.writer(self._file)
            return
        self._file = self.path.open("w", newline="")
        self._writer = csv.writer(self._file)
        self._writer.writerow(TRAINING_EPISODE_COLUMNS)

    def _on_step(self) -> bool:
        for info in self.locals["infos"]:
            episode = info.get("episode")
            if episode is None:
                continue
            self.episodes += 1
            start = [self.num_timesteps, f"{time.perf_counter() - self._start:.3f}", self.episodes,
                     repr(float(episode["r"])), int(episode["l"])]
            self._writer.writerow(episode_row(self._columns, start, episode_ends(info)))
        return True

    def _on_rollout_end(self) -> None:
        if self._file is not None:
            self._file.flush()

    def _on_training_end(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


@dataclass(frozen=True)
class TrainingResult:
    """What a training run returns: the model, wall time, episodes, hyperparameters, evaluations and
    where it resumed from."""

    model: BaseAlgorithm
    wall_time_s: float
    episodes: int
    hyperparameters: dict[str, Any]
    #: The deterministic evaluations' best and last rows (``PeriodicEvaluation.summary``).
    evaluations: dict[str, Any]
    #: Timesteps at which this call started (0, or the checkpoint it resumed from).
    resumed_from: int
    #: The imitation's last round (``imitation.csv``'s columns; its wall time is not in
    #: ``wall_time_s``), or ``None`` without one.
    imitation: Optional[dict[str, Any]] = None


#: Constructor arguments the trainer sets itself.
_SET_BY_TRAINER = ("self", "policy", "env", "seed", "device", "verbose", "_init_setup_model")


def check_keywords(algo: str, hyperparameters: Mapping[str, Any]) -> None:
    """Checks, before anything trains, that ``hyperparameters`` are keywords of
    ``algo``'s constructor (an InvalidInputError naming the others) and that their
    values are what :func:`~chaincart_env.tools.compare.recipes.sb3_keywords` reads."""
    import inspect

    from chaincart_env.tools.compare.recipes import sb3_keywords

    cls = algorithm_class(algo)
    accepted = sorted(set(inspect.signature(cls.__init__).parameters) - set(_SET_BY_TRAINER))
    unknown = sorted(set(hyperparameters) - set(accepted))
    if unknown:
        raise InvalidInputError(
            f"{algo} keywords {unknown}: not keywords of {cls.__name__}; expected some of {', '.join(accepted)}"
        )
    sb3_keywords(hyperparameters, f"{algo} keywords")


def _variance_floor(config: ChainCartConfig, plan: Any, curriculum: Optional[PlanStarts], envs: Any) -> Any:
    """The normalisation's variance floor of a curriculum's ``spread_floor`` (``None``
    without one): the share of each env observation's spread along ``plan``, squared; the
    components wrappers append (history, time, a base's command) keep their counted spread."""
    if curriculum is None or not curriculum.spread_floor:
        return None
    from chaincart_env.tools.compare.curriculum import plan_observations

    floor = np.zeros(envs.observation_space.shape, dtype=np.float64)
    floor[: config.obs_dim] = (curriculum.spread_floor * plan_observations(config, plan).std(axis=0)) ** 2
    return floor


def _new_agent(
    algo: str, config: ChainCartConfig, seed: int, num_envs: int, kwargs: dict[str, Any],
    normalize: Optional[Mapping[str, Any]] = None, curriculum: Optional[PlanStarts] = None,
    history: Optional[int] = None, shaping: Optional[Shaping] = None, elapsed_time: bool = False,
    residual: Optional[dict[str, Any]] = None,
) -> BaseAlgorithm:
    from chaincart_env.tools.compare.normalization import normalized_envs
    from chaincart_env.tools.compare.recipes import sb3_keywords

    keywords = sb3_keywords(kwargs)  # checked before the envs are built
    native: Any = ChainCartVecEnv(num_envs, config, seed=seed)
    # One plan serves the plan starts, the plan bonus and the tube: the planner takes seconds.
    plan: Any = plan_states(config) if curriculum is not None or (shaping and shaping.follows_plan) else None
    if shaping and shaping.plan_tube:  # innermost: plan starts then place the episodes it ends
        from chaincart_env.tools.compare.plan_tube import PlanTube

        native = PlanTube(native, plan, shaping.plan_tube)
    if curriculum is not None:
        native = PlanStartEnvs(native, plan, curriculum, seed)
    if residual is not None:
        from chaincart_env.residual import VecResidualAction

        native = VecResidualAction(native, **residual)
    if history is not None or elapsed_time:
        from chaincart_env.elapsed_time import with_observation_extras

        native = with_observation_extras(native, history, elapsed_time)
    if shaping:
        from chaincart_env.tools.compare.shaped_rewards import shaped_envs

        native = shaped_envs(native, shaping, plan)
    # VecNormalize outside VecMonitor, as in the zoo: the episode log keeps the rewards trained on, unscaled.
    monitored = VecMonitor(native)
    venv = normalized_envs(monitored, normalize, _variance_floor(config, plan, curriculum, monitored))
    try:
        model = algorithm_class(algo)("MlpPolicy", venv, seed=seed, device="cpu", verbose=0, **keywords)
    except TypeError as error:  # an unknown or ill-typed keyword
        raise InvalidInputError(f"{algo} keywords {kwargs}: {error}") from None
    if residual is not None:  # saved with the model: every evaluation then adds the same base
        from chaincart_env.residual import RESIDUAL_ATTRIBUTE

        setattr(model, RESIDUAL_ATTRIBUTE, {**residual, "config": config.to_dict()})
    statistics = model.get_vec_normalize_env()
    if statistics is not None:  # rewards are normalised by their discounted return, with the agent's discount
        statistics.gamma = float(getattr(model, "gamma", statistics.gamma))
    return model


def quiet_logger() -> Logger:
    """A logger for an SB3 model that writes nothing, as SB3's own at ``verbose=0``. Without
    a logger of its own a model gets SB3's, which makes a folder in the temporary
    directory at every ``learn()``; this one makes none."""
    return Logger(folder=None, output_formats=[])


def _anchoring(imitation: Optional[Imitation], directory: Path) -> list[BaseCallback]:
    """What keeps ``imitation``'s copy while the agent trains on (none without one)."""
    from chaincart_env.tools.compare.anchoring import CriticWarmup, ImitationAnchor

    if imitation is None:
        return []
    kept: list[BaseCallback] = []
    if imitation.critic_warmup:
        kept.append(CriticWarmup(imitation.critic_warmup))
    if imitation.anchor_weight > 0:
        kept.append(ImitationAnchor(directory, imitation.anchor_weight))
    return kept


def _statistics_freeze(curriculum: Optional[PlanStarts]) -> list[BaseCallback]:
    """What freezes the observation statistics at the curriculum's first widening (none
    unless it asks)."""
    from chaincart_env.tools.compare.plan_start_envs import FreezeStatisticsOnWidening

    return [FreezeStatisticsOnWidening()] if curriculum is not None and curriculum.freeze_statistics else []


def _mirror_loss(
    algo: str, config: ChainCartConfig, weight: float, history: Optional[int], elapsed_time: bool = False
) -> list[BaseCallback]:
    """The mirror loss of weight ``weight`` (none for 0), or an InvalidInputError naming
    an algorithm it does not serve."""
    from chaincart_env.tools.compare.mirror_loss import MIRROR_ALGOS, MirrorLoss, check_mirror_weight

    if not check_mirror_weight(weight):
        return []
    if algorithm_class(algo) not in {algorithm_class(name) for name in MIRROR_ALGOS}:
        raise InvalidInputError(f"mirror weight {weight} with {algo}: expected an agent of {list(MIRROR_ALGOS)}")
    return [MirrorLoss(config, weight, history or 0, elapsed_time)]


def _check_residual(
    residual: Any, imitation: Optional[Imitation], curriculum: Optional[PlanStarts], mirror_weight: float
) -> Optional[dict[str, Any]]:
    """Refuses a residual agent with what it cannot take: an imitation (the learner would
    copy the base it already has), plan starts (the base's clock starts at the plan's
    beginning) and the mirror loss (the base's command in the observation is not mirrored).
    Returns the residual keywords checked (:func:`chaincart_env.residual.residual_keywords`)."""
    if residual is None:
        return None
    from chaincart_env.residual import residual_keywords

    keywords = residual_keywords(residual)
    given = [what for what, on in (("an imitation", imitation is not None), ("plan starts", curriculum is not None),
                                   ("the mirror loss", bool(mirror_weight))) if on]
    if given:
        raise InvalidInputError(f"residual scale {keywords['scale']} with {' and '.join(given)}: expected a "
                                "residual agent trained without them (its base is a model-based controller already)")
    return keywords


def training_config(
    config: ChainCartConfig, reward: Optional[str], conditions: Optional[Mapping[str, Any]] = None
) -> ChainCartConfig:
    """``config`` as the agent trains on it: with the training reward ``reward`` and the
    configuration keys of ``conditions`` (e.g. a robust agent's draws,
    :data:`~chaincart_env.robust_training.ROBUST_CONDITIONS`) on top; ``config`` itself
    for neither. Checked by building one env: an InvalidInputError names an unknown
    reward or a bad condition."""
    changes = dict(conditions or {})
    if reward is not None and reward != config.reward:
        changes["reward"] = reward
    if not changes:
        return config
    changed = config.replace(**changes)
    changed.make_batch(1, "same_step", 0)
    return changed


def steps_trained(model: BaseAlgorithm, timesteps: int) -> tuple[int, str]:
    """The env steps ``model.learn(total_timesteps=timesteps)`` takes (SB3 collects
    whole rollouts: ``n_steps`` per env for on-policy algorithms, ``train_freq`` steps
    per env for off-policy ones) and the unit it rounds to, in words."""
    n_envs = model.n_envs
    if isinstance(model, OnPolicyAlgorithm):  # PPO, A2C (off-policy ones have n_steps too: n-step returns)
        unit, words = int(model.n_steps) * n_envs, f"rollouts of n_steps x num_envs = {model.n_steps} x {n_envs}"
    else:
        freq = getattr(model, "train_freq", None)
        if freq is None or getattr(freq.unit, "value", "step") != "step":
            return timesteps, "whole episodes"  # not known in advance
        unit, words = int(freq.frequency) * n_envs, f"collections of train_freq x num_envs = {freq.frequency} x {n_envs}"
    return -(-timesteps // unit) * unit, f"whole {words} = {unit} steps"


def train(
    config: ChainCartConfig,
    *,
    algo: str = "ppo",
    timesteps: int,
    seed: int = 0,
    num_envs: int = 8,
    directory: Path,
    eval_seeds: Sequence[int],
    eval_every: int,
    checkpoint_every: int,
    progress_bar: bool = True,
    hyperparameters: Optional[Mapping[str, Any]] = None,
    resume: bool = False,
    normalize: Optional[Mapping[str, Any]] = None,
    imitation: Optional[Imitation] = None,
    curriculum: Optional[PlanStarts] = None,
    training_reward: Optional[str] = None,
    history: Optional[int] = None,
    conditions: Optional[Mapping[str, Any]] = None,
    shaping: Optional[Shaping] = None,
    warm_start_from: Optional[Path] = None,
    mirror_weight: float = 0.0,
    elapsed_time: bool = False,
    residual: Any = None,
) -> TrainingResult:
    """Trains ``algo`` for ``timesteps`` env steps on ``num_envs`` envs of ``config``
    (env i seeded ``seed + i``, the agent seeded ``seed``) into ``directory``: every
    training episode in ``training_episodes.csv``, the deterministic policy evaluated
    on ``eval_seeds`` every ``eval_every`` steps (``evaluations.csv``,
    ``best_model.zip``), a checkpoint every ``checkpoint_every`` steps. With
    ``resume=True`` and a checkpoint in ``directory``, training continues from it (and
    ends as the uninterrupted run would). ``normalize``: ``VecNormalize`` keywords (a
    recipe's ``normalize``; the statistics are the agent's, saved with each of its model files by
    :func:`~chaincart_env.tools.compare.normalization.save_agent`), ``None`` for none; a resumed
    run keeps its checkpoint's. ``imitation``: a new agent first imitates the planner's
    controller (:func:`~chaincart_env.tools.compare.imitation.imitate`, logged in
    ``imitation.csv``); the first evaluation, at step 0, scores the imitation; the imitation's
    ``critic_warmup`` and ``anchor_weight`` keep it as the agent trains on
    (:mod:`~chaincart_env.tools.compare.anchoring`). ``curriculum``:
    a share of the training episodes starts along the planner's plan
    (:mod:`~chaincart_env.tools.compare.curriculum`; a resumed run keeps its checkpoint's); the
    windows it drew from go to ``curriculum.csv``. ``training_reward``: the training envs
    reward with it (``"exp"``, ``"tolerance"``) instead of ``config``'s reward; the
    evaluations keep ``config`` (its success criterion does not depend on the reward).
    ``conditions``: configuration keys the training envs take on top of ``config`` (a
    robust agent's per-episode draws), and the periodic evaluations (which choose the best model)
    take them too, with ``config``'s reward. ``shaping``: the
    training reward's shaping terms (an off-track penalty, a bonus for following the
    planner's swing-up: :mod:`~chaincart_env.tools.compare.shaping`). ``warm_start_from``: a new agent starts
    from the weights of the agent saved there (:mod:`~chaincart_env.tools.compare.warm_start`).
    ``history``:
    the agent observes the last ``history`` observations and actions too
    (:class:`~chaincart_env.history.VecHistoryObservation`; its evaluations add them as it acts).
    ``elapsed_time``: the agent observes the elapsed fraction of its episode too, after any
    history (:class:`~chaincart_env.elapsed_time.VecElapsedTimeObservation`; likewise added in
    its evaluations).
    ``mirror_weight``: the weight of the mirror loss beside PPO's
    (:mod:`~chaincart_env.tools.compare.mirror_loss`), 0 for none.
    ``residual``: the agent corrects a model-based controller, with these
    :class:`~chaincart_env.residual.ResidualAction` keywords: the scale, and the base
    planner's cost weights if given (a bare number is the scale). The model records
    them, so that its evaluations add the same base. ``None`` for a plain agent. It
    excludes an imitation and plan starts, which would start the base's clock away from
    its plan."""
    from chaincart_env.tools.compare.checkpoints import CHECKPOINT_DIR, Checkpointer, restore
    from chaincart_env.tools.compare.normalization import normalization_file
    from chaincart_env.tools.compare.periodic_eval import BEST_MODEL_FILE, EVALUATIONS_FILE, PeriodicEvaluation
    from chaincart_env.tools.compare.run_files import settled_directory

    cls = algorithm_class(algo)
    residual = _check_residual(residual, imitation, curriculum, mirror_weight)
    acting_on_statistics = {"freezing the observation statistics": curriculum and curriculum.freeze_statistics,
                            "flooring the observation spread": curriculum and curriculum.spread_floor}
    for setting, asked in acting_on_statistics.items():
        if asked and normalize is None:
            raise InvalidInputError(f"a curriculum {setting} with {algo}'s recipe, which does not normalise "
                                    "observations: expected a recipe with normalize")
    if isinstance(timesteps, bool) or not isinstance(timesteps, int) or timesteps < 1:
        raise InvalidInputError(f"timesteps = {timesteps!r}: expected an integer >= 1")
    kwargs = dict(hyperparameters or {})  # on top of SB3's defaults; a scene's recipe comes from the caller
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    resuming = resume and settled_directory(directory / CHECKPOINT_DIR).is_dir()
    trained_on = training_config(config, training_reward, conditions)
    mirror = _mirror_loss(algo, trained_on, mirror_weight, history, elapsed_time)
    model = restore(directory, cls)[0] if resuming else _new_agent(algo, trained_on, seed, num_envs, kwargs,
                                                                    normalize, curriculum, history, shaping,
                                                                    elapsed_time, residual)
    if warm_start_from is not None and not resuming:
        from chaincart_env.tools.compare.warm_start import warm_start

        warm_start(model, Path(warm_start_from))
    imitated = imitate(model, config, imitation, seed, directory) if imitation is not None and not resuming else None
    if imitation is not None and (imitation.critic_warmup or imitation.anchor_weight > 0):
        from chaincart_env.tools.compare.anchoring import fix_statistics

        fix_statistics(model)  # the statistics the imitation fitted the policy under
    resumed_from = int(model.num_timesteps)
    planned, unit = steps_trained(model, timesteps)
    if planned != timesteps and not resuming:  # said before training, so the progress bar's total is no surprise
        print(f"{label_of(algo)} trains in {unit}: {timesteps} timesteps asked, {planned} trained")
    logger = EpisodeCsvLogger(directory / EPISODES_FILE, append=resuming)
    # An agent trained on drawn conditions is judged on them, so that its best model is the one that
    # holds up under them (on the scene alone the starting agent of a fine-tuning could stay the best).
    judged_on = config if not conditions else config.replace(**conditions)
    evaluation = PeriodicEvaluation(judged_on, eval_seeds, eval_every, directory, resume=resuming)
    checkpoints = Checkpointer(directory, checkpoint_every, logs=(EPISODES_FILE, EVALUATIONS_FILE),
                               keep=(BEST_MODEL_FILE, normalization_file(directory / BEST_MODEL_FILE).name))
    start = time.perf_counter()
    callbacks = [logger, evaluation, checkpoints, *_anchoring(imitation, directory), *mirror,
                 *_statistics_freeze(curriculum)]
    model.set_logger(quiet_logger())
    model.learn(total_timesteps=max(0, planned - resumed_from), callback=callbacks,
                progress_bar=progress_bar, reset_num_timesteps=not resuming)
    write_curriculum_log(model.get_env(), directory / CURRICULUM_FILE)
    return TrainingResult(model, time.perf_counter() - start, logger.episodes, kwargs, evaluation.summary(),
                          resumed_from, imitated)
