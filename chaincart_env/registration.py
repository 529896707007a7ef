"""The Gymnasium ids: ``ChainCart-v0`` (the default scene, configurable by keywords)
and one id per scene, ``ChainCart-<scene>-v0``, registered with that scene's episode
length.

``gymnasium.make`` wraps every id in a ``TimeLimit`` of the length the id was
registered with, whatever keywords the env is given (the same holds for Gymnasium's
``FrozenLake-v1`` with an 8x8 map versus ``FrozenLake8x8-v1``). So a scene whose
episodes are longer than the default scene's needs its own id for its length to
apply: ``gymnasium.make("ChainCart-paper-fig3-v0")`` runs the paper's Fig. 3 scene for
its 12 000 steps, and its ``spec`` says so.

Every scene also has a robust variant, ``ChainCart-<scene>-robust-v0``: the scene with
the per-episode draws robust agents train on
(:data:`~chaincart_env.robust_training.ROBUST_CONDITIONS`), and a residual one,
``ChainCart-<scene>-residual-v0``: the scene itself, under the id whose entries in the
packaged hyperparameter files train residual agents (their ``env_wrapper`` adds the
planner's controller, :mod:`chaincart_env.residual`).
"""

from __future__ import annotations

from typing import Any, Mapping, Optional

import gymnasium

from chaincart_env.config import DEFAULT_SCENE, SCENES
from chaincart_env.residual import RESIDUAL_VARIANT
from chaincart_env.robust_training import ROBUST_CONDITIONS, ROBUST_VARIANT

__all__ = ["ENV_ID", "scene_env_id", "register_envs"]

#: The id of the default scene, configurable by keywords.
ENV_ID = "ChainCart-v0"

_ENTRY_POINT = "chaincart_env.env:ChainCartEnv"
_VECTOR_ENTRY_POINT = "chaincart_env.vector:ChainCartVectorEnv"


def scene_env_id(scene: str, variant: Optional[str] = None) -> str:
    """The Gymnasium id of a scene, ``ChainCart-<scene>-v0``, or of its variant
    (``ChainCart-<scene>-robust-v0``)."""
    return f"ChainCart-{scene}-v0" if variant is None else f"ChainCart-{scene}-{variant}-v0"


def _register(env_id: str, scene: str | None, conditions: Optional[Mapping[str, Any]] = None) -> None:
    if env_id in gymnasium.registry:
        return
    length = SCENES[scene or DEFAULT_SCENE]["max_episode_steps"]
    gymnasium.register(
        id=env_id,
        entry_point=_ENTRY_POINT,
        vector_entry_point=_VECTOR_ENTRY_POINT,
        # The scene's own episode length, so that gymnasium.make's TimeLimit and the
        # spec-reading wrappers (TimeAwareObservation, ...) agree with the env.
        max_episode_steps=length,
        kwargs={**({} if scene is None else {"scene": scene}), **(conditions or {})},
    )


def register_envs() -> None:
    """Registers ``ChainCart-v0``, every scene's id and every scene's robust and residual
    variants (idempotent)."""
    _register(ENV_ID, None)
    for scene in SCENES:
        _register(scene_env_id(scene), scene)
        _register(scene_env_id(scene, ROBUST_VARIANT), scene, ROBUST_CONDITIONS)
        _register(scene_env_id(scene, RESIDUAL_VARIANT), scene)
