//! The Lyapunov equation `F^T X + X F + W = 0` for a Hurwitz `F`, by the sign function.
//!
//! `Z = [[F, 0], [W, -F^T]]` is similar to `diag(F, -F^T)` through `[[I, 0], [-X, I]]`,
//! so `sign(Z) = [[-I, 0], [2X, I]]`. Running the scaled Newton iteration on `Z`
//! block-wise needs only `F^-1`:
//! `F <- (F / c + c F^-1) / 2`, `W <- (W / c + c F^-T W F^-1) / 2`, `X = W_inf / 2`.
//! This costs O(N^3) per step instead of the O(N^6) of the Kronecker form, and needs
//! no Schur reordering. Used by the Newton-Kleinman polish of the Riccati solver.

use crate::analysis::sign::{inverse_and_scale, norm1, MAX_ITERATIONS, TOLERANCE};
use crate::error::{ChainError, Result};
use nalgebra::DMatrix;

/// Solves `F^T X + X F + W = 0`; `F` square and Hurwitz, `W` the same size.
/// Fails (naming the reason) if `F` is singular or has eigenvalues off the open left
/// half-plane (then `sign(F) != -I` and the iteration does not reach `-I`).
pub fn solve_lyapunov(f: &DMatrix<f64>, w: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = f.nrows();
    if f.ncols() != n || w.nrows() != n || w.ncols() != n {
        return Err(ChainError::Analysis {
            reason: format!(
                "Lyapunov equation with F {}x{} and W {}x{}: expected equal square sizes",
                f.nrows(),
                f.ncols(),
                w.nrows(),
                w.ncols()
            ),
        });
    }
    let (mut f, mut w) = (f.clone(), w.clone());
    let mut scaled = true;
    for _ in 0..MAX_ITERATIONS {
        let (inv, c) = inverse_and_scale(&f).ok_or_else(|| ChainError::Analysis {
            reason: "Lyapunov solve: F is singular, expected a Hurwitz matrix".into(),
        })?;
        let c = if scaled { c } else { 1.0 };
        let w_next = (&w / c + inv.transpose() * &w * &inv * c) * 0.5;
        let f_next = (&f / c + inv * c) * 0.5;
        let change = norm1(&(&f_next - &f)) / norm1(&f_next);
        f = f_next;
        w = w_next;
        scaled = change >= 1e-2 && scaled;
        if change <= TOLERANCE {
            let off = (&f + DMatrix::identity(n, n)).amax();
            if off > 1e-8 {
                return Err(ChainError::Analysis {
                    reason: format!(
                        "Lyapunov solve: sign(F) differs from -I by {off:e}: expected F Hurwitz"
                    ),
                });
            }
            let x = w * 0.5;
            return Ok((&x + x.transpose()) * 0.5);
        }
    }
    Err(ChainError::Analysis {
        reason: "Lyapunov solve: sign iteration did not converge (F has eigenvalues on the \
                 imaginary axis?)"
            .into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_and_rejects() {
        let f = DMatrix::from_row_slice(3, 3, &[-1.0, 2.0, 0.0, 0.0, -3.0, 1.0, -0.5, 0.0, -0.2]);
        let w = DMatrix::from_row_slice(3, 3, &[2.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 1.0]);
        let x = solve_lyapunov(&f, &w).unwrap();
        let residual = f.transpose() * &x + &x * &f + &w;
        assert!(residual.amax() < 1e-12 * w.amax(), "{residual}");
        let unstable = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        let e = solve_lyapunov(&unstable, &DMatrix::identity(2, 2)).unwrap_err();
        assert!(e.to_string().contains("Hurwitz"), "{e}");
    }
}
