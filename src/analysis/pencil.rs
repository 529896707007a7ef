//! The symmetric-definite generalized eigenproblem `K v = mu M v` (`K` symmetric,
//! `M` symmetric positive definite).
//!
//! Both the eigenvalues of the linearisation (`lambda^2 = -mu` for `K = G`) and the
//! controllability test (Prop. 3) need it. Reducing through the Cholesky factor
//! `M = L L^T` to the ordinary symmetric problem `L^-1 K L^-T u = mu u` keeps the
//! symmetry (real eigenvalues, orthogonal eigenvectors) that a general eigen-solver on
//! `M^-1 K` would throw away, and with it the exact multiplicities the test relies on.

use crate::analysis::checks::{check_finite_matrix, check_square, check_symmetric};
use crate::error::{ChainError, Result};
use nalgebra::{Cholesky, DMatrix, DVector, SymmetricEigen};
use std::ops::Range;

/// Eigenvalues in ascending order with eigenvectors normalised in the `M`-norm
/// (`V^T M V = I`), one column per eigenvalue.
#[derive(Debug, Clone)]
pub struct PencilEigen {
    /// Eigenvalues, ascending.
    pub values: DVector<f64>,
    /// Eigenvectors, one column per eigenvalue, `M`-orthonormal.
    pub vectors: DMatrix<f64>,
}

fn analysis(reason: String) -> ChainError {
    ChainError::Analysis { reason }
}

/// Solves `K v = mu M v`. Fails if `M` is not positive definite or the shapes differ.
pub fn solve_pencil(k: &DMatrix<f64>, m: &DMatrix<f64>) -> Result<PencilEigen> {
    let n = check_square("K", k)?;
    if check_square("M", m)? != n {
        return Err(analysis(format!(
            "M is {}x{} but K is {n}x{n}: expected the same size",
            m.nrows(),
            m.ncols()
        )));
    }
    check_finite_matrix("K", k)?;
    check_finite_matrix("M", m)?;
    check_symmetric("K", k)?;
    check_symmetric("M", m)?;
    let l = Cholesky::new(m.clone())
        .ok_or_else(|| analysis("M is not positive definite: Cholesky failed".into()))?
        .unpack();
    // S = L^-1 K L^-T, computed as L^-1 (L^-1 K)^T since K is symmetric.
    let left = l
        .solve_lower_triangular(k)
        .ok_or_else(|| analysis("Cholesky factor of M is singular".into()))?;
    let s = l
        .solve_lower_triangular(&left.transpose())
        .ok_or_else(|| analysis("Cholesky factor of M is singular".into()))?;
    let s = (&s + s.transpose()) * 0.5;
    let eig = SymmetricEigen::new(s);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let values = DVector::from_iterator(n, order.iter().map(|&j| eig.eigenvalues[j]));
    let u = DMatrix::from_fn(n, n, |i, c| eig.eigenvectors[(i, order[c])]);
    let vectors = l
        .transpose()
        .solve_upper_triangular(&u)
        .ok_or_else(|| analysis("Cholesky factor of M is singular".into()))?;
    Ok(PencilEigen { values, vectors })
}

/// Groups ascending eigenvalues into clusters whose neighbours differ by at most
/// `rel_tol * max|value|`: numerically equal eigenvalues, whose eigenvectors are only
/// determined as a subspace. Returns index ranges into `values`.
pub fn clusters(values: &DVector<f64>, rel_tol: f64) -> Vec<Range<usize>> {
    let scale = values.amax();
    let mut out = Vec::new();
    let mut start = 0;
    for j in 1..=values.len() {
        if j == values.len() || values[j] - values[j - 1] > rel_tol * scale {
            out.push(start..j);
            start = j;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_known_pencil() {
        // K = diag(2, 12), M = diag(1, 4): mu = 2, 3 with v = e1, e2 / 2.
        let k = DMatrix::from_diagonal(&DVector::from_vec(vec![12.0, 2.0]));
        let m = DMatrix::from_diagonal(&DVector::from_vec(vec![4.0, 1.0]));
        let e = solve_pencil(&k, &m).unwrap();
        assert!((e.values[0] - 2.0).abs() < 1e-14 && (e.values[1] - 3.0).abs() < 1e-14);
        let vtmv = e.vectors.transpose() * &m * &e.vectors;
        assert!((vtmv - DMatrix::identity(2, 2)).amax() < 1e-14);
        let residual = &k * &e.vectors - &m * &e.vectors * DMatrix::from_diagonal(&e.values);
        assert!(residual.amax() < 1e-13);
        assert!(solve_pencil(&k, &(-m)).is_err());
    }

    #[test]
    fn clusters_group_equal_values() {
        let v = DVector::from_vec(vec![-1.0, -1.0 + 1e-14, 0.5, 2.0, 2.0, 2.0]);
        assert_eq!(clusters(&v, 1e-10), vec![0..2, 2..3, 3..6]);
    }
}
