"""What a model-based policy reads from an env: the nominal (or true) model, the force
limit, the track, the control period and the goal convention."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from chaincart_env import _core
from chaincart_env.config import config_of, nominal_model_of
from chaincart_env.errors import InvalidInputError
from chaincart_env.model import ChainCart

__all__ = [
    "ACTUATION_COMMANDS", "SCENE_PLANS", "EnvSettings", "check_force_actuation", "env_settings",
    "goal_signs",
    "nearest_equilibrium", "observation_batch",
]

#: The plan length (s) and the plan start (``"equilibrium"`` or ``"state"``) of the
#: plan-following policies on the scenes where the planner's defaults (1 + n s from the
#: start equilibrium, enough for every transition of two links) are not: three links
#: need longer plans, and plans from each episode's observed start, since from a start
#: near one of their unstable equilibria the chain leaves a plan that begins at the
#: equilibrium before its feedback catches up (the transitions tables of docs/task.md).
SCENE_PLANS: dict[str, tuple[float, str]] = {
    "swingup-3": (7.0, "state"),
    "transitions-3": (7.0, "state"),
}


@dataclass(frozen=True)
class EnvSettings:
    """The task as a controller sees it."""

    model: ChainCart
    #: The largest command per cart axis: a force (N), or with ``env_settings(rig=True)``
    #: the actuation's limit (N, m/s^2 or V).
    max_force: float
    track_limit: float
    dt: float
    substeps: int
    target: tuple[int, ...]
    #: The observation ends with the target's n signs (goal-conditioned scenes).
    goal_observation: bool
    #: The scene the env's configuration started from ("" for none).
    scene: str = ""
    #: The env's episode length in control periods (0: not known): no episode is longer.
    max_episode_steps: int = 0
    #: The largest standard deviation of the env's observation noise (state units).
    obs_noise: float = 0.0

    @property
    def n_links(self) -> int:
        """The number of links of the model."""
        return int(self.model.n_links)

    @property
    def state_dim(self) -> int:
        """The length of the model's state vector."""
        return int(self.model.state_dim)

    @property
    def obs_dim(self) -> int:
        """The length of an observation: the state, then the target's signs on goal-conditioned
        scenes."""
        return self.state_dim + (self.n_links if self.goal_observation else 0)


def env_settings(env: Any, oracle: bool = False, controller: str = "this controller", rig: bool = False) -> EnvSettings:
    """The settings of a ``ChainCartEnv``, its vector envs or SB3 VecEnv (anything that
    exposes the config through ``unwrapped`` or ``config``). ``oracle=True`` takes the
    true parameters of the env (or of its first env) instead of the nominal model.
    ``rig=True`` is for a controller that plans on the model it is given: the model then
    carries the config's real-rig effects (:meth:`ChainCartConfig.rig_model`: joint
    damping, cart friction, the actuation) and ``max_force`` is the actuation's command
    limit (:attr:`ChainCartConfig.command_scale`: N, m/s^2 or V). Without it, an env whose
    actions command anything but a force (``actuation``) is refused: ``controller`` (its
    name, for the message) computes forces on the ideal model."""
    config = config_of(env)
    if not rig:
        check_force_actuation(config, controller)
    model = nominal_model_of(env)
    if oracle:
        from chaincart_env.policies.lqr import _true_param_rows

        p = _true_param_rows(env)[0]
        model = ChainCart(
            config.n_links, p["cart_mass"], p["link_masses"], p["link_lengths"], p["gravity"], config.planar
        )
    if rig and config.has_rig_effects:
        model = config.rig_model(model)
    if config.integrator != "rk4":
        raise InvalidInputError(
            f"integrator = {config.integrator!r}: the planner's model steps with 'rk4'; expected an rk4 scene"
        )
    return EnvSettings(
        model=model,
        max_force=float(config.command_scale if rig else config.max_force),
        track_limit=float(config.track_limit),
        dt=float(config.dt),
        substeps=int(config.substeps),
        target=tuple(int(s) for s in config.target_signs),
        goal_observation=bool(getattr(config, "goal_observation", False)),
        scene=str(getattr(config, "scene", None) or ""),
        max_episode_steps=int(getattr(config, "max_episode_steps", 0) or 0),
        obs_noise=float(np.max(np.asarray(config.obs_noise))) if config.obs_noise is not None else 0.0,
    )


def check_force_actuation(config: Any, controller: str) -> None:
    """Refuses a config whose actions do not command the cart's force: ``controller``
    computes forces on the ideal model, which an acceleration or voltage command would
    misread (``LQRPolicy`` designs for every actuation)."""
    if config.actuation != "force":
        raise InvalidInputError(
            f"actuation = {config.actuation!r}: {controller} computes cart forces and the env's actions "
            f"command the cart's {ACTUATION_COMMANDS.get(config.actuation, config.actuation)}; expected "
            "actuation='force' (LQRPolicy designs for every actuation)"
        )


#: What an action commands in each actuation but force, for messages.
ACTUATION_COMMANDS = {"acceleration": "acceleration (m/s^2)", "voltage": "motor voltage (V)"}


def nearest_equilibrium(model: _core.ChainCart, state: np.ndarray) -> tuple[int, ...]:
    """The equilibrium whose links point the way the state's do: ``s_i = +1`` where link
    ``i`` points down (``q_i . e3 >= 0``), ``-1`` where it points up."""
    start, stop = model.state_layout["q"]
    per_link = (stop - start) // model.n_links
    q = np.asarray(state[start:stop]).reshape(model.n_links, per_link)
    return tuple(1 if v >= 0.0 else -1 for v in q[:, -1])


def goal_signs(tail: np.ndarray, n: int) -> tuple[int, ...]:
    """The target read from an observation's last ``n`` entries (+1/-1 each)."""
    signs = np.asarray(tail[-n:], dtype=np.float64)
    if not np.all(np.abs(np.abs(signs) - 1.0) < 1e-6):
        raise InvalidInputError(
            f"observation ends with {signs.tolist()}: expected the target's {n} signs +1/-1 (goal observation)"
        )
    return tuple(int(round(v)) for v in signs)


def observation_batch(settings: EnvSettings, observation: Any) -> np.ndarray:
    """``observation`` (one or a batch) as a float64 batch of ``settings.obs_dim``
    columns, checked: shape and finite entries."""
    obs = np.asarray(observation, dtype=np.float64)
    batch = np.atleast_2d(obs)
    width = settings.obs_dim
    if batch.ndim != 2 or batch.shape[1] != width:
        raise InvalidInputError(f"observation has shape {obs.shape}: expected ({width},) or (N, {width})")
    if not np.all(np.isfinite(batch)):
        raise InvalidInputError("observation has non-finite entries: expected finite states")
    return batch
