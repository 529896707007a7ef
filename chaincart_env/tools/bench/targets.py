"""Targets section: the speed goals of the Rust core and of the Python package,
each with the measured number and whether it is met, from the sections that ran."""

from __future__ import annotations

from typing import Optional

from chaincart_env.tools.bench.bench_report import fmt_rate
from chaincart_env.tools.bench.context import BenchContext

__all__ = ["targets_section"]


def _verdict(ok: Optional[bool]) -> str:
    return "not measured" if ok is None else ("met" if ok else "NOT met")


def _core_targets(ctx: BenchContext) -> list[list[str]]:
    crit = ctx.results.get("criterion", {})
    step = crit.get("step/rk4/5", {}).get("median")
    batch = crit.get("batch/4096", {}).get("median")
    rate = 4096 / batch if batch else None
    return [
        ["5-link rk4 step, 1 substep, one core (criterion step/rk4/5)", "<= 0.5 us",
         f"{step * 1e6:.3f} us" if step else "n/a", _verdict(step <= 0.5e-6 if step else None)],
        ["4096-state batch, 2 cores (criterion batch/4096)", ">= 4 M env-steps/s",
         fmt_rate(rate), _verdict(rate >= 4e6 if rate else None)],
    ] + _lane_targets(crit)  # fmt: skip


def _lane_targets(crit: dict[str, dict[str, float]]) -> list[list[str]]:
    """The SIMD-lane goals of the raw batch: 4096 paper systems, widest kernel, 2 cores."""
    f64 = max((4096 / m for k, v in crit.items() if k.startswith("batch_kernel/avx")
               and k.endswith("/4096") and (m := v.get("median"))), default=None)  # fmt: skip
    f32_time = crit.get("batch_kernel/f32/4096", {}).get("median")
    f32 = 4096 / f32_time if f32_time else None
    return [
        [f"4096 paper systems on SIMD lanes, {name}, 2 cores (criterion batch_kernel)", f">= {goal / 1e6:g} M env-steps/s",
         fmt_rate(r), _verdict(r >= goal if r else None)]
        for name, r, goal in (("f64", f64, 20e6), ("f32", f32, 35e6))
    ]  # fmt: skip


def _package_targets(ctx: BenchContext) -> list[list[str]]:
    rows = []
    single = ctx.results.get("single", {})
    base = single.get("CartPole-v1")
    for label in ("default", "ChainCart-v0 paper 5-link, substeps 1"):
        r = single.get(label)
        ok = (r >= base) if r and base else None
        name = "default scene" if label == "default" else "paper 5-link, 1 substep"
        rows.append([f"gym.make single env, {name}", ">= CartPole-v1",
                     f"{fmt_rate(r)} vs {fmt_rate(base)} steps/s", _verdict(ok)])  # fmt: skip
    vector = ctx.results.get("vector", {}).get("chaincart", {})
    for n_envs, bound, what in ((4096, 0.10, "< 10% of a step"), (1, 5e-6, "< 5 us per call")):
        cells = [(k, m) for (k, n), m in vector.items() if n == n_envs]
        if not cells:
            rows.append([f"vector env Python overhead, N = {n_envs}", what, "n/a", _verdict(None)])
            continue
        overhead = {k: m["vector_call"] - m["native_call"] for k, m in cells}
        value = {k: (o / m["vector_call"] if n_envs > 1 else o) for (k, m), o in zip(cells, overhead.values())}
        worst = max(value.values())
        shown = ", ".join(f"n={k}: " + (f"{v:.1%}" if n_envs > 1 else f"{v * 1e6:.1f} us") for k, v in value.items())
        rows.append([f"vector env Python overhead, N = {n_envs}", what, shown, _verdict(worst < bound)])
    return rows + _vector_speed_targets(ctx)


def _vector_speed_targets(ctx: BenchContext) -> list[list[str]]:
    """The vector env's rate at N = 4096 (5 spatial links) and one planar link against
    Gymnasium's NumPy CartPoleVectorEnv in the same run."""
    five = ctx.results.get("vector", {}).get("chaincart", {}).get((5, 4096), {}).get("vector")
    rows = [["ChainCartVectorEnv, 5 spatial links, N = 4096", ">= 8 M env-steps/s", fmt_rate(five),
             _verdict(five >= 8e6 if five else None)]]  # fmt: skip
    planar = ctx.results.get("planar_link", {})
    cartpole = planar.get("cartpole")
    for precision in ("f64", "f32"):
        r = planar.get(precision, {}).get("vector")
        ok = r > cartpole if r and cartpole else None
        rows.append([f"ChainCartVectorEnv, 1 planar link, {precision}, N = 4096", "> CartPoleVectorEnv",
                     f"{fmt_rate(r)} vs {fmt_rate(cartpole)}", _verdict(ok)])  # fmt: skip
    return rows


def targets_section(ctx: BenchContext) -> None:
    """The targets section: each speed goal, what was measured, and the verdict."""
    ctx.report.heading("Speed targets")
    rows = _core_targets(ctx) + _package_targets(ctx)
    ctx.report.table(["target", "goal", "measured", "verdict"], rows, 4)
    ctx.report.paragraph(
        "A target reads 'not measured' when the section it needs did not run in this invocation "
        "(criterion results come from the last `cargo bench --bench dynamics`)."
    )
