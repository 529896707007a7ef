"""The Python front end of a native ``EnvBatch``: one implementation of what the three
env classes share, each keeping its framework's API and base class.

* :class:`FrontEnd` (all three: :class:`~chaincart_env.ChainCartEnv`,
  :class:`~chaincart_env.ChainCartVectorEnv`, :class:`~chaincart_env.ChainCartVecEnv`):
  the configuration resolved from a config and/or its keywords, the model, the native
  batch built from it, the rendering helpers, ``dt``, pickling and deepcopy.
* :class:`BatchFrontEnd` (the two vector envs): tiled rendering of the first envs and
  ``episode_targets``.
* :class:`EnvOfBatch` (``ChainCartEnv``, and each sub-env of ``ChainCartVecEnv`` as
  ``get_attr`` and ``env_method`` see it): one env's ``state``, ``model_state``,
  ``elapsed_steps``, ``episode_target``, ``true_params`` and ``set_state``.

The functions build what the envs return: spaces, checked seeds and reset options, and
the info of a step.
"""

from __future__ import annotations

from typing import Any, Mapping, Optional, Sequence

import numpy as np
from gymnasium import spaces

from chaincart_env import _core
from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError, InvalidTypeError
from chaincart_env.rendering import RENDER_MODES, EnvRendering, check_shown_envs

__all__ = [
    "FrontEnd",
    "BatchFrontEnd",
    "EnvOfBatch",
    "RESET_OPTIONS",
    "action_space",
    "check_num_envs",
    "check_seed",
    "diagnostics_info",
    "entropy_seed",
    "episode_info",
    "fresh_seeds",
    "observation_space",
    "start_state_option",
]

#: Keys ``ChainCartEnv.reset`` (and ``ChainCartVecEnv.set_options``) accept in ``options``.
RESET_OPTIONS = ("state",)


def check_num_envs(num_envs: Any) -> int:
    """``num_envs`` as an int >= 1, or a clear error."""
    if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)):
        raise InvalidTypeError(f"num_envs = {num_envs!r}: expected an integer >= 1")
    if num_envs < 1:
        raise InvalidInputError(f"num_envs = {num_envs!r}: expected an integer >= 1")
    return int(num_envs)


def check_seed(seed: Any) -> int:
    """``seed`` as an int in ``[0, 2**64)``, or a clear error naming it."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise InvalidTypeError(f"seed = {seed!r}: expected an integer in [0, 2**64)")
    if not 0 <= int(seed) < 2**64:
        raise InvalidInputError(f"seed = {seed!r}: expected an integer in [0, 2**64)")
    return int(seed)


def entropy_seed() -> int:
    """A fresh 63-bit seed from the OS entropy pool."""
    return int(np.random.SeedSequence().generate_state(1, np.uint64)[0] >> np.uint64(1))


def fresh_seeds(num_envs: int) -> list[Optional[int]]:
    """Seeds ``base + i`` of envs ``i < num_envs`` from one fresh entropy seed ``base``
    (a batch's first reset without a seed: env i then replays the single env seeded
    ``base + i``)."""
    base = entropy_seed()
    return [base + i for i in range(num_envs)]


def observation_space(config: ChainCartConfig) -> spaces.Box:
    """Box of one observation: link direction components in [-1, 1] (unbounded too
    with ``obs_noise``), the rest unbounded (``-inf``/``inf``, Gymnasium's convention;
    observations themselves are always finite)."""
    dtype = np.dtype(config.obs_dtype)
    high = np.full(config.obs_dim, np.inf, dtype=dtype)
    if not np.any(np.asarray(config.obs_noise if config.obs_noise is not None else 0.0)):
        start, stop = config.state_layout["q"]
        high[start:stop] = 1.0
    high[config.state_dim :] = 1.0  # the target's signs, when observed
    return spaces.Box(-high, high, dtype=dtype.type)


def action_space(config: ChainCartConfig) -> spaces.Box:
    """Box(-1, 1) of one normalised force: 2 numbers (spatial) or 1 (planar), float32."""
    return spaces.Box(-1.0, 1.0, shape=(config.force_dim,), dtype=np.float32)


def episode_info(events: int, e_q: float, e_w: float) -> dict[str, Any]:
    """The info keys of an episode's last step."""
    return {
        "is_success": bool(events & _core.EVENT_SUCCESS),
        "numerical_failure": bool(events & _core.EVENT_NUMERICAL_FAILURE),
        "out_of_track": bool(events & _core.EVENT_OUT_OF_TRACK),
        "fell": bool(events & _core.EVENT_FELL),
        "e_q": float(e_q),
        "e_w": float(e_w),
    }


