"""``ChainCartVectorEnv``: N envs whose batch lives and steps in Rust.

A vector step is one native call (GIL released, envs stepped in parallel in fixed
chunks, so results do not depend on the thread count); Python only builds the info
dict when an episode ended (or diagnostics are on).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Mapping, Optional, Union

import numpy as np
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from chaincart_env import _core
from chaincart_env.config import REGISTERED_EPISODE_STEPS, ChainCartConfig
from chaincart_env.errors import InvalidInputError, InvalidTypeError
from chaincart_env.front_end import (
    BatchFrontEnd,
    action_space,
    check_seed,
    entropy_seed,
    fresh_seeds,
    observation_space,
)
from chaincart_env.rendering import VECTOR_RENDER_MODES
from chaincart_env.spec import JsonSpec

__all__ = ["ChainCartVectorEnv", "autoreset_mode_of"]

_NATIVE_MODE = {
    AutoresetMode.NEXT_STEP: "next_step",
    AutoresetMode.SAME_STEP: "same_step",
    AutoresetMode.DISABLED: "disabled",
}

_EPISODE_KEYS = ("is_success", "numerical_failure", "out_of_track", "fell", "e_q", "e_w")


def autoreset_mode_of(mode: Union[AutoresetMode, str]) -> AutoresetMode:
    """An ``AutoresetMode`` from itself, its value (``"NextStep"``) or a snake-case
    name (``"next_step"``)."""
    if isinstance(mode, AutoresetMode):
        return mode
    if isinstance(mode, str):
        for m, native in _NATIVE_MODE.items():
            if mode in (m.value, native, m.name):
                return m
    raise InvalidInputError(
        f"autoreset_mode = {mode!r}: expected an AutoresetMode or one of 'next_step', 'same_step', 'disabled'"
    )


def episode_infos(batch: _core.EnvBatch) -> tuple[np.ndarray, dict[str, Any]]:
    """The envs whose episode ended on the last step and their batched episode-end info
    (Gymnasium's ``key`` / ``_key`` layout; the masks are one shared array)."""
    ended, *values = batch.episode_arrays()
    info: dict[str, Any] = {}
    for key, value in zip(_EPISODE_KEYS, values):
        info[key] = value
        info["_" + key] = ended
    return ended, info


def _scene_length_kept(kwargs: dict[str, Any]) -> dict[str, Any]:
    """``gymnasium.make_vec`` passes the registered episode length (the default
    scene's) as ``max_episode_steps`` unless it is given one; that default must not cut
    a chosen scene's (or config's) own length. So a ``max_episode_steps`` equal to the
    registered length is dropped: where the rest of the configuration has another
    length that one stays, and where it has the registered one nothing changes."""
    if kwargs.get("max_episode_steps") != REGISTERED_EPISODE_STEPS:
        return kwargs
    return {k: v for k, v in kwargs.items() if k != "max_episode_steps"}


class ChainCartVectorEnv(JsonSpec, BatchFrontEnd, VectorEnv):
    """``num_envs`` copies of :class:`chaincart_env.ChainCartEnv` stepped together in
    Rust, as one Gymnasium ``VectorEnv`` (:class:`chaincart_env.ChainCartVecEnv` is the
    stable-baselines3 one, on the same native batch). Arguments as for the single env (a config and/or its keywords) plus
    ``num_envs`` and ``autoreset_mode`` (an ``AutoresetMode`` or ``"next_step"``,
    ``"same_step"``, ``"disabled"``).

    * Next-step (default): the step after an episode ended resets that env (its
      action is ignored), returning the first observation, reward 0 and both flags
      false.
    * Same-step: an ended env is reset in the same step; ``info["final_obs"]`` (object
      array) and ``info["final_info"]`` hold the last observation and the episode-end
      info, with the ``_final_obs`` / ``_final_info`` masks.
    * Disabled: ended envs must be reset with ``reset(options={"reset_mask": mask})``
      before they are stepped again.

    Sim-to-real keywords (``randomize``, ``params``, ``mismatch``, ``obs_noise``,
    ``action_delay``, ``force_rate_limit``, ``force_noise``) as for the single env; env
    i's parameters, noises and force disturbances are those of the single env seeded
    ``s + i``. With a parameter gap,
    ``info["params"]`` (arrays over the envs, mask ``_params``) comes with ``reset``
    and with every step in which some env started a new episode; ``true_params``
    reads them at any time.

    Episode-end keys (``is_success``, ``numerical_failure``, ``out_of_track``, ``fell``,
    ``e_q``, ``e_w``) come batched with ``_key`` masks, like Gymnasium's vector envs.
    ``reset(seed=s)`` seeds env i with ``s + i`` (or a list of per-env seeds): env i
    then reproduces the single env reset with ``seed=s + i`` bit for bit. A bad action
    in any env (wrong shape, NaN, inf) raises before any env moves; a scalar (``step(0)``)
    is a ``TypeError`` (:class:`~chaincart_env.InvalidTypeError`), as in Gymnasium's
    vector envs. Diagnostics, when enabled, are top-level arrays of every env that
    stepped (of the state the step reached); as in ``SyncVectorEnv``, an env's reset
    (next-step autoreset) has none (mask false, value 0), and with same-step autoreset
    an ended env's diagnostics are in ``final_info``.

    Rendering follows Gymnasium's ``VectorEnv.render``: each env is drawn at
    ``render_width x render_height`` (``render_camera``, ``render_trail`` as for the
    single env) with the force of its last step, and

    * ``"rgb_array"``: ``render()`` returns a tuple of ``num_envs`` uint8 frames (what
      ``gymnasium.wrappers.vector.HumanRendering`` and ``RecordVideo`` read);
    * ``"rgb_array_list"``: ``render()`` returns a tuple of ``num_envs`` lists, each
      env's frames since the last ``render()`` (one per reset and per step; a reset
      starts the lists afresh);
    * ``"human"``: every reset and step shows the first ``render_envs`` envs (default
      ``min(num_envs, 4)``) tiled in a window; ``render()`` returns ``None``.

    :meth:`render_tiled` returns that mosaic as an image: the first ``render_envs``
    frames row by row in the most nearly square grid
    (:func:`chaincart_env.rendering.tile_frames`, 2 grey pixels between tiles).
    """

    metadata: dict[str, Any] = {
        "render_modes": list(VECTOR_RENDER_MODES),
        "render_fps": 50,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        config: Optional[ChainCartConfig | Mapping[str, Any]] = None,
        *,
        autoreset_mode: Union[AutoresetMode, str] = AutoresetMode.NEXT_STEP,
        render_mode: Optional[str] = None,
        render_width: Optional[int] = None,
        render_height: Optional[int] = None,
        render_envs: Optional[int] = None,
        render_camera: Any = None,
        render_trail: float = 0.0,
        **kwargs: Any,
    ) -> None:
        self.autoreset_mode = autoreset_mode_of(autoreset_mode)
        native_mode = _NATIVE_MODE[self.autoreset_mode]
        self._open_batch(config, _scene_length_kept(kwargs), num_envs, native_mode, entropy_seed())
        self.num_envs = self._batch_size
        self._open_tiled_rendering(
            render_mode, render_width, render_height, render_envs, render_camera, render_trail, VECTOR_RENDER_MODES
        )
        # rgb_array_list: per step, the tuple of every env's frame
        self._frame_history: list[tuple[np.ndarray, ...]] = []
        self.metadata = {**self._with_render_fps(type(self).metadata), "autoreset_mode": self.autoreset_mode}
        self.single_observation_space = observation_space(self.config)
        self.single_action_space = action_space(self.config)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._same_step = self.autoreset_mode == AutoresetMode.SAME_STEP

    @property
    def model_states(self) -> np.ndarray:
        """Float64 states in the observed layout, shape ``(num_envs, state_dim)``."""
        return self._batch.states()

    @property
    def states(self) -> np.ndarray:
        """Full float64 spatial states, shape ``(num_envs, 4 + 6n)`` (planar embedded)."""
        y = self._batch.states()
        if not self.config.planar:
            return y
        return np.stack([self.model.to_spatial(row) for row in y])

    @property
    def elapsed_steps(self) -> np.ndarray:
        """Steps taken in each env's current episode."""
        return self._batch.step_counts()

    def reset(
        self,
        *,
        seed: Optional[Union[int, Sequence[Optional[int]]]] = None,
        options: Optional[dict[str, Any]] = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Resets all envs (or those in ``options["reset_mask"]``). ``seed``: an int
        (env i gets ``seed + i``), a list of per-env seeds (``None`` entries continue
        their stream), or ``None``."""
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            base = check_seed(seed)
            super().reset(seed=base)
            seeds: list[Optional[int]] = [(base + i) % 2**64 for i in range(self.num_envs)]
        elif seed is None:
            seeds = [None] * self.num_envs if self._seeded else fresh_seeds(self.num_envs)
        elif isinstance(seed, Sequence) and not isinstance(seed, str):
            if len(seed) != self.num_envs:
                raise InvalidInputError(f"seed has {len(seed)} entries, expected num_envs = {self.num_envs}")
            seeds = [None if s is None else check_seed(s) for s in seed]
        else:
            raise InvalidTypeError(f"seed = {seed!r}: expected an int, a list of num_envs ints (or None), or None")
        mask = None
        if options is not None and not isinstance(options, dict):
            raise InvalidTypeError(f"options = {options!r}: expected a dict (or None)")
        unknown = sorted(set(options or {}) - {"reset_mask"})
        if unknown:
            raise InvalidInputError(f"options has unknown keys {unknown}: expected some of ['reset_mask']")
        if options is not None and "reset_mask" in options:
            mask = options["reset_mask"]
            if not (isinstance(mask, np.ndarray) and mask.dtype == np.bool_):
                raise InvalidTypeError(
                    f"options['reset_mask'] = {mask!r}: expected a bool numpy array of shape ({self.num_envs},)"
                )
            if mask.shape != (self.num_envs,):
                raise InvalidInputError(
                    f"options['reset_mask'] = {mask!r}: expected a bool numpy array of shape ({self.num_envs},)"
                )
            if not mask.any():
                raise InvalidInputError("options['reset_mask'] has no True entry: expected at least one env to reset")
        self._seeded = True
        obs = self._batch.reset(seeds, mask)
        if self.render_mode is not None:
            self._frame_history.clear()
            self._draw_reset(mask)
        info: dict[str, Any] = {}
        if self.config.has_param_gap:
            info["params"] = self.true_params
            info["_params"] = np.ones(self.num_envs, dtype=np.bool_) if mask is None else mask.copy()
        return obs, info

    @property
    def true_params(self) -> dict[str, np.ndarray]:
        """Every env's true physical parameters in its current episode, arrays with a
        leading ``num_envs`` axis: ``cart_mass``, ``gravity`` ``(num_envs,)``,
        ``link_masses``, ``link_lengths`` ``(num_envs, n_links)``. ``model`` stays the
        nominal system."""
        return self._batch.param_arrays()

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Steps every env; ``actions`` of shape ``(num_envs, force_dim)``."""
        if not self._seeded:
            raise ResetNeeded("ChainCartVectorEnv: call reset() before step()")
        obs, rewards, terminated, truncated, n_ended = self._batch.step(actions)
        if self.render_mode is not None:
            self._draw_step(actions, self._fresh_envs())
        if n_ended == 0 and not self._diagnostics:
            return obs, rewards, terminated, truncated, {}
        return obs, rewards, terminated, truncated, self._infos(n_ended)

    def _fresh_envs(self) -> np.ndarray:
        """The envs reset by the last step, drawn without a force: with next-step
        autoreset their action was ignored; with same-step they show their new start."""
        events = self._batch.events()
        fresh = (events & _core.EVENT_RESET) != 0
        if self._same_step:
            fresh |= (events & _core.EVENT_ENDED) != 0
        return fresh

    def _show_frame(self, reset: bool = False) -> None:
        """``rgb_array_list``: every env's frame kept for ``render()``; otherwise as for
        every front end (human mode: the window's frame when due)."""
        if self.render_mode == "rgb_array_list":
            self._frame_history.append(tuple(self._frames()))
        else:
            super()._show_frame(reset)

    def _infos(self, n_ended: int) -> dict[str, Any]:
        info: dict[str, Any] = {}
        # Envs that started a new episode in this step: their info is that of a reset.
        events = self._batch.events()
        fresh = (events & (_core.EVENT_ENDED if self._same_step else _core.EVENT_RESET)) != 0
        if self.config.has_param_gap and fresh.any():
            info["params"], info["_params"] = self.true_params, fresh
        if self._diagnostics and not fresh.all():
            info.update(self._diagnostic_infos(~fresh, with_errors=True))
        if n_ended == 0:
            return info
        ended, episode = episode_infos(self._batch)
        if self._same_step:
            finals = self._batch.final_observations()
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(ended):
                final_obs[i] = finals[i]
            if self._diagnostics:  # of the state each episode ended in
                episode.update(self._diagnostic_infos(ended, with_errors=False))
            info["final_obs"], info["_final_obs"] = final_obs, ended
            info["final_info"], info["_final_info"] = episode, ended
        else:
            if self._diagnostics:  # e_q, e_w are already there for every env that stepped
                for key in ("e_q", "_e_q", "e_w", "_e_w"):
                    del episode[key]
            info.update(episode)
        return info

    def _diagnostic_infos(self, envs: np.ndarray, with_errors: bool) -> dict[str, Any]:
        """The diagnostics (and ``e_q``, ``e_w``) of the envs in the mask ``envs``,
        zero for the others, as ``SyncVectorEnv`` batches keys that only some envs'
        infos carry (an env's reset info has no diagnostics)."""
        values = dict(zip(_core.DIAGNOSTICS, self._batch.diagnostics().T))
        if with_errors:
            errors = self._batch.errors()
            values.update(e_q=errors[:, 0], e_w=errors[:, 1])
        info: dict[str, Any] = {}
        for key, value in values.items():
            info[key], info["_" + key] = np.where(envs, value, 0.0), envs
        return info

    def render(self) -> Optional[tuple[Any, ...]]:
        """``rgb_array``: a tuple of every env's frame (uint8 ``(render_height,
        render_width, 3)``); ``rgb_array_list``: a tuple of every env's frames since the
        last call; ``human``: shows the tiled first ``render_envs`` envs (also done by
        every ``reset`` and ``step``) and returns ``None``. No render mode: ``None``."""
        if self.render_mode == "rgb_array":
            return tuple(self._frames())
        if self.render_mode == "rgb_array_list":
            history, self._frame_history = self._frame_history, []
            return tuple([frames[i] for frames in history] for i in range(self.num_envs))
        if self.render_mode == "human":
            self._draw()
        return None

    def render_tiled(self) -> np.ndarray:
        """The current frames of the first ``render_envs`` envs tiled in one uint8
        image (the picture human mode shows), in any render mode."""
        return self._rendering.image(self._batch.states())

    def close_extras(self, **kwargs: Any) -> None:
        """Closes the human-mode window, if one is open (Gymnasium's ``close_extras``)."""
        self._close_window()
