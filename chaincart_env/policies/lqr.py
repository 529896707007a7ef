"""The paper's LQR controller (eq. u) as a baseline policy with the SB3 calling convention.

The gain ``K`` (shape ``(2, 4 + 4n)``) comes from the Rust core's Riccati solver for
the linearisation of Prop. 2 at the target equilibrium ``s``. Applied to the
nonlinear state as in the paper,

    u = -K z,  z = [x, C^T(s_1 e3 x q_1) .. C^T(s_n e3 x q_n), xdot, C^T w_1 .. C^T w_n],

then scaled to the env's normalised action space and clipped to [-1, 1] (the force
saturates at ``max_force``). Planar observations are embedded in the spatial state
(the planar dynamics are the e1-e3 block of the spatial ones) and only the e1 force
is returned.

On a rig (:attr:`ChainCartConfig.has_rig_effects`) :meth:`LQRPolicy.from_env` designs
on the linearisation with the config's rig (:meth:`ChainCartConfig.lqr_gain`): joint
damping and viscous cart friction enter as damping (Coulomb friction is left out),
and ``u`` is the command of the actuation (a force, the cart's acceleration or the
motor's voltage), scaled by :attr:`ChainCartConfig.command_scale`.
"""

from __future__ import annotations

from typing import Any, Callable, Optional, Sequence

import numpy as np
import numpy.typing as npt

from chaincart_env.config import config_of, nominal_model_of

__all__ = ["LQRPolicy", "OracleLQRPolicy", "lqr_coordinates"]


def lqr_coordinates(states: np.ndarray, target: npt.ArrayLike) -> np.ndarray:
    """Local coordinates z of eq. (u) for a batch of spatial states, shape (N, 4 + 4n)."""
    states = np.atleast_2d(np.asarray(states, dtype=np.float64))
    s = np.asarray(target, dtype=np.float64)
    n = s.shape[0]
    q = states[:, 4 : 4 + 3 * n].reshape(-1, n, 3)
    w = states[:, 4 + 3 * n : 4 + 6 * n].reshape(-1, n, 3)
    # C^T (s_i e3 x q_i) = s_i (-q_y, q_x).
    xi = np.stack([-q[:, :, 1], q[:, :, 0]], axis=2) * s[None, :, None]
    return np.concatenate(
        [states[:, 0:2], xi.reshape(-1, 2 * n), states[:, 2:4], w[:, :, :2].reshape(-1, 2 * n)],
        axis=1,
    )


def _planar_to_spatial(obs: np.ndarray, n: int) -> np.ndarray:
    """[x, xdot, (q_e1, q_e3)_i, w_i] -> [x(2), xdot(2), q_i(3), w_i(3)]."""
    batch = obs.shape[0]
    q2 = obs[:, 2 : 2 + 2 * n].reshape(batch, n, 2)
    q = np.zeros((batch, n, 3))
    q[:, :, 0], q[:, :, 2] = q2[:, :, 0], q2[:, :, 1]
    w = np.zeros((batch, n, 3))
    w[:, :, 1] = obs[:, 2 + 2 * n : 2 + 3 * n]
    out = np.zeros((batch, 4 + 6 * n))
    out[:, 0], out[:, 2] = obs[:, 0], obs[:, 1]
    out[:, 4 : 4 + 3 * n] = q.reshape(batch, -1)
    out[:, 4 + 3 * n :] = w.reshape(batch, -1)
    return out


