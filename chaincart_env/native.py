"""What the three env classes share about holding a native ``EnvBatch``."""

from __future__ import annotations

from typing import Any

import numpy as np

from chaincart_env.errors import InvalidInputError, InvalidTypeError

__all__ = ["NativeBatchCopies", "check_num_envs"]


def check_num_envs(num_envs: Any) -> int:
    """``num_envs`` as an int >= 1, or a clear error."""
    if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)):
        raise InvalidTypeError(f"num_envs = {num_envs!r}: expected an integer >= 1")
    if num_envs < 1:
        raise InvalidInputError(f"num_envs = {num_envs!r}: expected an integer >= 1")
    return int(num_envs)


class NativeBatchCopies:
    """Pickling and deepcopy for an env whose native batch lives in ``_batch``: the
    batch is rebuilt by ``_rebuild_batch()`` from the config and restored from a
    snapshot of everything that evolves, so a copy continues identically."""

    _batch: Any

    def _rebuild_batch(self) -> Any:
        raise NotImplementedError

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_batch"] = self._batch.snapshot()
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        snapshot = state.pop("_batch")
        self.__dict__.update(state)
        self._batch = self._rebuild_batch()
        self._batch.restore(snapshot)
