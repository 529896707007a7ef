//! Prop. 3: controllability of the linearisation by the eigenvector (PBH) test.
//!
//! The linearisation at `s` is controllable iff no generalized eigenvector of the
//! chain with the cart held, `(lambda^2 M_qq + G_qq) v = 0`, satisfies `v^T M_qx = 0`
//! (a mode that exerts no force on the cart cannot be driven through it). This is the
//! test used here, never the rank of the Kalman matrix `[B, AB, ..., A^(N-1) B]`: for
//! the paper's 5-link system that matrix spans so many orders of magnitude that a
//! numerical rank calls every equilibrium uncontrollable (`tests/analysis.rs` records it).
//!
//! **Repeated eigenvalues.** For an eigenvalue of multiplicity `k` the eigenvectors
//! form a subspace and the test must hold on all of it: with `V` an orthonormal basis
//! of the eigenspace, `v = V c` is orthogonal to `M_qx` for some `c != 0` iff
//! `V^T M_qx` (`k x 2`) has rank `< k`. So the per-eigenspace measure is the `k`-th
//! singular value of `V^T M_qx`, which is zero whenever `k > 2` (more coincident modes
//! than inputs). Eigenvalues are grouped with [`CLUSTER_TOLERANCE`].
//!
//! **Margin.** `margin = min over eigenspaces of sigma_k(V^T M_qx) / ||M_qx||_2`, with
//! `V` orthonormal in the *Euclidean* sense (all coordinates are angles in radians, so
//! Euclidean length is the natural one; it makes the margin dimensionless, in [0, 1],
//! and invariant under a change of mass or length unit). Controllable iff
//! `margin > CONTROLLABILITY_THRESHOLD`.
//!
//! **Every equilibrium is double-degenerate, and that is harmless.** All blocks of
//! `M_qq`, `G_qq` are multiples of `I2` and those of `M_qx` multiples of the rotation
//! `E`, so every eigenvalue has the pair of eigenvectors `v (x) e1`, `v (x) e2`
//! (planar modes in the two vertical planes). `V^T M_qx = (v . c) E`-like with `E`
//! orthogonal: rank 2 iff the planar mode `v` moves the cart, so the double
//! eigenvalue needs exactly the two inputs the cart has.
//!
//! **There is no uncontrollable equilibrium for positive masses and lengths.** In the
//! horizontal mass positions `y_k = sum_{a<=k} s_a l_a theta_a` the planar problem is
//! `K y = mu diag(m) y` with `K = D^T diag(k_a) D` (`D` the first-difference matrix,
//! `k_a = s_a g (sum_{b>=a} m_b) / l_a != 0`), a tridiagonal pencil with non-zero
//! off-diagonals `-k_(a+1)`; and `v^T M_qx ~ sum_k m_k y_k`. Summing the rows of
//! `K y = mu diag(m) y` gives `mu sum_k m_k y_k = k_1 y_1`. Now `mu != 0` (`G_qq` is
//! regular) and `y_1 != 0` (else the tridiagonal recursion makes `y = 0`), and the same
//! recursion makes every planar eigenvalue simple. So every mode moves the cart, for
//! every `s`, every `n` and all positive parameters (the cart mass does not even
//! enter). The margin only tends to 0 in degenerate limits (e.g. a vanishing outboard
//! mass, whose mode then barely touches the cart). The tests check this numerically
//! and check the detector on genuinely uncontrollable systems instead (two equal
//! pendulums side by side on the cart; hand-built pencils).
//!
//! **With a rig** ([`controllability_with_rig`]). Joint damping adds `D_qq` to the
//! chain's rows, cart friction and a motor's back-EMF damp the cart's, and acceleration
//! actuation prescribes the cart. In every case a mode the input cannot reach is a
//! left eigenvector `w` of `lambda^2 M + lambda D + G` with `w^T B = 0`: `B` acts on the
//! cart rows only, so `w` has no cart part, the cart rows (`D` and `G` have no cart-chain
//! blocks) leave `lambda^2 M_xq v = 0`, and the test becomes the damped chain's
//! quadratic eigenproblem `(lambda^2 M_qq + lambda D_qq + G_qq) v = 0` with
//! `v^H M_qx = 0` (`lambda != 0` as `G_qq` is regular). The eigenvalues come from its
//! companion matrix, each eigenspace as the null space of the matrix
//! `lambda^2 M_qq + lambda D_qq + G_qq` (its smallest singular vectors, as many as the
//! eigenvalue's cluster), and the margin is the undamped one's,
//! `sigma_k(V^H M_qx) / ||M_qx||_2` with `V` unitary. Without damping it is Prop. 3's
//! margin (each `mu` gives the pair `lambda = +-sqrt(-mu)` with the same eigenspace).
//! Cart friction, the motor and the actuation leave the verdict unchanged; damping can
//! change it (hand-built pencils in the tests: two equal decoupled modes stay
//! uncontrollable under equal damping, and unequal damping splits them).

