"""The paper's analysis through the Python bindings, checked against independent
oracles: SciPy's Riccati solver and eigen-solvers, a finite-difference linearisation
of ``ChainCart.derivative`` written here, the paper's energy formula, and the paper's
eq. (u) written out with ``np.cross`` for the LQR policy."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import scipy.linalg as sla

import chaincart_env  # noqa: F401  (registers ChainCart-v0)
from chaincart_env import ChainCart, ChainCartError, ChainCartVecEnv, LQRPolicy

PAPER = ChainCart(5)
PAPER_EQUILIBRIA = PAPER.equilibria()
RIDDLE_TOLERANCE = 1e-8


def paper_weights(s: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The paper's weights: hanging Q = diag[8 I2, I_2n, 8 I2, I_2n]; others Q = diag[I2, 8 I_2n, I2, 8 I_2n]; R = I2."""
    n = len(s)
    cart, links = (8.0, 1.0) if all(v == 1 for v in s) else (1.0, 8.0)
    block = [cart] * 2 + [links] * (2 * n)
    return np.diag(block + block), np.eye(2)


def scipy_gain(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray) -> np.ndarray:
    X = sla.solve_continuous_are(A, B, Q, R)
    return np.linalg.solve(R, B.T @ X)


def relative_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def random_chain(rng: np.random.Generator) -> tuple[ChainCart, list[int]]:
    """Masses and lengths spread over a factor of ~40, random n and s."""
    n = int(rng.integers(1, 6))
    masses = np.exp(rng.uniform(np.log(0.05), np.log(2.0), n))
    lengths = np.exp(rng.uniform(np.log(0.05), np.log(1.0), n))
    cart = float(np.exp(rng.uniform(np.log(0.1), np.log(5.0))))
    model = ChainCart(n, cart, masses.tolist(), lengths.tolist())
    return model, [int(v) for v in rng.choice([-1, 1], n)]


# -- Riccati / LQR gain ----------------------------------------------------------------


@pytest.mark.parametrize("s", PAPER_EQUILIBRIA, ids=lambda s: "".join("+" if v > 0 else "-" for v in s))
def test_gain_matches_scipy_at_every_paper_equilibrium(s: list[int]) -> None:
    # Measured: relative errors 1e-12..3e-11 over the 32, although SciPy's own X has
    # Riccati residuals up to ~1e-3 ||Q|| (X has condition numbers up to 3e8): the gain
    # is far better conditioned than X, so no equilibrium needs the residual fallback.
    A, B = PAPER.linearize(s)
    Q, R = paper_weights(s)
    K = PAPER.lqr_gain(s)
    assert K.shape == (2, 24)
    assert relative_error(K, scipy_gain(A, B, Q, R)) <= RIDDLE_TOLERANCE
    closed_loop = np.linalg.eigvals(A - B @ K)
    assert closed_loop.real.max() < 0, closed_loop


def gain_fixed_point_residual(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, K: np.ndarray) -> tuple[float, float]:
    """How far K is from optimal without knowing its X: the closed-loop cost matrix P_K
    ((A - BK)^T P + P (A - BK) + Q + K^T R K = 0) gives the Newton-Kleinman update
    R^-1 B^T P_K, which equals K exactly at the LQR gain. Returns (relative residual,
    trace(P_K))."""
    closed = A - B @ K
    P = sla.solve_continuous_lyapunov(closed.T, -(Q + K.T @ R @ K))
    return relative_error(np.linalg.solve(R, B.T @ P), K), float(np.trace(P))


#: Above this condition number of the Riccati solution X, 1e-8 agreement is beyond
#: what either solver can promise (forward error ~ cond(X) * eps).
WELL_CONDITIONED = 1e10