def diagnostics_info(diagnostics: np.ndarray, errors: np.ndarray) -> dict[str, float]:
    """One env's info of a step with ``diagnostics=True``: its row of the batch's
    ``diagnostics()`` under the core's names, then ``e_q`` and ``e_w`` (its row of
    ``errors()``)."""
    info = dict(zip(_core.DIAGNOSTICS, map(float, diagnostics)))
    info.update(e_q=float(errors[0]), e_w=float(errors[1]))
    return info


def start_state_option(options: Optional[dict[str, Any]]) -> Optional[np.ndarray]:
    """The ``state`` reset option (a full state in this scene's layout), checking that
    ``options`` is a dict with known keys only."""
    if options is None:
        return None
    if not isinstance(options, dict):
        raise InvalidTypeError(f"options = {options!r}: expected a dict (or None)")
    unknown = sorted(set(options) - set(RESET_OPTIONS))
    if unknown:
        raise InvalidInputError(f"options has unknown keys {unknown}: expected some of {list(RESET_OPTIONS)}")
    if "state" not in options:
        return None
    return np.asarray(options["state"], dtype=np.float64)


class FrontEnd:
    """What every env class holds over its native batch: ``config`` (resolved once),
    ``model`` (the nominal system), the batch of ``_batch_size`` envs in ``_batch``,
    the rendering in ``_rendering`` with ``render_mode``, and ``dt``. A pickled or
    deep-copied env rebuilds its batch from the config and restores a snapshot of
    everything that evolves, so the copy continues identically.

    No ``__init__``, ``reset``, ``step``, ``render`` or ``close`` here: those are the
    frameworks'. A constructor calls :meth:`_open_batch`, then :meth:`_open_rendering`.
    """

    config: ChainCartConfig
    model: _core.ChainCart
    render_mode: Optional[str]
    _batch: _core.EnvBatch
    _batch_size: int
    _autoreset: str
    _rendering: EnvRendering
    _diagnostics: bool
    _seeded: bool

    def _open_batch(
        self,
        config: Optional[ChainCartConfig | Mapping[str, Any]],
        keywords: Mapping[str, Any],
        num_envs: Any,
        autoreset: str,
        seed: int = 0,
    ) -> None:
        """Resolves the config (``config`` and/or its keywords on top), then builds the
        model and a native batch of ``num_envs`` envs with the core's ``autoreset``
        mode, its streams seeded from ``seed`` until the first reset seeds them."""
        self._batch_size = check_num_envs(num_envs)
        self.config = ChainCartConfig.coerce(config, **keywords)
        self.model = self.config.make_model()
        self._autoreset = autoreset
        # Before the rendering: the core refuses a num_envs too large to allocate
        # before anything is.
        self._batch = self.config.make_batch(self._batch_size, autoreset, seed)
        self._diagnostics = self.config.diagnostics
        self._seeded = False

    def _open_rendering(
        self,
        render_mode: Optional[str],
        width: Optional[int],
        height: Optional[int],
        camera: Any,
        trail: float,
        *,
        shown: int = 1,
        tiled: bool = False,
        modes: Sequence[str] = RENDER_MODES,
    ) -> None:
        """The rendering of the first ``shown`` envs (``tiled``: in a grid), each env's
        last force and trail remembered; ``render_mode`` one of ``modes`` (checked)."""
        self._rendering = EnvRendering(
            render_mode,
            self.config,
            width,
            height,
            shown=shown,
            tiled=tiled,
            tracked=self._batch_size,
            modes=modes,
            camera=camera,
            trail=trail,
            targets=self._episode_targets if self.config.goal_conditioned else None,
        )
        self.render_mode = self._rendering.mode

    def _with_render_fps(self, metadata: Mapping[str, Any]) -> dict[str, Any]:
        """``metadata`` with this config's ``render_fps``."""
        return {**metadata, "render_fps": self._rendering.fps}

    @property
    def dt(self) -> float:
        """Control period (s): the time one step advances."""
        return self.config.dt

    def _episode_targets(self) -> np.ndarray:
        """Each env's episode target (one row per env), for the renderer's ghosts."""
        return self._batch.targets()

    def _start_at(self, index: int, state: np.ndarray) -> np.ndarray:
        """Puts env ``index`` at a reset option's ``state`` (validated by the core:
        length, finiteness, ``|q_i| = 1`` and ``w_i . q_i = 0``); its observation."""
        self._batch.set_state(index, state)
        return self._batch.observations()[index]

    def _draw_reset(self, mask: Optional[np.ndarray] = None) -> None:
        """After a reset of the envs in ``mask`` (all: ``None``): no force shown, new
        trails, and in human mode a frame."""
        self._rendering.clear_forces(mask)
        self._rendering.record_tips(self._batch.states)
        self._show_frame(reset=True)

    def _draw_step(self, actions: np.ndarray, fresh: Optional[np.ndarray] = None) -> None:
        """After a step under ``actions``: each env's force and tip remembered (envs
        flagged ``fresh`` started a new episode, so they show no force), and in human
        mode a frame when one is due."""
        self._rendering.record_forces(actions, fresh)
        self._rendering.record_tips(self._batch.states, fresh)
        self._show_frame()

    def _show_frame(self, reset: bool = False) -> None:
        """Human mode: shows the window's frame after a reset and every
        ``steps_per_frame``-th step."""
        if self._rendering.human_frame_due(reset=reset):
            self._draw()

    def _draw(self) -> Optional[np.ndarray]:
        """The frame of the first env (or the grid of the first shown envs) in
        ``rgb_array`` mode; shown in the window in ``human`` mode (``None``)."""
        return self._rendering.render(self._batch.states())

    def _frames(self) -> list[np.ndarray]:
        """Every env's frame."""
        return self._rendering.frames(self._batch.states())

    def _close_window(self) -> None:
        """Closes the human-mode window, if one is open."""
        rendering = getattr(self, "_rendering", None)  # None: the constructor failed
        if rendering is not None:
            rendering.close()

    def _rebuild_batch(self) -> _core.EnvBatch:
        """A fresh batch like the one built by :meth:`_open_batch` (for copies)."""
        return self.config.make_batch(self._batch_size, self._autoreset)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_batch"] = self._batch.snapshot()
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        snapshot = state.pop("_batch")
        self.__dict__.update(state)
        self._batch = self._rebuild_batch()
        self._batch.restore(snapshot)


