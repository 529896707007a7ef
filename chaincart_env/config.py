"""One validated configuration object for every chaincart env, and the named scenes.

A :class:`ChainCartConfig` is built from a scene (``scene=``, default
:data:`DEFAULT_SCENE`) whose values fill every keyword not given explicitly, then
normalised (scalars stay scalars, sequences become tuples, names stay names) and
validated once by the Rust core: a bad value raises :class:`ChainCartError` (a
``ValueError``) naming the value and what was expected.
"""

from __future__ import annotations

import dataclasses
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, Optional, Union

import numpy as np

from chaincart_env import _core
from chaincart_env.errors import ChainCartError, InvalidInputError, InvalidTypeError
from chaincart_env.model import ChainCart

__all__ = [
    "ChainCartConfig",
    "RewardWeights",
    "SCENES",
    "DEFAULT_SCENE",
    "EQUILIBRIUM_NAMES",
    "START_NAMES",
    "REALITY_KEYS",
]

#: Names accepted for ``target`` (besides a sign tuple).
EQUILIBRIUM_NAMES = ("hanging", "inverted", "folded", "folded_up", "paper-fig1", "paper-fig2", "paper-fig3")
#: Names accepted for ``start`` (besides a sign tuple or a full state).
START_NAMES = ("target", "hanging", "inverted", "folded", "folded_up", "paper-fig1", "paper-fig2", "paper-fig3")


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward ``r = exp(-c)``,

    ``c = q sum_i |q_i - s_i e3|^2 + w sum_i |w_i|^2 + x |x|^2 + v |xdot|^2 + u |a|^2``

    (``a`` the clipped normalised action). All finite and >= 0.
    """

    q: float = 1.0
    w: float = 0.1
    x: float = 0.1
    v: float = 0.1
    u: float = 0.01

    def as_tuple(self) -> tuple[float, float, float, float, float]:
        return (self.q, self.w, self.x, self.v, self.u)

    @classmethod
    def coerce(cls, value: Any) -> "RewardWeights":
        """A ``RewardWeights``, a mapping with some of the keys q, w, x, v, u (the rest
        default), or a sequence of five numbers."""
        if isinstance(value, RewardWeights):
            return value
        if isinstance(value, Mapping):
            names = {f.name for f in fields(cls)}
            unknown = sorted(set(value) - names)
            if unknown:
                raise InvalidInputError(
                    f"reward_weights has unknown keys {unknown}: expected some of {sorted(names)}"
                )
            return cls(**{k: _number(f"reward_weights.{k}", v) for k, v in value.items()})
        if isinstance(value, Sequence) and not isinstance(value, str) and len(value) == 5:
            return cls(*(_number("reward_weights", v) for v in value))
        raise InvalidTypeError(
            f"reward_weights = {value!r}: expected a RewardWeights, a mapping with keys q, w, x, v, u, "
            "or five numbers"
        )


#: The keywords of the reality gap (parameter mismatch and randomisation, sensor noise,
#: control delay, force-rate limit) as the core defines them: ``(name, default, help)``.
#: Their values are checked and brought into canonical form by the core.
REALITY_KEYS: tuple[tuple[str, Any, str], ...] = tuple(_core.REALITY_KEYS)
_REALITY_NAMES = tuple(name for name, _, _ in REALITY_KEYS)

_DEFAULTS: dict[str, Any] = dict(
    n_links=1,
    cart_mass=1.0,
    link_masses=0.1,
    link_lengths=0.5,
    gravity=9.81,
    planar=True,
    target="inverted",
    start="target",
    start_noise=0.05,
    dt=0.02,
    integrator="rk4",
    # Two 10 ms RK4 steps per 20 ms control period: with single 20 ms steps, random
    # pushes whip the links past 25 rad/s and about 7% of random-action episodes end
    # flagged as under-resolved (a link turning > 0.5 rad in one step); with two, none.
    substeps=2,
    max_force=10.0,
    track_limit=2.4,
    max_episode_steps=500,
    reward_weights=RewardWeights(),
    obs_dtype="float32",
    success_tolerances=(0.1, 0.5),
    diagnostics=False,
    **{name: default for name, default, _ in REALITY_KEYS},
)

_PAPER: dict[str, Any] = dict(
    _DEFAULTS,
    n_links=5,
    cart_mass=0.5,
    link_masses=0.1,
    link_lengths=0.1,
    planar=False,
    start_noise=0.0,
    dt=0.01,
    # RK4 needs ~1 ms steps for millimetre accuracy on the paper's system (docs/performance.md).
    substeps=10,
    max_force=100.0,
    track_limit=10.0,
    max_episode_steps=1000,
)

#: Named scenes: every config keyword's value. ``inverted-2`` is the default.
SCENES: dict[str, dict[str, Any]] = {
    # A CartPole-sized planar inverted pendulum (point mass 0.1 kg at 0.5 m on a 1 kg
    # cart, unstable at ~4.6 1/s). PPO solves it in seconds.
    "inverted-1": dict(_DEFAULTS),
    # The default: the planar double inverted pendulum, two such links. LQR holds it
    # from +-0.05 noise; PPO (SB3 defaults, 8 envs) needs a few hundred thousand steps,
    # about a minute and a half on two cores: a PPO-vs-LQR comparison with a learning
    # curve that fits in five minutes.
    "inverted-2": dict(_DEFAULTS, n_links=2, max_force=20.0),
    # Swing-up of the planar single pendulum from hanging.
    "swingup-1": dict(_DEFAULTS, start="hanging", max_force=10.0, track_limit=3.0),
    # The paper's figures are continuous-time results: their scenes hold the force for
    # at most 1 ms. Fig. 1: uncontrolled (max_force 0: every action is ignored) motion
    # from IC1 near the folded equilibrium s = (-1, 1, -1, 1, -1), scored against it;
    # RK4 at 1 ms is accurate to about a millimetre over 1 s (docs/performance.md, speed vs accuracy).
    "paper-fig1": dict(_PAPER, target="paper-fig1", start="paper-fig1", max_force=0.0, dt=1e-3, substeps=1, max_episode_steps=10_000),
    # Fig. 2: stabilise the hanging equilibrium from IC1. The chain falls from the folded
    # start far outside the linear region; the LQR catches it when the force is held
    # for 0.3 ms or less (a 1 ms hold pumps energy into the fast modes), so 0.1 ms.
    # e_q and e_w stay below 1e-3 from 9.2 s.
    "paper-fig2": dict(_PAPER, target="hanging", start="paper-fig2", dt=1e-4, substeps=1, max_episode_steps=100_000),
    # Fig. 3: stabilise s = (-1, -1, -1, 1, 1) from the Fig. 3 initial condition. With
    # the paper's weights the slowest closed-loop poles are -0.77 +- 0.56i: e_q and e_w
    # fall below 1e-3 at 11.3 s, so the episode lasts 12 s.
    "paper-fig3": dict(_PAPER, target="paper-fig3", start="paper-fig3", dt=1e-3, substeps=1, max_episode_steps=12_000),
    # Sim-to-real scenes on the default double inverted pendulum. "-randomized": every
    # reset draws the cart mass and each link's mass and length within +-25 % of the
    # model's, so a controller designed on the model meets a different system in
    # every episode. "-noisy": Gaussian sensor noise (0.01 in every state component:
    # 1 cm, 0.01 rad, 0.01 m/s, 0.01 rad/s) and a one-period (20 ms) control delay.
    "inverted-2-randomized": dict(
        _DEFAULTS, n_links=2, max_force=20.0, randomize={"cart_mass": 0.25, "link_masses": 0.25, "link_lengths": 0.25}
    ),
    "inverted-2-noisy": dict(_DEFAULTS, n_links=2, max_force=20.0, obs_noise=0.01, action_delay=1),
    # The same two on the spatial double pendulum (cart in the plane, links on spherical joints).
    "spatial-inverted-2-randomized": dict(
        _DEFAULTS,
        n_links=2,
        planar=False,
        max_force=20.0,
        randomize={"cart_mass": 0.25, "link_masses": 0.25, "link_lengths": 0.25},
    ),
    "spatial-inverted-2-noisy": dict(
        _DEFAULTS, n_links=2, planar=False, max_force=20.0, obs_noise=0.01, action_delay=1
    ),
}

DEFAULT_SCENE = "inverted-2"
#: The episode length ``ChainCart-v0`` is registered with: the default scene's.
REGISTERED_EPISODE_STEPS: int = SCENES[DEFAULT_SCENE]["max_episode_steps"]

# Typed "unset" default: every field is filled from the scene in __post_init__.
_UNSET: Any = None

Floats = Union[float, tuple[float, ...]]


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InvalidTypeError(f"{name} = {value!r}: expected a number")
    return float(value)


def _integer(name: str, value: Any) -> int:
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return int(value)
    if isinstance(value, numbers.Real) and not isinstance(value, bool) and float(value).is_integer():
        return int(float(value))
    raise InvalidTypeError(f"{name} = {value!r}: expected an integer")


def _per_link(name: str, value: Any) -> Floats:
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, str):
        return tuple(_number(f"{name}[{i}]", v) for i, v in enumerate(value))
    raise InvalidTypeError(f"{name} = {value!r}: expected a number or one number per link")


def _name_or_numbers(name: str, value: Any) -> Union[str, tuple[float, ...]]:
    if isinstance(value, str):
        return value
    if isinstance(value, (Sequence, np.ndarray)):
        return tuple(_number(f"{name}[{i}]", v) for i, v in enumerate(value))
    raise InvalidTypeError(f"{name} = {value!r}: expected a name or a sequence of numbers")


@dataclass(frozen=True)
class ChainCartConfig:
    """Everything that defines a chaincart env (see :class:`chaincart_env.ChainCartEnv`
    for the meaning of each keyword). Keywords left out take the scene's value."""

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
    #: Success at the time limit: ``e_q <= success_tolerances[0]`` and ``e_w <= [1]``.
    success_tolerances: tuple[float, float] = _UNSET
    #: Put energies and constraint residuals in every step's info (costs time).
    diagnostics: bool = _UNSET
    #: Reality gap (see :data:`REALITY_KEYS` for forms and defaults): stored in the
    #: canonical form the core returns. ``{}`` / ``0`` / ``inf`` switch a scene's
    #: setting off.
    randomize: Optional[dict[str, Any]] = _UNSET
    params: Optional[dict[str, Any]] = _UNSET
    mismatch: Optional[dict[str, Any]] = _UNSET
    obs_noise: Optional[Floats] = _UNSET
    action_delay: int = _UNSET
    force_rate_limit: Optional[float] = _UNSET
    _model: ChainCart = field(default=_UNSET, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        scene = DEFAULT_SCENE if self.scene is None else self.scene
        if scene not in SCENES:
            raise InvalidInputError(f"unknown scene {scene!r}: expected one of {sorted(SCENES)}")
        values = {f.name: getattr(self, f.name) for f in fields(self) if f.init and f.name != "scene"}
        for name, value in values.items():
            if value is None:
                values[name] = SCENES[scene][name]
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        set_("scene", scene)
        set_("n_links", _integer("n_links", values["n_links"]))
        if self.n_links < 0:
            raise InvalidInputError(f"n_links = {self.n_links}: expected an integer >= 1")
        for name in ("cart_mass", "gravity", "start_noise", "dt", "max_force", "track_limit"):
            set_(name, _number(name, values[name]))
        set_("link_masses", _per_link("link_masses", values["link_masses"]))
        set_("link_lengths", _per_link("link_lengths", values["link_lengths"]))
        if not isinstance(values["planar"], (bool, np.bool_)):
            raise InvalidTypeError(f"planar = {values['planar']!r}: expected True or False")
        set_("planar", bool(values["planar"]))
        set_("target", _name_or_numbers("target", values["target"]))
        set_("start", _name_or_numbers("start", values["start"]))
        if not isinstance(values["integrator"], str):
            raise InvalidInputError(
                f"integrator = {values['integrator']!r}: expected one of {list(_core.INTEGRATORS)}"
            )
        set_("integrator", values["integrator"])
        for name in ("substeps", "max_episode_steps"):
            v = _integer(name, values[name])
            if v < 1:
                raise InvalidInputError(f"{name} = {v}: expected an integer >= 1")
            set_(name, v)
        set_("reward_weights", RewardWeights.coerce(values["reward_weights"]))
        try:
            dtype = np.dtype(values["obs_dtype"]).name
        except TypeError:
            dtype = repr(values["obs_dtype"])
        if dtype not in ("float32", "float64"):
            raise InvalidInputError(f"obs_dtype = {values['obs_dtype']!r}: expected 'float32' or 'float64'")
        set_("obs_dtype", dtype)
        tol = values["success_tolerances"]
        if not (isinstance(tol, Sequence) and len(tol) == 2):
            raise InvalidInputError(f"success_tolerances = {tol!r}: expected two numbers (e_q, e_w)")
        set_("success_tolerances", (_number("success_tolerances[0]", tol[0]), _number("success_tolerances[1]", tol[1])))
        if not isinstance(values["diagnostics"], (bool, np.bool_)):
            raise InvalidTypeError(f"diagnostics = {values['diagnostics']!r}: expected True or False")
        set_("diagnostics", bool(values["diagnostics"]))
        # Validation by the core: the physical parameters, then the task on a batch of one.
        model = ChainCart(
            self.n_links, self.cart_mass, self.link_masses, self.link_lengths, self.gravity, self.planar
        )
        set_("_model", model)
        for name in _REALITY_NAMES:
            set_(name, values[name])
        set_("action_delay", _integer("action_delay", values["action_delay"]))
        canonical = _core.EnvBatch(model, 1, **self.task_kwargs()).task
        for name in _REALITY_NAMES:
            set_(name, canonical[name])

    # -- derived values -------------------------------------------------------------

    def make_model(self) -> ChainCart:
        """A fresh :class:`ChainCart` with this config's physical parameters."""
        return ChainCart(self.n_links, self.cart_mass, self.link_masses, self.link_lengths, self.gravity, self.planar)

    @property
    def target_signs(self) -> tuple[int, ...]:
        """The target equilibrium as a tuple of +1 (hanging link) / -1 (upright link)."""
        if isinstance(self.target, str):
            return tuple(_core.target_signs(self.target, self.n_links))
        return tuple(int(s) for s in self.target)

    @property
    def state_dim(self) -> int:
        """Length of the observed state: ``2 + 3n`` planar, ``4 + 6n`` spatial."""
        return self._model.state_dim

    @property
    def force_dim(self) -> int:
        """Length of an action: 1 planar, 2 spatial."""
        return self._model.force_dim

    def task_kwargs(self, autoreset_mode: str = "next_step", seed: int = 0) -> dict[str, Any]:
        """Keyword arguments of :class:`chaincart_env._core.EnvBatch` for this config."""
        return dict(
            target=self.target,
            start=self.start,
            start_noise=self.start_noise,
            dt=self.dt,
            integrator=self.integrator,
            substeps=self.substeps,
            max_force=self.max_force,
            track_limit=self.track_limit,
            max_episode_steps=self.max_episode_steps,
            reward_weights=self.reward_weights.as_tuple(),
            success_tolerances=self.success_tolerances,
            obs_dtype=self.obs_dtype,
            autoreset_mode=autoreset_mode,
            diagnostics=self.diagnostics,
            seed=seed,
            **{name: getattr(self, name) for name in _REALITY_NAMES},
        )

    def make_batch(self, num_envs: int, autoreset_mode: str, seed: int = 0) -> _core.EnvBatch:
        """A native batch of ``num_envs`` envs of this task."""
        return _core.EnvBatch(self._model, num_envs, **self.task_kwargs(autoreset_mode, seed))

    def replace(self, **changes: Any) -> "ChainCartConfig":
        """A copy with some keywords changed (the others keep their resolved values)."""
        return dataclasses.replace(self, **changes)

    @property
    def has_reality_gap(self) -> bool:
        """The true system or its sensing/actuation differs from the nominal model."""
        return any(getattr(self, name) != default for name, default, _ in REALITY_KEYS)

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
