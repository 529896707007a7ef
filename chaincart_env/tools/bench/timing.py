"""Timing loops shared by the benchmark sections."""

from __future__ import annotations

import time
from typing import Any, Callable

__all__ = ["rate", "best_seconds"]


def rate(fn: Callable[[], Any], min_time: float, repeats: int) -> float:
    """Best calls per second of ``fn`` over ``repeats`` runs of at least ``min_time`` s.

    Calls are made in doubling batches so that the clock is read rarely."""
    best = 0.0
    for _ in range(repeats):
        calls, batch, start = 0, 1, time.perf_counter()
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


def best_seconds(fn: Callable[[], Any], repeats: int) -> float:
    """Shortest wall time of ``repeats`` calls of ``fn`` (for calls long enough to time singly)."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best
