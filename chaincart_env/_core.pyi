"""The native extension of chaincart_env (Rust, PyO3): the physics model and the env batch.

Arrays are NumPy; inputs accept any array-like (converted to float64), outputs are
fresh arrays. Invalid input raises :class:`InvalidInputError` (a ``ValueError``; of a
wrong type: :class:`InvalidTypeError`, also a ``TypeError``) whose message names the
value and what was expected; a failed integration :class:`IntegrationError` (a
``RuntimeError``), a failed analysis :class:`AnalysisError` (all from
``chaincart_env.errors``, subclasses of :class:`ChainCartError`).
"""

from collections.abc import Sequence
from typing import Any, Mapping, Optional, Union, final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self, disjoint_base

from chaincart_env.errors import (
    AnalysisError as AnalysisError,
    ChainCartError as ChainCartError,
    IntegrationError as IntegrationError,
    InvalidInputError as InvalidInputError,
    InvalidTypeError as InvalidTypeError,
)

__all__ = [
    "ChainCartError",
    "InvalidInputError",
    "InvalidTypeError",
    "IntegrationError",
    "AnalysisError",
    "ChainCart",
    "EnvBatch",
    "Plan",
    "TrajectoryTracker",
    "MpcController",
    "EnergyController",
    "num_threads",
    "time_scaling",
    "MAX_LINKS",
    "MAX_STATE_VALUES",
    "MIN_FRAME_SIZE",
    "MAX_FRAME_SIZE",
    "render_frame",
    "check_camera",
    "check_plan_weights",
    "default_view",
    "CAMERA_DEFAULTS",
    "RENDER_VIEWS",
    "target_signs",
    "paper_initial_condition",
    "INTEGRATORS",
    "DIAGNOSTICS",
    "EVENT_ENDED",
    "EVENT_SUCCESS",
    "EVENT_OUT_OF_TRACK",
    "EVENT_FELL",
    "EVENT_NUMERICAL_FAILURE",
    "EVENT_RESET",
    "RNG_BYTES",
    "REALITY_KEYS",
    "CONFIG_KEYS",
    "SCENES",
    "SCENE_SUMMARIES",
    "DEFAULT_SCENE",
    "TARGET_NAMES",
    "START_NAMES",
    "REWARD_WEIGHTS",
    "ResolvedConfig",
    "resolve_config",
]

#: Integrator names: "rk4", "rkmk4", "variational", "lie_euler", "adaptive".
INTEGRATORS: tuple[str, ...]
#: Names of the diagnostics columns (energy, kinetic_energy, potential_energy,
#: residual_unit_length, residual_tangency).
DIAGNOSTICS: tuple[str, ...]
#: Event bit: the episode ended on the last step.
EVENT_ENDED: int
#: Event bit: the episode ended at the time limit within the success tolerances.
EVENT_SUCCESS: int
#: Event bit: terminated because the cart left the track.
EVENT_OUT_OF_TRACK: int
#: Event bit: terminated by a fall (``e_q`` left ``fall_limit`` after coming within it).
EVENT_FELL: int
#: Event bit: terminated because the integration failed (last good state kept).
EVENT_NUMERICAL_FAILURE: int
#: Event bit: next-step autoreset reset the env instead of stepping it.
EVENT_RESET: int
#: Bytes of one env's RNG state in a snapshot.
RNG_BYTES: int
#: ``(name, default, help, expected)`` of every configuration key, in the order of
#: ``ChainCartConfig``'s fields; the default is the default scene's value and
#: ``expected`` the accepted values in the words errors use.
CONFIG_KEYS: tuple[tuple[str, Any, str, str], ...]
#: ``(name, default, help)`` of each reality-gap key (a part of :data:`CONFIG_KEYS`).
REALITY_KEYS: tuple[tuple[str, Any, str], ...]
#: Every scene's value of every key: scene name -> dict.
SCENES: dict[str, dict[str, Any]]
#: Every scene's one-line summary: scene name -> text.
SCENE_SUMMARIES: dict[str, str]
#: The scene whose values fill the keys not given.
DEFAULT_SCENE: str
#: Names accepted for ``target`` (besides a sign tuple).
TARGET_NAMES: tuple[str, ...]
#: Names accepted for ``start`` (besides a sign tuple or a full state).
START_NAMES: tuple[str, ...]
#: Default reward weights by name (q, w, x, v, u).
REWARD_WEIGHTS: dict[str, float]

