"""Recorded episodes and the quantities the paper plots, as plain NumPy.

:func:`rollout` runs one episode of a scene through the Gymnasium env itself (so a
figure shows exactly what ``gym.make("ChainCart-v0", scene=...)`` does) and keeps the
full float64 spatial state and the applied force of every step. The functions below
it turn a stack of spatial states into the paper's curves: link directions, the tip
position relative to the cart, the errors ``e_q`` and ``e_w``, the links' kinetic
energy ``T_q`` (eq. T2) and the settle time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional, Protocol, Sequence

import gymnasium as gym
import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.env import ChainCartEnv
from chaincart_env.model import ChainCart

__all__ = [
    "Trajectory",
    "Predictor",
    "rollout",
    "link_directions",
    "tip_positions",
    "paper_errors",
    "link_kinetic_energy",
    "settle_time",
]


class Predictor(Protocol):
    """Anything with the stable-baselines3 ``predict`` convention (e.g. ``LQRPolicy``)."""

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        """The action for ``observation`` (SB3's ``predict``): ``(action, state)``."""


@dataclass(frozen=True)
class Trajectory:
    """One recorded episode. ``states[k]`` is the spatial state at ``times[k]``;
    ``forces[k]`` (newtons) is held over ``[times[k], times[k+1])``."""

    config: ChainCartConfig
    times: np.ndarray
    states: np.ndarray
    forces: np.ndarray
    terminated: bool
    truncated: bool
    info: dict[str, Any]

    @property
    def model(self) -> ChainCart:
        """The spatial model of the scene (planar scenes' states are embedded)."""
        return ChainCart(**{**self.config.make_model().params, "planar": False})

    @property
    def target(self) -> tuple[int, ...]:
        """The target equilibrium's signs."""
        return self.config.target_signs


def rollout(config: ChainCartConfig, policy: Optional[Predictor] = None, seed: int = 0) -> Trajectory:
    """One episode of ``config`` (to its end) with ``policy`` (None: zero force).

    The env observes float64 so that the policy acts on the exact state, as the
    paper's continuous-time controller does; everything else is the scene's."""
    # gymnasium.make's TimeLimit takes the registered (default scene's) length unless told.
    env = gym.make("ChainCart-v0", config=config.replace(obs_dtype="float64"), max_episode_steps=config.max_episode_steps)
    base = env.unwrapped
    assert isinstance(base, ChainCartEnv)
    steps = config.max_episode_steps
    states = np.empty((steps + 1, 4 + 6 * config.n_links))
    forces = np.zeros((steps, 2))
    obs, _ = env.reset(seed=seed)
    states[0] = base.state
    zero = np.zeros(config.force_dim, dtype=np.float32)
    terminated = truncated = False
    info: dict[str, Any] = {}
    k = 0
    while not (terminated or truncated):
        action = zero if policy is None else policy.predict(obs)[0]
        # What the env applies: the clipped action times the force limit (planar: on e1).
        applied = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0) * config.max_force
        forces[k, : applied.shape[0]] = applied
        obs, _, terminated, truncated, info = env.step(action)
        k += 1
        states[k] = base.state
    env.close()
    return Trajectory(
        config=config,
        times=np.arange(k + 1) * config.dt,
        states=states[: k + 1],
        forces=forces[:k],
        terminated=bool(terminated),
        truncated=bool(truncated),
        info=dict(info),
    )


def link_directions(states: np.ndarray, n_links: int) -> tuple[np.ndarray, np.ndarray]:
    """``(q, w)``, each of shape ``(T, n, 3)``, from spatial states ``(T, 4 + 6n)``."""
    states = np.atleast_2d(states)
    q = states[:, 4 : 4 + 3 * n_links].reshape(-1, n_links, 3)
    w = states[:, 4 + 3 * n_links : 4 + 6 * n_links].reshape(-1, n_links, 3)
    return q, w


def tip_positions(states: np.ndarray, link_lengths: Sequence[float]) -> np.ndarray:
    """The last mass relative to the cart, ``sum_i l_i q_i``, shape ``(T, 3)``."""
    lengths = np.asarray(link_lengths, dtype=np.float64)
    q, _ = link_directions(states, lengths.shape[0])
    return np.einsum("i,tij->tj", lengths, q)


def paper_errors(states: np.ndarray, target: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The paper's ``e_q = sum_i |q_i - s_i e3|`` and ``e_w = sum_i |w_i|`` per state."""
    s = np.asarray(target, dtype=np.float64)
    q, w = link_directions(states, s.shape[0])
    goal = np.zeros((s.shape[0], 3))
    goal[:, 2] = s
    return np.linalg.norm(q - goal, axis=2).sum(axis=1), np.linalg.norm(w, axis=2).sum(axis=1)


def link_kinetic_energy(
    states: np.ndarray, link_masses: Sequence[float], link_lengths: Sequence[float]
) -> np.ndarray:
    """The paper's ``T_q`` (eq. T2): ``1/2 sum_i m_i |sum_{a<=i} l_a qdot_a|^2`` with
    ``qdot_a = w_a x q_a``, the kinetic energy the links would have on a cart at rest."""
    masses = np.asarray(link_masses, dtype=np.float64)
    lengths = np.asarray(link_lengths, dtype=np.float64)
    q, w = link_directions(states, masses.shape[0])
    mass_velocities = np.cumsum(lengths[None, :, None] * np.cross(w, q), axis=1)
    return 0.5 * np.einsum("i,tij,tij->t", masses, mass_velocities, mass_velocities)


def settle_time(times: np.ndarray, e_q: np.ndarray, e_w: np.ndarray, tolerance: float) -> Optional[float]:
    """The first time from which ``e_q`` and ``e_w`` stay below ``tolerance`` to the end
    (None if they are not below it at the end)."""
    inside = (np.asarray(e_q) < tolerance) & (np.asarray(e_w) < tolerance)
    if not inside[-1]:
        return None
    outside = np.flatnonzero(~inside)
    return float(times[0] if outside.size == 0 else times[outside[-1] + 1])