class BatchFrontEnd(FrontEnd):
    """What the two vector envs (Gymnasium's and stable-baselines3's) add: the first
    ``render_envs`` envs drawn tiled, and every env's episode target."""

    def _open_tiled_rendering(
        self,
        render_mode: Optional[str],
        width: Optional[int],
        height: Optional[int],
        render_envs: Optional[int],
        camera: Any,
        trail: float,
        modes: Sequence[str] = RENDER_MODES,
    ) -> None:
        """The rendering of the first ``render_envs`` envs (default ``min(num_envs,
        4)``) tiled in a grid."""
        shown = check_shown_envs(render_envs, self._batch_size)
        self._open_rendering(render_mode, width, height, camera, trail, shown=shown, tiled=True, modes=modes)

    @property
    def episode_targets(self) -> np.ndarray:
        """Each env's target signs for its current episode, shape ``(num_envs,
        n_links)`` (goal-conditioned tasks draw them at every reset)."""
        return self._episode_targets()


class EnvOfBatch:
    """Env ``_env_index`` of a native batch: ``ChainCartEnv`` (env 0 of its one-env
    batch) and each sub-env view of ``ChainCartVecEnv``. Reads ``_batch``, ``config``
    and ``model``: the env's own, or the VecEnv's that its view forwards."""

    _env_index: int = 0
    config: ChainCartConfig
    model: _core.ChainCart
    _batch: _core.EnvBatch

    @property
    def model_state(self) -> np.ndarray:
        """The float64 state in the model's (observed) layout."""
        return self._batch.states()[self._env_index]

    @property
    def state(self) -> np.ndarray:
        """The full float64 state ``[x(2), xdot(2), q_i(3), w_i(3)]`` (planar states embedded)."""
        y = self._batch.states()[self._env_index]
        return self.model.to_spatial(y) if self.config.planar else y

    @property
    def elapsed_steps(self) -> int:
        """Steps taken in the current episode."""
        return int(self._batch.step_counts()[self._env_index])

    @property
    def episode_target(self) -> tuple[int, ...]:
        """The target equilibrium of the current episode (goal-conditioned tasks draw
        it at every reset; otherwise the config's target)."""
        return tuple(int(s) for s in self._batch.targets()[self._env_index])

    def set_state(self, state: np.ndarray) -> None:
        """Puts the env at ``state`` (model layout; checked) without ending the episode."""
        self._batch.set_state(self._env_index, state)

    @property
    def true_params(self) -> dict[str, Any]:
        """The physical parameters the env really simulates in this episode
        (``cart_mass``, ``link_masses``, ``link_lengths``, ``gravity``): the model's
        unless ``params``, ``mismatch`` or ``randomize`` is set. ``model`` stays the
        nominal system."""
        return self._batch.env_params(self._env_index)

    def get_true_params(self) -> dict[str, Any]:
        """:attr:`true_params`, as a method (for ``env_method``-style access)."""
        return self.true_params
