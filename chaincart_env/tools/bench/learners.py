"""Benchmark section ``learners``: how fast each learner trains on the native vector env,
in env steps per second of ``model.learn`` (collection and updates), side by side.

The env steps a CPU second buys bound how fast a recipe reaches its goal, and on this
package's envs the learner, not the env, spends the time: a ``ChainCartVecEnv`` of 64
envs steps millions of env-steps/s, PPO trains thousands. Every learner runs the
``swingup-2`` scene (its observation and action, 300-step episodes) with one thread
(torch's, and JAX's where this process has not started JAX before):

* stable-baselines3 PPO with ``swingup-2``'s recipe (64 envs, ``n_steps=64``,
  ``batch_size=512``, 10 epochs);
* stable-baselines3 SAC, and TQC of sb3-contrib (where installed), as off-policy
  learners run: one env with a gradient step per env step (SB3's default), and 64 envs
  with one gradient step per 64 env steps (many envs, fewer gradient steps);
* SBX (the JAX port of stable-baselines3, extra ``sbx``) PPO and SAC in the same
  settings, where installed.

Each timing is the best of the run's repeats of ``learn`` for a fixed budget, after one
untimed ``learn`` that builds the networks, fills the replay buffer past
``learning_starts`` and compiles (JAX). Gradient steps per second follow from the
setting (PPO: ``n_epochs`` passes of minibatches per rollout).
"""

from __future__ import annotations

import importlib
import os
import time
from dataclasses import dataclass
from typing import Any, Callable

from chaincart_env.tools.bench.bench_report import fmt_rate
from chaincart_env.tools.bench.context import BenchContext

__all__ = ["LEARNERS", "Learner", "LearnerRate", "learners_section", "measure_learner"]

#: The scene every learner trains on.
SCENE = "swingup-2"
#: PPO's settings: the swing-up recipe's.
PPO_SETTINGS = {"n_steps": 64, "batch_size": 512, "n_epochs": 10}
#: Off-policy settings: a small replay buffer (the timing needs no more) and updates from the start.
OFF_POLICY = {"buffer_size": 100_000, "learning_starts": 256, "batch_size": 256}


@dataclass(frozen=True)
class Learner:
    """One learner in one setting: the library and class that train, the envs it
    steps, its keywords and how many gradient steps one env step buys."""

    label: str
    module: str
    cls: str
    n_envs: int
    keywords: dict[str, Any]
    gradient_steps_per_env_step: float

    def available(self) -> bool:
        """Whether the library is installed."""
        try:
            importlib.import_module(self.module)
        except ImportError:
            return False
        return True


def _ppo(label: str, module: str) -> Learner:
    per_env_step = PPO_SETTINGS["n_epochs"] / PPO_SETTINGS["batch_size"]
    return Learner(label, module, "PPO", 64, dict(PPO_SETTINGS), per_env_step)


def _off_policy(label: str, module: str, cls: str, n_envs: int) -> Learner:
    return Learner(label, module, cls, n_envs, {**OFF_POLICY, "train_freq": 1, "gradient_steps": 1}, 1.0 / n_envs)


#: Every learner and setting the section times, in the table's order.
LEARNERS: tuple[Learner, ...] = (
    _ppo("SB3 PPO", "stable_baselines3"),
    _ppo("SBX PPO", "sbx"),
    _off_policy("SB3 SAC", "stable_baselines3", "SAC", 1),
    _off_policy("SBX SAC", "sbx", "SAC", 1),
    _off_policy("SB3 SAC", "stable_baselines3", "SAC", 64),
    _off_policy("SBX SAC", "sbx", "SAC", 64),
    _off_policy("TQC (sb3-contrib)", "sb3_contrib", "TQC", 1),
    _off_policy("TQC (sb3-contrib)", "sb3_contrib", "TQC", 64),
)


@dataclass(frozen=True)
class LearnerRate:
    """A learner's measured training rate."""

    learner: Learner
    env_steps_per_s: float

    @property
    def gradient_steps_per_s(self) -> float:
        """Gradient steps per second: the env rate times the setting's gradient steps per env step."""
        return self.env_steps_per_s * self.learner.gradient_steps_per_env_step


def measure_learner(learner: Learner, env_steps: int, repeats: int,
                    clock: Callable[[], float] = time.perf_counter) -> LearnerRate:
    """Trains ``learner`` on ``n_envs`` envs of the scene: one untimed ``learn`` of
    ``env_steps``, then the best of ``repeats`` timed ones of ``env_steps`` each."""
    import torch

    from chaincart_env import ChainCartConfig
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.training import quiet_logger

    _one_jax_thread()
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        algorithm = getattr(importlib.import_module(learner.module), learner.cls)
        venv = ChainCartVecEnv(learner.n_envs, ChainCartConfig(scene=SCENE), seed=0)
        model = algorithm("MlpPolicy", venv, seed=0, verbose=0, **learner.keywords)
        model.set_logger(quiet_logger())
        model.learn(env_steps)
        best = 0.0
        for _ in range(repeats):
            start = clock()
            model.learn(env_steps, reset_num_timesteps=False)
            best = max(best, env_steps / (clock() - start))
    finally:
        torch.set_num_threads(threads)
    return LearnerRate(learner, best)


def _one_jax_thread() -> None:
    """One thread for JAX too: XLA reads its flags when JAX starts, so this holds only
    if it runs before SBX is first imported (checking for SBX imports it)."""
    os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")


def _budget(learner: Learner, quick: bool) -> int:
    if learner.cls == "PPO":  # whole rollouts
        rollouts = 1 if quick else 4
        return rollouts * learner.keywords["n_steps"] * learner.n_envs
    return (256 if quick else 512) * max(1, learner.n_envs // 8)  # one env: tens of gradient steps a second


def learners_section(ctx: BenchContext) -> None:
    """The learners section: env steps and gradient steps per second of training."""
    ctx.report.heading("Learners: training rate on the native vector env")
    quick = ctx.settings.quick
    rows, missing, rates = [], [], {}
    _one_jax_thread()
    for learner in LEARNERS:
        if not learner.available():
            missing.append(learner.label)
            continue
        rate = measure_learner(learner, _budget(learner, quick), ctx.settings.repeats)
        rates[(learner.label, learner.n_envs)] = rate.env_steps_per_s
        rows.append([learner.label, str(learner.n_envs), f"{learner.gradient_steps_per_env_step:.4g}",
                     fmt_rate(rate.env_steps_per_s), fmt_rate(rate.gradient_steps_per_s)])
    ctx.report.paragraph(
        f"`model.learn` on `ChainCartVecEnv` of `{SCENE}`, one torch thread, CPU; PPO with the scene's "
        "recipe, the off-policy learners with a gradient step per collection of `n_envs` env steps."
    )
    ctx.report.table(["learner", "envs", "gradient steps per env step", "env-steps/s", "gradient steps/s"], rows)
    if missing:
        names = ", ".join(sorted(set(missing)))
        ctx.report.paragraph(f"Not installed, not measured: {names} (`pip install chaincart-env[sbx]` for SBX).")
    ctx.results["learners"] = rates

