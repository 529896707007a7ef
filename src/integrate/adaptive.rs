//! Dormand-Prince 5(4) with error control: the reference method.
//!
//! Local error is estimated from the embedded 4th-order solution and kept below
//! `tolerance * (1 + |y|)` per component (RMS norm); after each accepted step the
//! state is projected back onto the constraints.

use super::{StepOptions, Stepper};
use crate::error::{ChainError, IntegrationFailure, Result};
use crate::geometry::Geometry;
use crate::model::Chain;

const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// 5th-order weights (equal to the last row of A: first same as last).
const B5: [f64; 7] = [
    35.0 / 384.0,
    0.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
    0.0,
];
/// 4th-order embedded weights.
const B4: [f64; 7] = [
    5179.0 / 57600.0,
    0.0,
    7571.0 / 16695.0,
    393.0 / 640.0,
    -92097.0 / 339200.0,
    187.0 / 2100.0,
    1.0 / 40.0,
];
const MAX_STEPS: usize = 1_000_000;

/// Tries one step of size h from `y`; leaves the 5th-order result in `s.rk.trial` and
/// returns the scaled error norm.
fn try_step<G: Geometry>(
    chain: &Chain<G>,
    s: &mut Stepper<G>,
    y: &[f64],
    u: G::Cart,
    h: f64,
    tol: f64,
) -> f64 {
    let dim = y.len();
    chain.derivative(y, u, &mut s.ws, &mut s.rk.stages[0]);
    for (stage, row) in A.iter().enumerate().skip(1) {
        let (done, rest) = s.rk.stages.split_at_mut(stage);
        let tmp = &mut s.rk.base;
        for (j, t) in tmp.iter_mut().enumerate() {
            *t = y[j] + h * done.iter().zip(row).map(|(k, a)| a * k[j]).sum::<f64>();
        }
        chain.derivative(tmp, u, &mut s.ws, &mut rest[0]);
    }
    s.stats.evaluations += 7;
    // The 7th stage was evaluated at the 5th-order solution (FSAL row), kept in s.rk.base.
    s.rk.trial.copy_from_slice(&s.rk.base);
    let mut sum = 0.0;
    for (j, (y0, y1)) in y.iter().zip(&s.rk.trial).enumerate() {
        let err: f64 =
            s.rk.stages
                .iter()
                .zip(B5.iter().zip(&B4))
                .map(|(k, (b5, b4))| (b5 - b4) * k[j])
                .sum::<f64>()
                * h;
        let scale = tol * (1.0 + y0.abs().max(y1.abs()));
        sum += (err / scale).powi(2);
    }
    (sum / dim as f64).sqrt()
}

pub(super) fn integrate<G: Geometry>(
    chain: &Chain<G>,
    s: &mut Stepper<G>,
    y: &mut [f64],
    u: G::Cart,
    dt: f64,
    opts: &StepOptions,
) -> Result<()> {
    let mut t = 0.0;
    let mut h = dt / opts.substeps as f64;
    while t < dt {
        if s.stats.accepted_steps + s.stats.rejected_steps >= MAX_STEPS {
            return Err(ChainError::integration(
                t,
                IntegrationFailure::TooManySteps { limit: MAX_STEPS },
            ));
        }
        let last = t + h >= dt;
        if last {
            h = dt - t;
        }
        let err = try_step(chain, s, y, u, h, opts.tolerance);
        if !err.is_finite() {
            // Blow-up inside the trial: shrink hard, and give up if h underflows.
            h *= 0.1;
            s.stats.rejected_steps += 1;
            if h < dt * 1e-14 {
                return Err(ChainError::integration(
                    t,
                    IntegrationFailure::StepSizeUnderflow,
                ));
            }
            continue;
        }
        if err <= 1.0 {
            y.copy_from_slice(&s.rk.trial);
            chain.project(y);
            t = if last { dt } else { t + h };
            s.stats.accepted_steps += 1;
        } else {
            s.stats.rejected_steps += 1;
        }
        let factor = if err == 0.0 {
            5.0
        } else {
            (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
        };
        h *= factor;
        if h < dt * 1e-14 {
            return Err(ChainError::integration(
                t,
                IntegrationFailure::StepSizeUnderflow,
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stage times (not needed by an autonomous-in-time step, only checked here).
    const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];

    #[test]
    fn tableau_is_consistent() {
        for (row, c) in A.iter().zip(C) {
            let sum: f64 = row.iter().sum();
            assert!((sum - c).abs() < 1e-15);
        }
        assert!((B5.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!((B4.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }
}
