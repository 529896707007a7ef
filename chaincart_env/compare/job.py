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
from chaincart_env.compare.training import train
from chaincart_env.config import ChainCartConfig

__all__ = ["OUTPUT_FILES", "EVALUATION_FILES", "lqr_baseline", "run_compare", "run_evaluate"]

#: What evaluation writes (compare and evaluate).
EVALUATION_FILES = ("comparison.csv", "comparison.md", "episodes.csv", "errors.png", "filmstrip.png")
#: What compare writes in all.
OUTPUT_FILES = EVALUATION_FILES + (
    "training_episodes.csv", "learning_curve.csv", "learning_curve.png", "model.zip", "config.json", "run.json",
)


def _describe(config: ChainCartConfig) -> str:
    return (
        f"scene {config.scene}: {config.n_links} link(s), {'planar' if config.planar else 'spatial'}, "
        f"target {config.target_signs}, start {config.start!r} +- {config.start_noise}, dt {config.dt} s, "
        f"max_force {config.max_force} N, {config.max_episode_steps} steps"
    )


def lqr_baseline(config: ChainCartConfig, oracle: bool = False) -> Any:
    """The LQR baseline of ``config`` (``LQRPolicy.from_env``, designed on the nominal
    model; ``oracle=True``: per env on the true parameters); a scene it cannot serve
    (e.g. no force) is a ChainCartError naming it."""
    from chaincart_env.env import ChainCartEnv
    from chaincart_env.lqr import LQRPolicy

    try:
        return LQRPolicy.from_env(ChainCartEnv(config), oracle=oracle)
    except ValueError as error:
        raise ChainCartError(f"no LQR baseline for scene {config.scene!r}: {error}") from None


def _evaluate_and_report(
    model: Any, algo: str, config: ChainCartConfig, out: Path, eval_seed: int, eval_episodes: int
) -> list[dict[str, Any]]:
    """Evaluates ``model`` and the LQR baseline on the same seeded starts and writes
    the table (CSV, Markdown), per-episode rows, the error plot and the filmstrip."""
    seeds = evaluation_seeds(eval_seed, eval_episodes)
    baseline = lqr_baseline(config)
    policies = [(algo.upper(), model), ("LQR", baseline)]
    if config.has_param_gap:
        policies.append(("LQR oracle", lqr_baseline(config, oracle=True)))
    runs, episodes, summaries = evaluate_policies(policies, config, seeds)
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
    if config.has_param_gap:
        notes.append(
            "The true system differs from the model (randomize/params/mismatch): LQR is designed on the "
            "nominal model; LQR oracle on each episode's true parameters (an upper bound)."
        )
    print(write_markdown(out / "comparison.md", f"{algo.upper()} vs LQR", summaries, notes))
    plot_errors(out / "errors.png", runs, config.success_tolerances)
    write_filmstrip(out / "filmstrip.png", runs, config)
    return summaries


def _set_torch_threads(threads: Optional[int]) -> None:
    if threads is not None:
        import torch

        torch.set_num_threads(threads)


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
) -> list[dict[str, Any]]:
    """Trains ``algo`` on ``config``, saves it, compares it with the LQR baseline and
    writes :data:`OUTPUT_FILES` into ``out``; returns the two summaries."""
    evaluation_seeds(eval_seed, eval_episodes)  # bad evaluation settings fail before training
    lqr_baseline(config)  # so does a scene without a baseline
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    _set_torch_threads(torch_threads)
    start = time.perf_counter()
    print(_describe(config))
    print(f"training {algo.upper()} for {timesteps} timesteps on {num_envs} envs, seed {seed} -> {out}")
    result = train(config, algo=algo, timesteps=timesteps, seed=seed, num_envs=num_envs,
                   episodes_csv=out / "training_episodes.csv", progress_bar=progress_bar,
                   hyperparameters=hyperparameters)
    print(f"trained in {result.wall_time_s:.1f} s ({result.episodes} training episodes)")
    info = dict(
        algo=algo.lower(), timesteps=timesteps, timesteps_trained=int(result.model.num_timesteps), seed=seed, num_envs=num_envs, eval_seed=eval_seed,
        eval_episodes=eval_episodes, hyperparameters=result.hyperparameters,
        training_wall_time_s=round(result.wall_time_s, 2), training_episodes=result.episodes,
        machine=f"{platform.machine()}, {platform.python_implementation()} {platform.python_version()}",
    )
    save_run(out, result.model, config, info)
    summaries = _evaluate_and_report(result.model, algo, config, out, eval_seed, eval_episodes)
    curve = learning_curve(read_training_episodes(out / "training_episodes.csv"), timesteps)
    write_csv(out / "learning_curve.csv", curve, LEARNING_CURVE_COLUMNS)
    plot_learning_curve(out / "learning_curve.png", curve, algo.upper(), summaries[1])
    total = time.perf_counter() - start
    print(f"wall time {total:.1f} s (training {result.wall_time_s:.1f} s); wrote {', '.join(OUTPUT_FILES)} in {out}")
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
    summaries = _evaluate_and_report(run.model, str(run.info["algo"]), run.config, out, first_seed, episodes)
    print(f"wrote {', '.join(EVALUATION_FILES)} in {out}")
    return summaries