def test_gain_matches_scipy_for_random_masses_and_lengths() -> None:
    # Measured over these 25 chains: 24 agree to <= 3e-10. One (n = 5, s = (-1,-1,1,-1,-1),
    # tip masses 0.06 and 0.07 kg against 0.55 kg inboard) agrees only to 4e-8: its
    # weakest mode barely moves the cart (PBH margin 7e-6), the gain reaches 4e6 and
    # cond(X) = 3e12, and both solvers' gains have Newton-Kleinman residuals ~1e-8
    # (SciPy's 8e-9, ours 1.5e-8). There the check is that residual and the cost.
    rng = np.random.default_rng(20240604)
    ill_conditioned = 0
    for _ in range(25):
        model, s = random_chain(rng)
        A, B = model.linearize(s)
        Q, R = paper_weights(s)
        K = model.lqr_gain(s)
        X = sla.solve_continuous_are(A, B, Q, R)
        K_scipy = np.linalg.solve(R, B.T @ X)
        assert np.linalg.eigvals(A - B @ K).real.max() < 0
        if np.linalg.cond(X) <= WELL_CONDITIONED:
            assert relative_error(K, K_scipy) <= RIDDLE_TOLERANCE, (model.params, s)
            continue
        ill_conditioned += 1
        ours, our_cost = gain_fixed_point_residual(A, B, Q, R, K)
        theirs, their_cost = gain_fixed_point_residual(A, B, Q, R, K_scipy)
        assert ours <= 10 * theirs + 1e-12, (model.params, s, ours, theirs)
        assert abs(our_cost - their_cost) <= 1e-6 * their_cost
    assert ill_conditioned <= 2


def test_custom_weights_match_scipy() -> None:
    rng = np.random.default_rng(7)
    model, s = ChainCart(3, 0.8, [0.2, 0.1, 0.3], [0.3, 0.2, 0.25]), [-1, 1, -1]
    A, B = model.linearize(s)
    N = A.shape[0]
    F = rng.normal(size=(N, N))
    Q = F @ F.T + 0.1 * np.eye(N)
    G = rng.normal(size=(2, 2))
    R = G @ G.T + 0.5 * np.eye(2)
    K = model.lqr_gain(s, Q, R)
    assert relative_error(K, scipy_gain(A, B, Q, R)) <= RIDDLE_TOLERANCE
    # Weights matter: the paper's default gives another gain.
    assert relative_error(model.lqr_gain(s), K) > 1e-2
    # Only R given: Q stays the paper's.
    assert relative_error(model.lqr_gain(s, None, 4 * np.eye(2)), scipy_gain(A, B, paper_weights(s)[0], 4 * np.eye(2))) <= RIDDLE_TOLERANCE


def _nan_q() -> np.ndarray:
    q = np.eye(12)
    q[3, 3] = np.nan
    return q


@pytest.mark.parametrize(
    "Q, R, message",
    [
        (np.eye(3), None, r"Q is 3x3, expected 12x12"),
        (np.ones(12), None, r"Q has shape \(12,\), expected a 2-D matrix"),
        (np.eye(12) + np.triu(np.ones((12, 12)), 1), None, r"Q is not symmetric: Q\[0, 1\] = 1 but Q\[1, 0\] = 0"),
        (-np.eye(12), None, r"Q has eigenvalue -1.*positive semi-definite"),
        (_nan_q(), None, r"Q\[3, 3\] = NaN: expected a finite number"),
        (None, np.eye(3), r"R is 3x3, expected 2x2"),
        (None, np.zeros((2, 2)), r"R has eigenvalue 0.*positive definite"),
        (None, np.array([[1.0, 2.0], [0.0, 1.0]]), r"R is not symmetric"),
        (None, np.array([[1.0, np.inf], [np.inf, 1.0]]), r"R\[\d, \d\] = inf: expected a finite number"),
        ("abc", None, r"Q = abc: expected a 2-D matrix of numbers"),
        (None, [[1.0], [2.0, 3.0]], r"R = .*: expected a 2-D matrix of numbers"),
    ],
    ids=["Q-shape", "Q-1d", "Q-asymmetric", "Q-not-psd", "Q-nan", "R-shape", "R-singular", "R-asymmetric", "R-inf",
         "Q-text", "R-ragged"],
)
def test_bad_weights_are_refused_with_a_clear_message(Q: object, R: object, message: str) -> None:
    with pytest.raises(ChainCartError, match=message):
        ChainCart(2).lqr_gain("inverted", Q, R)


