"""The paper's chain pendulum on a cart as a MuJoCo model, for side-by-side benchmarks.

The cart is a body on two slide joints driven by motors; each link is a body on a
ball joint whose mass sits at its outboard end (an ``<inertial>`` point mass, with a
rotational inertia of 1e-14 kg m^2: small enough that the motion matches the
point-mass model, large enough for MuJoCo's inertia checks). Contacts are off.
MuJoCo's gravity is set to ``+g`` along its z axis, so MuJoCo's z *is* the paper's
e3 and no frame change is needed.

State mapping (ours -> MuJoCo): each link's world orientation is the shortest
rotation taking e3 to q_i, and its world angular velocity is w_i (no spin about the
link, which a point mass cannot feel); ball joints store the rotation and angular
velocity relative to the parent body, in the child's frame.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

LINK_INERTIA = 1e-14

MUJOCO_INTEGRATORS = {"euler": "Euler", "rk4": "RK4", "implicitfast": "implicitfast"}


def build_mjcf(
    cart_mass: float,
    link_masses: Sequence[float],
    link_lengths: Sequence[float],
    gravity: float = 9.81,
    timestep: float = 1e-3,
    integrator: str = "rk4",
) -> str:
    """MJCF text of the chain on a cart."""
    if integrator not in MUJOCO_INTEGRATORS:
        raise ValueError(f"integrator={integrator!r}: expected one of {sorted(MUJOCO_INTEGRATORS)}")
    inertia = f"{LINK_INERTIA:g} {LINK_INERTIA:g} {LINK_INERTIA:g}"
    bodies = []
    for i, (m, length) in enumerate(zip(link_masses, link_lengths)):
        # Link i+1 hangs from the outboard end of link i (or from the cart).
        pos = "0 0 0" if i == 0 else f"0 0 {link_lengths[i - 1]:.17g}"
        bodies.append(
            f'<body name="link{i + 1}" pos="{pos}">'
            f'<joint name="ball{i + 1}" type="ball" damping="0" armature="0"/>'
            f'<inertial pos="0 0 {length:.17g}" mass="{m:.17g}" diaginertia="{inertia}"/>'
        )
    chain = "".join(bodies) + "</body>" * len(bodies)
    return f"""<mujoco model="chain_pendulum_on_cart">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep:.17g}" gravity="0 0 {gravity:.17g}" integrator="{MUJOCO_INTEGRATORS[integrator]}">
    <flag contact="disable" energy="enable"/>
  </option>
  <worldbody>
    <body name="cart">
      <joint name="cart_x" type="slide" axis="1 0 0" damping="0" armature="0"/>
      <joint name="cart_y" type="slide" axis="0 1 0" damping="0" armature="0"/>
      <inertial pos="0 0 0" mass="{cart_mass:.17g}" diaginertia="{inertia}"/>
      {chain}
    </body>
  </worldbody>
  <actuator>
    <motor joint="cart_x" gear="1"/>
    <motor joint="cart_y" gear="1"/>
  </actuator>
</mujoco>"""


def _hat(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rotation_from_e3(q: np.ndarray) -> np.ndarray:
    """Shortest rotation taking e3 to the unit vector q."""
    e3 = np.array([0.0, 0.0, 1.0])
    axis = np.cross(e3, q)
    s, c = np.linalg.norm(axis), float(q @ e3)
    if s < 1e-15:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = _hat(axis / s)
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def _quat_from_matrix(r: np.ndarray) -> np.ndarray:
    import mujoco

    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, r.reshape(-1))
    return quat


def state_to_mujoco(n_links: int, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(qpos, qvel) of the MuJoCo model for one of our spatial states."""
    state = np.asarray(state, dtype=float)
    q = state[4 : 4 + 3 * n_links].reshape(n_links, 3)
    w = state[4 + 3 * n_links :].reshape(n_links, 3)
    qpos = np.empty(2 + 4 * n_links)
    qvel = np.empty(2 + 3 * n_links)
    qpos[:2], qvel[:2] = state[:2], state[2:4]
    parent_rot, parent_w = np.eye(3), np.zeros(3)
    for i in range(n_links):
        rot = _rotation_from_e3(q[i] / np.linalg.norm(q[i]))
        qpos[2 + 4 * i : 6 + 4 * i] = _quat_from_matrix(parent_rot.T @ rot)
        qvel[2 + 3 * i : 5 + 3 * i] = rot.T @ (w[i] - parent_w)
        parent_rot, parent_w = rot, w[i]
    return qpos, qvel


