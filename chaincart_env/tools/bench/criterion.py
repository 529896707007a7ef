"""Criterion section: the Rust core's own benchmarks (``cargo bench --bench dynamics``,
benches/dynamics.rs, in a source checkout) read back from criterion's JSON output. It
does not run cargo bench (a few minutes); it reports the last run's numbers and when
they were written, if there are any (an installed package has none unless
``CARGO_TARGET_DIR`` points at a checkout's target directory)."""

from __future__ import annotations

import datetime
import json
import os
from pathlib import Path
from typing import Optional

from chaincart_env.tools.bench.bench_report import fmt_rate, fmt_time
from chaincart_env.tools.bench.context import BenchContext

__all__ = ["criterion_section", "read_criterion", "criterion_dir"]

ROOT = Path(__file__).resolve().parents[3]


def criterion_dir() -> Optional[Path]:
    """Where criterion writes: ``$CARGO_TARGET_DIR/criterion``, else the source
    checkout's ``target/criterion``; ``None`` for an installed package without either."""
    if "CARGO_TARGET_DIR" in os.environ:
        return Path(os.environ["CARGO_TARGET_DIR"]) / "criterion"
    if (ROOT / "Cargo.toml").is_file():
        return ROOT / "target" / "criterion"
    return None


def read_criterion(directory: Optional[Path] = None) -> dict[str, dict[str, float]]:
    """``{full_id: {"median": seconds, "mtime": unix time}}`` of every benchmark's latest run."""
    directory = directory or criterion_dir()
    out: dict[str, dict[str, float]] = {}
    if directory is None or not directory.is_dir():
        return out
    for bench in sorted(directory.glob("**/new/benchmark.json")):
        meta = json.loads(bench.read_text())
        estimates = json.loads((bench.parent / "estimates.json").read_text())
        out[meta["full_id"]] = {"median": estimates["median"]["point_estimate"] * 1e-9, "mtime": bench.stat().st_mtime}
    return out


def _table(results: dict[str, dict[str, float]], group: str) -> list[list[str]]:
    by_name: dict[str, dict[int, float]] = {}
    for full_id, r in results.items():
        parts = full_id.split("/")
        if parts[0] != group:
            continue
        name, size = ("/".join(parts[1:-1]) or group), int(parts[-1])
        by_name.setdefault(name, {})[size] = r["median"]
    sizes = sorted({n for v in by_name.values() for n in v})
    return [["n = " + str(n)] + [fmt_time(by_name[name].get(n)) for name in by_name] for n in sizes], list(by_name)  # type: ignore[return-value]


def criterion_section(ctx: BenchContext) -> None:
    """The section of the Rust core's criterion results, read from the last ``cargo bench`` run (a
    note when there is none)."""
    ctx.report.heading("Rust core: criterion benchmarks (`cargo bench --bench dynamics`)")
    results = read_criterion()
    if not results:
        where = criterion_dir()
        found = f"under `{where}`" if where is not None else "(this is an installed package, not a source checkout)"
        ctx.report.paragraph(
            f"No criterion results {found}. To produce them, run `cargo bench --bench dynamics` in a source "
            "checkout of chaincart; set `CARGO_TARGET_DIR` to that checkout's `target` directory to report them "
            "from elsewhere."
        )
        return
    ctx.results["criterion"] = results
    newest = datetime.datetime.fromtimestamp(max(r["mtime"] for r in results.values()))
    ctx.report.paragraph(f"Medians from the last run (written {newest:%Y-%m-%d %H:%M}); one core except `batch`.")
    for group, title in (("accel", "one acceleration evaluation"), ("step", "one step, dt = 1 ms, 1 substep"),
                         ("planar_vs_spatial", "one rk4 step, planar vs spatial model")):  # fmt: skip
        rows, names = _table(results, group)  # type: ignore[misc]
        if rows:
            ctx.report.paragraph(f"`{group}`: {title}.")
            ctx.report.table(["links"] + names, rows)
    batch = {int(k.split("/")[1]): v["median"] for k, v in results.items() if k.startswith("batch/")}
    if batch:
        ctx.report.paragraph("`batch`: one rk4 step of N paper systems (5 links) on all cores.")
        batch_rows = [[str(n), fmt_time(t), fmt_rate(n / t)] for n, t in sorted(batch.items())]
        ctx.report.table(["N", "time per batch step", "env-steps/s"], batch_rows)
