//! The continuous-time algebraic Riccati equation
//! `A^T X + X A - X B R^-1 B^T X + Q = 0` and its stabilising solution.
//!
//! Method (after balancing the state, [`crate::analysis::balance`]):
//! 1. `sign(H)` of the Hamiltonian `H = [[A, -S], [-Q, -A^T]]`, `S = B R^-1 B^T`, by the
//!    determinant-scaled Newton iteration ([`crate::analysis::sign`]). The stable invariant
//!    subspace of `H` is the null space of `sign(H) + I`; the stabilising `X` is the one
//!    whose graph `[I; X]` spans it, i.e. the least-squares solution of
//!    `[W12; W22 + I] X = -[W11 + I; W21]` (`W = sign H`), solved by Householder QR.
//! 2. Newton-Kleinman polish: with `K = R^-1 B^T X`, solve the Lyapunov equation
//!    `(A - B K)^T X' + X' (A - B K) + Q + K^T R K = 0` and keep `X'` while the residual
//!    drops (up to [`POLISH_STEPS`] steps). Newton converges quadratically from the
//!    sign-function result, so this recovers the digits the sign iteration loses on
//!    ill-conditioned Hamiltonians.
//! 3. Checks: `X` finite, symmetric positive semi-definite, `A - B K` Hurwitz and the
//!    residual small. A stabilising solution exists iff `(A, B)` is stabilisable and
//!    `(A, Q)` has no unobservable mode on the imaginary axis; when it does not, one of
//!    these checks fails and the error says which.

use crate::analysis::balance::balancing_scale;
use crate::analysis::checks::{
    check_finite_matrix, check_pd, check_psd, check_shape, check_square,
};
use crate::analysis::lyapunov::solve_lyapunov;
use crate::analysis::sign::{matrix_sign, SignFailure};
use crate::error::{ChainError, Result};
use nalgebra::{Cholesky, DMatrix, QR};

/// Newton-Kleinman steps after the sign function, at most (typically 1-2 are taken).
pub const POLISH_STEPS: usize = 30;

/// Newton polishing stops once the normalised residual is this small (a few ulps).
pub const ROUND_OFF_RESIDUAL: f64 = 1e-14;

/// A solution whose normalised residual exceeds this is rejected. Deliberately loose:
/// on the upright equilibria of long chains `X` spans ten or more decades and ~1e-9 is
/// all double precision gives; the closed-loop check, not this, is what certifies the
/// gain, and the achieved residual is reported in [`CareSolution::residual`].
pub const RESIDUAL_TOLERANCE: f64 = 1e-6;

/// The stabilising solution and how good it is.
#[derive(Debug, Clone, PartialEq)]
pub struct CareSolution {
    /// `X`, symmetric positive semi-definite.
    pub x: DMatrix<f64>,
    /// `K = R^-1 B^T X`: `u = -K z` stabilises `A`.
    pub gain: DMatrix<f64>,
    /// `||A^T X + X A - X S X + Q||_F / (||Q||_F + 2 ||A^T X||_F + ||X S X||_F)`, with
    /// `S = B R^-1 B^T`: the residual relative to the terms that cancel in it. Meaningful
    /// even when `Q = 0`, and not inflated by a large `X` the way `/ ||Q||` is.
    pub residual: f64,
    /// Largest real part of the eigenvalues of `A - B K` (negative).
    pub closed_loop_abscissa: f64,
    /// Iterations of the matrix sign function.
    pub sign_iterations: usize,
    /// Newton-Kleinman refinement steps after it.
    pub newton_steps: usize,
}

fn analysis(reason: String) -> ChainError {
    ChainError::Analysis { reason }
}

fn validate(a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, r: &DMatrix<f64>) -> Result<()> {
    let n = check_square("A", a)?;
    let m = b.ncols();
    if m == 0 {
        return Err(analysis(format!(
            "B is {}x0: expected at least one input column",
            b.nrows()
        )));
    }
    check_shape("B", b, n, m)?;
    check_shape("Q", q, n, n)?;
    check_shape("R", r, m, m)?;
    for (name, mat) in [("A", a), ("B", b), ("Q", q), ("R", r)] {
        check_finite_matrix(name, mat)?;
    }
    check_psd("Q", q)?;
    check_pd("R", r)
}

/// Everything the residual and the gain need, computed once.
struct Problem<'a> {
    a: &'a DMatrix<f64>,
    b: &'a DMatrix<f64>,
    q: &'a DMatrix<f64>,
    r: &'a DMatrix<f64>,
    /// `R^-1 B^T`.
    rinv_bt: DMatrix<f64>,
    /// `S = B R^-1 B^T`.
    s: DMatrix<f64>,
}

