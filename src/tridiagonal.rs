//! Tridiagonal solves without pivoting (Thomas algorithm).
//!
//! The link-tension systems of the dynamics are symmetric positive definite and
//! weakly diagonally dominant, so elimination without pivoting is stable.

/// Solves `A t = b` in place for a tridiagonal `A` with diagonal `diag`, sub-diagonal
/// `lower` (`lower[i]` = `A[i+1][i]`) and super-diagonal `upper` (`upper[i]` = `A[i][i+1]`).
/// `rhs` is overwritten with the solution; `scratch` (length n) is clobbered.
#[inline]
pub fn solve(diag: &[f64], lower: &[f64], upper: &[f64], rhs: &mut [f64], scratch: &mut [f64]) {
    let n = diag.len();
    let mut denom = diag[0];
    rhs[0] /= denom;
    for i in 1..n {
        scratch[i - 1] = upper[i - 1] / denom;
        denom = diag[i] - lower[i - 1] * scratch[i - 1];
        rhs[i] = (rhs[i] - lower[i - 1] * rhs[i - 1]) / denom;
    }
    for i in (0..n.saturating_sub(1)).rev() {
        rhs[i] -= scratch[i] * rhs[i + 1];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_nonsymmetric_system() {
        let diag = [4.0, 5.0, 6.0, 7.0];
        let lower = [1.0, -2.0, 0.5];
        let upper = [2.0, 1.0, -1.0];
        let x = [1.0, -2.0, 3.0, 0.25];
        let mut b = [0.0; 4];
        for i in 0..4 {
            b[i] = diag[i] * x[i];
            if i > 0 {
                b[i] += lower[i - 1] * x[i - 1];
            }
            if i < 3 {
                b[i] += upper[i] * x[i + 1];
            }
        }
        let mut scratch = [0.0; 4];
        solve(&diag, &lower, &upper, &mut b, &mut scratch);
        for i in 0..4 {
            assert!((b[i] - x[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn one_by_one() {
        let mut b = [3.0];
        solve(&[2.0], &[], &[], &mut b, &mut [0.0]);
        assert_eq!(b[0], 1.5);
    }
}
