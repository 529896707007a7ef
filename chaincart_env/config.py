"""One validated configuration object for every chaincart env, and the named scenes.

The keys, their defaults, the scenes and every check are defined once, in the Rust
core; this module reads them from ``_core``. A :class:`ChainCartConfig` is resolved by
one call into the core (``_core.resolve_config``): the scene (``scene=``, default
:data:`DEFAULT_SCENE`) fills every keyword not given, each value is brought into
canonical form (scalars stay scalars, sequences become tuples, names stay names) and
checked, the task against the model; a bad value raises
:class:`~chaincart_env.errors.InvalidInputError` (a ``ValueError``) or
:class:`~chaincart_env.errors.InvalidTypeError` (a ``TypeError``) naming the value and
what was expected; a keyword that does not exist raises
:class:`~chaincart_env.errors.UnknownKeyError` (both) naming the closest one. The
core hands back one native object (``_core.ResolvedConfig``) holding the model and the
task; envs build their batches from it, so the configuration crosses into Rust once.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, Optional, TypeVar, Union

import numpy as np

from chaincart_env import _core
from chaincart_env.errors import InvalidInputError, InvalidTypeError, UnknownKeyError

__all__ = [
    "ChainCartConfig",
    "RewardWeights",
    "SCENES",
    "DEFAULT_SCENE",
    "EQUILIBRIUM_NAMES",
    "START_NAMES",
    "CONFIG_KEYS",
    "REALITY_KEYS",
    "config_of",
    "nominal_model_of",
    "env_arguments",
    "value_text",
]

#: Every configuration keyword as the core defines it, in the order of
#: :class:`ChainCartConfig`'s fields: ``(name, default, help, expected)`` (the default
#: is the default scene's value; ``expected`` says what values are accepted).
CONFIG_KEYS: tuple[tuple[str, Any, str, str], ...] = tuple(_core.CONFIG_KEYS)
#: The keywords of the reality gap (parameter mismatch and randomisation, sensor noise,
#: control delay, force-rate limit) as the core defines them: ``(name, default, help)``.
#: Their values are checked and brought into canonical form by the core.
REALITY_KEYS: tuple[tuple[str, Any, str], ...] = tuple(_core.REALITY_KEYS)
_KEYWORDS: frozenset[str] = frozenset(name for name, *_ in CONFIG_KEYS)
#: Names accepted for ``target`` (besides a sign tuple).
EQUILIBRIUM_NAMES: tuple[str, ...] = tuple(_core.TARGET_NAMES)
#: Names accepted for ``start`` (besides a sign tuple or a full state).
START_NAMES: tuple[str, ...] = tuple(_core.START_NAMES)
#: The scene whose values fill every keyword not given.
DEFAULT_SCENE: str = _core.DEFAULT_SCENE

_REWARD_DEFAULTS: dict[str, float] = dict(_core.REWARD_WEIGHTS)


def value_text(value: Any) -> str:
    """A configuration value as the docs show it (Python literals, ``None`` for off)."""
    if isinstance(value, tuple):
        return "(" + ", ".join(value_text(v) for v in value) + ")"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k!r}: {value_text(v)}" for k, v in value.items()) + "}"
    return repr(value)


def env_arguments(indent: str = "    ") -> str:
    """The env keywords as a reStructuredText bullet list (for the env docstring)."""
    lines = []
    for name, default, help_text, _ in CONFIG_KEYS:
        lines.append(f"{indent}* ``{name}`` (default ``{value_text(default)}``): {help_text}")
    return "\n".join(lines)


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward ``r = exp(-c)``,

    ``c = q sum_i |q_i - s_i e3|^2 + w sum_i |w_i|^2 + x |x|^2 + v |xdot|^2 + u |a|^2``

    (``a`` the clipped normalised action). All finite and >= 0 (checked by the core).
    """

    q: float = _REWARD_DEFAULTS["q"]
    w: float = _REWARD_DEFAULTS["w"]
    x: float = _REWARD_DEFAULTS["x"]
    v: float = _REWARD_DEFAULTS["v"]
    u: float = _REWARD_DEFAULTS["u"]

    def as_tuple(self) -> tuple[float, float, float, float, float]:
        """``(q, w, x, v, u)``, the order the core reads them in."""
        return (self.q, self.w, self.x, self.v, self.u)

    @classmethod
    def coerce(cls, value: Any) -> "RewardWeights":
        """A ``RewardWeights``, a mapping with some of the keys q, w, x, v, u (the rest
        default), or a sequence of five numbers (checked by the core)."""
        if isinstance(value, RewardWeights):
            return value
        return cls(*_core.resolve_config({"reward_weights": value}).values()["reward_weights"])