use crate::analysis::checks::{check_finite_matrix, check_shape, check_square};
use crate::analysis::linearize::Linearization;
use crate::analysis::pencil::{clusters, solve_pencil};
use crate::error::{ChainError, Result};
use crate::params::{ChainParams, Rig};
use nalgebra::{Complex, DMatrix, QR, SVD};

/// A margin at or below this is reported uncontrollable. Round-off in the margin of
/// an exactly uncontrollable system is ~1e-15; the paper's system has margins from
/// 3.3e-3 to 4.1e-2. 1e-8 (about the square root of machine epsilon) sits safely
/// between. Since no chain equilibrium is exactly uncontrollable (module docs), a chain
/// verdict "uncontrollable" means *numerically* so: some mode moves the cart less than
/// 1e-8 of the strongest coupling (long chains with very uneven links get there), and
/// a stabilising gain would be astronomically large; the Riccati solver already fails
/// on unstable modes with margins of ~1e-6.
pub const CONTROLLABILITY_THRESHOLD: f64 = 1e-8;

/// Eigenvalues `mu` closer than this times `max|mu|` are one (repeated) eigenvalue.
pub const CLUSTER_TOLERANCE: f64 = 1e-9;

/// Verdict of the PBH test and how far from the verdict changing the system is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controllability {
    /// `margin > CONTROLLABILITY_THRESHOLD`.
    pub controllable: bool,
    /// `min_eigenspaces sigma_k(V^T M_qx) / ||M_qx||_2`, in [0, 1] (module docs).
    pub margin: f64,
    /// `mu = -lambda^2` of the eigenspace that attains the margin.
    pub weakest_mode: f64,
    /// Its multiplicity (2 for every mode of a chain: the two vertical planes).
    pub weakest_multiplicity: usize,
}

/// Prop. 3 at equilibrium `s` of the chain with parameters `params`.
pub fn controllability(params: &ChainParams, s: &[f64]) -> Result<Controllability> {
    let lin = Linearization::new(params, s)?;
    pbh_margin(&lin.m_qq(), &lin.g_qq(), &lin.m_qx())
}

/// The PBH eigenvector test for `M_qq xdd + G_qq x = M_qx u` with `M_qq` symmetric
/// positive definite, `G_qq` symmetric (regular for the test to be Prop. 3's), `M_qx`
/// with one column per input.
pub fn pbh_margin(
    m_qq: &DMatrix<f64>,
    g_qq: &DMatrix<f64>,
    m_qx: &DMatrix<f64>,
) -> Result<Controllability> {
    let dim = check_square("M_qq", m_qq)?;
    check_shape("M_qx", m_qx, dim, m_qx.ncols().max(1))?;
    check_finite_matrix("M_qx", m_qx)?;
    let eig = solve_pencil(g_qq, m_qq)?;
    let scale = spectral_norm(m_qx);
    let mut weakest = Controllability {
        controllable: false,
        margin: f64::INFINITY,
        weakest_mode: f64::NAN,
        weakest_multiplicity: 0,
    };
    for range in clusters(&eig.values, CLUSTER_TOLERANCE) {
        let basis = eig.vectors.columns(range.start, range.len()).into_owned();
        let coupling = if scale > 0.0 {
            eigenspace_coupling(basis, m_qx) / scale
        } else {
            0.0
        };
        if coupling < weakest.margin {
            weakest.margin = coupling;
            weakest.weakest_mode = eig.values[range.start];
            weakest.weakest_multiplicity = range.len();
        }
    }
    weakest.controllable = weakest.margin > CONTROLLABILITY_THRESHOLD;
    Ok(weakest)
}