def link_kinematics(n_links: int, qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """Our (q_i, w_i) from a MuJoCo state, plus each link's world rotation."""
    import mujoco

    q = np.empty((n_links, 3))
    w = np.empty((n_links, 3))
    rots = []
    rot, omega = np.eye(3), np.zeros(3)
    for i in range(n_links):
        local = np.empty(9)
        mujoco.mju_quat2Mat(local, qpos[2 + 4 * i : 6 + 4 * i])
        rot = rot @ local.reshape(3, 3)
        omega = omega + rot @ qvel[2 + 3 * i : 5 + 3 * i]
        q[i], w[i] = rot[:, 2], omega
        rots.append(rot)
    return q, w, rots


def mujoco_to_state(n_links: int, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
    """Our spatial state from a MuJoCo state (spins projected tangent to the links)."""
    q, w, _ = link_kinematics(n_links, qpos, qvel)
    w = w - (np.sum(w * q, axis=1) / np.sum(q * q, axis=1))[:, None] * q
    return np.concatenate([qpos[:2], qvel[:2], q.reshape(-1), w.reshape(-1)])


def point_accelerations(n_links: int, qpos: np.ndarray, qvel: np.ndarray, qacc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cart acceleration and link accelerations qdd_i = d^2 q_i / dt^2 from MuJoCo's qacc.

    These do not depend on how fast a link spins about itself, so they compare
    directly with ours whatever spin MuJoCo carries."""
    q, _, rots = link_kinematics(n_links, qpos, qvel)
    qdd = np.empty((n_links, 3))
    omega, alpha = np.zeros(3), np.zeros(3)
    for i in range(n_links):
        rel = rots[i] @ qvel[2 + 3 * i : 5 + 3 * i]
        rel_dot = rots[i] @ qacc[2 + 3 * i : 5 + 3 * i]
        new_omega = omega + rel
        # d/dt (R nu) = omega x (R nu) + R nu_dot, with R's own rate omega_i.
        alpha = alpha + np.cross(new_omega, rel) + rel_dot
        omega = new_omega
        qdd[i] = np.cross(alpha, q[i]) + np.cross(omega, np.cross(omega, q[i]))
    return qacc[:2].copy(), qdd


def chain_point_accelerations(derivative: np.ndarray, state: np.ndarray, n_links: int) -> tuple[np.ndarray, np.ndarray]:
    """Cart acceleration and qdd_i from one of our state derivatives:
    ``qdd_i = wdot_i x q_i + w_i x qdot_i``."""
    q = state[4 : 4 + 3 * n_links].reshape(n_links, 3)
    w = state[4 + 3 * n_links :].reshape(n_links, 3)
    qdot = derivative[4 : 4 + 3 * n_links].reshape(n_links, 3)
    wdot = derivative[4 + 3 * n_links :].reshape(n_links, 3)
    return derivative[2:4].copy(), np.cross(wdot, q) + np.cross(w, qdot)


def random_spatial_state(n_links: int, rng: np.random.Generator) -> np.ndarray:
    """A random spatial state on the constraints: unit q_i, w_i tangent to q_i."""
    q = rng.normal(size=(n_links, 3))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.normal(size=(n_links, 3))
    w -= np.sum(w * q, axis=1, keepdims=True) * q
    return np.concatenate([rng.normal(size=2), rng.normal(size=2), q.reshape(-1), w.reshape(-1)])


def mujoco_accelerations(mj_model: object, data: object, n_links: int, state: np.ndarray, force: np.ndarray) -> np.ndarray:
    """MuJoCo's cart and link-point accelerations ``[xdd(2), qdd_1..qdd_n]`` at ``state``."""
    import mujoco

    data.qpos[:], data.qvel[:] = state_to_mujoco(n_links, state)  # type: ignore[attr-defined]
    data.ctrl[:] = force  # type: ignore[attr-defined]
    mujoco.mj_forward(mj_model, data)
    xdd, qdd = point_accelerations(n_links, data.qpos, data.qvel, data.qacc)  # type: ignore[attr-defined]
    return np.concatenate([xdd, qdd.reshape(-1)])


def acceleration_mismatch(chain: object, mj_model: object, states: np.ndarray, forces: np.ndarray) -> float:
    """Largest relative difference ``|a_mujoco - a_ours| / |a_ours|`` over ``states``
    (``a`` the stacked cart and link-point accelerations); ``chain`` is a spatial
    :class:`chaincart_env.ChainCart` with the parameters ``mj_model`` was built from."""
    import mujoco

    n = chain.n_links  # type: ignore[attr-defined]
    data = mujoco.MjData(mj_model)
    worst = 0.0
    for state, force in zip(states, forces):
        xdd, qdd = chain_point_accelerations(chain.derivative(state, force), state, n)  # type: ignore[attr-defined]
        ours = np.concatenate([xdd, qdd.reshape(-1)])
        theirs = mujoco_accelerations(mj_model, data, n, state, force)
        worst = max(worst, float(np.linalg.norm(theirs - ours) / np.linalg.norm(ours)))
    return worst
