"""Warm starts: a new training run that begins from a saved agent's weights.

A robust agent learns the swing-up more surely from an agent that already performs it
on the nominal system than from scratch under noise and delay: the nominal run finds
the motion, the robust run then makes it hold under the draws (fine-tuning). The saved
agent must be of the same algorithm with the same observation and action spaces
(e.g. both trained with the same ``--history``); its network weights and optimiser
state are loaded into the new agent before it trains, and its normalisation
statistics too where both normalise observations.

The saved agent is loaded with stable-baselines3's loader, which unpickles: a file
passed here is trusted code, as with any SB3 model file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from chaincart_env.errors import InvalidInputError

__all__ = ["agent_file", "warm_start"]


def agent_file(source: Path) -> Path:
    """The model file of ``source``: a model file itself, or a training run's folder
    (its ``best_model.zip``, the model that scored best in training, else its
    ``model.zip``); an InvalidInputError naming it otherwise."""
    from chaincart_env.tools.compare.run_files import BEST_MODEL_FILE, MODEL_FILE

    source = Path(source)
    if source.is_dir():
        for name in (BEST_MODEL_FILE, MODEL_FILE):
            if (source / name).is_file():
                return source / name
        raise InvalidInputError(f"warm start {source}: a folder without {BEST_MODEL_FILE} or {MODEL_FILE}; expected a "
                                "training run's folder or a model file")
    if not source.is_file():
        raise InvalidInputError(f"warm start {source}: no such file; expected a training run's folder or a model file")
    return source


def warm_start(model: Any, source: Path) -> Path:
    """Loads the weights (and optimiser state) of the agent saved at ``source`` into
    ``model``, and its normalisation statistics where ``model`` normalises; returns the
    model file read. An InvalidInputError says why an agent does not fit."""
    from chaincart_env.tools.compare.normalization import load_statistics

    path = agent_file(source)
    statistics, normalizer = load_statistics(path), model.get_vec_normalize_env()
    if (statistics is None) != (normalizer is None):
        raise InvalidInputError(
            f"warm start {path}: {'has' if statistics is not None else 'has no'} normalisation statistics where the "
            f"new agent {'does not normalise' if normalizer is None else 'normalises'}; expected an agent trained with "
            "the same normalisation"
        )
    if statistics is not None:
        _check_floors(path, statistics, normalizer)
    try:
        model.set_parameters(str(path), exact_match=True, device="cpu")
    except (ValueError, RuntimeError, KeyError) as error:
        first_line = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise InvalidInputError(f"warm start {path}: {first_line}; expected an agent of the same algorithm with the "
                                "same observation and action spaces") from None
    if statistics is not None:
        normalizer.obs_rms, normalizer.ret_rms = statistics.obs_rms, statistics.ret_rms
    return path


def _check_floors(path: Path, statistics: Any, normalizer: Any) -> None:
    """Refuses a warm start whose agent divided its observations by other spreads than the
    new agent's statistics would (a spread floor on one side only, or another floor)."""
    import numpy as np

    from chaincart_env.tools.compare.normalization import variance_floor_of

    saved, new = variance_floor_of(statistics), variance_floor_of(normalizer)
    same = saved is None and new is None or saved is not None and new is not None and np.array_equal(saved, new)
    if not same:
        raise InvalidInputError(
            f"warm start {path}: its observation spread floor ({'none' if saved is None else 'set'}) differs from the "
            f"new agent's ({'none' if new is None else 'set'}); expected the same --curriculum-spread-floor on the "
            "same scene"
        )