def _with_weights(values: dict[str, Any]) -> dict[str, Any]:
    return {**values, "reward_weights": RewardWeights(*values["reward_weights"])}


#: Named scenes: every config keyword's value (as the core defines them). ``inverted-2``
#: is the default.
SCENES: dict[str, dict[str, Any]] = {
    name: _with_weights({k: v for k, v in values.items() if k != "scene"}) for name, values in _core.SCENES.items()
}
#: The episode length ``ChainCart-v0`` is registered with: the default scene's.
REGISTERED_EPISODE_STEPS: int = SCENES[DEFAULT_SCENE]["max_episode_steps"]

# Typed "unset" default: every field is filled from the scene in __post_init__.
_UNSET: Any = None

Floats = Union[float, tuple[float, ...]]


def _plain(name: str, value: Any) -> Any:
    """``value`` in a type the core reads: reward weights as numbers, a NumPy dtype
    (or anything ``np.dtype`` takes) as its name."""
    if isinstance(value, RewardWeights):
        return value.as_tuple()
    if name == "obs_dtype" and value is not None and not isinstance(value, str):
        try:
            return np.dtype(value).name
        except TypeError:
            return value  # the core names it and what was expected
    return value


def unknown_keyword_message(name: str) -> str:
    """The core's message for an unknown configuration keyword: it names the closest
    keyword when one is near (``n_link`` -> ``n_links``) and lists them all."""
    try:
        _core.resolve_config({name: None})
    except InvalidInputError as error:
        return str(error)
    raise AssertionError(f"{name!r} is a configuration keyword")


_T = TypeVar("_T")


def _fields_of_the_key_table(cls: type[_T]) -> type[_T]:
    """Makes every key of the core's table a field of ``cls``, in table order, before
    ``dataclass`` reads its annotations: a key the class body declares keeps its type
    (for type checkers and editors), a key it does not is a field all the same, typed
    ``Any``. So a new key of the table is a keyword of the config without a line here;
    a declared name that is not a key is an error."""
    declared = dict(cls.__dict__.get("__annotations__", {}))
    public = [name for name in declared if not name.startswith("_")]
    strays = [name for name in public if name not in _KEYWORDS]
    if strays:
        raise TypeError(f"{cls.__name__} declares {strays}: expected keys of the core's table")
    annotations: dict[str, Any] = {}
    for name, *_ in CONFIG_KEYS:
        annotations[name] = declared.get(name, Any)
        if name not in cls.__dict__:
            setattr(cls, name, _UNSET)
    annotations.update({name: kind for name, kind in declared.items() if name.startswith("_")})
    cls.__annotations__ = annotations
    return cls