def test_weights_without_a_stabilising_solution_are_refused() -> None:
    # Q = 0 at the hanging equilibrium: the undamped pendulum modes are unobservable
    # and marginal, so (A, Q) is not detectable and no stabilising solution exists.
    with pytest.raises(ChainCartError, match="no stabilising Riccati solution.*detectable"):
        ChainCart(2).lqr_gain("hanging", np.zeros((12, 12)))


# -- linearisation -------------------------------------------------------------------


def state_from_local(z: np.ndarray, s: list[int]) -> np.ndarray:
    """An exact chart around equilibrium s: z = [x, p_1..p_n, xdot, c_1..c_n] with
    p_i = C^T (s_i e3 x q_i) (q_i on the hemisphere around s_i e3) and c_i = C^T w_i
    (w_i . q_i = 0 fixes the third component)."""
    n = len(s)
    x, p, xdot, c = z[0:2], z[2 : 2 + 2 * n].reshape(n, 2), z[2 + 2 * n : 4 + 2 * n], z[4 + 2 * n :].reshape(n, 2)
    q = np.empty((n, 3))
    w = np.empty((n, 3))
    for i, si in enumerate(s):
        # s e3 x q = s (-q_y, q_x, 0)
        q[i, 0], q[i, 1] = si * p[i, 1], -si * p[i, 0]
        q[i, 2] = si * np.sqrt(1.0 - q[i, 0] ** 2 - q[i, 1] ** 2)
        w[i, :2] = c[i]
        w[i, 2] = -(c[i] @ q[i, :2]) / q[i, 2]
    return np.concatenate([x, xdot, q.ravel(), w.ravel()])


def local_rates(model: ChainCart, s: list[int], state: np.ndarray, force: np.ndarray) -> np.ndarray:
    """d/dt of the chart coordinates along the nonlinear flow (from ``derivative``)."""
    n = len(s)
    rate = model.derivative(state, force)
    qdot = rate[4 : 4 + 3 * n].reshape(n, 3)
    wdot = rate[4 + 3 * n :].reshape(n, 3)
    e3 = np.array([0.0, 0.0, 1.0])
    pdot = np.array([si * np.cross(e3, qd)[:2] for si, qd in zip(s, qdot)])
    return np.concatenate([rate[0:2], pdot.ravel(), rate[2:4], wdot[:, :2].ravel()])