class LQRPolicy:
    """LQR baseline: ``predict(obs) -> (action, None)`` like a stable-baselines3 model.

    Build it with :meth:`from_env` (gain for the env's target, actuation, command scale
    and scene) or :meth:`from_model`. ``max_force`` is what an action of magnitude 1
    commands: the force limit (N) in force actuation, else the env's
    ``command_scale`` (m/s^2 or V), and the gain's ``u`` is in the same unit. Works on one observation or a batch. Keeps nothing from one
    call to the next (gains designed per target are a cache), so one object serves
    any number of episodes, with or without ``episode_start``.
    """

    def __init__(self, gain: np.ndarray, target: Sequence[float], max_force: float, planar: bool = False):
        self.target = np.asarray(target, dtype=np.float64)
        self.n_links = int(self.target.shape[0])
        gain = np.asarray(gain, dtype=np.float64)
        expected = (2, 4 + 4 * self.n_links)
        if gain.shape != expected:
            raise ValueError(f"gain has shape {gain.shape}: expected {expected} for {self.n_links} links")
        if not np.all(np.isfinite(gain)):
            raise ValueError("gain has non-finite entries: expected a finite matrix")
        if not (np.isfinite(max_force) and max_force > 0):
            raise ValueError(f"max_force = {max_force}: expected a finite number > 0")
        self.gain = gain
        self.max_force = float(max_force)
        self.planar = bool(planar)
        self.state_dim = (2 + 3 * self.n_links) if planar else (4 + 6 * self.n_links)
        #: Goal-conditioned observations (see :meth:`goal_conditioned`): designs a gain
        #: per target signs read from the observation's tail; None: the fixed target.
        self._design: Optional[Callable[[tuple[int, ...]], np.ndarray]] = None
        self._gains: dict[tuple[int, ...], np.ndarray] = {}

    def goal_conditioned(self, model: Any, Q: Optional[np.ndarray] = None, R: Optional[np.ndarray] = None) -> "LQRPolicy":
        """Reads the target from the observation's last ``n_links`` numbers (the
        ``goal_observation`` layout) and designs that target's gain on ``model`` (a
        ``ChainCart``, or a ``ChainCartConfig`` to design with its rig) the first time it
        is seen. Returns ``self``."""
        self._design = lambda signs: np.asarray(model.lqr_gain(list(signs), Q, R), dtype=np.float64)
        self._gains = {tuple(int(s) for s in self.target): self.gain}
        return self

    @property
    def obs_dim(self) -> int:
        """Length of the observations it takes: the state, plus the target's signs
        when goal-conditioned."""
        return self.state_dim + (self.n_links if self._design is not None else 0)

    @classmethod
    def from_model(
        cls,
        model: Any,
        target: Sequence[float],
        max_force: float,
        Q: Optional[np.ndarray] = None,
        R: Optional[np.ndarray] = None,
        planar: Optional[bool] = None,
    ) -> "LQRPolicy":
        """Gain from ``model.lqr_gain(target, Q, R)`` (defaults: the paper's weights)."""
        gain = model.lqr_gain(list(target), Q, R)
        return cls(gain, target, max_force, model.planar if planar is None else planar)

    @classmethod
    def from_env(
        cls, env: Any, Q: Optional[np.ndarray] = None, R: Optional[np.ndarray] = None, *, oracle: bool = False
    ) -> "LQRPolicy":
        """For a ``ChainCartEnv``, its vector envs or SB3 VecEnv (anything exposing the
        config through ``unwrapped`` or ``config``).

        By default the gain is designed on the env's nominal ``model``, what a control
        engineer knows: the honest baseline when the true system differs (``params``,
        ``mismatch``, ``randomize``). ``oracle=True`` returns an
        :class:`OracleLQRPolicy` instead, which designs one gain per env on that env's
        true parameters of the current episode (an upper bound no real controller
        reaches)."""
        config = config_of(env)
        if oracle:
            return OracleLQRPolicy(env, Q, R)
        designer = config if config.has_rig_effects else nominal_model_of(env)
        policy = cls.from_model(designer, config.target_signs, config.command_scale, Q, R, planar=config.planar)
        return policy.goal_conditioned(designer, Q, R) if config.goal_observation else policy

    def forces(self, observation: np.ndarray) -> np.ndarray:
        """Unsaturated commands (newtons in force actuation; m/s^2 or V on a rig that
        commands the cart's acceleration or a motor's voltage), shape (N, 2) for
        spatial, (N, 1) for planar."""
        obs = np.asarray(observation, dtype=np.float64)
        batch = np.atleast_2d(obs)
        if batch.ndim != 2 or batch.shape[1] != self.obs_dim:
            raise ValueError(
                f"observation has shape {obs.shape}: expected ({self.obs_dim},) or (N, {self.obs_dim})"
            )
        if not np.all(np.isfinite(batch)):
            raise ValueError("observation has non-finite entries: expected finite states")
        states = batch[:, : self.state_dim]
        states = _planar_to_spatial(states, self.n_links) if self.planar else states
        if self._design is None:
            u = -lqr_coordinates(states, self.target) @ self.gain.T
        else:
            u = np.zeros((batch.shape[0], 2))
            signs = np.where(batch[:, self.state_dim :] < 0, -1, 1)
            for row, target in enumerate(map(tuple, signs.tolist())):
                gain = self._gains.get(target)
                if gain is None:
                    gain = self._gains[target] = self._design(target)
                u[row] = -lqr_coordinates(states[row : row + 1], np.asarray(target, dtype=np.float64)) @ gain.T
        return u[:, :1] if self.planar else u

    def predict(
        self,
        observation: np.ndarray,
        state: Optional[Any] = None,
        episode_start: Optional[np.ndarray] = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Optional[Any]]:
        """Actions in the env's normalised space, clipped to [-1, 1]; same batch shape as the input."""
        single = np.asarray(observation).ndim == 1
        actions = np.clip(self.forces(observation) / self.max_force, -1.0, 1.0).astype(np.float32)
        return (actions[0] if single else actions), state

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        return self.predict(observation)[0]


