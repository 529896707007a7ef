"""The Gymnasium environment ``ChainCart-v0`` (one env; see :mod:`chaincart_env.vector`
for the native vector env)."""

from __future__ import annotations

from typing import Any, Mapping, Optional, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium.error import ResetNeeded

from chaincart_env import _core
from chaincart_env.config import ChainCartConfig, env_arguments
from chaincart_env.front_end import (
    RESET_OPTIONS as RESET_OPTIONS,  # re-exported: a name of this module too
    EnvOfBatch,
    FrontEnd,
    action_space,
    check_seed,
    diagnostics_info,
    episode_info,
    observation_space,
    start_state_option,
)
from chaincart_env.rendering import RENDER_MODES
from chaincart_env.spec import JsonSpec

__all__ = ["ChainCartEnv", "observation_space", "action_space", "episode_info"]

_ENDED = _core.EVENT_ENDED


class ChainCartEnv(JsonSpec, EnvOfBatch, FrontEnd, gym.Env[np.ndarray, np.ndarray]):
    """The chain pendulum on a cart (Lee, Leok & McClamroch, CDC 2012): stabilise an
    equilibrium of ``n`` links on a cart by pushing the cart.

    ## Description

    Links are massless rods with point masses at their outboard ends, joined to each
    other and to the cart by spherical joints (planar scenes: hinges in the e1-e3
    plane). The cart moves in the horizontal plane (planar: along e1); ``e3`` points
    along gravity, so a hanging link has ``q_i = +e3`` and an upright one ``q_i = -e3``.
    Each of the ``2^n`` equilibria is a sign tuple ``s`` (``s_i = +1`` hanging link,
    ``-1`` upright). The task is to bring the chain to the **target** equilibrium with
    the cart at rest at the origin. The physics (exact O(n) dynamics, five integrators)
    and the whole task run in Rust.

    ## Action Space

    ``Box(-1, 1, (2,), float32)`` (planar: ``(1,)``): the horizontal force on the cart
    divided by ``max_force``, held for one control period ``dt`` (with ``actuation``
    ``"acceleration"`` or ``"voltage"``: the cart's acceleration divided by
    ``max_acceleration``, or the motor's voltage divided by ``max_voltage``). Values outside
    ``[-1, 1]`` are clipped per axis; NaN or infinite actions raise
    :class:`ChainCartError`. With ``max_force = 0`` (scene ``paper-fig1``) every
    action is ignored.

    ## Observation Space

    The full state, float32 by default (``obs_dtype="float64"`` on request), spatial
    length ``4 + 6n``:

    | Index               | Observation                                          | Min   | Max  |
    |---------------------|------------------------------------------------------|-------|------|
    | 0, 1                | cart position ``x`` (m)                              | -inf  | inf  |
    | 2, 3                | cart velocity ``xdot`` (m/s)                         | -inf  | inf  |
    | 4 + 3i .. 6 + 3i    | link i direction ``q_i`` (unit vector), i = 0..n-1   | -1    | 1    |
    | 4 + 3n + 3i .. + 2  | link i angular velocity ``w_i`` (rad/s, normal to q_i) | -inf | inf  |

    Unbounded components have infinite bounds (Gymnasium's convention), but
    observations are always finite: a state beyond the dtype's range saturates at its
    largest finite number. Planar scenes observe only
    their planar state, length ``2 + 3n``: ``[x, xdot, (q_i . e1, q_i . e3) for each
    link, w_i . e2 for each link]``. The cart position stays within ``track_limit``
    (plus the last step's travel, when the episode terminates).

    ## Rewards

    ``r = exp(-c)`` in ``(0, 1]`` after each step, with

    ``c = w_q sum_i |q_i - s_i e3|^2 + w_w sum_i |w_i|^2 + w_x |x|^2 + w_v |xdot|^2 + w_u |a|^2``

    where ``a`` is the clipped normalised action and ``|q_i - s_i e3|^2 = 2(1 - cos
    tilt_i)``. It is 1 exactly at the target with the cart at rest at the origin and
    no force. The weights are ``reward_weights`` (defaults under Arguments). The
    step on which the integration fails is rewarded 0.

    ## Starting State

    A base state (``start``: the target equilibrium, another equilibrium, or one of
    the paper's initial conditions) plus independent uniform noise in
    ``[-start_noise, start_noise)`` on every local coordinate, drawn in this order:
    cart position, cart velocity (1 or 2 numbers each), then per link a tilt about
    the horizontal axes (a rotation vector ``(u, u, 0)``, planar: an angle about e2,
    which keeps ``|q_i| = 1``), then per link a horizontal spin added to ``w_i`` and
    projected onto the tangent plane of the tilted link (so ``w_i . q_i = 0``).
    ``reset(seed=s)`` is reproducible bit for bit (ChaCha8 stream seeded with ``s``).
    ``reset(options={"state": y})`` starts from the given state instead (this scene's
    layout; checked: finite, ``|q_i| = 1``, ``w_i . q_i = 0``); other keys are errors.

    ## Episode End

    * Termination: the cart leaves the track, ``max_k |x_k| > track_limit``
      (``info["out_of_track"]``), or the integration fails numerically (non-finite
      state, ``| |q_i| - 1 | > 1e-6``, an implicit solver gives up, or a link turns
      more than 0.5 rad in one integrator step, where the result would be finite but wrong;
      ``info["numerical_failure"]``): the observation is then the last good state,
      never NaN. With ``fall_limit > 0``, also a fall: ``e_q`` beyond ``fall_limit``
      after the episode's chain stayed within it for ``fall_hold`` seconds (one step
      by default; ``info["fell"]``), so that a lost balance ends the episode instead
      of running on, while a swing passing through the limit on its way up does not.
    * Truncation: ``max_episode_steps`` steps.

    On the last step ``info`` holds ``is_success`` (truncated, not terminated, and the
    paper's ``e_q = sum |q_i - s_i e3|`` and ``e_w = sum |w_i|`` at most
    ``success_tolerances``), ``numerical_failure``,
    ``out_of_track``, ``fell``, ``e_q`` and ``e_w``; other steps' info is empty unless
    ``diagnostics=True``, which adds ``energy``, ``kinetic_energy``,
    ``potential_energy``, ``residual_unit_length``, ``residual_tangency``, ``e_q``,
    ``e_w`` to every step. Stepping after the episode ended raises ``ResetNeeded``.

    ## Arguments

    ``ChainCartEnv(config=None, *, render_mode=None, render_width=None, render_height=None,
    render_camera=None, render_trail=0.0, **keywords)`` or
    ``gymnasium.make("ChainCart-v0", **keywords)``, keywords of
    :class:`ChainCartConfig` (explicit keywords override the scene's values; the list
    is generated from the core's definition of the keys):

    <configuration keys>

    Sim-to-real keys (all off by default; see the robustness docs): with a parameter
    gap, ``reset`` returns ``info["params"]``, the episode's true parameters (also
    :attr:`true_params`).

    Episode length with ``gymnasium.make``: every scene has its own id,
    ``ChainCart-<scene>-v0`` (:func:`chaincart_env.scene_env_id`), registered with the
    scene's length (so ``gymnasium.make("ChainCart-paper-fig3-v0")`` runs the paper's
    Fig. 3 to its end); ``ChainCart-v0`` is the default scene's. ``gymnasium.make`` adds a
    ``TimeLimit`` of the id's length unless given its own ``max_episode_steps``
    (``-1``: none), a keyword that is Gymnasium's and does not reach the env; the env's
    own length (whose last step carries ``is_success``) is the config's. For another
    length pass both, e.g. ``gymnasium.make("ChainCart-v0", config={"max_episode_steps":
    100}, max_episode_steps=100)``; ``gymnasium.make_vec`` passes ``max_episode_steps``
    on to the vector env itself.

    ``render_mode``: ``None``, ``"rgb_array"`` (``render()`` returns a uint8 frame of
    ``render_height x render_width x 3`` pixels, by default 360 x 480 in the 3-D view
    and 240 x 480 in the flat views) or ``"human"`` (a live window in real time; where
    no window can open, a warning once per process and no window). The picture is the
    config's ``render_view``; ``render_camera`` (a
    :class:`~chaincart_env.rendering.Camera` or a dict of its settings) places the 3-D
    view's camera, and ``render_trail`` (seconds, default 0: none) draws the tip's
    path over that long.
    ``metadata["render_fps"]`` is ``round(1 / dt)`` capped at 50; with shorter control
    periods (the paper's scenes) the window shows every ``round(1 / (dt * 50))``-th
    step. The frame shows the state with the force of the last step; see
    :class:`~chaincart_env.rendering.ChainRenderer`.

    The unwrapped env exposes ``state`` (the full float64 spatial state, planar states
    embedded), ``model_state`` (the float64 state in the observed layout), ``dt``,
    ``model`` (its :class:`ChainCart`) and ``config``.
    """

    metadata: dict[str, Any] = {"render_modes": list(RENDER_MODES), "render_fps": 50}

    def __init__(
        self,
        config: Optional[ChainCartConfig | Mapping[str, Any]] = None,
        *,
        render_mode: Optional[str] = None,
        render_width: Optional[int] = None,
        render_height: Optional[int] = None,
        render_camera: Any = None,
        render_trail: float = 0.0,
        **kwargs: Any,
    ) -> None:
        self._open_batch(config, kwargs, 1, "disabled")
        self._open_rendering(render_mode, render_width, render_height, render_camera, render_trail)
        self.observation_space = observation_space(self.config)
        self.action_space = action_space(self.config)
        self.metadata = self._with_render_fps(type(self).metadata)
        self._needs_reset = True

    def reset(
        self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Starts a new episode (Gymnasium's ``reset``): ``seed`` reseeds the env,
        ``options={"state": y}`` starts from the full state ``y``. Returns the first
        observation and the info dict."""
        start = start_state_option(options)
        native_seed = None if seed is None else check_seed(seed)
        super().reset(seed=native_seed)
        if native_seed is None and not self._seeded:
            native_seed = int(self.np_random.integers(0, 2**63))
        # native_seed None: continue this env's stream
        self._seeded = True
        self._needs_reset = False
        obs = self._batch.reset_one(native_seed)
        if start is not None:
            obs = self._start_at(0, start)
        if self.render_mode is not None:
            self._draw_reset()
        return obs, ({"params": self.true_params} if self.config.has_param_gap else {})

    def step(self, action: np.ndarray) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """One control period under ``action`` (Gymnasium's ``step``): ``(obs, reward, terminated,
        truncated, info)``; after an episode ends, ``reset()`` must come first."""
        if self._needs_reset:
            raise ResetNeeded("ChainCartEnv: call reset() before step() (and after an episode ends)")
        obs, reward, terminated, truncated, events = self._batch.step_one(action)
        if self.render_mode is not None:
            self._draw_step(action)
        if not (events & _ENDED or self._diagnostics):
            return obs, reward, terminated, truncated, {}
        return obs, reward, terminated, truncated, self._info(events)

    def _info(self, events: int) -> dict[str, Any]:
        errors = self._batch.errors()[0]
        info = diagnostics_info(self._batch.diagnostics()[0], errors) if self._diagnostics else {}
        if events & _ENDED:
            self._needs_reset = True
            info.update(episode_info(events, errors[0], errors[1]))
        return info

    def render(self) -> Optional[np.ndarray]:  # type: ignore[override]
        """``rgb_array``: the frame of the current state and the last step's force,
        uint8 ``(render_height, render_width, 3)``. ``human``: shows it (also done by
        every ``reset`` and ``step``) and returns ``None``. No render mode: ``None``."""
        if self.render_mode is None:
            gym.logger.warn("ChainCartEnv.render() without a render_mode: pass render_mode='rgb_array' or 'human'")
            return None
        return self._draw()

    def close(self) -> None:
        """Closes the human-mode window, if one is open."""
        self._close_window()


# The argument list comes from the core's one definition of the configuration keys.
ChainCartEnv.__doc__ = (ChainCartEnv.__doc__ or "").replace("    <configuration keys>", env_arguments())
