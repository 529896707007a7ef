"""ChainCart from Python: shapes, errors, and agreement with simple physics."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from paper_dense import elwm_derivative

from chaincart_env import ChainCart, ChainCartError, _core


def random_state(model: ChainCart, rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
    """A random state on the constraint manifold (unit q_i, w_i normal to q_i)."""
    n = model.n_links
    if model.planar:
        angles = rng.uniform(-np.pi, np.pi, n)
        q = np.stack([np.sin(angles), np.cos(angles)], axis=1)
        return np.concatenate([rng.normal(0, scale, 2), q.ravel(), rng.normal(0, scale, n)])
    q = rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.normal(0, scale, (n, 3))
    w -= np.sum(w * q, axis=1, keepdims=True) * q
    return np.concatenate([rng.normal(0, scale, 4), q.ravel(), w.ravel()])


def test_defaults_are_the_papers_system_and_params_round_trip() -> None:
    m = ChainCart(5)
    assert m.params == dict(
        n_links=5, cart_mass=0.5, link_masses=(0.1,) * 5, link_lengths=(0.1,) * 5, gravity=9.81, planar=False
    )
    assert (m.state_dim, m.force_dim) == (34, 2)
    p = ChainCart(3, 1.0, [0.1, 0.2, 0.3], 0.5, planar=True)
    assert (p.state_dim, p.force_dim, p.link_masses, p.link_lengths) == (11, 1, (0.1, 0.2, 0.3), (0.5,) * 3)
    assert ChainCart(**p.params).params == p.params


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(n_links=0), "n_links = 0: expected at least one link"),
        (dict(n_links=-2), "n_links = -2"),
        (dict(n_links=2, link_masses=[0.1, -1.0]), "link_masses[1] = -1: expected a finite number > 0"),
        (dict(n_links=2, link_lengths=[0.1, 0.2, 0.3]), "link_lengths has length 3, expected 2"),
        (dict(n_links=1, cart_mass=float("nan")), "cart_mass = NaN"),
        (dict(n_links=1, gravity=0.0), "gravity = 0"),
        (dict(n_links=1, link_masses="heavy"), "link_masses = heavy: expected a number or a sequence"),
    ],
)
def test_bad_parameters_raise_chaincart_errors_naming_them(kwargs: dict, message: str) -> None:
    with pytest.raises(ChainCartError, match=None) as e:
        ChainCart(**kwargs)
    assert message in str(e.value)
    assert isinstance(e.value, ValueError)


def test_bad_inputs_raise_clear_errors() -> None:
    m = ChainCart(2)
    y = m.equilibrium("hanging")
    with pytest.raises(ChainCartError, match=r"state has shape \(3,\), expected \(16,\)"):
        m.derivative([0.0, 0.0, 0.0], [0.0, 0.0])
    with pytest.raises(ChainCartError, match=r"force has shape \(1,\), expected \(2,\)"):
        m.step(y, [0.0], 0.01)
    bad = y.copy()
    bad[5] = np.inf
    with pytest.raises(ChainCartError, match=r"state\[5\] = inf: expected a finite number"):
        m.energy(bad)
    with pytest.raises(ChainCartError, match='unknown integrator "euler"'):
        m.step(y, [0.0, 0.0], 0.01, integrator="euler")
    with pytest.raises(ChainCartError, match="dt = -0.1"):
        m.step(y, [0.0, 0.0], -0.1)
    with pytest.raises(ChainCartError, match="substeps = 0"):
        m.step(y, [0.0, 0.0], 0.1, substeps=0)
    with pytest.raises(ChainCartError, match=r"forces has shape \(4,\), expected \(steps, 2\)"):
        m.simulate(y, np.zeros(4), 0.01)
    with pytest.raises(ChainCartError, match=r"s\[1\] = 0.5: expected \+1"):
        m.equilibrium([1, 0.5])
    with pytest.raises(ChainCartError, match="unknown equilibrium \"sideways\""):
        m.equilibrium("sideways")
    with pytest.raises(ChainCartError, match="s has length 3, expected 2"):
        m.errors(y, [1, 1, 1])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 6))
def test_derivative_matches_the_papers_dense_equations(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    masses, lengths = rng.uniform(0.05, 2.0, n), rng.uniform(0.05, 2.0, n)
    m = ChainCart(n, rng.uniform(0.1, 3.0), masses, lengths, 9.81)
    y = random_state(m, rng)
    u = rng.normal(0, 5, 2)
    expected = elwm_derivative(m.cart_mass, masses, lengths, 9.81, y, u)
    got = m.derivative(y, u)
    assert np.allclose(got, expected, rtol=1e-9, atol=1e-9 * (1 + np.abs(expected).max()))


@pytest.mark.parametrize("planar", [False, True])
def test_every_equilibrium_is_a_fixed_point(planar: bool) -> None:
    m = ChainCart(3, 1.0, 0.2, 0.4, planar=planar)
    for k in range(8):
        s = [(-1.0 if (k >> i) & 1 else 1.0) for i in range(3)]
        y = m.equilibrium(s)
        assert np.all(m.derivative(y, np.zeros(m.force_dim)) == 0.0)
        assert np.array_equal(m.step(y, np.zeros(m.force_dim), 0.05, "rk4", 4), y)
        assert m.errors(y, s) == (0.0, 0.0)
        # Potential energy: each mass at height -(sum of s_a l_a) below the cart.
        heights = np.cumsum(np.array(s) * 0.4)
        assert m.energy(y) == pytest.approx(-0.2 * 9.81 * heights.sum(), abs=1e-12)


@pytest.mark.parametrize("integrator", ["rk4", "rkmk4", "variational"])
def test_uncontrolled_motion_conserves_energy_and_momentum(integrator: str) -> None:
    m = ChainCart(3, 0.5, 0.1, 0.1)
    rng = np.random.default_rng(1)
    y0 = random_state(m, rng, scale=0.5)
    traj = m.simulate(y0, np.zeros((500, 2)), 1e-3, integrator)
    assert traj.shape == (501, m.state_dim)
    energies = np.array([m.energy(y) for y in traj])
    # Fourth-order methods at 1 ms keep energy to ~1e-7 here; the second-order
    # variational integrator's (bounded, oscillating) error is ~1e-5.
    tolerance = 1e-4 if integrator == "variational" else 1e-5
    assert np.abs(energies - energies[0]).max() < tolerance * max(1.0, abs(energies[0]))
    momenta = np.array([m.horizontal_momentum(y) for y in traj])
    # The variational integrator keeps momentum to round-off; the others to their accuracy.
    assert np.abs(momenta - momenta[0]).max() < (1e-10 if integrator == "variational" else 1e-6)
    assert max(max(m.residuals(y)) for y in traj) < 1e-9
    # The motion is not trivial: the links moved.
    assert np.abs(traj[-1] - traj[0]).max() > 1e-2


def test_a_push_adds_its_work_to_the_energy() -> None:
    m = ChainCart(2, 1.0, 0.2, 0.5)
    y0 = m.equilibrium("hanging")
    f = np.array([2.0, -1.0])
    traj = m.simulate(y0, np.tile(f, (200, 1)), 1e-3, "rk4", 4)
    cart = traj[:, 0:2]
    work = float(f @ (cart[-1] - cart[0]))
    assert m.energy(traj[-1]) - m.energy(y0) == pytest.approx(work, rel=1e-6)
    # Momentum grows by the impulse.
    impulse = f * 0.2
    assert np.allclose(m.horizontal_momentum(traj[-1]), impulse, rtol=1e-9)


def test_planar_model_is_the_spatial_model_in_the_plane() -> None:
    planar, spatial = ChainCart(3, 1.0, 0.1, 0.3, planar=True), ChainCart(3, 1.0, 0.1, 0.3)
    rng = np.random.default_rng(5)
    y = random_state(planar, rng, 0.5)
    forces = rng.normal(0, 1, (50, 1))
    a = planar.simulate(y, forces, 0.01)
    b = spatial.simulate(planar.to_spatial(y), np.concatenate([forces, np.zeros((50, 1))], axis=1), 0.01)
    for ya, yb in zip(a, b):
        assert np.allclose(planar.to_spatial(ya), yb, atol=1e-12)
        assert np.allclose(planar.from_spatial(yb), ya, atol=1e-12)


def test_simulate_with_a_policy_equals_simulate_with_its_forces() -> None:
    m = ChainCart(2, planar=True)
    y0 = m.equilibrium("inverted")
    policy = lambda t, y: np.array([np.sin(3 * t) - 2.0 * y[0]])  # noqa: E731
    traj = m.simulate(y0, policy, 0.01, "rkmk4", 2, steps=40)
    forces = np.array([policy(k * 0.01, traj[k]) for k in range(40)])
    assert np.array_equal(m.simulate(y0, forces, 0.01, "rkmk4", 2), traj)
    with pytest.raises(ChainCartError, match="steps="):
        m.simulate(y0, policy, 0.01)


def test_numerical_failure_raises_naming_the_step() -> None:
    m = ChainCart(2)
    y = m.equilibrium("inverted")
    y[4:7] = [np.sin(0.3), 0.0, -np.cos(0.3)]
    with pytest.raises(ChainCartError, match="numerical failure at t = .* s: .* at step"):
        m.simulate(y, np.full((50, 2), 1e6), 5.0, "lie_euler")


def test_errors_follow_the_papers_definition() -> None:
    m = ChainCart(2)
    rng = np.random.default_rng(2)
    y = random_state(m, rng)
    q, w = y[4:10].reshape(2, 3), y[10:16].reshape(2, 3)
    s = np.array([1.0, -1.0])
    e3 = np.array([0.0, 0.0, 1.0])
    e_q = sum(np.linalg.norm(q[i] - s[i] * e3) for i in range(2))
    e_w = sum(np.linalg.norm(w[i]) for i in range(2))
    assert np.allclose(m.errors(y, s), (e_q, e_w), rtol=1e-14)
    assert m.errors(y, s) == m.errors(y, (1, -1))
    assert m.residuals(y)[0] < 1e-15


def test_paper_initial_conditions_and_named_targets() -> None:
    ic1 = _core.paper_initial_condition("paper-fig1")
    assert np.array_equal(ic1, _core.paper_initial_condition("paper-fig2"))
    assert np.array_equal(ic1[:4], [0.2, 0.1, 0.0, -0.1])
    assert np.allclose(ic1[4 + 12 : 4 + 15], [np.sin(np.radians(1)), 0, -np.cos(np.radians(1))])
    ic3 = _core.paper_initial_condition("paper-fig3")
    assert np.allclose(ic3[4 + 3 : 4 + 6], -np.array([0, np.sin(np.radians(4)), np.cos(np.radians(4))]))
    assert _core.target_signs("paper-fig3", 5) == [-1, -1, -1, 1, 1]
    assert _core.target_signs("folded_up", 5) == [-1, 1, -1, 1, -1] == _core.target_signs("paper-fig1", 5)
    with pytest.raises(ChainCartError, match="paper figure"):
        _core.paper_initial_condition("paper-fig4")


def test_lqr_gain_shape_and_errors() -> None:
    m = ChainCart(2)
    k = m.lqr_gain("inverted")
    assert k.shape == (2, 12) and np.all(np.isfinite(k))
    # Weights of the wrong size are refused by the core.
    with pytest.raises(ChainCartError):
        m.lqr_gain("inverted", np.eye(3))
    # The closed loop of the spatial linear model is stable: simulate it from a tilt
    # with u = -K z (z in the paper's ordering) and check it comes back.
    y = m.equilibrium("inverted")
    y[4:7] = [np.sin(0.05), 0.0, -np.cos(0.05)]
    s = np.array([-1.0, -1.0])

    def policy(t: float, state: np.ndarray) -> np.ndarray:
        q = state[4:10].reshape(2, 3)
        w = state[10:16].reshape(2, 3)
        xi = np.stack([-q[:, 1], q[:, 0]], axis=1) * s[:, None]
        z = np.concatenate([state[0:2], xi.ravel(), state[2:4], w[:, :2].ravel()])
        return -k @ z

    traj = m.simulate(y, policy, 0.01, steps=800)
    assert m.errors(traj[-1], s)[0] < 1e-3 < m.errors(traj[0], s)[0]


def test_models_pickle_and_copy() -> None:
    m = ChainCart(2, 1.0, [0.1, 0.2], 0.3, planar=True)
    for clone in (pickle.loads(pickle.dumps(m)), copy.deepcopy(m)):
        assert type(clone) is ChainCart
        assert clone.params == m.params
    assert "ChainCart(n_links=2" in repr(m)
