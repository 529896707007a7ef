//! The failure guard of one control step: when a step counts as failed
//! ([`Guard`], [`StepStatus`]) and a [`Stepper`] that undoes a failed step
//! ([`GuardedStepper`]). Every path that steps envs (single simulations, the per-env
//! path of a batch, the lane kernel) judges a step by these rules.

use super::{Method, StepOptions, Stepper};
use crate::error::{check_positive, Result};
use crate::geometry::{Geometry, Vector};
use crate::model::Chain;

/// Outcome of the last step of one env.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum StepStatus {
    #[default]
    /// The step succeeded.
    Ok = 0,
    /// The state became NaN or infinite; the env keeps its last good state.
    NonFinite = 1,
    /// `| |q_i| - 1 |` exceeded the failure tolerance; the env keeps its last good state.
    ConstraintViolation = 2,
    /// An implicit solve or step-size control gave up; the env keeps its last good state.
    SolverFailure = 3,
    /// A link turned more than [`Guard::max_turn_per_step`] in one integrator step: the motion
    /// is too fast for the step size and the result would be finite but wrong.
    Unresolved = 4,
}

/// Default largest angle (rad) a link may turn in one integrator step before the
/// step is flagged [`StepStatus::Unresolved`]. At this angle a 4th-order step already errs
/// by about a percent; beyond it explicit methods return finite garbage.
pub const MAX_TURN_PER_STEP: f64 = 0.5;

impl StepStatus {
    /// Whether the step failed (the env kept its last good state).
    pub fn is_failure(self) -> bool {
        self != StepStatus::Ok
    }
    /// What happened, in words, for messages.
    pub fn describe(self) -> &'static str {
        match self {
            StepStatus::Ok => "ok",
            StepStatus::NonFinite => "non-finite state",
            StepStatus::ConstraintViolation => "constraint violation (|q_i| drifted from 1)",
            StepStatus::SolverFailure => "integrator failed (Newton or step-size control)",
            StepStatus::Unresolved => {
                "motion too fast for the step size (a link turned further than Guard::max_turn_per_step in one integrator step)"
            }
        }
    }
}

/// When a step counts as failed (see [`StepStatus`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guard {
    /// Largest tolerated `| |q_i| - 1 |` after a step.
    pub unit_length_tolerance: f64,
    /// Largest angle (rad) a link may turn in one integrator step.
    pub max_turn_per_step: f64,
}

impl Default for Guard {
    fn default() -> Self {
        Self {
            unit_length_tolerance: 1e-6,
            max_turn_per_step: MAX_TURN_PER_STEP,
        }
    }
}

impl Guard {
    /// Checks every tolerance (finite, > 0).
    pub fn validate(&self) -> Result<()> {
        check_positive("unit_length_tolerance", self.unit_length_tolerance)?;
        check_positive("max_turn_per_step", self.max_turn_per_step)
    }
}

/// A [`Stepper`] plus a backup of the state, so that a failed step can be undone.
/// Shared by batches and single-state simulations.
#[derive(Debug, Clone)]
pub struct GuardedStepper<G: Geometry> {
    stepper: Stepper<G>,
    backup: Vec<f64>,
}

impl<G: Geometry> GuardedStepper<G> {
    /// Buffers sized for `chain`.
    pub fn new(chain: &Chain<G>) -> Self {
        Self {
            stepper: Stepper::new(chain),
            backup: vec![0.0; chain.state_dim()],
        }
    }

    /// Steps `y` by one control period; on failure `y` keeps its old value and the
    /// status says why.
    pub fn step(
        &mut self,
        chain: &Chain<G>,
        y: &mut [f64],
        force: G::Cart,
        dt: f64,
        opts: &StepOptions,
        guard: &Guard,
    ) -> StepStatus {
        self.backup.copy_from_slice(y);
        let status = match self.stepper.step(chain, y, force, dt, opts) {
            Err(_) => StepStatus::SolverFailure,
            Ok(()) if !y.iter().all(|v| v.is_finite()) => StepStatus::NonFinite,
            Ok(()) if chain.unit_length_residual(y) > guard.unit_length_tolerance => {
                StepStatus::ConstraintViolation
            }
            Ok(())
                if turn_per_step(chain, &self.backup, y, dt, opts, guard.max_turn_per_step)
                    > guard.max_turn_per_step =>
            {
                StepStatus::Unresolved
            }
            Ok(()) => StepStatus::Ok,
        };
        if status.is_failure() {
            y.copy_from_slice(&self.backup);
        }
        status
    }
}