def finite_difference_linearisation(model: ChainCart, s: list[int], eps: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    n = len(s)
    N = 4 + 4 * n
    A = np.empty((N, N))
    B = np.empty((N, 2))
    zero_force = np.zeros(2)
    for j in range(N):
        dz = np.zeros(N)
        dz[j] = eps
        plus = local_rates(model, s, state_from_local(dz, s), zero_force)
        minus = local_rates(model, s, state_from_local(-dz, s), zero_force)
        A[:, j] = (plus - minus) / (2 * eps)
    origin = state_from_local(np.zeros(N), s)
    for j in range(2):
        du = np.zeros(2)
        du[j] = eps
        B[:, j] = (local_rates(model, s, origin, du) - local_rates(model, s, origin, -du)) / (2 * eps)
    return A, B


def test_chart_is_centred_on_the_equilibrium() -> None:
    s = [-1, 1, -1, 1, -1]
    assert np.allclose(state_from_local(np.zeros(24), s), PAPER.equilibrium(s), atol=0)


@pytest.mark.parametrize("case", range(8))
def test_linearize_matches_finite_differences_of_derivative(case: int) -> None:
    if case < 4:
        model, s = PAPER, [[1] * 5, [-1] * 5, [-1, 1, -1, 1, -1], [-1, -1, -1, 1, 1]][case]
    else:
        model, s = random_chain(np.random.default_rng(100 + case))
    A, B = model.linearize(s)
    A_fd, B_fd = finite_difference_linearisation(model, s)
    # Central differences at eps = 1e-6: truncation ~eps^2, round-off ~1e-16/eps.
    assert relative_error(A, A_fd) < 1e-7, (model.params, s)
    assert relative_error(B, B_fd) < 1e-7
    # The first-order form is the paper's second-order one, M xdd + G x = B u.
    M, G, B2 = model.linearize(s, second_order=True)
    half = M.shape[0]
    assert np.array_equal(A[:half, :half], np.zeros((half, half))) and np.array_equal(A[:half, half:], np.eye(half))
    assert np.allclose(A[half:, :half], -np.linalg.solve(M, G), rtol=1e-12, atol=1e-9 * np.abs(A).max())
    assert np.allclose(B[half:], np.linalg.solve(M, B2), rtol=1e-12, atol=1e-12 * np.abs(B).max())
    assert np.array_equal(B[:half], np.zeros((half, 2)))


# -- eigenvalues, controllability, equilibria -----------------------------------------


@pytest.mark.parametrize("s", PAPER_EQUILIBRIA, ids=lambda s: "".join("+" if v > 0 else "-" for v in s))
def test_eigenvalue_structure(s: list[int]) -> None:
    eig = PAPER.eigenvalues(s)
    A, _ = PAPER.linearize(s)
    reference = np.linalg.eigvals(A)
    assert eig.shape == (24,)
    scale = np.abs(reference).max()
    key = lambda z: (round(z.real / scale, 6), round(z.imag / scale, 6))  # noqa: E731
    assert np.allclose(sorted(eig, key=key), sorted(reference, key=key), atol=1e-6 * scale)
    zeros = np.abs(eig) < 1e-9 * scale
    assert zeros.sum() == 4  # the cart's double integrators in e1 and e2
    upright = s.count(-1)
    positive = (eig.real > 1e-6 * scale) & (np.abs(eig.imag) < 1e-9 * scale)
    if upright == 0:
        # Hanging: G_qq > 0, so lambda^2 < 0: purely imaginary pairs.
        assert np.abs(eig.real).max() < 1e-9 * scale and np.all(np.abs(eig[~zeros].imag) > 1.0)
    else:
        # Sylvester's inertia: G_qq has 2 * upright negative eigenvalues, hence as many
        # real lambda^2 > 0: saddles with positive real eigenvalues.
        assert positive.sum() == 2 * upright


def pbh_margin_scipy(model: ChainCart, s: list[int]) -> float:
    """Prop. 3's eigenvector test written with SciPy: for each eigenspace V (Euclidean
    orthonormal) of (G_qq, M_qq), sigma_min(V^T M_qx) / ||M_qx||_2; the minimum."""
    M, G, _ = model.linearize(s, second_order=True)
    M_qq, G_qq, M_qx = M[2:, 2:], G[2:, 2:], M[2:, :2]
    mu, vectors = sla.eigh(G_qq, M_qq)
    scale = np.abs(mu).max()
    margin, start = np.inf, 0
    while start < len(mu):
        stop = start + 1
        while stop < len(mu) and abs(mu[stop] - mu[start]) < 1e-9 * scale:
            stop += 1
        basis, _ = np.linalg.qr(vectors[:, start:stop])
        coupling = np.linalg.svd(basis.T @ M_qx, compute_uv=False)
        k = stop - start
        margin = min(margin, coupling[k - 1] if k <= 2 else 0.0)
        start = stop
    return float(margin / np.linalg.norm(M_qx, 2))


def test_all_32_paper_equilibria_are_controllable_with_margins() -> None:
    margins = []
    for s in PAPER_EQUILIBRIA:
        controllable, margin = PAPER.controllability(s)
        assert controllable is True
        assert margin == pytest.approx(pbh_margin_scipy(PAPER, s), rel=1e-6)
        margins.append(margin)
        # The classic PBH rank test on (A, B) agrees: [A - lambda I, B] has full rank at
        # every eigenvalue, far from round-off (measured: sigma_min >= 0.047).
        A, B = PAPER.linearize(s)
        sigma = min(
            np.linalg.svd(np.hstack([A - lam * np.eye(24), B]), compute_uv=False)[-1] for lam in np.linalg.eigvals(A)
        )
        assert sigma > 1e-3
    # Measured 3.3e-3 .. 4.1e-2 (src/analysis/controllability.rs).
    assert 1e-3 < min(margins) and max(margins) < 0.1


def test_margin_vanishes_only_as_the_tip_mass_vanishes() -> None:
    # No chain equilibrium is uncontrollable (proof in src/analysis/controllability.rs);
    # the margin only tends to 0 in degenerate limits such as a massless tip, whose
    # mode then barely touches the cart: the margin scales with the tip mass.
    previous = np.inf
    for tip in (1e-2, 1e-4, 1e-6):
        model = ChainCart(3, 0.5, [0.1, 0.1, tip], 0.1)
        controllable, margin = model.controllability([-1, -1, -1])
        assert controllable and margin < previous
        assert margin == pytest.approx(pbh_margin_scipy(model, [-1, -1, -1]), rel=1e-4)
        previous = margin
    assert previous < 1e-4
    # Below the 1e-8 threshold the verdict is "numerically uncontrollable".
    controllable, margin = ChainCart(3, 0.5, [0.1, 0.1, 1e-10], 0.1).controllability([-1, -1, -1])
    assert not controllable and 0 < margin < 1e-8


def test_equilibria_order_and_energies() -> None:
    assert len(PAPER_EQUILIBRIA) == 32
    # Binary order: bit i of the index set means link i + 1 upright; hanging first.
    for index, s in enumerate(PAPER_EQUILIBRIA):
        assert s == [-1 if index >> i & 1 else 1 for i in range(5)]
    masses = np.array(PAPER.link_masses)
    lengths = np.array(PAPER.link_lengths)
    outboard = np.cumsum(masses[::-1])[::-1]  # sum_{a >= i} m_a
    energies = []
    for s in PAPER_EQUILIBRIA:
        y = PAPER.equilibrium(s)
        # Paper eq. (V) at q_i = s_i e3, nothing moving.
        expected = -np.sum(outboard * PAPER.gravity * lengths * np.array(s))
        assert PAPER.energy(y) == pytest.approx(expected, rel=1e-12, abs=1e-15)
        assert PAPER.errors(y, s) == (0.0, 0.0)
        energies.append(PAPER.energy(y))
    assert int(np.argmin(energies)) == 0  # hanging is the minimum
    assert int(np.argmax(energies)) == 31  # inverted is the maximum
    assert len(ChainCart(1).equilibria()) == 2 and ChainCart(3).equilibria()[5] == [-1, 1, -1]


# -- LQR policy ------------------------------------------------------------------------


def paper_force(gain: np.ndarray, s: list[int], state: np.ndarray) -> np.ndarray:
    """Eq. (u): u = -K_x x - K_xd xdot - sum_i [K_qi C^T(s_i e3 x q_i) + K_wi C^T w_i]."""
    n = len(s)
    e3 = np.array([0.0, 0.0, 1.0])
    q = state[4 : 4 + 3 * n].reshape(n, 3)
    w = state[4 + 3 * n :].reshape(n, 3)
    K_x, K_q = gain[:, 0:2], gain[:, 2 : 2 + 2 * n]
    K_xd, K_w = gain[:, 2 + 2 * n : 4 + 2 * n], gain[:, 4 + 2 * n :]
    u = -K_x @ state[0:2] - K_xd @ state[2:4]
    for i in range(n):
        u -= K_q[:, 2 * i : 2 * i + 2] @ np.cross(s[i] * e3, q[i])[:2]
        u -= K_w[:, 2 * i : 2 * i + 2] @ w[i, :2]
    return u


def test_policy_on_a_spatial_scene_is_the_papers_feedback() -> None:
    env = gym.make("ChainCart-v0", scene="paper-fig3", start_noise=0.02)
    policy = LQRPolicy.from_env(env)
    config = env.unwrapped.config
    s = list(config.target_signs)
    gain = env.unwrapped.model.lqr_gain(s)
    observations = np.stack([env.reset(seed=k)[0] for k in range(6)])
    assert observations.dtype == np.float32
    actions, state = policy.predict(observations)
    assert state is None and actions.shape == (6, 2) and actions.dtype == np.float32
    for obs, action in zip(observations, actions):
        expected = np.clip(paper_force(gain, s, obs.astype(np.float64)) / config.max_force, -1, 1)
        assert np.allclose(action, expected, rtol=1e-6, atol=1e-7)
        single, _ = policy.predict(obs)
        assert single.shape == (2,) and single.dtype == np.float32 and np.array_equal(single, action)


def test_policy_on_a_planar_scene_embeds_the_state() -> None:
    env = gym.make("ChainCart-v0", start_noise=0.1)  # default scene: planar, 2 links
    policy = LQRPolicy.from_env(env)
    base = env.unwrapped
    gain = base.model.lqr_gain([-1, -1])
    obs, _ = env.reset(seed=3)
    action, _ = policy.predict(obs)
    assert action.shape == (1,) and action.dtype == np.float32
    spatial = base.model.to_spatial(obs.astype(np.float64))
    expected = paper_force(gain, [-1, -1], spatial)
    assert expected[1] == 0.0  # in-plane state, in-plane force
    assert action[0] == pytest.approx(np.clip(expected[0] / base.config.max_force, -1, 1), rel=1e-6, abs=1e-7)
    batch, _ = policy.predict(np.stack([obs, obs]))
    assert batch.shape == (2, 1) and np.array_equal(batch[0], action)


def test_policy_saturates_at_the_force_limit() -> None:
    policy = LQRPolicy.from_model(PAPER, [-1, -1, -1, 1, 1], max_force=5.0)
    state = PAPER.equilibrium([-1, -1, -1, 1, 1])
    state[0:2] = [30.0, -30.0]  # far off: the unsaturated force is hundreds of newtons
    raw = policy.forces(state)[0]
    assert np.all(np.abs(raw) > 5.0)
    action, _ = policy.predict(state)
    assert np.array_equal(action, np.sign(raw).astype(np.float32))
    assert np.all(np.abs(policy.predict(PAPER.equilibrium([-1, -1, -1, 1, 1]))[0]) == 0)


def test_sb3_evaluate_policy_accepts_the_policy() -> None:
    from stable_baselines3.common.evaluation import evaluate_policy

    env = gym.make("ChainCart-v0")
    mean, std = evaluate_policy(LQRPolicy.from_env(env), env, n_eval_episodes=3, warn=False)
    assert mean > 480.0  # 500 steps, reward <= 1 each; the LQR holds the default scene
    venv = ChainCartVecEnv(4, seed=0)
    mean_vec, _ = evaluate_policy(LQRPolicy.from_env(venv), venv, n_eval_episodes=4, warn=False)
    assert mean_vec > 480.0


@pytest.mark.parametrize(
    "observation, message",
    [
        (np.zeros(7), r"observation has shape \(7,\): expected \(8,\) or \(N, 8\)"),
        (np.zeros((2, 3, 8)), r"observation has shape \(2, 3, 8\)"),
        (np.full(8, np.nan), "non-finite"),
    ],
)
def test_policy_refuses_bad_observations(observation: np.ndarray, message: str) -> None:
    policy = LQRPolicy.from_env(gym.make("ChainCart-v0"))
    with pytest.raises(ValueError, match=message):
        policy.predict(observation)
