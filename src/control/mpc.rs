//! Receding-horizon iLQR along a plan.
//!
//! At control step `k`, from the measured state, it solves the planner's problem over
//! the next `H` steps (the planner's running cost) with, as terminal cost, the
//! planner's own quadratic value function at step `k + H` of the plan (its cost-to-go
//! from there): from a state on the plan the optimum is the plan itself, and from a
//! disturbed one it is the best return to it within the horizon. Near the plan's end
//! the horizon shrinks to the end (terminal cost: the target's, with its LQR
//! cost-to-go), and after it a short horizon holds the target.
//!
//! **Warm start.** The previous solution shifted by one step (forces and feedback
//! gains; the new last step from the plan), rolled out from the measured state with
//! its feedback: even with no iteration at all, the controller is the plan's
//! time-varying feedback. Then iLQR iterates within the budget (iterations and wall
//! time per step) and the first force is applied.
//!
//! **Why a global plan.** From hanging, a short horizon sees no reason to swing (the
//! force's gradient vanishes there); the plan supplies the swing and its cost-to-go,
//! and the receding horizon supplies robustness to disturbances and model error.

use super::chart::ChartPoint;
use super::cost::Cost;
use super::ilqr::{Ilqr, IlqrOptions, Terminal};
use super::jacobian::StepModel;
use super::vector::ScalarGeometry;
use crate::error::{InputError, Result};
use nalgebra::{DMatrix, DVector};
use std::time::Instant;

/// What a receding-horizon controller follows: a plan with its feedback gains and
/// value function (from the planner's last backward pass), and the target's LQR.
#[derive(Debug, Clone)]
pub struct Reference {
    /// Planned states (`K + 1`).
    pub points: Vec<ChartPoint>,
    /// Planned forces (`K` steps).
    pub forces: Vec<f64>,
    /// Feedback gains (`K`).
    pub gains: Vec<DMatrix<f64>>,
    /// Value gradient and Hessian at each planned state (`K + 1`).
    pub value_gradient: Vec<DVector<f64>>,
    /// See `value_gradient`.
    pub value_hessian: Vec<DMatrix<f64>>,
    /// The target equilibrium.
    pub target: ChartPoint,
    /// The target's LQR gain in the chart (`u = -K local(target, y)`).
    pub target_gain: DMatrix<f64>,
}

impl Reference {
    fn steps(&self) -> usize {
        self.gains.len()
    }
    fn point(&self, i: usize) -> &ChartPoint {
        self.points.get(i).unwrap_or(&self.target)
    }
    fn gain(&self, i: usize) -> &DMatrix<f64> {
        self.gains.get(i).unwrap_or(&self.target_gain)
    }
    fn force(&self, i: usize, nu: usize) -> &[f64] {
        if i < self.steps() {
            &self.forces[i * nu..(i + 1) * nu]
        } else {
            &[0.0, 0.0][..nu]
        }
    }
}

/// Horizon and compute budget of [`Mpc`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MpcOptions {
    /// Steps looked ahead (>= 1).
    pub horizon: usize,
    /// Steps looked ahead after the plan's end (>= 1, at most `horizon`).
    pub hold_horizon: usize,
    /// iLQR iterations per control step (>= 1).
    pub iterations: usize,
    /// Wall time per control step, s (> 0; `inf`: none, the iterations alone bound
    /// the work).
    pub budget: f64,
}

impl Default for MpcOptions {
    fn default() -> Self {
        Self {
            horizon: 40,
            hold_horizon: 25,
            iterations: 2,
            budget: 0.002,
        }
    }
}

impl MpcOptions {
    /// Checks the options, naming a bad one.
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("horizon", self.horizon),
            ("hold_horizon", self.hold_horizon),
            ("iterations", self.iterations),
        ] {
            if value == 0 {
                return Err(InputError::InvalidParameter {
                    name,
                    value: 0.0,
                    expected: "an integer >= 1",
                }
                .into());
            }
        }
        if self.hold_horizon > self.horizon {
            return Err(InputError::InvalidParameter {
                name: "hold_horizon",
                value: self.hold_horizon as f64,
                expected: "at most horizon",
            }
            .into());
        }
        super::ilqr::check_budget("budget", self.budget)
    }
}

