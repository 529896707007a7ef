"""Benchmark section ``cells``: a study's evaluation cells run serially in this process
and as Ray tasks on a local Ray cluster of this machine's CPUs (``compare --address
local``), side by side in one run (needs the ``rllib`` extra for Ray).

The cells are those of the default scene's study: the LQR baseline and an (untrained)
SB3 PPO policy, a torch network like a trained agent's, each on the main scene and on
every value of the default sweeps, from the same seeded starts (the PPO policy when
the ``sb3`` extra is installed). The cold pass includes starting Ray's worker
processes; the warm passes alternate with the serial ones, and the best of each counts.
"""

from __future__ import annotations

import io
import os
import time
from typing import Any

from chaincart_env.tools.bench.bench_report import fmt_ratio
from chaincart_env.tools.bench.context import BenchContext
from chaincart_env.tools.bench.rllib_sampling import MISSING_NOTE, rllib_available

__all__ = ["cells_section", "time_cells"]


def time_cells(cells: list[Any], sources: dict[str, Any], distributed: bool) -> float:
    """Seconds to evaluate ``cells`` (serially here, or as Ray tasks)."""
    from chaincart_env.tools.compare.cell_runner import map_cells
    from chaincart_env.tools.compare.study import evaluate_cell

    start = time.perf_counter()
    map_cells(evaluate_cell, cells, shared=sources, distributed=distributed, torch_threads=1)
    return time.perf_counter() - start


def _untrained_ppo(config: Any) -> dict[str, Any]:
    """An SB3 PPO policy as a source (nothing without the sb3 extra)."""
    try:
        from stable_baselines3 import PPO
    except ImportError:
        return {}
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.policy_sources import PolicySource

    buffer = io.BytesIO()
    PPO("MlpPolicy", ChainCartVecEnv(1, config), seed=0, device="cpu").save(buffer)
    return {"PPO (untrained)": PolicySource("sb3", buffer.getvalue(), algo="ppo")}


def cells_section(ctx: BenchContext) -> None:
    """Time the default study's cells serially and as Ray tasks on a local cluster and
    report both (a note instead without Ray)."""
    ctx.report.heading("A study's cells: serially vs as Ray tasks on a local cluster")
    if not rllib_available():
        ctx.report.paragraph(MISSING_NOTE)
        return
    import ray

    from chaincart_env.config import ChainCartConfig
    from chaincart_env.tools.compare.cell_runner import LOCAL, ray_cluster, torch_threads
    from chaincart_env.tools.compare.policy_sources import PolicySource
    from chaincart_env.tools.compare.study import EvaluationCell, SweepPoint
    from chaincart_env.tools.compare.sweeps import DEFAULT_SWEEPS, SWEEP_AXES

    quick = ctx.settings.quick
    config = ChainCartConfig(max_episode_steps=100) if quick else ChainCartConfig()
    starts = tuple(range(1_000_000, 1_000_000 + (5 if quick else 50)))
    points = [SweepPoint(axis, v, SWEEP_AXES[axis].apply(config, v)) for axis, vs in DEFAULT_SWEEPS.items() for v in vs]
    sources = {"LQR": PolicySource.lqr(config), **_untrained_ppo(config)}
    cells = [EvaluationCell(name, variant, starts) for variant in [config] + [p.config for p in points]
             for name in sources]
    cpus = os.cpu_count() or 1
    serial, spread = [], []
    with torch_threads(1):  # as compare's default (--torch-threads 1), and as in every task
        time_cells(cells[: len(sources)], sources, distributed=False)  # this process warm, as a worker will be
        start = time.perf_counter()
        with ray_cluster(LOCAL, cpus) as cluster:
            started = time.perf_counter() - start
            cold = time_cells(cells, sources, distributed=True)
            for _ in range(ctx.settings.repeats):
                serial.append(time_cells(cells, sources, distributed=False))
                spread.append(time_cells(cells, sources, distributed=True))
    ctx.report.paragraph(
        f"{len(cells)} cells ({' and '.join(sources)}, each on the default scene and the {len(points)} values of "
        "the default sweeps), "
        f"{len(starts)} seeded starts of {config.max_episode_steps} steps each; Ray {ray.__version__}, {cluster}. "
        f"Starting the cluster took {started:.1f} s; the first pass of tasks, which starts Ray's worker processes, "
        f"{cold:.1f} s. Then serial and distributed passes alternate, best of {len(serial)}."
    )
    rows = [
        ["serially, in this process", f"{min(serial):.2f} s", "1"],
        [f"as Ray tasks ({cpus} CPUs)", f"{min(spread):.2f} s", fmt_ratio(min(serial), min(spread))],
    ]
    ctx.report.table(["cells run", "time", "speed-up"], rows, numeric_from=1)
    ctx.results["cells"] = {"serial_s": min(serial), "distributed_s": min(spread), "cold_s": cold, "start_s": started}
