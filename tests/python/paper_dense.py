"""The paper's eq. (ELwm) transcribed in NumPy: an oracle independent of the Rust code."""

from __future__ import annotations

import numpy as np


def hat(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def elwm_derivative(cart_mass, masses, lengths, gravity, state, force):
    """d/dt of [x, xdot, q_1..n, w_1..n] from the dense (2+3n) system of eq. (ELwm)."""
    masses, lengths = np.asarray(masses, float), np.asarray(lengths, float)
    n = len(masses)
    state = np.asarray(state, float)
    q = state[4 : 4 + 3 * n].reshape(n, 3)
    w = state[4 + 3 * n :].reshape(n, 3)
    outboard = np.cumsum(masses[::-1])[::-1]  # sum_{a>=i} m_a
    m0 = outboard * lengths  # M_0i (times C^T)
    mij = lambda i, j: outboard[max(i, j)] * lengths[i] * lengths[j]  # noqa: E731
    ct = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    e3 = np.array([0.0, 0.0, 1.0])
    dim = 2 + 3 * n
    a = np.zeros((dim, dim))
    b = np.zeros(dim)
    a[:2, :2] = (cart_mass + masses.sum()) * np.eye(2)
    b[:2] = force
    for j in range(n):
        a[:2, 2 + 3 * j : 5 + 3 * j] = -m0[j] * ct @ hat(q[j])
        b[:2] += m0[j] * (w[j] @ w[j]) * ct @ q[j]
    for i in range(n):
        r = slice(2 + 3 * i, 5 + 3 * i)
        a[r, :2] = m0[i] * hat(q[i]) @ ct.T
        b[r] = outboard[i] * gravity * lengths[i] * hat(q[i]) @ e3
        for j in range(n):
            c = slice(2 + 3 * j, 5 + 3 * j)
            if i == j:
                a[r, c] = mij(i, i) * np.eye(3)
            else:
                a[r, c] = -mij(i, j) * hat(q[i]) @ hat(q[j])
                b[r] += mij(i, j) * (w[j] @ w[j]) * hat(q[i]) @ q[j]
    sol = np.linalg.solve(a, b)
    out = np.empty_like(state)
    out[:2] = state[2:4]
    out[2:4] = sol[:2]
    out[4 : 4 + 3 * n] = np.cross(w, q).reshape(-1)
    out[4 + 3 * n :] = sol[2:]
    return out


def link_accelerations(state: np.ndarray, derivative: np.ndarray, n: int) -> np.ndarray:
    """qdd_i = wdot_i x q_i + w_i x (w_i x q_i)."""
    q = state[4 : 4 + 3 * n].reshape(n, 3)
    w = state[4 + 3 * n :].reshape(n, 3)
    wdot = derivative[4 + 3 * n :].reshape(n, 3)
    return np.cross(wdot, q) + np.cross(w, np.cross(w, q))