/// Prop. 3 at equilibrium `s` of the chain with parameters `params` on the rig `rig`
/// (module docs, "With a rig"); without joint damping it is [`controllability`].
pub fn controllability_with_rig(
    params: &ChainParams,
    s: &[f64],
    rig: &Rig,
) -> Result<Controllability> {
    rig.validate(params.n_links())?;
    if !rig.has_joint_damping() {
        return controllability(params, s);
    }
    let lin = Linearization::with_rig(params, s, rig)?;
    pbh_margin_damped(&lin.m_qq(), &lin.d_qq(), &lin.g_qq(), &lin.m_qx())
}

/// The PBH test for `M_qq xdd + D_qq xdot + G_qq x = M_qx u` (`M_qq` symmetric positive
/// definite, `G_qq` regular): the margin of [`pbh_margin`] over the eigenspaces of the
/// quadratic eigenproblem. `weakest_mode` is `|lambda|^2` of the weakest eigenvalue
/// (`|mu|` of the undamped pencil).
pub fn pbh_margin_damped(
    m_qq: &DMatrix<f64>,
    d_qq: &DMatrix<f64>,
    g_qq: &DMatrix<f64>,
    m_qx: &DMatrix<f64>,
) -> Result<Controllability> {
    let dim = check_square("M_qq", m_qq)?;
    check_shape("D_qq", d_qq, dim, dim)?;
    check_shape("G_qq", g_qq, dim, dim)?;
    check_shape("M_qx", m_qx, dim, m_qx.ncols().max(1))?;
    for (name, m) in [
        ("M_qq", m_qq),
        ("D_qq", d_qq),
        ("G_qq", g_qq),
        ("M_qx", m_qx),
    ] {
        check_finite_matrix(name, m)?;
    }
    let inverse = m_qq
        .clone()
        .try_inverse()
        .ok_or_else(|| ChainError::Analysis {
            reason: "M_qq is singular".to_string(),
        })?;
    // The companion matrix of the quadratic eigenproblem: its eigenvalues are lambda.
    let mut companion = DMatrix::<f64>::zeros(2 * dim, 2 * dim);
    companion
        .view_mut((0, dim), (dim, dim))
        .fill_with_identity();
    companion
        .view_mut((dim, 0), (dim, dim))
        .copy_from(&(-&inverse * g_qq));
    companion
        .view_mut((dim, dim), (dim, dim))
        .copy_from(&(-&inverse * d_qq));
    let lambdas: Vec<Complex<f64>> = companion.complex_eigenvalues().iter().copied().collect();
    let scale = spectral_norm(m_qx);
    let largest = lambdas.iter().map(|l| l.norm()).fold(0.0, f64::max);
    let complex = |m: &DMatrix<f64>| m.map(|x| Complex::new(x, 0.0));
    let (m_c, d_c, g_c, b_c) = (complex(m_qq), complex(d_qq), complex(g_qq), complex(m_qx));
    let mut weakest = Controllability {
        controllable: false,
        margin: f64::INFINITY,
        weakest_mode: f64::NAN,
        weakest_multiplicity: 0,
    };
    // Eigenvalues closer than the tolerance are one eigenvalue, its cluster's size its
    // multiplicity (each of a chain's twice: the two vertical planes).
    let mut taken = vec![false; lambdas.len()];
    for first in 0..lambdas.len() {
        if taken[first] {
            continue;
        }
        let lambda = lambdas[first];
        let mut k = 0;
        for (other, seen) in taken.iter_mut().enumerate().skip(first) {
            if !*seen && (lambdas[other] - lambda).norm() <= CLUSTER_TOLERANCE * largest.max(1.0) {
                *seen = true;
                k += 1;
            }
        }
        let coupling = if k > m_qx.ncols() {
            0.0 // more coincident modes than inputs
        } else if scale > 0.0 {
            let quadratic = &m_c * (lambda * lambda) + &d_c * lambda + &g_c;
            let basis = null_space(quadratic, k);
            let y = basis.adjoint() * &b_c;
            SVD::new(y, false, false).singular_values.min() / scale
        } else {
            0.0
        };
        if coupling < weakest.margin {
            weakest.margin = coupling;
            weakest.weakest_mode = lambda.norm_sqr();
            weakest.weakest_multiplicity = k;
        }
    }
    weakest.controllable = weakest.margin > CONTROLLABILITY_THRESHOLD;
    Ok(weakest)
}