def _true_param_rows(env: Any) -> list[dict[str, Any]]:
    """The current true parameters of each env of ``env`` (one dict per env): a
    single, vector or SB3 env, or a native ``_core.EnvBatch``."""
    base = getattr(env, "unwrapped", env)
    if hasattr(base, "get_attr") and hasattr(base, "env_method"):  # an SB3 VecEnv
        return list(base.get_attr("true_params"))
    params = base.param_arrays() if hasattr(base, "param_arrays") else base.true_params
    cart = np.atleast_1d(params["cart_mass"])
    if np.ndim(params["cart_mass"]) == 0:  # a single env
        return [params]
    return [
        {
            "cart_mass": float(cart[i]),
            "link_masses": list(params["link_masses"][i]),
            "link_lengths": list(params["link_lengths"][i]),
            "gravity": float(params["gravity"][i]),
        }
        for i in range(cart.shape[0])
    ]


class OracleLQRPolicy(LQRPolicy):
    """LQR with perfect knowledge of the true system: before each action it reads the
    true parameters of every env of ``env`` (single, vector or SB3 VecEnv) for the
    current episode and uses a gain designed on them (cached per parameter set). Its
    observations must come from that env, one row per env in env order. With no
    parameter gap it acts exactly as :meth:`LQRPolicy.from_env`.
    """

    def __init__(self, env: Any, Q: Optional[np.ndarray] = None, R: Optional[np.ndarray] = None) -> None:
        from chaincart_env.model import ChainCart

        base = getattr(env, "unwrapped", env)
        config = base.config
        self._env, self._Q, self._R = env, Q, R
        if config.has_rig_effects:  # the true parameters with the rig (the same for every env)
            self._make_model: Callable[[dict[str, Any]], Any] = lambda p: config.replace(
                cart_mass=float(p["cart_mass"]), link_masses=tuple(map(float, p["link_masses"])),
                link_lengths=tuple(map(float, p["link_lengths"])), gravity=float(p["gravity"]),
            )
            nominal = config.lqr_gain(config.target_signs, Q, R)
        else:
            self._make_model = lambda p: ChainCart(
                config.n_links, p["cart_mass"], p["link_masses"], p["link_lengths"], p["gravity"], config.planar
            )
            nominal = base.model.lqr_gain(list(config.target_signs), Q, R)
        self._gains_by_params: dict[tuple[float, ...], np.ndarray] = {}
        super().__init__(nominal, config.target_signs, config.command_scale, config.planar)

    def _gain(self, params: dict[str, Any]) -> np.ndarray:
        key = (
            float(params["cart_mass"]),
            *map(float, params["link_masses"]),
            *map(float, params["link_lengths"]),
            float(params["gravity"]),
        )
        gain = self._gains_by_params.get(key)
        if gain is None:
            gain = np.asarray(self._make_model(params).lqr_gain(list(self.target), self._Q, self._R))
            self._gains_by_params[key] = gain
        return gain

    def bind(self, env: Any) -> None:
        """Reads the true parameters from ``env`` from now on (another env of the same
        config, or the native batch whose observations the policy receives)."""
        self._env = env

    def gains(self) -> np.ndarray:
        """The gain of each env for its current episode, shape ``(num_envs, 2, 4 + 4n)``."""
        return np.stack([self._gain(p) for p in _true_param_rows(self._env)])

    def forces(self, observation: np.ndarray) -> np.ndarray:
        """The feedback forces for ``observation`` (one state or a batch), each env with
        the gain designed on its current true parameters (:meth:`gains`)."""
        obs = np.asarray(observation, dtype=np.float64)
        batch = np.atleast_2d(obs)
        gains = self.gains()
        if batch.ndim != 2 or batch.shape != (gains.shape[0], self.state_dim):
            raise ValueError(
                f"observation has shape {obs.shape}: expected one row of {self.state_dim} per env "
                f"({gains.shape[0]} envs)"
            )
        if not np.all(np.isfinite(batch)):
            raise ValueError("observation has non-finite entries: expected finite states")
        states = _planar_to_spatial(batch, self.n_links) if self.planar else batch
        z = lqr_coordinates(states, self.target.tolist())
        u = -np.einsum("nij,nj->ni", gains, z)
        return u[:, :1] if self.planar else u
