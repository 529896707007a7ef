"""Scaling section: time of one acceleration evaluation against the number of links
n = 1 .. 256 for the O(n) tension form and the paper's dense form (eq. ELwm), and of one
rk4 step of the O(n) form, timed in Rust through the native module
(``_core.time_scaling``: the loop runs in Rust, so Python's call overhead stays out),
with the log-log slope fitted by least squares."""

from __future__ import annotations

from collections import defaultdict
from typing import Sequence

import numpy as np

from chaincart_env import _core
from chaincart_env.tools.bench.bench_report import fmt_time
from chaincart_env.tools.bench.context import BenchContext

__all__ = ["scaling_section", "fit_loglog_slope", "parse_scaling_output", "FIT_FROM_N"]

#: The slope is fitted from this n on, where the leading term dominates the constant costs.
FIT_FROM_N = 8
FORMS = {"fast": "O(n) form, accelerations", "dense": "dense form (LU), accelerations", "fast_rk4_step": "O(n) form, one rk4 step"}


def fit_loglog_slope(ns: Sequence[float], times: Sequence[float]) -> tuple[float, float]:
    """``(slope, prefactor)`` of the least-squares fit ``time = prefactor * n**slope``."""
    n_arr, t_arr = np.asarray(ns, dtype=float), np.asarray(times, dtype=float)
    if len(set(n_arr.tolist())) < 2:
        raise ValueError(f"fit_loglog_slope needs at least two distinct n, got {list(ns)}")
    both = np.concatenate([n_arr, t_arr])
    if n_arr.shape != t_arr.shape or not (np.all(np.isfinite(both)) and np.all(both > 0)):
        raise ValueError(f"fit_loglog_slope needs positive finite n and times, got n={list(ns)}, times={list(times)}")
    x, y = np.log(n_arr), np.log(t_arr)
    slope, intercept = np.polyfit(x, y, 1)
    return float(slope), float(np.exp(intercept))


def parse_scaling_output(text: str) -> dict[str, dict[int, float]]:
    """``{form: {n: seconds}}`` from the example's ``form n seconds`` lines."""
    out: dict[str, dict[int, float]] = defaultdict(dict)
    for line in text.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] in FORMS:
            out[parts[0]][int(parts[1])] = float(parts[2])
    return dict(out)


def measure(max_n: int, min_time: float) -> dict[str, dict[int, float]]:
    """``{form: {n: seconds}}`` for n = 1, 2, 4, .. max_n, timed in Rust."""
    out: dict[str, dict[int, float]] = {form: {} for form in FORMS}
    n = 1
    while n <= max_n:
        for form in FORMS:
            out[form][n] = _core.time_scaling(form, n, min_time)
        n *= 2
    return out


def _plot(ctx: BenchContext, data: dict[str, dict[int, float]], fits: dict[str, tuple[float, float]]) -> None:
    path = ctx.plot_path("scaling.png")
    if path is None:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    for form, times in data.items():
        ns = sorted(times)
        slope, pre = fits[form]
        line = ax.plot(ns, [times[n] for n in ns], "o", label=f"{FORMS[form]} (slope {slope:.2f})")
        fit_ns = [n for n in ns if n >= FIT_FROM_N]
        ax.plot(fit_ns, [pre * n**slope for n in fit_ns], "-", color=line[0].get_color(), alpha=0.6)
    ax.set(xscale="log", yscale="log", xlabel="number of links n", ylabel="seconds",
           title="Cost against the number of links (fits from n = 8)")  # fmt: skip
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def scaling_section(ctx: BenchContext) -> None:
    """The scaling section: time of the O(n) and dense accelerations and of an rk4 step against the
    number of links, with the fitted slopes."""
    ctx.report.heading("Scaling with the number of links")
    quick = ctx.settings.quick
    data = measure(128 if quick else 256, 0.01 if quick else 0.1)
    fits = {form: fit_loglog_slope([n for n in t if n >= FIT_FROM_N], [t[n] for n in t if n >= FIT_FROM_N])
            for form, t in data.items()}  # fmt: skip
    ctx.results["scaling"] = {"data": data, "fits": fits}
    ctx.report.paragraph(
        "Timed in Rust through the native module (`_core.time_scaling`; the same numbers as "
        "`cargo run --release --example scaling`): best of 3 timed runs per point, one core. "
        f"Slopes are least-squares fits of log time on log n for n >= {FIT_FROM_N} (expected: 1 for the O(n) form, "
        "3 for the dense LU solve)."
    )
    ns = sorted(next(iter(data.values())))
    header = ["n"] + [FORMS[f] for f in data] + ["dense / fast"]
    rows = [[str(n)] + [fmt_time(data[f].get(n)) for f in data] + [f"{data['dense'][n] / data['fast'][n]:.0f}x"] for n in ns]
    rows.append(["fitted slope"] + [f"{fits[f][0]:.2f}" for f in data] + [""])
    ctx.report.table(header, rows)
    _plot(ctx, data, fits)
