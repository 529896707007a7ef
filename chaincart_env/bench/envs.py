"""``python -m chaincart_env bench``: env-steps per second of the chaincart envs against
Gymnasium's CartPole, measured in the same run, as Markdown tables.

Method: every measured callable is run in a loop until ``min_time`` has elapsed; the
best rate of ``repeats`` runs is kept (the machine may be shared, and the best run is
the one least disturbed). Actions are precomputed, so sampling costs nothing. Single
envs are reset when an episode ends, inside the timed loop; vector envs autoreset.

Python-side overhead of the vector env = time of ``ChainCartVectorEnv.step`` minus time
of the raw native ``EnvBatch.step`` on the same batch (the Rust call the env wraps,
made directly from Python), measured interleaved.
"""

from __future__ import annotations

import itertools
import os
import platform
import time
from typing import Any, Callable, Optional, Sequence

import gymnasium as gym
import numpy as np

import chaincart_env  # noqa: F401  (registers ChainCart-v0)
from chaincart_env import _core
from chaincart_env.config import DEFAULT_SCENE, ChainCartConfig
from chaincart_env.vector import ChainCartVectorEnv

__all__ = ["run_bench", "rate"]


def rate(fn: Callable[[], Any], min_time: float, repeats: int) -> float:
    """Best calls per second of ``fn`` over ``repeats`` runs of at least ``min_time`` s."""
    best = 0.0
    for _ in range(repeats):
        calls, start = 0, time.perf_counter()
        batch = 1
        while True:
            for _ in range(batch):
                fn()
            calls += batch
            elapsed = time.perf_counter() - start
            if elapsed >= min_time:
                break
            batch = min(batch * 2, 4096)
        best = max(best, calls / elapsed)
    return best


def _single_loop(env: gym.Env, actions: Sequence[Any]) -> Callable[[], None]:
    it = itertools.cycle(actions)

    def step() -> None:
        _, _, terminated, truncated, _ = env.step(next(it))
        if terminated or truncated:
            env.reset()

    return step


def _fmt(x: float) -> str:
    if x >= 1e6:
        return f"{x / 1e6:.2f} M"
    if x >= 1e3:
        return f"{x / 1e3:.1f} k"
    return f"{x:.0f}"


def _ratio(a: float, b: float) -> str:
    return f"{a / b:.2f}x" if b > 0 else "n/a"