impl<'a> Problem<'a> {
    fn new(
        a: &'a DMatrix<f64>,
        b: &'a DMatrix<f64>,
        q: &'a DMatrix<f64>,
        r: &'a DMatrix<f64>,
    ) -> Result<Self> {
        let chol = Cholesky::new(r.clone())
            .ok_or_else(|| analysis("R is not positive definite: Cholesky failed".into()))?;
        let rinv_bt = chol.solve(&b.transpose());
        let s = b * &rinv_bt;
        let s = (&s + s.transpose()) * 0.5;
        Ok(Self {
            a,
            b,
            q,
            r,
            rinv_bt,
            s,
        })
    }

    fn hamiltonian(&self) -> DMatrix<f64> {
        let n = self.a.nrows();
        let mut h = DMatrix::zeros(2 * n, 2 * n);
        h.view_mut((0, 0), (n, n)).copy_from(self.a);
        h.view_mut((0, n), (n, n)).copy_from(&(-&self.s));
        h.view_mut((n, 0), (n, n)).copy_from(&(-self.q));
        h.view_mut((n, n), (n, n)).copy_from(&(-self.a.transpose()));
        h
    }

    fn gain(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        &self.rinv_bt * x
    }

    /// Normwise backward error of `X` (see [`CareSolution::residual`]).
    fn residual(&self, x: &DMatrix<f64>) -> f64 {
        let ax = self.a.transpose() * x;
        let xsx = x * &self.s * x;
        let res = &ax + ax.transpose() - &xsx + self.q;
        // The sizes of the terms that cancel: round-off in the residual is eps times
        // this, however large X is, so the ratio is a fair accuracy measure.
        let scale = self.q.norm() + 2.0 * ax.norm() + xsx.norm();
        if scale > 0.0 {
            res.norm() / scale
        } else {
            res.norm()
        }
    }
}

/// `X` from the stable invariant subspace `null(sign(H) + I)`.
fn graph_solution(w: &DMatrix<f64>, n: usize) -> Result<DMatrix<f64>> {
    let mut lhs = DMatrix::zeros(2 * n, n);
    let mut rhs = DMatrix::zeros(2 * n, n);
    let eye = DMatrix::<f64>::identity(n, n);
    lhs.view_mut((0, 0), (n, n))
        .copy_from(&w.view((0, n), (n, n)));
    lhs.view_mut((n, 0), (n, n))
        .copy_from(&(w.view((n, n), (n, n)) + &eye));
    rhs.view_mut((0, 0), (n, n))
        .copy_from(&(-(w.view((0, 0), (n, n)) + &eye)));
    rhs.view_mut((n, 0), (n, n))
        .copy_from(&(-w.view((n, 0), (n, n))));
    // Householder QR: backward stable, cheaper than an SVD, and the spread of the
    // diagonal of R is enough to tell a (numerically) non-graph subspace apart.
    let qr = QR::new(lhs);
    let r = qr.r();
    let diag = r.diagonal().map(f64::abs);
    let (hi, lo) = (diag.max(), diag.min());
    if lo.is_nan() || lo <= 1e-14 * hi {
        // The stable subspace is not a graph over the first block: some stable
        // direction of H has no component in x, which happens exactly when an
        // unstable mode cannot be reached from the input.
        return Err(analysis(format!(
            "no stabilising Riccati solution: the stable invariant subspace of the Hamiltonian \
             is not the graph of a matrix (conditioning {:e}); expected (A, B) stabilisable \
             (or X is too large for double precision: nearly uncontrollable unstable modes)",
            lo / hi
        )));
    }
    let x = r
        .solve_upper_triangular(&(qr.q().transpose() * rhs))
        .ok_or_else(|| analysis("least-squares solve for X failed: R is singular".into()))?;
    Ok((&x + x.transpose()) * 0.5)
}

