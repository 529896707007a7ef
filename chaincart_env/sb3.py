"""``ChainCartVecEnv``: a stable-baselines3 ``VecEnv`` directly on the Rust batch (no
DummyVecEnv or SubprocVecEnv). Importing this module imports stable-baselines3 (the
``sb3`` extra); ``import chaincart_env`` alone does not."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Mapping, Optional

import gymnasium as gym
import numpy as np
from gymnasium.error import ResetNeeded
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.front_end import (
    BatchFrontEnd,
    EnvOfBatch,
    action_space,
    check_seed,
    diagnostics_info,
    entropy_seed,
    episode_info,
    fresh_seeds,
    observation_space,
    start_state_option,
)

__all__ = ["ChainCartVecEnv"]


class _EnvView(EnvOfBatch):
    """Sub-env ``index`` as ``get_attr``, ``set_attr`` and ``env_method`` see it: its
    own ``state``, ``model_state`` (both settable), ``elapsed_steps``,
    ``episode_target``, ``true_params``, ``set_state`` (those of :class:`EnvOfBatch`),
    ``render``, the attributes set on it alone, and every attribute of the VecEnv (shared
    by all envs; among them the batch, config and model :class:`EnvOfBatch` reads)."""

    #: Attributes stored on the view itself (everything else set goes to the VecEnv).
    _OWN = ("_vec", "_env_index")

    def __init__(self, vec: "ChainCartVecEnv", index: int) -> None:
        object.__setattr__(self, "_vec", vec)
        object.__setattr__(self, "_env_index", index)

    # The states of EnvOfBatch, settable here.
    @property
    def model_state(self) -> np.ndarray:
        return super().model_state

    @model_state.setter
    def model_state(self, state: np.ndarray) -> None:
        self.set_state(state)

    @property
    def state(self) -> np.ndarray:
        return super().state

    @state.setter
    def state(self, state: np.ndarray) -> None:
        y = np.asarray(state, dtype=np.float64)
        self.set_state(self._vec.model.from_spatial(y) if self._vec.config.planar else y)

    def get_wrapper_attr(self, name: str) -> Any:
        return getattr(self, name)

    def set_wrapper_attr(self, name: str, value: Any, *, force: bool = True) -> bool:
        """Sets ``name`` on this env alone, as ``set_attr`` with its index does."""
        self._vec.set_attr(name, value, indices=[self._env_index])
        return True

    def render(self) -> Optional[np.ndarray]:
        """This env's frame (``None`` without a render mode)."""
        vec = self._vec
        if vec.render_mode is None:
            return None
        return vec._rendering.frames([vec._batch.states()[self._env_index]], first=self._env_index)[0]

    def __getattr__(self, name: str) -> Any:
        # Not the view's own: shared by all envs of the batch. (Special and own names
        # are never forwarded: unpickling looks some up before _vec exists.)
        if name.startswith("__") or name in self._OWN:
            raise AttributeError(name)
        return getattr(self._vec, name)

    def __setattr__(self, name: str, value: Any) -> None:
        # A property of the view (per-env state) or an attribute of this env alone.
        object.__setattr__(self, name, value)


