//! Diagonal balancing (Parlett & Reinsch 1969): a diagonal `D` of powers of two such
//! that `D^-1 A D` has rows and columns of comparable size.
//!
//! The chain's `A = [[0, I], [-M^-1 G, 0]]` mixes an identity block with stiffness
//! terms of order `g / l_min ~ 1e3-1e4`, and the weights `Q` see positions and
//! velocities alike. Solving the Riccati equation in the balanced state `z = D z~`
//! (`A~ = D^-1 A D`, `B~ = D^-1 B`, `Q~ = D Q D`, `X = D^-1 X~ D^-1`) costs nothing,
//! is exact (powers of two), and buys one to two digits of accuracy on the
//! ill-conditioned upright equilibria.

use nalgebra::{DMatrix, DVector};

/// Sweeps at most; balancing converges in a handful.
const MAX_SWEEPS: usize = 100;

/// The scaling `d` (diagonal of `D`) that balances `a` in the 1-norm.
pub fn balancing_scale(a: &DMatrix<f64>) -> DVector<f64> {
    let n = a.nrows();
    let mut d = DVector::from_element(n, 1.0);
    let mut m = a.clone();
    for _ in 0..MAX_SWEEPS {
        let mut converged = true;
        for i in 0..n {
            let (col, row) = off_diagonal_sums(&m, i);
            // A row or column that is zero off the diagonal (the cart position's
            // column of A, say) has no partner to balance against.
            if col == 0.0 || row == 0.0 {
                continue;
            }
            let f = power_of_two_factor(col, row);
            if (col * f + row / f) < 0.95 * (col + row) {
                converged = false;
                d[i] *= f;
                for j in 0..n {
                    m[(i, j)] /= f;
                    m[(j, i)] *= f;
                }
            }
        }
        if converged {
            break;
        }
    }
    d
}

fn off_diagonal_sums(m: &DMatrix<f64>, i: usize) -> (f64, f64) {
    let (mut col, mut row) = (0.0, 0.0);
    for j in 0..m.nrows() {
        if j != i {
            col += m[(j, i)].abs();
            row += m[(i, j)].abs();
        }
    }
    (col, row)
}

/// The power of two `f` that brings `col * f` and `row / f` within a factor 2.
fn power_of_two_factor(col: f64, row: f64) -> f64 {
    let (mut c, mut r, mut f) = (col, row, 1.0);
    while c < r / 2.0 {
        c *= 2.0;
        r /= 2.0;
        f *= 2.0;
    }
    while c >= r * 2.0 {
        c /= 2.0;
        r *= 2.0;
        f /= 2.0;
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balances_a_lopsided_matrix() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 4096.0, 0.0]);
        let d = balancing_scale(&a);
        let dm = DMatrix::from_diagonal(&d);
        let inv = DMatrix::from_diagonal(&d.map(|v| 1.0 / v));
        let b = &inv * &a * &dm;
        assert!(
            (b[(0, 1)] / b[(1, 0)]).abs() <= 4.0 && (b[(1, 0)] / b[(0, 1)]).abs() <= 4.0,
            "{b}"
        );
        assert!(d.iter().all(|v| v.log2().fract() == 0.0));
    }
}
