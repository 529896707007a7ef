"""Scaling section: time of one acceleration evaluation against the number of links
n = 1 .. 256 for the O(n) tension form and the paper's dense form (eq. ELwm), and of one
rk4 step of the O(n) form, measured in Rust by ``examples/scaling.rs`` (the dense form
has no Python binding; timing in Rust keeps Python's call overhead out), with the
log-log slope fitted by least squares."""

from __future__ import annotations

import shutil
import subprocess
from collections import defaultdict
from pathlib import Path
from typing import Sequence

import numpy as np

from chaincart_env.bench.report import fmt_time
from chaincart_env.bench.suite import BenchContext

__all__ = ["scaling_section", "fit_loglog_slope", "parse_scaling_output", "FIT_FROM_N"]

ROOT = Path(__file__).resolve().parents[2]
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


def _run_example(quick: bool) -> dict[str, dict[int, float]]:
    command = ["cargo", "run", "--quiet", "--release", "--example", "scaling", "--"]
    command += ["--quick", "--max-n", "128"] if quick else ["--max-n", "256"]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, check=True)
    return parse_scaling_output(done.stdout)


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
    ctx.report.heading("Scaling with the number of links")
    if shutil.which("cargo") is None:
        ctx.report.paragraph("cargo is not on PATH: the scaling section (timed in Rust) is skipped.")
        return
    data = _run_example(ctx.settings.quick)
    fits = {form: fit_loglog_slope([n for n in t if n >= FIT_FROM_N], [t[n] for n in t if n >= FIT_FROM_N])
            for form, t in data.items()}  # fmt: skip
    ctx.results["scaling"] = {"data": data, "fits": fits}
    ctx.report.paragraph(
        "`cargo run --release --example scaling`: best of 3 timed runs per point, in Rust, one core. "
        f"Slopes are least-squares fits of log time on log n for n >= {FIT_FROM_N} (expected: 1 for the O(n) form, "
        "3 for the dense LU solve)."
    )
    ns = sorted(next(iter(data.values())))
    header = ["n"] + [FORMS[f] for f in data] + ["dense / fast"]
    rows = [[str(n)] + [fmt_time(data[f].get(n)) for f in data] + [f"{data['dense'][n] / data['fast'][n]:.0f}x"] for n in ns]
    rows.append(["fitted slope"] + [f"{fits[f][0]:.2f}" for f in data] + [""])
    ctx.report.table(header, rows)
    _plot(ctx, data, fits)