class ChainCartVecEnv(BatchFrontEnd, VecEnv):
    """``num_envs`` chaincart envs as one stable-baselines3 ``VecEnv`` (for SB3's
    algorithms; :class:`chaincart_env.ChainCartVectorEnv` is the Gymnasium one).

    Arguments as for :class:`chaincart_env.ChainCartEnv` (a config and/or its keywords)
    plus ``num_envs`` and an optional ``seed`` (env i gets ``seed + i`` at the first
    reset; ``seed()`` does the same for the next reset). Autoreset is same-step, as
    SB3 expects: a done env's ``info`` holds ``terminal_observation``,
    ``TimeLimit.truncated`` (truncated and not terminated) and the episode-end keys
    ``is_success``, ``numerical_failure``, ``out_of_track``, ``fell``, ``e_q``, ``e_w``.
    Rewards are float32. Works with ``VecMonitor`` and ``VecNormalize``.

    ``get_attr``, ``set_attr`` and ``env_method`` take every index form SB3 takes
    (``None`` for all envs, an int, negative ints counting from the end, a sequence)
    and see each sub-env as a view with its own ``state``, ``model_state`` (both
    settable), ``elapsed_steps``, ``set_state``, ``render``, ``set_wrapper_attr``,
    ``true_params`` / ``get_true_params()`` (the env's true physical parameters; with a
    parameter gap also in ``reset_infos`` and, for the new episode, in a done env's
    info under ``"params"``) and every attribute of this VecEnv (``config``, ``model``,
    ``dt``, ...). ``set_attr`` of an attribute the VecEnv has sets it for all envs (only
    all envs at once: it is shared); any other name is set per env, on the envs given.
    ``set_options`` reaches each env's next reset (``{"state": y}`` starts that env at
    ``y``). No env is wrapped (``env_is_wrapped`` is all False).

    Rendering: ``render_mode`` ``"rgb_array"`` or ``"human"``, frames of
    ``render_width x render_height`` (``render_camera``, ``render_trail`` as for the
    single env) with each env's last force; ``render()`` tiles the
    first ``render_envs`` envs (default ``min(num_envs, 4)``) like
    :class:`chaincart_env.ChainCartVectorEnv` (``human``: in a window), and
    ``get_images()`` returns every env's frame (with ``metadata["render_fps"]`` as for
    the single env, what SB3's ``VecVideoRecorder`` reads).
    """

    def __init__(
        self,
        num_envs: int = 1,
        config: Optional[ChainCartConfig | Mapping[str, Any]] = None,
        *,
        seed: Optional[int] = None,
        render_mode: Optional[str] = None,
        render_width: Optional[int] = None,
        render_height: Optional[int] = None,
        render_envs: Optional[int] = None,
        render_camera: Any = None,
        render_trail: float = 0.0,
        **kwargs: Any,
    ) -> None:
        self._open_batch(config, kwargs, num_envs, "same_step", entropy_seed())
        self._open_tiled_rendering(render_mode, render_width, render_height, render_envs, render_camera, render_trail)
        self._actions: Optional[np.ndarray] = None
        self._views = [_EnvView(self, i) for i in range(self._batch_size)]
        super().__init__(self._batch_size, observation_space(self.config), action_space(self.config))
        self.metadata = self._with_render_fps(self.metadata)  # type: ignore[assignment]  # SB3 types it as lists
        if seed is not None:
            self.seed(seed)

    def seed(self, seed: Optional[int] = None) -> Sequence[Optional[int]]:
        """Seeds of the next ``reset`` (SB3's ``seed``): env i gets ``seed + i``."""
        if seed is not None:
            check_seed(seed)
        return super().seed(seed)

    def reset(self) -> VecEnvObs:
        """Resets every env (SB3's ``reset``) with the seeds and options set since the last reset;
        returns the observations."""
        seeds: list[Optional[int]] = [None if s is None else check_seed(s) for s in self._seeds]
        starts = [start_state_option(options or None) for options in self._options]
        if not self._seeded and all(s is None for s in seeds):
            seeds = fresh_seeds(self.num_envs)
        self._seeded = True
        obs = self._batch.reset(seeds, None)
        for i, start in enumerate(starts):
            if start is not None:
                obs[i] = self._start_at(i, start)
        if self.render_mode is not None:
            self._draw_reset()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        if self.config.has_param_gap:
            for i, info in enumerate(self.reset_infos):
                info["params"] = self._batch.env_params(i)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Keeps ``actions`` for the next ``step_wait`` (SB3's ``step_async``)."""
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        """Steps every env with the actions of ``step_async`` in one native call (SB3's
        ``step_wait``): observations, rewards, dones and infos, ended envs reset."""
        if self._actions is None:
            raise InvalidInputError("step_wait() without step_async(actions): expected actions first")
        if not self._seeded:
            self._actions = None
            raise ResetNeeded("ChainCartVecEnv: call reset() before step()")
        actions, self._actions = self._actions, None
        obs, rewards, terminated, truncated, n_ended = self._batch.step(actions)
        dones = terminated | truncated
        if self.render_mode is not None:
            self._draw_step(actions, fresh=dones)  # done envs show their new start
        # As DummyVecEnv: TimeLimit.truncated in every info.
        infos: list[dict[str, Any]] = [
            {"TimeLimit.truncated": bool(tr and not te)} for te, tr in zip(terminated, truncated)
        ]
        if self._diagnostics:
            diag, errors = self._batch.diagnostics(), self._batch.errors()
            for k, info in enumerate(infos):
                info.update(diagnostics_info(diag[k], errors[k]))
        if n_ended:
            events, errors = self._batch.events(), self._batch.errors()
            finals = self._batch.final_observations()
            for i in np.flatnonzero(dones):
                info = infos[i]
                info.update(episode_info(int(events[i]), errors[i, 0], errors[i, 1]))
                info["terminal_observation"] = finals[i]
                if self.config.has_param_gap:
                    info["params"] = self._batch.env_params(int(i))  # of the new episode
        return obs, rewards.astype(np.float32), dones, infos

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        """Env indices in ``[0, num_envs)`` from every form SB3 accepts (negative ints
        count from the end, as for DummyVecEnv's list of envs)."""
        if indices is None:
            return list(range(self.num_envs))
        many = [indices] if isinstance(indices, (int, np.integer)) else indices
        try:
            items = list(many)  # type: ignore[arg-type]
        except TypeError:
            raise TypeError(f"indices = {indices!r}: expected None, an int or a sequence of ints") from None
        out = []
        for i in items:
            if isinstance(i, bool) or not isinstance(i, (int, np.integer)):
                raise TypeError(f"indices = {indices!r}: expected None, an int or a sequence of ints")
            if not -self.num_envs <= i < self.num_envs:
                raise IndexError(f"env index {i} out of range for num_envs = {self.num_envs}")
            out.append(int(i) % self.num_envs)
        return out

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """Attribute ``attr_name`` of each env in ``indices`` (SB3's ``get_attr``)."""
        return [getattr(self._views[i], attr_name) for i in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Sets attribute ``attr_name`` of the envs in ``indices`` (SB3's ``set_attr``)."""
        targets = self._indices(indices)
        per_env = isinstance(getattr(_EnvView, attr_name, None), property) or not hasattr(self, attr_name)
        if per_env:
            for i in targets:
                setattr(self._views[i], attr_name, value)
        elif sorted(set(targets)) == list(range(self.num_envs)):
            setattr(self, attr_name, value)
        elif targets:
            raise InvalidInputError(
                f"set_attr({attr_name!r}) on envs {targets} only: {attr_name!r} is shared by all "
                f"{self.num_envs} envs of the batch (expected indices=None)"
            )

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        """Calls method ``method_name`` of each env in ``indices`` (SB3's ``env_method``)."""
        return [
            getattr(self._views[i], method_name)(*method_args, **method_kwargs) for i in self._indices(indices)
        ]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        """False for every env: the envs of the native batch are never wrapped (SB3's
        ``env_is_wrapped``)."""
        return [False for _ in self._indices(indices)]

    def get_images(self) -> Sequence[Optional[np.ndarray]]:
        """Every env's frame (``None`` each without a render mode)."""
        if self.render_mode is None:
            return [None for _ in range(self.num_envs)]
        return self._frames()

    def render(self, mode: Optional[str] = None) -> Optional[np.ndarray]:
        """The first ``render_envs`` envs tiled (``rgb_array``) or shown (``human``);
        another ``mode`` than the constructor's goes to SB3's ``VecEnv.render``."""
        if self.render_mode is None or (mode is not None and mode != self.render_mode):
            return super().render(mode)
        return self._draw()

    def close(self) -> None:
        """Closes the human-mode window, if one is open."""
        self._close_window()