/// Estimated largest angle a link turned in one integrator step: the larger of the
/// end spin times the step and the angle between the old and new link directions
/// spread over the substeps, the latter left out (0) when a cheap bound already puts
/// it within `max_turn` (see [`swept_per_step`]), which leaves the verdict
/// `turn > max_turn` unchanged. The adaptive method controls its own error: 0.
fn turn_per_step<G: Geometry>(
    chain: &Chain<G>,
    old: &[f64],
    new: &[f64],
    dt: f64,
    opts: &StepOptions,
    max_turn: f64,
) -> f64 {
    if opts.method == Method::Adaptive {
        return 0.0;
    }
    let lay = chain.layout();
    let substeps = opts.substeps as f64;
    let chord = (0..lay.n)
        .map(|i| (lay.load_q(new, i) - lay.load_q(old, i)).norm_squared())
        .fold(0.0, f64::max)
        .sqrt();
    (chain.max_spin(new) * dt / substeps).max(swept_per_step(chord, substeps, max_turn))
}

/// The angle between the old and new link directions spread over the substeps,
/// `2 asin(min(chord / 2, 1)) / substeps` (the per-env and the lane guards share it);
/// skipped (0) when `swept <= chord pi / 2` already proves it within `max_turn`, which
/// at resolved step sizes is nearly always and saves the `asin`.
#[inline(always)]
pub(crate) fn swept_per_step(chord: f64, substeps: f64, max_turn: f64) -> f64 {
    if swept_surely_within(chord, max_turn * substeps) {
        return 0.0;
    }
    let swept = 2.0 * (0.5 * chord).min(1.0).asin();
    swept / substeps
}

/// Whether `swept <= chord pi / 2` proves the swept angle `2 asin(min(chord / 2, 1))`
/// within `bound` (the per-step limit times the substeps) without the `asin`.
#[inline(always)]
pub(crate) fn swept_surely_within(chord: f64, bound: f64) -> bool {
    // A relative margin far above the few roundings between the bound and the value.
    chord * std::f64::consts::FRAC_PI_2 * (1.0 + 1e-9) <= bound
}

#[cfg(test)]
mod tests {
    use super::swept_per_step;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The guard's verdict with the exact swept angle, as if no bound were tried.
    fn exact_exceeds(chord: f64, substeps: f64, max_turn: f64) -> bool {
        2.0 * (0.5 * chord).min(1.0).asin() / substeps > max_turn
    }

    #[test]
    fn skipping_the_asin_never_changes_the_turn_verdict() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut skipped = 0;
        for _ in 0..200_000 {
            let substeps = [1.0, 2.0, 4.0, 10.0][rng.random_range(0..4)];
            let max_turn: f64 = rng.random_range(0.01..1.5);
            // Half the chords right at the bound, where a wrong shortcut would show.
            let chord = if rng.random_bool(0.5) {
                let at_bound = max_turn * substeps / std::f64::consts::FRAC_PI_2;
                (at_bound * (1.0 + rng.random_range(-1e-6..1e-6))).min(2.5)
            } else {
                rng.random_range(0.0..2.5)
            };
            let swept = swept_per_step(chord, substeps, max_turn);
            if swept == 0.0 && chord > 0.0 {
                skipped += 1;
            }
            assert_eq!(
                swept > max_turn,
                exact_exceeds(chord, substeps, max_turn),
                "chord {chord}, substeps {substeps}, max_turn {max_turn}"
            );
        }
        // The shortcut is taken, else this test would prove nothing about it.
        assert!(skipped > 10_000, "{skipped}");
    }

    #[test]
    fn the_swept_angle_is_exact_when_the_bound_cannot_decide() {
        // A half-turn chord (2) sweeps pi; far beyond any bound of 0.1 rad per step.
        assert_eq!(swept_per_step(2.0, 1.0, 0.1), std::f64::consts::PI);
        assert_eq!(swept_per_step(2.0, 4.0, 0.1), std::f64::consts::PI / 4.0);
        assert_eq!(swept_per_step(1e-3, 1.0, 0.1), 0.0);
    }
}
