//! The box-constrained quadratic program of the control-limited backward pass
//! (Tassa, Mansard & Todorov 2014): `min d^T H d / 2 + g^T d` over `lo <= d <= hi`, for
//! one or two inputs, solved exactly.
//!
//! With one input the minimiser is the clamped Newton step. With two, the minimiser of
//! a convex quadratic over a rectangle lies in its interior, on one of its four edges
//! (a one-dimensional clamped minimisation) or at a corner, so the best of those nine
//! candidates is the exact solution. The inputs strictly inside their bounds are the
//! free set: the feedback gain acts on them only.

use nalgebra::{DMatrix, DVector};

/// The solution: the step and which inputs are free.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxSolution {
    /// The minimiser (first `m` entries).
    pub step: [f64; 2],
    /// Whether each input is strictly inside its bounds.
    pub free: [bool; 2],
}

/// Minimises `d^T H d / 2 + g^T d` over `lo <= d <= hi` (`H` is `m x m`, `m` 1 or 2);
/// `None` when `H` is not positive definite (the caller regularises and retries).
pub fn solve_box_qp(
    h: &DMatrix<f64>,
    g: &DVector<f64>,
    lo: &[f64],
    hi: &[f64],
) -> Option<BoxSolution> {
    match h.nrows() {
        1 => one(h[(0, 0)], g[0], lo[0], hi[0]),
        2 => two(h, g, lo, hi),
        m => panic!("box QP for {m} inputs: only 1 or 2 are supported"),
    }
}

fn one(h: f64, g: f64, lo: f64, hi: f64) -> Option<BoxSolution> {
    // Also refuses a NaN curvature.
    if h.is_nan() || h <= 0.0 {
        return None;
    }
    let d = -g / h;
    let step = d.clamp(lo, hi);
    Some(BoxSolution {
        step: [step, 0.0],
        free: [d > lo && d < hi, false],
    })
}

fn two(h: &DMatrix<f64>, g: &DVector<f64>, lo: &[f64], hi: &[f64]) -> Option<BoxSolution> {
    let (a, b, c) = (h[(0, 0)], h[(0, 1)], h[(1, 1)]);
    let det = a * c - b * b;
    if !(a > 0.0 && det > 0.0) {
        return None;
    }
    let objective = |d: [f64; 2]| {
        0.5 * (a * d[0] * d[0] + 2.0 * b * d[0] * d[1] + c * d[1] * d[1])
            + g[0] * d[0]
            + g[1] * d[1]
    };
    let inside = |d: [f64; 2]| (0..2).all(|i| d[i] > lo[i] && d[i] < hi[i]);
    let interior = [(-c * g[0] + b * g[1]) / det, (b * g[0] - a * g[1]) / det];
    if inside(interior) {
        return Some(BoxSolution {
            step: interior,
            free: [true, true],
        });
    }
    let diag = [a, c];
    let mut best: Option<([f64; 2], f64)> = None;
    for fixed in 0..2 {
        let other = 1 - fixed;
        for bound in [lo[fixed], hi[fixed]] {
            // Minimise over the other input with this one at its bound.
            let mut d = [0.0; 2];
            d[fixed] = bound;
            d[other] = (-(g[other] + b * bound) / diag[other]).clamp(lo[other], hi[other]);
            let value = objective(d);
            if best.is_none_or(|(_, v)| value < v) {
                best = Some((d, value));
            }
        }
    }
    let (step, _) = best.expect("four candidates");
    Some(BoxSolution {
        step,
        free: [
            step[0] > lo[0] && step[0] < hi[0],
            step[1] > lo[1] && step[1] < hi[1],
        ],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn two_inputs_match_a_fine_grid_search() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for _ in 0..200 {
            let m = DMatrix::from_fn(2, 2, |_, _| rng.random_range(-1.0..1.0));
            let h = &m * m.transpose() + DMatrix::identity(2, 2) * 0.05;
            let g = DVector::from_fn(2, |_, _| rng.random_range(-3.0..3.0));
            let lo = [rng.random_range(-2.0..0.0), rng.random_range(-2.0..0.0)];
            let hi = [rng.random_range(0.0..2.0), rng.random_range(0.0..2.0)];
            let sol = solve_box_qp(&h, &g, &lo, &hi).unwrap();
            let f = |d: [f64; 2]| {
                let v = DVector::from_row_slice(&d);
                0.5 * (v.transpose() * &h * &v)[0] + g.dot(&v)
            };
            let mut grid_best = f64::INFINITY;
            let steps = 400;
            for i in 0..=steps {
                for j in 0..=steps {
                    let d = [
                        lo[0] + (hi[0] - lo[0]) * i as f64 / steps as f64,
                        lo[1] + (hi[1] - lo[1]) * j as f64 / steps as f64,
                    ];
                    grid_best = grid_best.min(f(d));
                }
            }
            assert!(f(sol.step) <= grid_best + 1e-12, "{sol:?}");
            assert!((0..2).all(|i| sol.step[i] >= lo[i] && sol.step[i] <= hi[i]));
        }
    }

    #[test]
    fn one_input_is_the_clamped_newton_step_and_indefinite_is_refused() {
        let h = DMatrix::from_element(1, 1, 2.0);
        let sol = solve_box_qp(&h, &DVector::from_element(1, -10.0), &[-1.0], &[3.0]).unwrap();
        assert_eq!((sol.step[0], sol.free[0]), (3.0, false));
        let sol = solve_box_qp(&h, &DVector::from_element(1, -1.0), &[-1.0], &[3.0]).unwrap();
        assert_eq!((sol.step[0], sol.free[0]), (0.5, true));
        assert!(solve_box_qp(&-h, &DVector::from_element(1, 1.0), &[-1.0], &[1.0]).is_none());
        let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(solve_box_qp(&indefinite, &DVector::zeros(2), &[-1.0; 2], &[1.0; 2]).is_none());
    }
}
