"""The main job: train, evaluate against the LQR baseline, report; and the re-run of
the evaluation from saved files."""

from __future__ import annotations

import platform
import time
from pathlib import Path
from typing import Any, Optional

from chaincart_env._core import ChainCartError
from chaincart_env.compare.evaluation import EPISODE_COLUMNS, METRIC_COLUMNS, evaluate_policies, evaluation_seeds
from chaincart_env.compare.filmstrip import write_filmstrip
from chaincart_env.compare.learning_curve import LEARNING_CURVE_COLUMNS, learning_curve, read_training_episodes
from chaincart_env.compare.plots import plot_errors, plot_learning_curve
from chaincart_env.compare.run_files import load_run, save_run
from chaincart_env.compare.tables import write_csv, write_markdown
from chaincart_env.config import ChainCartConfig

__all__ = [
    "OUTPUT_FILES", "EVALUATION_FILES", "RLLIB_OUTPUT_FILES", "TRAINERS", "lqr_baseline", "run_compare",
    "run_evaluate",
]  # fmt: skip

#: The trainers of compare: stable-baselines3 on one machine, Ray RLlib on a cluster.
TRAINERS = ("sb3", "rllib")

#: What evaluation writes (compare and evaluate).
EVALUATION_FILES = ("comparison.csv", "comparison.md", "episodes.csv", "errors.png", "filmstrip.png")
#: What compare writes in all.
OUTPUT_FILES = EVALUATION_FILES + (
    "training_episodes.csv", "learning_curve.csv", "learning_curve.png", "model.zip", "config.json", "run.json",
)
#: What compare --trainer rllib writes: the RLlib checkpoint instead of model.zip.
RLLIB_OUTPUT_FILES = tuple("rllib_checkpoint" if name == "model.zip" else name for name in OUTPUT_FILES)


def _describe(config: ChainCartConfig) -> str:
    return (
        f"scene {config.scene}: {config.n_links} link(s), {'planar' if config.planar else 'spatial'}, "
        f"target {config.target_signs}, start {config.start!r} +- {config.start_noise}, dt {config.dt} s, "
        f"max_force {config.max_force} N, {config.max_episode_steps} steps"
    )


def lqr_baseline(config: ChainCartConfig) -> Any:
    """The LQR baseline of ``config`` (``LQRPolicy.from_env``); a scene it cannot serve
    (e.g. no force) is a ChainCartError naming it."""
    from chaincart_env.env import ChainCartEnv
    from chaincart_env.lqr import LQRPolicy

    try:
        return LQRPolicy.from_env(ChainCartEnv(config))
    except ValueError as error:
        raise ChainCartError(f"no LQR baseline for scene {config.scene!r}: {error}") from None


def policy_label(algo: str, trainer: str = "sb3") -> str:
    """The trained policy's name in tables and plots: ``PPO``, or ``PPO (RLlib)``."""
    return algo.upper() + (" (RLlib)" if trainer == "rllib" else "")


def _evaluate_and_report(
    model: Any, label: str, config: ChainCartConfig, out: Path, eval_seed: int, eval_episodes: int
) -> list[dict[str, Any]]:
    """Evaluates ``model`` and the LQR baseline on the same seeded starts and writes
    the table (CSV, Markdown), per-episode rows, the error plot and the filmstrip."""
    seeds = evaluation_seeds(eval_seed, eval_episodes)
    baseline = lqr_baseline(config)
    runs, episodes, summaries = evaluate_policies([(label, model), ("LQR", baseline)], config, seeds)
    write_csv(out / "comparison.csv", summaries, METRIC_COLUMNS)
    write_csv(out / "episodes.csv", episodes, EPISODE_COLUMNS)
    tol_q, tol_w = config.success_tolerances
    notes = [
        _describe(config),
        f"{eval_episodes} evaluation episodes, seeds {seeds[0]}..{seeds[-1]}, deterministic actions; "
        "mean ± std over episodes.",
        f"Success: the episode reaches the time limit with e_q <= {tol_q} and e_w <= {tol_w}. "
        "Time to settle: the first time after which e_q and e_w stay within these tolerances to the end "
        "(successful episodes only).",
    ]
    print(write_markdown(out / "comparison.md", f"{label} vs LQR", summaries, notes))
    plot_errors(out / "errors.png", runs, config.success_tolerances)
    write_filmstrip(out / "filmstrip.png", runs, config)
    return summaries


def _set_torch_threads(threads: Optional[int]) -> None:
    if threads is not None:
        import torch

        torch.set_num_threads(threads)


def _train_sb3(config: ChainCartConfig, out: Path, algo: str, timesteps: int, seed: int, num_envs: int,
               progress_bar: bool, hyperparameters: Optional[dict[str, Any]]) -> tuple[Any, dict[str, Any]]:
    from chaincart_env.compare.training import train

    print(f"training {algo.upper()} for {timesteps} timesteps on {num_envs} envs, seed {seed} -> {out}")
    result = train(config, algo=algo, timesteps=timesteps, seed=seed, num_envs=num_envs,
                   episodes_csv=out / "training_episodes.csv", progress_bar=progress_bar,
                   hyperparameters=hyperparameters)
    info = dict(timesteps_trained=int(result.model.num_timesteps), num_envs=num_envs)
    return result, info


