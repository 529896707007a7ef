"""The robustness axes of the leaderboard: what a controller meets on a real bench.

Each axis varies one imperfection from none to severe, on top of the scene; every
controller runs the same seeded episodes at every value. The first value of each axis
is the scene itself (or, for the start perturbation, the scene's own start noise), so
that the axes share the nominal point.

| axis | what varies | values |
|---|---|---|
| ``mismatch`` | true masses and lengths x U[1 - p, 1 + p] per episode | 0 to 0.4 |
| ``obs_noise`` | Gaussian sensor noise, std in state units | 0 to 0.05 |
| ``force_noise`` | applied force x (1 + N(0, sigma^2)) each step | 0 to 0.5 |
| ``delay`` | control delay, control periods | 0 to 4 |
| ``force_rate_limit`` | largest change of the force, N/s | none to 200 |
| ``start_noise`` | half-width of the start perturbation | the scene's to 0.5 |
| ``joint_damping`` | viscous damping added at every joint, N m s/rad | 0 to 0.03 |
| ``cart_friction`` | Coulomb friction added on the cart, N | 0 to 1 |

The friction and damping axes change the true system only: the model-based
controllers are designed on the scene (``DesignSource``), so they meet them as an
unmodelled effect, as the dfki double-pendulum benchmark's friction axes do. A servo
axis (``actuation="acceleration"``) absorbs cart friction, so on such a scene
``cart_friction`` leaves the scene as it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.sweeps import SWEEP_AXES

__all__ = ["AXES", "AXIS_NAMES", "RobustnessAxis", "axis_values", "parse_axes"]


@dataclass(frozen=True)
class RobustnessAxis:
    """One axis: its name, words for tables and plots, its values (a full run and a
    quick one) and how a value changes a scene's configuration."""

    name: str
    label: str
    values: tuple[float, ...]
    quick_values: tuple[float, ...]
    apply: Callable[[ChainCartConfig, float], ChainCartConfig]


def _sweep_axis(name: str) -> Callable[[ChainCartConfig, float], ChainCartConfig]:
    return SWEEP_AXES[name].apply


def _rate_limit(config: ChainCartConfig, value: float) -> ChainCartConfig:
    return config.replace(force_rate_limit=None if math.isinf(value) else value)


def _force_noise(config: ChainCartConfig, value: float) -> ChainCartConfig:
    return config.replace(force_noise=None if value == 0 else {"multiplicative": value})


def _added_joint_damping(config: ChainCartConfig, value: float) -> ChainCartConfig:
    if value == 0:
        return config
    damping = config.joint_damping if isinstance(config.joint_damping, tuple) else (config.joint_damping,)
    return config.replace(joint_damping=tuple(c + value for c in damping))


def _added_cart_friction(config: ChainCartConfig, value: float) -> ChainCartConfig:
    if value == 0 or config.actuation == "acceleration":  # a servo axis tracks its command whatever the friction
        return config
    return config.replace(cart_coulomb_friction=config.cart_coulomb_friction + value)


#: The axes, in table order.
AXES: tuple[RobustnessAxis, ...] = (
    RobustnessAxis("mismatch", "model mismatch p", (0.0, 0.1, 0.2, 0.3, 0.4), (0.0, 0.3), _sweep_axis("mismatch")),
    RobustnessAxis("obs_noise", "observation noise (std)", (0.0, 0.005, 0.01, 0.02, 0.05), (0.0, 0.02),
                   _sweep_axis("obs_noise")),
    RobustnessAxis("force_noise", "force noise (relative std)", (0.0, 0.1, 0.2, 0.3, 0.5), (0.0, 0.3), _force_noise),
    RobustnessAxis("delay", "control delay (periods)", (0.0, 1.0, 2.0, 3.0, 4.0), (0.0, 2.0), _sweep_axis("delay")),
    RobustnessAxis("force_rate_limit", "force-rate limit (N/s)", (math.inf, 2000.0, 1000.0, 500.0, 200.0),
                   (math.inf, 500.0), _rate_limit),
    RobustnessAxis("start_noise", "start perturbation (half-width)", (0.05, 0.1, 0.2, 0.3, 0.5), (0.05, 0.3),
                   _sweep_axis("start_noise")),
    RobustnessAxis("joint_damping", "joint damping added (N m s/rad)", (0.0, 0.003, 0.01, 0.02, 0.03), (0.0, 0.02),
                   _added_joint_damping),
    RobustnessAxis("cart_friction", "cart Coulomb friction added (N)", (0.0, 0.1, 0.2, 0.5, 1.0), (0.0, 0.5),
                   _added_cart_friction),
)

#: The axis names, in table order.
AXIS_NAMES = tuple(axis.name for axis in AXES)


def parse_axes(text: str | None) -> tuple[RobustnessAxis, ...]:
    """``"mismatch,delay"`` into those axes (all of them for ``None``)."""
    if text is None:
        return AXES
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in AXIS_NAMES]
    if unknown or not names:
        raise InvalidInputError(f"--axes {text!r}: expected names among {list(AXIS_NAMES)}, separated by commas")
    return tuple(axis for axis in AXES if axis.name in names)


def axis_values(axis: RobustnessAxis, quick: bool) -> Sequence[float]:
    """The values of ``axis`` a run evaluates."""
    return axis.quick_values if quick else axis.values