def run_bench(quick: bool = False, sizes: Sequence[int] = (1, 16, 256, 4096)) -> int:
    min_time, repeats = (0.05, 1) if quick else (0.4, 3)
    rng = np.random.default_rng(0)
    print("# chaincart env benchmark" + (" (--quick: smoke run, numbers are noisy)" if quick else ""))
    print()
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} logical CPUs, "
        f"rayon threads {_core.num_threads()}, Python {platform.python_version()}, "
        f"numpy {np.__version__}, gymnasium {gym.__version__}. "
        "Best of {repeats} runs of >= {min_time} s each; a shared machine makes every number a lower bound "
        "on what a quiet one gives.".format(repeats=repeats, min_time=min_time)
    )
    print()

    # -- single envs through gym.make ---------------------------------------------
    cart_actions = [int(a) for a in rng.integers(0, 2, 1000)]
    cartpole = gym.make("CartPole-v1")
    cartpole.reset(seed=0)
    base_rate = rate(_single_loop(cartpole, cart_actions), min_time, repeats)
    rows = [("CartPole-v1 (gym.make)", "4 numbers, Euler", base_rate)]
    single_configs = [
        (f"ChainCart-v0 default ({DEFAULT_SCENE})", ChainCartConfig()),
        ("ChainCart-v0 paper 5-link, substeps 1", ChainCartConfig(scene="paper-fig2", substeps=1)),
        ("ChainCart-v0 paper-fig2 (substeps 10)", ChainCartConfig(scene="paper-fig2")),
    ]
    for label, config in single_configs:
        env = gym.make("ChainCart-v0", config=config)
        env.reset(seed=0)
        single_actions = list(rng.uniform(-1, 1, (1000, config.force_dim)).astype(np.float32))
        what = f"{config.state_dim} numbers, {config.integrator} x{config.substeps}"
        rows.append((label, what, rate(_single_loop(env, single_actions), min_time, repeats)))
    print("## Single env (`gym.make`, wrappers included)")
    print()
    print("| env | state, integrator | steps/s | us/step | vs CartPole-v1 |")
    print("|---|---|---:|---:|---:|")
    for label, what, r in rows:
        print(f"| {label} | {what} | {_fmt(r)} | {1e6 / r:.2f} | {_ratio(r, base_rate)} |")
    print()

    # -- raw model step -------------------------------------------------------------
    print("## Raw model step (`ChainCart.step` from Python, one state per call)")
    print()
    print("| model | steps/s | us/step |")
    print("|---|---:|---:|")
    for label, config in single_configs:
        model = config.make_model()
        state = model.equilibrium(config.target_signs)
        force = np.zeros(config.force_dim)
        dt, integrator, substeps = config.dt, config.integrator, config.substeps
        r = rate(lambda: model.step(state, force, dt, integrator, substeps), min_time, repeats)
        print(f"| {label.replace('ChainCart-v0 ', '')} | {_fmt(r)} | {1e6 / r:.2f} |")
    print()

    # -- vector envs ------------------------------------------------------------------
    try:
        from chaincart_env.sb3 import ChainCartVecEnv
    except ImportError:  # the sb3 extra is not installed
        ChainCartVecEnv = None  # type: ignore[assignment,misc]
    config = ChainCartConfig()
    print(f"## Vector envs, default scene ({DEFAULT_SCENE}); env-steps/s = N x calls/s")
    print()
    print(
        "| N | CartPoleVectorEnv | ChainCartVectorEnv | vs CartPole | ChainCartVecEnv (SB3) | vs CartPole "
        "| native EnvBatch.step |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|")
    overhead: dict[int, tuple[float, float]] = {}
    for n in sizes:
        cp = gym.make_vec("CartPole-v1", num_envs=n, vectorization_mode="vector_entry_point")
        cp.reset(seed=0)
        cp_actions = rng.integers(0, 2, n)
        r_cp = n * rate(lambda: cp.step(cp_actions), min_time, repeats)
        cp.close()
        vec = ChainCartVectorEnv(n, config)
        vec.reset(seed=0)
        acts = rng.uniform(-1, 1, (n, config.force_dim)).astype(np.float32)
        native = vec._batch
        # Interleave vector and native timings so that load changes hit both alike.
        t_vec, t_native = [], []
        for _ in range(max(2, repeats)):
            t_vec.append(1.0 / rate(lambda: vec.step(acts), min_time, 1))
            t_native.append(1.0 / rate(lambda: native.step(acts), min_time, 1))
        tv, tn = min(t_vec), min(t_native)
        overhead[n] = (tv, tn)
        r_sb3: Optional[float] = None
        if ChainCartVecEnv is not None:
            sb3 = ChainCartVecEnv(n, config, seed=0)
            sb3.reset()
            r_sb3 = n * rate(lambda: sb3.step(acts), min_time, repeats)
        sb3_cells = f"{_fmt(r_sb3)} | {_ratio(r_sb3, r_cp)}" if r_sb3 else "n/a | n/a"
        print(
            f"| {n} | {_fmt(r_cp)} | {_fmt(n / tv)} | {_ratio(n / tv, r_cp)} | {sb3_cells} | {_fmt(n / tn)} |"
        )
    print()
    print("## Python-side overhead of ChainCartVectorEnv.step")
    print()
    print("Vector step time minus the raw native `EnvBatch.step` on the same batch.")
    print()
    print("| N | vector step (us) | native step (us) | overhead (us) | overhead / step |")
    print("|---:|---:|---:|---:|---:|")
    for n, (tv, tn) in overhead.items():
        print(f"| {n} | {tv * 1e6:.2f} | {tn * 1e6:.2f} | {(tv - tn) * 1e6:.2f} | {(tv - tn) / tv:.1%} |")
    print()
    return 0