@dataclass(frozen=True)
@_fields_of_the_key_table
class ChainCartConfig:
    """Everything that defines a chaincart env. The fields are the core's configuration
    keys (:data:`CONFIG_KEYS`: meaning, accepted values and default of each, also in
    the :class:`chaincart_env.ChainCartEnv` docstring), in the table's order; those
    declared below carry their types. Keywords left out take the scene's value;
    reality-gap values are stored in the canonical form the core returns."""

    n_links: int = _UNSET
    cart_mass: float = _UNSET
    link_masses: Floats = _UNSET
    link_lengths: Floats = _UNSET
    gravity: float = _UNSET
    planar: bool = _UNSET
    target: Union[str, tuple[float, ...]] = _UNSET
    start: Union[str, tuple[float, ...]] = _UNSET
    start_noise: float = _UNSET
    dt: float = _UNSET
    integrator: str = _UNSET
    substeps: int = _UNSET
    max_force: float = _UNSET
    track_limit: float = _UNSET
    max_episode_steps: int = _UNSET
    reward_weights: RewardWeights = _UNSET
    scene: str = _UNSET
    obs_dtype: str = _UNSET
    success_tolerances: tuple[float, float] = _UNSET
    reward: str = _UNSET
    success_hold: float = _UNSET
    fall_limit: float = _UNSET
    fall_hold: float = _UNSET
    transitions: Optional[tuple[tuple[Any, Any], ...]] = _UNSET
    goal_observation: bool = _UNSET
    diagnostics: bool = _UNSET
    precision: str = _UNSET
    randomize: Optional[dict[str, Any]] = _UNSET
    params: Optional[dict[str, Any]] = _UNSET
    mismatch: Optional[dict[str, Any]] = _UNSET
    obs_noise: Optional[Floats] = _UNSET
    action_delay: Union[int, tuple[int, int]] = _UNSET
    force_rate_limit: Union[float, tuple[float, float], None] = _UNSET
    force_noise: Optional[dict[str, float]] = _UNSET
    render_view: Optional[str] = _UNSET
    joint_damping: Floats = _UNSET
    cart_viscous_friction: float = _UNSET
    cart_coulomb_friction: float = _UNSET
    coulomb_velocity: float = _UNSET
    actuation: str = _UNSET
    max_acceleration: float = _UNSET
    max_voltage: float = _UNSET
    motor: tuple[float, float, float, float, float] = _UNSET
    angle_encoder_counts: Optional[int] = _UNSET
    cart_encoder_counts: Optional[float] = _UNSET
    velocity_filter: float = _UNSET
    angle_encoder_reference: str = _UNSET
    _resolved: _core.ResolvedConfig = field(default=_UNSET, init=False, repr=False, compare=False)

    def __new__(cls, *args: Any, **kwargs: Any) -> "ChainCartConfig":
        # Before the generated __init__, whose TypeError would name no keyword to use.
        for name in kwargs:
            if name not in _KEYWORDS:
                raise UnknownKeyError(f"ChainCartConfig: {unknown_keyword_message(name)}")
        return super().__new__(cls)

    def __post_init__(self) -> None:
        given = {f.name: _plain(f.name, getattr(self, f.name)) for f in fields(self) if f.init}
        # One call: the core fills unset keywords from the scene, checks every value (the
        # task against the model) and returns the model, the task and each value in
        # canonical form.
        resolved = _core.resolve_config(given)
        for name, value in _with_weights(resolved.values()).items():
            object.__setattr__(self, name, value)
        object.__setattr__(self, "_resolved", resolved)

    # -- derived values -------------------------------------------------------------

    def make_model(self) -> _core.ChainCart:
        """The native model with this config's physical parameters (immutable, so the
        config and its envs share one); :class:`ChainCart` adds a ``simulate`` that takes
        a feedback policy."""
        return self._resolved.model

    @property
    def target_signs(self) -> tuple[int, ...]:
        """The target equilibrium as a tuple of +1 (hanging link) / -1 (upright link);
        for a goal-conditioned task (:attr:`goal_conditioned`), the first pair's target
        (each episode draws its own: the env's ``targets``)."""
        return tuple(int(s) for s in self._resolved.target)

    @property
    def goal_conditioned(self) -> bool:
        """Every reset draws its (start, target) pair: ``target`` or ``start`` is
        ``"any"``, or ``transitions`` lists the pairs."""
        return self._resolved.pairs is not None

    @property
    def pairs(self) -> Optional[list[tuple[tuple[int, ...], tuple[int, ...]]]]:
        """The (start, target) sign tuples a goal-conditioned task draws from, in the
        order the core indexes them; ``None`` for a fixed task."""
        pairs = self._resolved.pairs
        if pairs is None:
            return None
        return [(tuple(int(v) for v in s), tuple(int(v) for v in t)) for s, t in pairs]

    @property
    def obs_dim(self) -> int:
        """Length of an observation: :attr:`state_dim`, plus ``n_links`` target signs
        with ``goal_observation``."""
        return self._resolved.obs_dim

    @property
    def view(self) -> str:
        """The picture rendered frames show: ``render_view``, or for ``None`` the
        scene's default (``"3d"`` for spatial chains, ``"side"`` for planar ones)."""
        return self.render_view if self.render_view is not None else _core.default_view(self.planar)

    @property
    def state_dim(self) -> int:
        """Length of the observed state: ``2 + 3n`` planar, ``4 + 6n`` spatial."""
        return self._resolved.state_dim

    @property
    def state_layout(self) -> dict[str, tuple[int, int]]:
        """``(start, stop)`` of each block of the observed state (``x``, ``xdot``, ``q``,
        ``w``), as the core lays it out."""
        return self._resolved.model.state_layout

    @property
    def force_dim(self) -> int:
        """Length of an action: 1 planar, 2 spatial."""
        return self._resolved.force_dim

    def core_config(self) -> dict[str, Any]:
        """Every keyword as the core's ``resolve_config`` takes them."""
        return {**self.to_dict(), "reward_weights": self.reward_weights.as_tuple()}

    def make_batch(self, num_envs: int, autoreset_mode: str, seed: int = 0) -> _core.EnvBatch:
        """A native batch of ``num_envs`` envs of this task, built from the resolved
        configuration (nothing is resolved again)."""
        return _core.EnvBatch(self._resolved, num_envs, autoreset_mode=autoreset_mode, seed=seed)

    def replace(self, **changes: Any) -> "ChainCartConfig":
        """A copy with some keywords changed (the others keep their resolved values)."""
        return dataclasses.replace(self, **changes)

    @property
    def has_reality_gap(self) -> bool:
        """The true system or its sensing/actuation differs from the nominal model."""
        return any(getattr(self, name) != default for name, default, _ in REALITY_KEYS)

    @property
    def has_rig_effects(self) -> bool:
        """The true system has joint damping, cart friction or an actuation other than
        force (its envs then step one by one, in f64)."""
        damping = self.joint_damping if isinstance(self.joint_damping, tuple) else (self.joint_damping,)
        return (
            any(c != 0.0 for c in damping)
            or self.cart_viscous_friction != 0.0
            or self.cart_coulomb_friction != 0.0
            or self.actuation != "force"
        )

    @property
    def command_scale(self) -> float:
        """What an action of magnitude 1 commands per cart axis in this config's
        actuation: ``max_force`` (N), ``max_acceleration`` (m/s^2) or ``max_voltage`` (V)."""
        return {"force": self.max_force, "acceleration": self.max_acceleration, "voltage": self.max_voltage}[
            self.actuation
        ]

    def lqr_gain(
        self, target: Sequence[float], Q: Optional[np.ndarray] = None, R: Optional[np.ndarray] = None
    ) -> np.ndarray:
        """The LQR gain ``K`` (``(2, 4 + 4n)``) at equilibrium ``target`` of the nominal
        model with this config's real-rig effects: joint damping and viscous cart friction
        enter the linearisation as damping (Coulomb friction does not: its slope at rest
        holds only below ``coulomb_velocity``), and ``u = -K z`` is the command of the
        actuation per cart axis (N, m/s^2 or V; divide by :attr:`command_scale` for an
        action). Without rig effects it is ``make_model().lqr_gain(target, Q, R)``."""
        return np.asarray(self._resolved.lqr_gain(list(target), Q, R), dtype=np.float64)

    def rig_model(self, model: Optional[_core.ChainCart] = None) -> _core.ChainCart:
        """:meth:`make_model` (or ``model``, the same chain with other physical
        parameters) with this config's real-rig effects: its ``step`` and ``plan``, and
        the plan's tracker and MPC, move the chain as the rig does (joint damping, cart
        friction) under commands of the actuation (N, m/s^2 or V per cart axis). Its
        analysis methods (``linearize``, ``lqr_gain``, ``controllability``) stay the ideal
        chain's: this config's own methods count the rig."""
        return self._resolved.rig_model(self.make_model() if model is None else model)

    def controllability(self, target: Sequence[float]) -> tuple[bool, float]:
        """``(controllable, margin)`` of the linearisation at equilibrium ``target`` of the
        nominal model with this config's real-rig effects: Prop. 3's eigenvector test on
        the chain's damped modes (joint damping changes them; cart friction and the
        actuation mode do not change the verdict). Without joint damping it is
        ``make_model().controllability(target)``."""
        controllable, margin = self._resolved.controllability(list(target))
        return bool(controllable), float(margin)

    @property
    def has_param_gap(self) -> bool:
        """The true parameters differ from the model's (mismatch or randomisation)."""
        return any(getattr(self, name) is not None for name in ("randomize", "params", "mismatch"))

    def to_dict(self) -> dict[str, Any]:
        """The keywords as plain values (``ChainCartConfig(**config.to_dict())`` is equal)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.init}
        out["reward_weights"] = dataclasses.asdict(self.reward_weights)
        return out

    @classmethod
    def coerce(cls, config: "ChainCartConfig | Mapping[str, Any] | None" = None, **kwargs: Any) -> "ChainCartConfig":
        """The config of an env constructor: ``config`` (a config or a dict of keywords,
        if given) with ``kwargs`` on top."""
        if config is None:
            return cls(**kwargs)
        if isinstance(config, Mapping):
            return cls(**{**config, **kwargs})
        if not isinstance(config, ChainCartConfig):
            raise InvalidTypeError(f"config = {config!r}: expected a ChainCartConfig or a dict of keywords")
        return config.replace(**kwargs) if kwargs else config


def config_of(env: Any) -> ChainCartConfig:
    """The ``ChainCartConfig`` of a ``ChainCartEnv``, its vector envs or SB3 VecEnv (read
    through ``unwrapped`` or ``config``), or an InvalidInputError for another env."""
    config = getattr(getattr(env, "unwrapped", env), "config", None)
    if config is None:
        raise InvalidInputError(f"{type(env).__name__} exposes no chaincart config: expected a ChainCart env")
    return config


def nominal_model_of(env: Any) -> Any:
    """The nominal model of what :func:`config_of` accepts: an env's ``model``, else (a
    vector env, or anything holding only a ``config``) the config's."""
    base = getattr(env, "unwrapped", env)
    return base.model if hasattr(base, "model") else config_of(env).make_model()
