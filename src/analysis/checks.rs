//! Validation of the dense matrices users hand to the analysis code.
//!
//! Each check fails with a message that names the matrix, the offending value and
//! what was expected, so that a wrong weight or a transposed input is found at once
//! instead of surfacing as a non-convergent iteration later.

use crate::error::{ChainError, Result};
use nalgebra::{DMatrix, SymmetricEigen};

/// Relative tolerance for "symmetric": `|a_ij - a_ji| <= SYMMETRY_TOLERANCE * max|a|`.
/// Loose enough for matrices assembled in floating point, tight enough to catch a
/// non-symmetric weight passed by mistake.
pub const SYMMETRY_TOLERANCE: f64 = 1e-10;

/// Relative tolerance for semi-definiteness: the smallest eigenvalue may be this much
/// (times the largest magnitude) below zero and still count as zero.
pub const DEFINITENESS_TOLERANCE: f64 = 1e-12;

fn analysis(reason: String) -> ChainError {
    ChainError::Analysis { reason }
}

/// `m` must be `rows x cols`.
pub fn check_shape(name: &str, m: &DMatrix<f64>, rows: usize, cols: usize) -> Result<()> {
    if m.nrows() == rows && m.ncols() == cols {
        Ok(())
    } else {
        Err(analysis(format!(
            "{name} is {}x{}, expected {rows}x{cols}",
            m.nrows(),
            m.ncols()
        )))
    }
}

/// `m` must be square and non-empty; returns its size.
pub fn check_square(name: &str, m: &DMatrix<f64>) -> Result<usize> {
    if m.nrows() == m.ncols() && m.nrows() > 0 {
        Ok(m.nrows())
    } else {
        Err(analysis(format!(
            "{name} is {}x{}, expected a non-empty square matrix",
            m.nrows(),
            m.ncols()
        )))
    }
}

/// Every entry of `m` must be finite.
pub fn check_finite_matrix(name: &str, m: &DMatrix<f64>) -> Result<()> {
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            let v = m[(i, j)];
            if !v.is_finite() {
                return Err(analysis(format!(
                    "{name}[{i}, {j}] = {v}: expected a finite number"
                )));
            }
        }
    }
    Ok(())
}

/// `m` must equal its transpose up to [`SYMMETRY_TOLERANCE`] (relative).
pub fn check_symmetric(name: &str, m: &DMatrix<f64>) -> Result<()> {
    let scale = m.amax().max(f64::MIN_POSITIVE);
    for j in 0..m.ncols() {
        for i in 0..j {
            let (a, b) = (m[(i, j)], m[(j, i)]);
            if (a - b).abs() > SYMMETRY_TOLERANCE * scale {
                return Err(analysis(format!(
                    "{name} is not symmetric: {name}[{i}, {j}] = {a} but {name}[{j}, {i}] = {b}"
                )));
            }
        }
    }
    Ok(())
}

/// Smallest eigenvalue of the symmetric part of `m`.
pub fn min_symmetric_eigenvalue(m: &DMatrix<f64>) -> f64 {
    let sym = (m + m.transpose()) * 0.5;
    SymmetricEigen::new(sym).eigenvalues.min()
}

/// Symmetric and positive semi-definite (the state weight `Q`).
pub fn check_psd(name: &str, m: &DMatrix<f64>) -> Result<()> {
    check_symmetric(name, m)?;
    let low = min_symmetric_eigenvalue(m);
    if low < -DEFINITENESS_TOLERANCE * m.amax() {
        return Err(analysis(format!(
            "{name} has eigenvalue {low:e}: expected a positive semi-definite matrix"
        )));
    }
    Ok(())
}

/// Symmetric and positive definite (the input weight `R`).
pub fn check_pd(name: &str, m: &DMatrix<f64>) -> Result<()> {
    check_symmetric(name, m)?;
    let low = min_symmetric_eigenvalue(m);
    if low.is_nan() || low <= DEFINITENESS_TOLERANCE * m.amax() {
        return Err(analysis(format!(
            "{name} has eigenvalue {low:e}: expected a positive definite matrix"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_matrix_and_the_value() {
        let q = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 0.0, 1.0]);
        let e = check_symmetric("Q", &q).unwrap_err().to_string();
        assert!(
            e.contains("Q[0, 1] = 2") && e.contains("Q[1, 0] = 0"),
            "{e}"
        );
        let r = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        let e = check_pd("R", &r).unwrap_err().to_string();
        assert!(e.contains("R has eigenvalue -1") && e.contains("positive definite"));
        let e = check_shape("B", &r, 3, 2).unwrap_err().to_string();
        assert_eq!(e, "B is 2x2, expected 3x2");
        let mut bad = DMatrix::<f64>::identity(2, 2);
        bad[(1, 0)] = f64::NAN;
        let e = check_finite_matrix("A", &bad).unwrap_err().to_string();
        assert!(e.contains("A[1, 0] = NaN"), "{e}");
        assert!(check_psd("Q", &DMatrix::zeros(3, 3)).is_ok());
        assert!(check_pd("R", &DMatrix::zeros(1, 1)).is_err());
    }
}