/// Work done by the last [`Mpc::force`] call.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MpcStats {
    /// iLQR iterations.
    pub iterations: usize,
    /// Wall time, s.
    pub seconds: f64,
    /// Steps looked ahead.
    pub horizon: usize,
}

/// The receding-horizon controller.
#[derive(Debug, Clone)]
pub struct Mpc<G: ScalarGeometry> {
    solver: Ilqr<G>,
    reference: Reference,
    options: MpcOptions,
    last_step: Option<usize>,
    /// Statistics of the last call.
    pub stats: MpcStats,
}

impl<G: ScalarGeometry> Mpc<G> {
    /// A controller following `reference` with the planner's step `model` and `cost`.
    pub fn new(
        model: StepModel<G>,
        cost: Cost<G>,
        reference: Reference,
        max_force: f64,
        options: MpcOptions,
    ) -> Result<Self> {
        options.validate()?;
        Ok(Self {
            solver: Ilqr::new(model, cost, options.horizon, max_force),
            reference,
            options,
            last_step: None,
            stats: MpcStats::default(),
        })
    }

    /// Forgets the warm start (a new episode).
    pub fn reset(&mut self) {
        self.last_step = None;
    }

    /// Length of a state.
    pub fn state_dim(&self) -> usize {
        self.solver.model().state_dim()
    }
    /// Length of a force.
    pub fn force_dim(&self) -> usize {
        G::CART
    }
    /// The options.
    pub fn options(&self) -> &MpcOptions {
        &self.options
    }

    /// The force at control step `k` of the plan's clock in state `y` (checked by the
    /// caller: length, finite).
    pub fn force(&mut self, k: usize, y: &[f64], out: &mut [f64]) {
        let began = Instant::now();
        let nu = G::CART;
        let plan_steps = self.reference.steps();
        let (h, terminal) = if k + self.options.horizon <= plan_steps {
            let end = k + self.options.horizon;
            (
                self.options.horizon,
                Terminal::Quadratic {
                    point: self.reference.points[end].clone(),
                    value: 0.0,
                    gradient: self.reference.value_gradient[end].clone(),
                    hessian: self.reference.value_hessian[end].clone(),
                },
            )
        } else {
            (
                plan_steps.saturating_sub(k).max(self.options.hold_horizon),
                Terminal::Target,
            )
        };
        let previous = self.solver.horizon();
        let warm = self.last_step == Some(k.wrapping_sub(1)) && k > 0;
        if warm && (h == previous || h + 1 == previous) {
            let end = k + previous;
            let (point, gain) = (
                self.reference.point(end).clone(),
                self.reference.gain(end - 1).clone(),
            );
            let force = self.reference.force(end - 1, nu).to_vec();
            self.solver.shift(&point, &force, &gain);
            self.solver.set_horizon(h);
        } else {
            let points: Vec<ChartPoint> = (k..=k + h)
                .map(|i| self.reference.point(i).clone())
                .collect();
            let forces: Vec<f64> = (k..k + h)
                .flat_map(|i| self.reference.force(i, nu).to_vec())
                .collect();
            let gains: Vec<DMatrix<f64>> =
                (k..k + h).map(|i| self.reference.gain(i).clone()).collect();
            self.solver.load(&points, &forces, &gains);
        }
        self.solver.set_terminal(terminal);
        self.solver.rollout_with_feedback(y, 0.0);
        self.solver.accept_candidate();
        let options = IlqrOptions {
            max_iterations: self.options.iterations,
            deadline: super::ilqr::deadline_after(began, self.options.budget),
            ..IlqrOptions::default()
        };
        if self.solver.nominal.cost.is_finite() {
            self.solver.solve(y, &options);
        }
        out[..nu].copy_from_slice(self.solver.first_force());
        self.last_step = Some(k);
        self.stats = MpcStats {
            iterations: self.solver.iterations,
            seconds: began.elapsed().as_secs_f64(),
            horizon: h,
        };
    }
}