/// An orthonormal basis of the `k`-dimensional (numerical) null space of `q`: its right
/// singular vectors of the `k` smallest singular values.
fn null_space(q: DMatrix<Complex<f64>>, k: usize) -> DMatrix<Complex<f64>> {
    let n = q.ncols();
    let svd = SVD::new(q, false, true);
    let v_t = svd.v_t.expect("SVD computed with V");
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
    let mut basis = DMatrix::<Complex<f64>>::zeros(n, k);
    for (column, &row) in order.iter().take(k).enumerate() {
        basis.set_column(column, &v_t.row(row).adjoint());
    }
    basis
}

fn spectral_norm(m: &DMatrix<f64>) -> f64 {
    SVD::new(m.clone(), false, false).singular_values.max()
}

/// `sigma_k(V^T M_qx)` for an orthonormalised basis `V` (`dim x k`) of one eigenspace:
/// zero iff some eigenvector in the span is orthogonal to every input column.
fn eigenspace_coupling(basis: DMatrix<f64>, m_qx: &DMatrix<f64>) -> f64 {
    let k = basis.ncols();
    if k > m_qx.ncols() {
        // More coincident modes than inputs: some combination always misses the cart.
        return 0.0;
    }
    // The pencil's vectors are M-orthonormal; QR gives a Euclidean-orthonormal basis
    // of the same span (the margin's documented normalisation).
    let v = QR::new(basis).q();
    let y = v.transpose() * m_qx;
    SVD::new(y, false, false).singular_values.min()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    #[test]
    fn hand_built_pencils() {
        // Two modes, inputs along the first only: the second mode is uncontrollable.
        let m = DMatrix::<f64>::identity(2, 2);
        let g = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 2.0]));
        let b = DMatrix::from_column_slice(2, 1, &[1.0, 0.0]);
        let c = pbh_margin(&m, &g, &b).unwrap();
        assert!(!c.controllable && c.margin < 1e-15, "{c:?}");
        assert!((c.weakest_mode - 2.0).abs() < 1e-14);
        // Tilting the input couples both.
        let b = DMatrix::from_column_slice(2, 1, &[1.0, 0.5]);
        let c = pbh_margin(&m, &g, &b).unwrap();
        assert!(c.controllable && (c.margin - 0.5 / 1.25f64.sqrt()).abs() < 1e-14);
        // A double eigenvalue with one input is never controllable, whatever the input.
        let g = DMatrix::<f64>::identity(2, 2) * 3.0;
        let c = pbh_margin(&m, &g, &b).unwrap();
        assert!(!c.controllable && c.weakest_multiplicity == 2);
        // ... and with two independent inputs it is.
        let b2 = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.3, 1.0]);
        assert!(pbh_margin(&m, &g, &b2).unwrap().controllable);
    }

    #[test]
    fn damping_keeps_equal_modes_uncontrollable_and_unequal_damping_splits_them() {
        // Two equal oscillators driven by one input: the difference mode misses it.
        let m = DMatrix::<f64>::identity(2, 2);
        let g = DMatrix::<f64>::identity(2, 2) * 4.0;
        let b = DMatrix::from_column_slice(2, 1, &[1.0, 1.0]);
        let equal = DMatrix::<f64>::identity(2, 2) * 0.3;
        let c = pbh_margin_damped(&m, &equal, &g, &b).unwrap();
        assert!(!c.controllable && c.weakest_multiplicity == 2, "{c:?}");
        // Damped differently, the two modes have their own eigenvalues, each on the input.
        let unequal = DMatrix::from_diagonal(&DVector::from_vec(vec![0.1, 0.5]));
        let c = pbh_margin_damped(&m, &unequal, &g, &b).unwrap();
        assert!(c.controllable, "{c:?}");
        // Each eigenvector is a unit axis: its coupling is 1 / ||b|| = 1 / sqrt(2).
        assert!((c.margin - 0.5f64.sqrt()).abs() < 1e-12, "{c:?}");
        // An oscillator the input misses stays missed, damped or not.
        let g2 = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 2.0]));
        let first = DMatrix::from_column_slice(2, 1, &[1.0, 0.0]);
        let c = pbh_margin_damped(&m, &unequal, &g2, &first).unwrap();
        assert!(!c.controllable && c.margin < 1e-14, "{c:?}");
    }
}
