//! Cost against the number of links, timed in Rust (no caller overhead): one
//! acceleration evaluation of the O(n) tension form and of the paper's dense form
//! (eq. ELwm, an LU solve), and one rk4 step of the O(n) form, each on a moving
//! spatial chain. Used by `examples/scaling.rs` and the Python `bench` command.

use crate::dense::dense_derivative;
use crate::error::{ChainError, InputError, Result};
use crate::{ChainParams, Method, SpatialChain, StepOptions, Stepper};
use nalgebra::Vector2;
use std::hint::black_box;
use std::time::Instant;

/// What is timed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Form {
    /// Accelerations of the O(n) tension form.
    Fast,
    /// Accelerations of the dense form (LU solve of the paper's system).
    Dense,
    /// One rk4 step (dt = 1 ms) of the O(n) form.
    FastRk4Step,
}

impl Form {
    /// Every form.
    pub const ALL: [Form; 3] = [Form::Fast, Form::Dense, Form::FastRk4Step];

    /// The form's name.
    pub fn name(self) -> &'static str {
        match self {
            Form::Fast => "fast",
            Form::Dense => "dense",
            Form::FastRk4Step => "fast_rk4_step",
        }
    }

    /// The form with this name, or an error listing the names.
    pub fn from_name(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| {
                InputError::UnknownName {
                    kind: "form",
                    name: name.to_string(),
                    expected: &["fast", "dense", "fast_rk4_step"],
                }
                .into()
            })
    }
}

/// A spatial state of `chain` with every link tilted differently and spinning.
pub fn moving_state(chain: &SpatialChain) -> Vec<f64> {
    let n = chain.n_links();
    let mut y = vec![0.0; chain.state_dim()];
    for i in 0..n {
        let a = 0.3 + 0.2 * i as f64;
        y[4 + 3 * i] = a.sin();
        y[4 + 3 * i + 1] = 0.1;
        y[4 + 3 * i + 2] = a.cos();
        y[4 + 3 * n + 3 * i] = 0.2;
        y[4 + 3 * n + 3 * i + 1] = 0.5;
    }
    chain.project(&mut y);
    y
}

/// Best of 3 runs of the mean time of `f`, each run calling it for at least
/// `min_time` seconds.
pub fn seconds_per_call(min_time: f64, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let (mut calls, mut batch) = (0u64, 1u64);
        let start = Instant::now();
        loop {
            for _ in 0..batch {
                f();
            }
            calls += batch;
            let elapsed = start.elapsed().as_secs_f64();
            if elapsed >= min_time {
                best = best.min(elapsed / calls as f64);
                break;
            }
            batch = (batch * 2).min(1 << 16);
        }
    }
    best
}

/// Seconds per call of `form` for a uniform chain of `n_links` with the paper's cart
/// and links (0.5 kg cart, 0.1 kg and 0.1 m links) on one core.
pub fn time_form(form: Form, n_links: usize, min_time: f64) -> Result<f64> {
    crate::error::check_positive("min_time", min_time)?;
    let chain = SpatialChain::new(ChainParams::uniform(
        n_links,
        crate::params::PAPER_CART_MASS,
        crate::params::PAPER_LINK_MASS,
        crate::params::PAPER_LINK_LENGTH,
        crate::params::STANDARD_GRAVITY,
    )?);
    let y = moving_state(&chain);
    let u = Vector2::new(0.3, -0.2);
    let mut dy = vec![0.0; chain.state_dim()];
    Ok(match form {
        Form::Fast => {
            let mut ws = chain.workspace();
            seconds_per_call(min_time, || {
                chain.derivative(black_box(&y), u, &mut ws, &mut dy)
            })
        }
        Form::Dense => {
            let params = chain.params().clone();
            dense_derivative(&params, &y, u, &mut dy).ok_or_else(|| ChainError::Analysis {
                reason: format!(
                    "the dense system of {n_links} links is singular on the timing state"
                ),
            })?;
            seconds_per_call(min_time, || {
                let _ = dense_derivative(&params, black_box(&y), u, &mut dy);
            })
        }
        Form::FastRk4Step => {
            let opts = StepOptions {
                method: Method::Rk4,
                ..StepOptions::default()
            };
            let mut stepper = Stepper::new(&chain);
            let mut z = y.clone();
            stepper.step(&chain, &mut z, u, 1e-3, &opts)?;
            seconds_per_call(min_time, || {
                z.copy_from_slice(&y);
                let _ = stepper.step(&chain, &mut z, u, 1e-3, &opts);
            })
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_ones_are_refused() {
        for form in Form::ALL {
            assert_eq!(Form::from_name(form.name()), Ok(form));
        }
        assert!(Form::from_name("sparse").is_err());
    }

    #[test]
    fn every_form_times_a_positive_duration() {
        for form in Form::ALL {
            let t = time_form(form, 4, 1e-4).unwrap();
            assert!(t.is_finite() && t > 0.0, "{form:?}: {t}");
        }
        assert!(time_form(Form::Fast, 4, 0.0).is_err());
    }

    #[test]
    fn the_moving_state_is_on_the_constraint_manifold() {
        let chain = SpatialChain::new(ChainParams::uniform(3, 0.5, 0.1, 0.1, 9.81).unwrap());
        let y = moving_state(&chain);
        let r = chain.residuals(&y);
        assert!(r.unit_length < 1e-12 && r.tangency < 1e-12, "{r:?}");
    }
}