def resolve_config(config: dict[str, Any]) -> ResolvedConfig:
    """``config`` (a dict of keys, any subset; ``scene`` names the scene whose values
    fill the rest; ``None`` values are unset) resolved and checked once, the task
    against the model; raises :class:`InvalidInputError` naming a bad value."""
#: Most links a chain may have.
MAX_LINKS: int
#: Most float64 numbers in one batch state array or one simulated trajectory.
MAX_STATE_VALUES: int
#: Smallest frame side the renderer draws, pixels.
MIN_FRAME_SIZE: int
#: Largest frame side the renderer draws, pixels.
MAX_FRAME_SIZE: int
#: The camera settings of the 3-D view unless given (azimuth, elevation, distance, fov, follow).
CAMERA_DEFAULTS: dict[str, Any]
#: The values of the ``render_view`` key: ``"3d"``, ``"side"``, ``"top"``, ``"side+top"``.
RENDER_VIEWS: tuple[str, ...]

_Signs = Union[str, Sequence[float]]


@disjoint_base
class ChainCart:
    """The chain pendulum on a cart: ``n_links`` point masses ``link_masses`` on massless
    rods of ``link_lengths`` (scalars or one per link) on a cart of ``cart_mass``;
    gravity ``gravity`` along e3. ``planar=True`` is the planar special case.
    Parameters left unset (``None``) are the paper's example system (0.5 kg cart,
    0.1 kg and 0.1 m links, standard gravity), as in the paper's scenes; the env's
    default scene is another system (see ``SCENES``).

    State layout (docs/physics.md): ``[x(2), xdot(2), q_1..q_n (3 each), w_1..w_n (3 each)]``
    (length ``4 + 6n``); planar ``[x, xdot, (q_i . e1, q_i . e3)_i, (w_i . e2)_i]``
    (length ``2 + 3n``).
    """

    def __new__(
        cls,
        n_links: int,
        cart_mass: Optional[float] = None,
        link_masses: Optional[Union[float, Sequence[float]]] = None,
        link_lengths: Optional[Union[float, Sequence[float]]] = None,
        gravity: Optional[float] = None,
        planar: bool = False,
    ) -> Self: ...
    @property
    def n_links(self) -> int:
        """Number of links."""
    @property
    def planar(self) -> bool:
        """Whether this is the planar model."""
    @property
    def state_dim(self) -> int:
        """Length of a state: ``4 + 6n`` (spatial) or ``2 + 3n`` (planar)."""
    @property
    def force_dim(self) -> int:
        """Length of a force: 2 (spatial) or 1 (planar)."""
    @property
    def state_layout(self) -> dict[str, tuple[int, int]]:
        """``(start, stop)`` of each block of a state: ``x``, ``xdot``, ``q``, ``w``."""
    @property
    def cart_mass(self) -> float:
        """Cart mass (kg)."""
    @property
    def link_masses(self) -> tuple[float, ...]:
        """Link masses (kg), one per link."""
    @property
    def link_lengths(self) -> tuple[float, ...]:
        """Link lengths (m), one per link."""
    @property
    def gravity(self) -> float:
        """Gravitational acceleration (m/s^2) along e3."""
    @property
    def params(self) -> dict[str, Any]:
        """The constructor's arguments as a dict."""
    def derivative(self, state: npt.ArrayLike, force: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Time derivative of ``state`` under the horizontal ``force`` (``qdot_i = w_i x q_i``)."""
    def step(
        self,
        state: npt.ArrayLike,
        force: npt.ArrayLike,
        dt: float,
        integrator: str = "rk4",
        substeps: int = 1,
    ) -> npt.NDArray[np.float64]:
        """The state after ``dt`` under the constant ``force`` (``substeps`` integrator
        steps); raises on a numerical failure."""
    def simulate(
        self,
        state: npt.ArrayLike,
        forces: npt.ArrayLike,
        dt: float,
        integrator: str = "rk4",
        substeps: int = 1,
    ) -> npt.NDArray[np.float64]:
        """Trajectory of shape ``(steps + 1, state_dim)`` for ``forces`` of shape
        ``(steps, force_dim)`` (GIL released); raises naming the step that failed."""
    def energy(self, state: npt.ArrayLike) -> float:
        """Total energy (kinetic + potential; the cart's height is the zero of potential)."""
    def kinetic_energy(self, state: npt.ArrayLike) -> float:
        """Kinetic energy of cart and masses."""
    def potential_energy(self, state: npt.ArrayLike) -> float:
        """Gravitational potential energy of the masses."""
    def horizontal_momentum(self, state: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Total horizontal momentum (conserved without force), shape ``(force_dim,)``."""
    def residuals(self, state: npt.ArrayLike) -> tuple[float, float]:
        """``(max | |q_i| - 1 |, max |w_i . q_i|)``: how far ``state`` is off the constraints."""
    def errors(self, state: npt.ArrayLike, s: _Signs) -> tuple[float, float]:
        """The paper's ``(e_q, e_w) = (sum |q_i - s_i e3|, sum |w_i|)`` for equilibrium ``s``."""
    def equilibrium(self, s: _Signs) -> npt.NDArray[np.float64]:
        """The state of equilibrium ``s`` (name or signs) with the cart at rest at the origin."""
    def to_spatial(self, state: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The spatial state (``4 + 6n``) of a state of this model (planar: embedded)."""
    def from_spatial(self, state: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """This model's part of a spatial state (planar: the in-plane components)."""
    def lqr_gain(
        self, s: _Signs, Q: Optional[npt.ArrayLike] = None, R: Optional[npt.ArrayLike] = None
    ) -> npt.NDArray[np.float64]:
        """LQR gain ``K``, shape ``(2, 4 + 4n)``, of the spatial linearisation at ``s`` in
        the paper's ordering ``z = [x, C^T xi_i, xdot, C^T w_i]`` (``u = -K z``); default
        weights are the paper's."""
    def linearize(self, s: _Signs, second_order: bool = False) -> tuple[npt.NDArray[np.float64], ...]:
        """Linearisation at equilibrium ``s`` (paper Prop. 2): ``(A, B)`` of the first-order
        system in ``z = [x, C^T xi_1..n, xdot, C^T w_1..n]``, or with ``second_order=True``
        the paper's ``(M, G, B)`` in ``[x, C^T xi_1..n]``."""
    def eigenvalues(self, s: _Signs) -> npt.NDArray[np.complex128]:
        """Eigenvalues of the linearisation at ``s`` (roots of ``det(lambda^2 M + G) = 0``)."""
    def controllability(self, s: _Signs) -> tuple[bool, float]:
        """``(controllable, margin)`` of the linearisation at ``s`` by the PBH eigenvector
        test (paper Prop. 3); the margin is in [0, 1], controllable means > 1e-8."""
    def plan(
        self,
        start: Union[_Signs, npt.ArrayLike],
        target: _Signs,
        *,
        max_force: float,
        track_limit: float = 2.4,
        duration: Optional[float] = None,
        dt: float = 0.02,
        substeps: int = 2,
        max_iterations: int = 1000,
        max_time: float = 30.0,
        guesses: int = 10,
        weights: Optional[Mapping[str, float]] = None,
    ) -> "Plan":
        """A plan from ``start`` (an equilibrium name, a sign tuple or a full state) to
        the equilibrium ``target`` within ``max_force`` (N per axis) and ``track_limit``
        (m): control-limited iLQR over ``duration`` s (default ``1 + n_links``) at the
        control period ``dt`` with ``substeps`` RK4 steps, from up to ``guesses`` initial
        guesses, at most ``max_iterations`` iterations and ``max_time`` s (``inf``: no
        wall-time limit, the iterations alone bound the work). ``weights`` overrides cost
        weights (``x``, ``q``, ``v``, ``w``, ``force``, ``track``, ``terminal``,
        ``track_margin``)."""
    def equilibria(self) -> list[list[int]]:
        """All 2^n sign tuples, hanging first, in binary order; refused for n > 20."""
    def __reduce__(self) -> tuple[Any, ...]: ...

@final
class ResolvedConfig:
    """A configuration resolved, converted and checked once (:func:`resolve_config`):
    the model, the task on it and every key's value in canonical form. Env batches are
    built from it."""

    def values(self) -> dict[str, Any]:
        """Every configuration key's value, in canonical form, as a new dict."""
    @property
    def model(self) -> ChainCart:
        """The model of the configuration's physical parameters."""
    @property
    def state_dim(self) -> int:
        """Length of the observed state: ``2 + 3n`` planar, ``4 + 6n`` spatial."""
    @property
    def force_dim(self) -> int:
        """Length of an action: 1 planar, 2 spatial."""
    @property
    def obs_dim(self) -> int:
        """Length of an observation: ``state_dim``, plus ``n_links`` target signs when the
        task observes its goal (``goal_observation``)."""
    @property
    def target(self) -> list[float]:
        """The target's signs (for a goal-conditioned task, the first pair's)."""
    @property
    def pairs(self) -> Optional[list[tuple[list[float], list[float]]]]:
        """The (start, target) sign lists a goal-conditioned task draws from, or ``None``."""
    def lqr_gain(
        self, s: _Signs, Q: Optional[npt.ArrayLike] = None, R: Optional[npt.ArrayLike] = None
    ) -> npt.NDArray[np.float64]:
        """LQR gain ``K`` (``(2, 4 + 4n)``) at ``s`` for the model with this configuration's
        real-rig effects but Coulomb friction: ``u = -K z`` is the command of the actuation
        per cart axis (N, m/s^2 or V). Default weights are the paper's."""
    def controllability(self, s: _Signs) -> tuple[bool, float]:
        """``(controllable, margin)`` of the linearisation at ``s`` with this
        configuration's real-rig effects (Prop. 3's test, joint damping included)."""
    def linearize(self, s: _Signs) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """``(A, B)`` of the first-order linearisation at ``s`` with this configuration's
        real-rig effects, ``B`` per unit of the actuation's command."""
    def rig_model(self, model: ChainCart) -> ChainCart:
        """``model`` with this configuration's real-rig effects: its ``step``, ``plan`` and
        the plan's controllers follow the rig, their command the actuation's (N, m/s^2
        or V); its analysis methods stay the ideal chain's."""
    def __reduce__(self) -> tuple[Any, ...]: ...

@final
class Plan:
    """A plan of ``K`` control steps (``ChainCart.plan``)."""

    @property
    def times(self) -> npt.NDArray[np.float64]:
        """Instants, s, shape ``(K + 1,)``."""
    @property
    def states(self) -> npt.NDArray[np.float64]:
        """States in the model's layout, shape ``(K + 1, state_dim)``."""
    @property
    def forces(self) -> npt.NDArray[np.float64]:
        """Forces, N, shape ``(K, force_dim)``, each held over its interval."""
    @property
    def converged(self) -> bool:
        """The plan reaches the target within the tolerances and the track."""
    @property
    def target(self) -> list[int]:
        """The target's sign tuple."""
    @property
    def dt(self) -> float:
        """Control period, s."""
    @property
    def substeps(self) -> int:
        """RK4 steps per control period."""
    @property
    def max_force(self) -> float:
        """Force limit, N."""
    @property
    def track_limit(self) -> float:
        """Track limit, m."""
    @property
    def report(self) -> dict[str, Any]:
        """``cost``, ``iterations``, ``seconds``, ``guesses_tried``, ``best_guess``,
        ``status``, ``e_q``, ``e_w``, ``peak_force``, ``rms_force``, ``max_cart``,
        ``max_spin``, ``reaches_target``, ``within_track``, ``time_to_reach``, ``reason``."""
    def tracker(self) -> "TrajectoryTracker":
        """TVLQR along the plan, then the LQR at its target."""
    def mpc(
        self, horizon: int = 40, hold_horizon: int = 25, iterations: int = 2, budget: float = 0.002
    ) -> "MpcController":
        """Receding-horizon iLQR along the plan with a budget per control step
        (``budget=inf``: iterations alone, no wall-time limit)."""

@final
class TrajectoryTracker:
    """TVLQR along a plan, then the target's LQR."""

    def force(self, k: int, state: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The saturated force (N) at control step ``k`` of the plan's clock in ``state``."""
    @property
    def steps(self) -> int:
        """Number of planned steps."""

@final
class MpcController:
    """Receding-horizon iLQR along a plan."""

    def force(self, k: int, state: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The saturated force (N) at control step ``k`` of the plan's clock in ``state``."""
    def reset(self) -> None:
        """Forgets the warm start."""
    @property
    def stats(self) -> dict[str, Any]:
        """``iterations``, ``seconds`` and ``horizon`` of the last ``force`` call."""

@final
class EnergyController:
    """Energy shaping for one link, then the LQR catch."""

    def __new__(
        cls,
        model: ChainCart,
        max_force: float,
        gain: Optional[float] = None,
        centring: Optional[float] = None,
        damping: Optional[float] = None,
        catch_angle: Optional[float] = None,
        catch_rate: Optional[float] = None,
    ) -> "EnergyController": ...
    def force(self, state: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The saturated force (N) in ``state``."""
    def catching(self, state: npt.ArrayLike) -> bool:
        """Whether the LQR is in charge in ``state``."""

@final
class EnvBatch:
    """``num_envs`` envs of one RL task, stepped in Rust (see
    ``chaincart_env.ChainCartEnv`` for the task). ``config`` is a
    :class:`ResolvedConfig`, or a dict of configuration keys (any subset of
    :data:`CONFIG_KEYS`; ``scene`` names the scene whose values fill the rest, ``None``
    values are unset) resolved as :func:`resolve_config` does. Env i's RNG is seeded
    ``seed + i``.
    """

    def __new__(
        cls,
        config: Union[ResolvedConfig, dict[str, Any]],
        num_envs: int = 1,
        *,
        autoreset_mode: str = "next_step",
        seed: int = 0,
    ) -> Self: ...
    @property
    def num_envs(self) -> int:
        """Number of envs."""
    @property
    def state_dim(self) -> int:
        """Length of one state."""
    @property
    def obs_dim(self) -> int:
        """Numbers per observation: ``state_dim``, plus ``n_links`` target signs when the
        task observes its goal."""
    def targets(self) -> npt.NDArray[np.float64]:
        """Each env's target signs for its current episode, shape ``(num_envs, n_links)``
        (goal-conditioned tasks draw them at every reset)."""
    @property
    def force_dim(self) -> int:
        """Length of one action."""
    @property
    def planar(self) -> bool:
        """Whether the model is planar."""
    @property
    def obs_dtype(self) -> str:
        """``"float32"`` or ``"float64"``."""
    @property
    def autoreset_mode(self) -> str:
        """``"next_step"``, ``"same_step"`` or ``"disabled"``."""
    @property
    def diagnostics_enabled(self) -> bool:
        """Whether steps compute energies and residuals."""
    @property
    def config(self) -> dict[str, Any]:
        """Every configuration key's value in canonical form (a new dict)."""
    @property
    def base_state(self) -> npt.NDArray[np.float64]:
        """The state episodes start from before noise."""
    def true_params(self) -> dict[str, Any]:
        """The true parameters shared before randomisation (model with params/mismatch)."""
    def env_params(self, env: int) -> dict[str, Any]:
        """Env ``env``'s current true parameters."""
    def param_arrays(self) -> dict[str, npt.NDArray[np.float64]]:
        """Every env's current true parameters, arrays with a leading num_envs axis."""
    def observations(self) -> npt.NDArray[Any]:
        """Every env's current observation (noisy when obs_noise is set)."""
    def reset(
        self, seeds: Optional[Sequence[Optional[int]]] = None, mask: Optional[npt.NDArray[np.bool_]] = None
    ) -> npt.NDArray[Any]:
        """New episodes in the envs where ``mask`` is true (all if None), env k reseeded
        with ``seeds[k]`` unless None; returns every env's observation ``(num_envs, state_dim)``."""
    def reset_one(self, seed: Optional[int] = None) -> npt.NDArray[Any]:
        """``reset`` for a batch of one; the observation has shape ``(state_dim,)``."""
    def step(
        self, actions: npt.ArrayLike
    ) -> tuple[npt.NDArray[Any], npt.NDArray[np.float64], npt.NDArray[np.bool_], npt.NDArray[np.bool_], int]:
        """One step of every env (GIL released); ``actions`` of shape ``(num_envs,
        force_dim)``, clipped to [-1, 1]. Returns ``(obs, rewards, terminated, truncated,
        n_ended)``. Bad actions raise before any env moves (a scalar: ``InvalidTypeError``,
        a ``TypeError``)."""
    def step_one(self, action: npt.ArrayLike) -> tuple[npt.NDArray[Any], float, bool, bool, int]:
        """``step`` for a batch of one: ``(obs, reward, terminated, truncated, events)``."""
    def events(self) -> npt.NDArray[np.uint8]:
        """Event bits (``EVENT_*``) of the last step or reset, shape ``(num_envs,)``."""
    def episode_arrays(
        self,
    ) -> tuple[
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
    ]:
        """``(ended, is_success, numerical_failure, out_of_track, fell, e_q, e_w)`` of the last step."""
    def errors(self) -> npt.NDArray[np.float64]:
        """``(e_q, e_w)`` per env of the state the last step reached, shape ``(num_envs, 2)``."""
    def final_observations(self) -> npt.NDArray[Any]:
        """Same-step mode: last observations of the episodes that just ended (other rows stale)."""
    def diagnostics(self) -> npt.NDArray[np.float64]:
        """``DIAGNOSTICS`` per env of the last step (zeros unless enabled), shape ``(num_envs, 5)``."""
    def states(self) -> npt.NDArray[np.float64]:
        """A copy of every env's float64 state, shape ``(num_envs, state_dim)``."""
    def step_counts(self) -> npt.NDArray[np.uint64]:
        """Steps taken in each env's current episode."""
    def ended(self) -> npt.NDArray[np.bool_]:
        """Which envs' episodes ended without a reset since."""
    def set_state(self, env: int, state: npt.ArrayLike) -> None:
        """Overwrites env ``env``'s state (checked: length, finite, on the constraints)."""
    def snapshot(self) -> dict[str, npt.NDArray[Any]]:
        """Everything that evolves (states, RNG streams, step counts, ended flags)."""
    def restore(self, snapshot: dict[str, Any]) -> None:
        """Continues from a ``snapshot`` of a batch of the same shape."""
    def set_precision(self, precision: str) -> None:
        """Steps the physics in ``"f64"`` (default; every env bit-identical to a single env)
        or ``"f32"`` (the rk4 lane kernel in single precision: faster, within the accuracy
        published in docs/simd.md). Observations keep their dtype. Raises
        :class:`InvalidInputError` naming the value for anything else, or for ``"f32"``
        with an integrator other than rk4."""
    @property
    def precision(self) -> str:
        """``"f64"`` or ``"f32"``: the number type of the physics."""

def render_frame(
    link_lengths: Sequence[float],
    state: npt.ArrayLike,
    force: Sequence[float],
    *,
    target: Optional[Sequence[float]] = None,
    max_force: float = 1.0,
    track_limit: float = ...,
    width: int = 480,
    height: int = 240,
    view: Optional[str] = None,
    planar: bool = False,
    azimuth: Optional[float] = None,
    elevation: Optional[float] = None,
    distance: Optional[float] = None,
    fov: Optional[float] = None,
    follow: Optional[bool] = None,
    trail: Optional[npt.NDArray[np.float64]] = None,
) -> npt.NDArray[np.uint8]:
    """One ``(height, width, 3)`` uint8 frame of a spatial state in ``view``
    (``"3d"``, ``"side"``, ``"top"``, ``"side+top"``; ``None``: ``"side"`` if
    ``planar`` else ``"3d"``): the 3-D view seen by the camera settings (``None``:
    the defaults), the target faintly, the force as an arrow, the ``(k, 3)`` trail
    of tip positions as a fading line."""

def check_camera(
    *,
    azimuth: Optional[float] = None,
    elevation: Optional[float] = None,
    distance: Optional[float] = None,
    fov: Optional[float] = None,
    follow: Optional[bool] = None,
) -> dict[str, Any]:
    """Every camera setting (``None``: the default), checked; raises
    :class:`InvalidInputError` naming the first bad one and what it accepts."""

def check_plan_weights(weights: Optional[dict[str, float]] = None) -> dict[str, float]:
    """Every cost weight of the planner (``ChainCart.plan``'s ``weights``; the defaults
    for those not given), checked as a plan checks them; raises
    :class:`InvalidInputError` naming the first bad one and what it accepts."""

def default_view(planar: bool) -> str:
    """The view drawn when ``render_view`` is ``None``: ``"side"`` for planar chains,
    ``"3d"`` for spatial ones."""

def time_scaling(form: str, n_links: int, min_time: float = 0.1) -> float:
    """Seconds per call of ``form`` (``"fast"``, ``"dense"``, ``"fast_rk4_step"``) for a
    uniform spatial chain of ``n_links``, timed in Rust on one core."""

def num_threads() -> int:
    """The core's number of worker threads (set ``RAYON_NUM_THREADS`` before the first parallel step)."""

def target_signs(name: str, n_links: int) -> list[int]:
    """The sign tuple of a named equilibrium (``hanging``, ``inverted``, ``folded``,
    ``folded_up``, ``paper-fig1`` .. ``paper-fig3``)."""

def paper_initial_condition(figure: str) -> npt.NDArray[np.float64]:
    """The paper's initial condition (``"paper-fig1"`` .. ``"paper-fig3"``) as a spatial 5-link state."""
