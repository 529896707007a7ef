//! The matrix sign function by the scaled Newton iteration
//! `Z <- (Z / c + c Z^-1) / 2`, `c = |det Z|^(1/N)` (determinant scaling).
//!
//! `sign(Z)` maps every eigenvalue to -1 (left half-plane) or +1 (right half-plane),
//! so `(I - sign Z) / 2` projects onto the stable invariant subspace without computing
//! any eigenvector. That is what the Riccati and Lyapunov solvers need, and the
//! iteration is backward stable enough for the sizes here (up to ~200 square), where
//! a Schur-based method would need a reordering routine nalgebra does not have.
//! Scaling makes the iteration converge in ~10-20 steps even when eigenvalue
//! magnitudes spread over many decades (the chain's fast and slow modes).

use nalgebra::DMatrix;

/// Iteration cap: unscaled Newton needs ~log2(spread) + 6 steps, scaled far fewer; a
/// run that has not converged by now has eigenvalues on (or within round-off of) the
/// imaginary axis, where the sign is undefined.
pub const MAX_ITERATIONS: usize = 100;

/// Relative change below which the iteration is considered converged.
pub const TOLERANCE: f64 = 1e-12;

/// Inverse of `z` and `|det z|^(1/N)`, from one LU factorisation; `None` if singular.
/// The determinant is accumulated in logarithms so that it cannot overflow.
pub fn inverse_and_scale(z: &DMatrix<f64>) -> Option<(DMatrix<f64>, f64)> {
    let n = z.nrows();
    let lu = z.clone().lu();
    let u = lu.u();
    let log_det: f64 = (0..n).map(|i| u[(i, i)].abs().ln()).sum();
    let scale = (log_det / n as f64).exp();
    if !scale.is_finite() || scale == 0.0 {
        return None;
    }
    lu.try_inverse().map(|inv| (inv, scale))
}

/// One-norm (max column sum), cheap and adequate for convergence tests.
pub fn norm1(m: &DMatrix<f64>) -> f64 {
    m.column_iter()
        .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Why the iteration stopped without a result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SignFailure {
    /// An iterate was singular: an eigenvalue at (or numerically at) zero.
    Singular {
        /// The iteration at which it happened.
        iteration: usize,
    },
    /// No convergence within [`MAX_ITERATIONS`]: eigenvalues on the imaginary axis.
    NoConvergence {
        /// The last iteration's relative change.
        relative_change: f64,
    },
}

/// `sign(z)` and the number of iterations used.
pub fn matrix_sign(z: &DMatrix<f64>) -> Result<(DMatrix<f64>, usize), SignFailure> {
    let mut z = z.clone();
    let mut change = f64::INFINITY;
    let mut scaled = true;
    for iteration in 1..=MAX_ITERATIONS {
        let (inv, mut c) = inverse_and_scale(&z).ok_or(SignFailure::Singular { iteration })?;
        // Near convergence the scaling has done its job and c ~ 1; dropping it then
        // restores the clean quadratic convergence of the plain Newton iteration.
        if !scaled {
            c = 1.0;
        }
        let next = (&z / c + inv * c) * 0.5;
        change = norm1(&(&next - &z)) / norm1(&next);
        z = next;
        if change < 1e-2 {
            scaled = false;
        }
        if !change.is_finite() {
            return Err(SignFailure::Singular { iteration });
        }
        if change <= TOLERANCE {
            return Ok((z, iteration));
        }
    }
    Err(SignFailure::NoConvergence {
        relative_change: change,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_of_a_diagonalisable_matrix() {
        // T diag(-3, 0.01, 50) T^-1 has sign T diag(-1, 1, 1) T^-1.
        let t = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 0.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0]);
        let tinv = t.clone().try_inverse().unwrap();
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![-3.0, 0.01, 50.0]));
        let s = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![-1.0, 1.0, 1.0]));
        let (sign, iterations) = matrix_sign(&(&t * d * &tinv)).unwrap();
        assert!((sign - &t * s * &tinv).amax() < 1e-12, "{iterations}");
        assert!(iterations < 20);
    }

    #[test]
    fn imaginary_axis_eigenvalues_do_not_converge() {
        let rot = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -1.0, 0.0]);
        assert!(matches!(
            matrix_sign(&rot),
            Err(SignFailure::NoConvergence { .. }) | Err(SignFailure::Singular { .. })
        ));
    }
}
