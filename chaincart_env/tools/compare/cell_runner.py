"""The independent pieces of a study ("cells": one training seed, one policy evaluated
on one scene variant), run one after the other in this process or as Ray tasks on a
cluster, with the same results.

:func:`map_cells` calls ``function(shared, cell)`` for every cell and returns the
results in the cells' order. Serially, it calls it here. Distributed, every call is a
Ray task of one CPU (``torch_threads`` CPUs when more) on the cluster this process is
connected to (:func:`ray_cluster`); ``shared`` goes into Ray's object store once and
each task reads it from there. Ray places the tasks on the nodes with free CPUs and
re-runs a task whose worker or node was lost (its default for tasks); there is no
scheduler here. The same function runs on the same inputs either way, and torch runs
with the same number of threads in every task as in the serial run, so the results are
identical wherever the function is deterministic.

Cells must not rely on this machine's files: a task may run on another machine.
Inputs travel inside the cells (or ``shared``), outputs come back as return values.
"""

from __future__ import annotations

import importlib.util
import logging
import os
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Optional, Sequence, TypeVar

from chaincart_env.errors import ChainCartError, InvalidInputError

__all__ = ["LOCAL", "map_cells", "ray_cluster", "torch_threads"]

S = TypeVar("S")
C = TypeVar("C")
R = TypeVar("R")

#: The ``--address`` that starts a new Ray cluster on this machine for the run (Ray's
#: own name for it), even beside a cluster this machine already runs.
LOCAL = "local"


def _set_torch_threads(threads: int) -> None:
    if importlib.util.find_spec("torch") is not None:
        import torch

        torch.set_num_threads(threads)


@contextmanager
def torch_threads(threads: Optional[int]) -> Iterator[None]:
    """Torch runs with ``threads`` threads inside (``None``, or no torch: unchanged),
    as it does in every task of :func:`map_cells` given the same count."""
    if threads is None or importlib.util.find_spec("torch") is None:
        yield
        return
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def _run_cell(function: Callable[[S, C], R], shared: S, cell: C, torch_threads: Optional[int]) -> R:
    """One cell in a Ray worker, with the driver's torch thread count."""
    if torch_threads is not None:
        _set_torch_threads(torch_threads)
    return function(shared, cell)


def map_cells(
    function: Callable[[S, C], R],
    cells: Sequence[C],
    *,
    shared: S = None,  # type: ignore[assignment]
    distributed: bool = False,
    torch_threads: Optional[int] = None,
    on_result: Optional[Callable[[int, R], None]] = None,
) -> list[R]:
    """``[function(shared, cell) for cell in cells]``, serially here or (``distributed``)
    as Ray tasks on the connected cluster (module docstring). ``on_result(i, result)``
    is called as each cell finishes (in the order they finish), e.g. to save it before
    the others are done. ``function`` must be importable by name (a module-level
    function) where the tasks run."""
    results: list[Any] = [None] * len(cells)

    def finished(index: int, result: R) -> None:
        results[index] = result
        if on_result is not None:
            on_result(index, result)

    if not distributed:
        for index, cell in enumerate(cells):
            finished(index, function(shared, cell))
        return results
    import ray

    if not ray.is_initialized():
        raise ChainCartError("map_cells(distributed=True) needs a Ray session: connect first (ray_cluster)")
    task: Any = ray.remote(num_cpus=max(1, torch_threads or 1))(_run_cell)
    shared_ref = ray.put(shared)
    refs = [task.remote(function, shared_ref, cell, torch_threads) for cell in cells]
    index_of = {ref: index for index, ref in enumerate(refs)}
    pending = list(refs)
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        finished(index_of[done[0]], ray.get(done[0]))
    return results


@contextmanager
def ray_cluster(address: Optional[str], cpus_needed: int) -> Iterator[str]:
    """Connects to the cluster at ``address`` (``"auto"``: the one this machine joined
    with ``ray start``; ``HOST:PORT`` of its head), or (``None`` or :data:`LOCAL`)
    starts a new local one with at least ``cpus_needed`` CPUs, even beside a running
    ``ray start`` cluster; disconnects (and stops a local one) afterwards. A Ray
    session the caller already started is used as it is. Yields a description of the
    cluster; fewer CPUs than ``cpus_needed`` is a ChainCartError."""
    try:
        import ray
    except ImportError as error:
        raise InvalidInputError(
            f"a Ray cluster needs Ray ({error}): install the rllib extra, pip install 'chaincart-env[rllib]'"
        ) from None

    owned = not ray.is_initialized()
    local = address in (None, LOCAL)
    if owned:
        if local:
            ray.init(address=LOCAL, num_cpus=max(os.cpu_count() or 1, cpus_needed), include_dashboard=False,
                     logging_level=logging.WARNING)
        else:
            ray.init(address=address, logging_level=logging.WARNING)
    try:
        cpus = int(ray.cluster_resources().get("CPU", 0))
        nodes = sum(1 for node in ray.nodes() if node.get("Alive"))
        if not owned:
            where = "the Ray cluster of this session"
        else:
            where = "a local Ray cluster" if local else f"the Ray cluster at {address}"
        if cpus < cpus_needed:
            raise ChainCartError(
                f"{where} has {cpus} CPUs: expected at least {cpus_needed} (one per env runner); "
                "add machines with `ray start --address=...` or ask for fewer --num-env-runners"
            )
        yield f"{where}: {nodes} node(s), {cpus} CPUs"
    finally:
        if owned:
            ray.shutdown()