def _train_rllib(config: ChainCartConfig, out: Path, algo: str, timesteps: int, seed: int, rllib: dict[str, Any],
                 progress_bar: bool, hyperparameters: Optional[dict[str, Any]]) -> tuple[Any, dict[str, Any]]:
    try:
        import ray.rllib  # noqa: F401
    except ImportError as error:
        raise ChainCartError(
            f"--trainer rllib needs Ray RLlib ({error}): install the rllib extra, pip install 'chaincart-env[rllib]'"
        ) from None
    from chaincart_env.compare.rllib_training import CHECKPOINT_DIR, train_rllib

    if algo.lower() != "ppo":
        raise ChainCartError(f"--trainer rllib with --algo {algo}: the RLlib trainer offers ppo only")
    runners, per_runner = rllib["num_env_runners"], rllib["envs_per_runner"]
    print(f"training {algo.upper()} with RLlib for {timesteps} timesteps on {runners} env runner(s) x "
          f"{per_runner} envs, seed {seed} -> {out}")
    result = train_rllib(config, timesteps=timesteps, seed=seed, num_env_runners=runners,
                         envs_per_runner=per_runner, address=rllib.get("address"),
                         episodes_csv=out / "training_episodes.csv", checkpoint=out / CHECKPOINT_DIR,
                         progress=progress_bar, hyperparameters=hyperparameters)
    info = dict(timesteps_trained=result.timesteps_trained, num_env_runners=runners, envs_per_runner=per_runner,
                num_envs=runners * per_runner, training_iterations=result.iterations, cluster=result.cluster)
    return result, info


def run_compare(
    config: ChainCartConfig,
    *,
    out: Path,
    algo: str = "ppo",
    timesteps: int,
    seed: int = 0,
    num_envs: int = 8,
    eval_episodes: int = 50,
    eval_seed: int = 1_000_000,
    progress_bar: bool = True,
    torch_threads: Optional[int] = None,
    hyperparameters: Optional[dict[str, Any]] = None,
    trainer: str = "sb3",
    rllib: Optional[dict[str, Any]] = None,
) -> list[dict[str, Any]]:
    """Trains ``algo`` on ``config`` with ``trainer`` (``sb3``: ``num_envs`` envs in one
    process; ``rllib``: ``rllib = {"num_env_runners": ..., "envs_per_runner": ...,
    "address": ...}``), saves it, compares it with the LQR baseline and writes
    :data:`OUTPUT_FILES` (:data:`RLLIB_OUTPUT_FILES`) into ``out``; returns the two
    summaries."""
    if trainer not in TRAINERS:
        raise ChainCartError(f"trainer = {trainer!r}: expected one of {list(TRAINERS)}")
    evaluation_seeds(eval_seed, eval_episodes)  # bad evaluation settings fail before training
    lqr_baseline(config)  # so does a scene without a baseline
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    _set_torch_threads(torch_threads)
    start = time.perf_counter()
    print(_describe(config))
    if trainer == "rllib":
        settings = {"num_env_runners": 2, "envs_per_runner": 4, "address": None, **(rllib or {})}
        result, trained = _train_rllib(config, out, algo, timesteps, seed, settings, progress_bar, hyperparameters)
    else:
        result, trained = _train_sb3(config, out, algo, timesteps, seed, num_envs, progress_bar, hyperparameters)
    print(f"trained in {result.wall_time_s:.1f} s ({result.episodes} training episodes)")
    info = dict(
        trainer=trainer, algo=algo.lower(), timesteps=timesteps, seed=seed, eval_seed=eval_seed,
        eval_episodes=eval_episodes, hyperparameters=result.hyperparameters,
        training_wall_time_s=round(result.wall_time_s, 2), training_episodes=result.episodes,
        machine=f"{platform.machine()}, {platform.python_implementation()} {platform.python_version()}",
        **trained,
    )
    save_run(out, result.model, config, info)
    label = policy_label(algo, trainer)
    summaries = _evaluate_and_report(result.model, label, config, out, eval_seed, eval_episodes)
    curve = learning_curve(read_training_episodes(out / "training_episodes.csv"), timesteps)
    write_csv(out / "learning_curve.csv", curve, LEARNING_CURVE_COLUMNS)
    plot_learning_curve(out / "learning_curve.png", curve, label, summaries[1])
    total = time.perf_counter() - start
    files = RLLIB_OUTPUT_FILES if trainer == "rllib" else OUTPUT_FILES
    print(f"wall time {total:.1f} s (training {result.wall_time_s:.1f} s); wrote {', '.join(files)} in {out}")
    return summaries


def run_evaluate(
    path: Path,
    *,
    out: Optional[Path] = None,
    eval_episodes: Optional[int] = None,
    eval_seed: Optional[int] = None,
    torch_threads: Optional[int] = None,
) -> list[dict[str, Any]]:
    """Re-runs the comparison of a saved run (same starts unless told otherwise);
    writes :data:`EVALUATION_FILES` into ``out`` (default: ``<run>/evaluation``)."""
    _set_torch_threads(torch_threads)
    run = load_run(Path(path))
    out = run.directory / "evaluation" if out is None else Path(out)
    out.mkdir(parents=True, exist_ok=True)
    episodes = int(run.info.get("eval_episodes", 50)) if eval_episodes is None else eval_episodes
    first_seed = int(run.info.get("eval_seed", 1_000_000)) if eval_seed is None else eval_seed
    print(_describe(run.config))
    print(f"evaluating {run.directory} ({str(run.info.get('algo')).upper()}) -> {out}")
    label = policy_label(str(run.info["algo"]), str(run.info.get("trainer", "sb3")))
    summaries = _evaluate_and_report(run.model, label, run.config, out, first_seed, episodes)
    print(f"wrote {', '.join(EVALUATION_FILES)} in {out}")
    return summaries