/// Largest real part of the eigenvalues of `m` (finite input assumed).
pub fn spectral_abscissa(m: &DMatrix<f64>) -> f64 {
    m.complex_eigenvalues()
        .iter()
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Newton-Kleinman steps from `x`, returning the iterate with the smallest residual.
///
/// From a stabilising start every Newton iterate stabilises and the sequence decreases
/// monotonically to the solution (Kleinman 1968), but the residual may first grow
/// (the first step overshoots when the sign-function result is poor, as it is when an
/// unstable mode is weakly coupled to the input). So the loop runs on through such
/// growth, up to [`POLISH_STEPS`] steps, and stops early once the residual is at
/// round-off or has not improved for a few steps.
fn polish(p: &Problem, x: DMatrix<f64>) -> (DMatrix<f64>, usize) {
    let mut best = (p.residual(&x), x.clone(), 0);
    let mut current = x;
    let mut stalled = 0;
    for step in 1..=POLISH_STEPS {
        if best.0 <= ROUND_OFF_RESIDUAL || stalled >= 3 {
            break;
        }
        let k = p.gain(&current);
        let closed = p.a - p.b * &k;
        let w = p.q + k.transpose() * p.r * &k;
        let Ok(next) = solve_lyapunov(&closed, &w) else {
            break;
        };
        let residual = p.residual(&next);
        if residual < best.0 {
            best = (residual, next.clone(), step);
            stalled = 0;
        } else {
            stalled += 1;
        }
        current = next;
    }
    (best.1, best.2)
}

/// The stabilising solution of the CARE (see the module docs), or an error naming why
/// there is none (bad shapes or weights, unstabilisable pair, imaginary-axis modes
/// invisible to `Q`).
pub fn solve_care(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<CareSolution> {
    validate(a, b, q, r)?;
    let n = a.nrows();
    // Work in the balanced state z = D z~ (see `balance`); D is exact powers of two.
    let d = balancing_scale(a);
    let d_inv = d.map(|v| 1.0 / v);
    let a_bal = DMatrix::from_fn(n, n, |i, j| a[(i, j)] * d_inv[i] * d[j]);
    let b_bal = DMatrix::from_fn(n, b.ncols(), |i, j| b[(i, j)] * d_inv[i]);
    let q_bal = DMatrix::from_fn(n, n, |i, j| q[(i, j)] * d[i] * d[j]);
    let balanced = Problem::new(&a_bal, &b_bal, &q_bal, r)?;
    let (w, sign_iterations) = matrix_sign(&balanced.hamiltonian()).map_err(sign_error)?;
    let x0 = graph_solution(&w, n)?;
    check_finite_matrix("X", &x0)?;
    let (x_bal, newton_steps) = polish(&balanced, x0);
    let x = DMatrix::from_fn(n, n, |i, j| x_bal[(i, j)] * d_inv[i] * d_inv[j]);
    finish(&Problem::new(a, b, q, r)?, x, sign_iterations, newton_steps)
}

fn sign_error(failure: SignFailure) -> ChainError {
    let detail = match failure {
        SignFailure::Singular { iteration } => {
            format!("an iterate became singular at step {iteration}")
        }
        SignFailure::NoConvergence { relative_change } => {
            format!("no convergence (last relative change {relative_change:e})")
        }
    };
    analysis(format!(
        "no stabilising Riccati solution: the Hamiltonian has eigenvalues on the imaginary \
         axis ({detail}); expected (A, B) stabilisable and (A, Q) detectable"
    ))
}

/// Final checks and the gain.
fn finish(
    p: &Problem,
    x: DMatrix<f64>,
    sign_iterations: usize,
    newton_steps: usize,
) -> Result<CareSolution> {
    let gain = p.gain(&x);
    check_finite_matrix("K", &gain)?;
    let closed_loop_abscissa = spectral_abscissa(&(p.a - p.b * &gain));
    if closed_loop_abscissa.is_nan() || closed_loop_abscissa >= 0.0 {
        return Err(analysis(format!(
            "no stabilising Riccati solution: A - B K has an eigenvalue with real part \
             {closed_loop_abscissa:e}; expected (A, B) stabilisable (an unstable mode the input \
             cannot reach, or one so weakly coupled that X exceeds double precision?)"
        )));
    }
    let residual = p.residual(&x);
    if residual.is_nan() || residual > RESIDUAL_TOLERANCE {
        return Err(analysis(format!(
            "Riccati solution inaccurate: normalised residual {residual:e}, expected <= \
             {RESIDUAL_TOLERANCE:e} (an ill-conditioned problem: is an unstable mode only \
             weakly coupled to the input? see analysis::controllability)"
        )));
    }
    let low = crate::analysis::checks::min_symmetric_eigenvalue(&x);
    if low < -1e-8 * x.amax() {
        return Err(analysis(format!(
            "Riccati solution has eigenvalue {low:e}: expected positive semi-definite X"
        )));
    }
    Ok(CareSolution {
        x,
        gain,
        residual,
        closed_loop_abscissa,
        sign_iterations,
        newton_steps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_closed_form() {
        // a x + x a - x^2 b^2 / r + q = 0, stabilising root x = (a r + sqrt(a^2 r^2 + b^2 q r)) / b^2.
        for (a, b, q, r) in [
            (1.0, 1.0, 1.0, 1.0),
            (-2.0, 0.5, 3.0, 0.1),
            (5.0, 2.0, 0.0, 4.0),
        ] {
            let m = |v: f64| DMatrix::from_element(1, 1, v);
            let sol = solve_care(&m(a), &m(b), &m(q), &m(r)).unwrap();
            let exact = (a * r + (a * a * r * r + b * b * q * r).sqrt()) / (b * b);
            assert!(
                (sol.x[(0, 0)] - exact).abs() < 1e-12 * exact.abs().max(1.0),
                "{a} {b} {q} {r}"
            );
        }
    }
}
