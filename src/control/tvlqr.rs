//! Time-varying LQR along a plan, then the LQR at its target.
//!
//! Along the plan the deviation is measured in the chart about each planned state,
//! `d_k = local(y_k, y)`, and the discrete Riccati recursion
//!
//! `K_k = (R_d + B_k^T P_(k+1) B_k)^-1 B_k^T P_(k+1) A_k`,
//! `P_k = Q_d + A_k^T P_(k+1) (A_k - B_k K_k)`
//!
//! runs backwards on the exact step Jacobians from `P_K`, the target's Riccati solution
//! (`Q_d = Q dt`, `R_d = R dt` with the planner's running weights, so that the
//! recursion ends on its own continuous-time limit). The force is `u = clamp(u_k - K_k
//! d_k)`; after the plan, `u = clamp(-K local(target, y))` with the target's LQR gain
//! `K = R^-1 B^T P` in the same chart.

use super::chart::{local, ChartPoint};
use super::cost::{diagonal_weights, target_lqr, CostWeights};
use super::jacobian::{StepModel, StepWorkspace};
use super::plan::Plan;
use super::vector::ScalarGeometry;
use crate::error::{check_len, ChainError, Result};
use crate::model::Chain;
use nalgebra::{DMatrix, DVector};

/// The tracking controller of one plan.
#[derive(Debug, Clone)]
pub struct Tracker<G: ScalarGeometry> {
    points: Vec<ChartPoint>,
    forces: Vec<f64>,
    gains: Vec<DMatrix<f64>>,
    target: ChartPoint,
    target_gain: DMatrix<f64>,
    max_force: f64,
    state_dim: usize,
    delta: Vec<f64>,
    _g: std::marker::PhantomData<G>,
}

impl<G: ScalarGeometry> Tracker<G> {
    /// TVLQR along `plan` (planned for `chain` with the step `model`), with the running
    /// `weights` and the force limit `max_force`.
    pub fn new(
        chain: &Chain<G>,
        plan: &Plan,
        model: &StepModel<G>,
        weights: &CostWeights,
        max_force: f64,
    ) -> Result<Self> {
        let dim = chain.state_dim();
        let n = chain.n_links();
        let nu = G::CART;
        let k_steps = plan.forces.len() / nu;
        check_len("plan.states", &plan.states, (k_steps + 1) * dim)?;
        let points: Vec<ChartPoint> = plan
            .states
            .chunks(dim)
            .map(|y| ChartPoint::new::<G>(n, y))
            .collect();
        let (p_target, target_gain) = target_lqr(chain, &plan.target, weights)?;
        let nz = model.chart().dim();
        let dt = model.dt;
        let q = diagonal_weights::<G>(n, weights) * dt;
        let r = DMatrix::<f64>::identity(nu, nu) * (weights.force * dt);
        let mut ws: StepWorkspace<G> = model.workspace();
        let (mut a, mut b) = (DMatrix::zeros(nz, nz), DMatrix::zeros(nz, nu));
        let mut p = p_target;
        let mut gains = vec![DMatrix::zeros(nu, nz); k_steps];
        for k in (0..k_steps).rev() {
            model.jacobians(
                &points[k],
                &plan.forces[k * nu..(k + 1) * nu],
                &points[k + 1],
                &mut a,
                &mut b,
                &mut ws,
            );
            let pb = &p * &b;
            let s = &r + b.transpose() * &pb;
            let s_inv = s.try_inverse().ok_or_else(|| ChainError::Analysis {
                reason: format!("TVLQR: R + B^T P B is singular at step {k}"),
            })?;
            let gain = &s_inv * pb.transpose() * &a;
            let closed = &a - &b * &gain;
            let next = &q + a.transpose() * &p * closed;
            p = (&next + next.transpose()) * 0.5;
            gains[k] = gain;
        }
        let target = ChartPoint::new::<G>(n, &chain.equilibrium(&plan.target)?);
        Ok(Self {
            points,
            forces: plan.forces.clone(),
            gains,
            target,
            target_gain,
            max_force,
            state_dim: dim,
            delta: vec![0.0; nz],
            _g: std::marker::PhantomData,
        })
    }

    /// Length of a force.
    pub fn force_dim(&self) -> usize {
        G::CART
    }
    /// Number of planned steps.
    pub fn steps(&self) -> usize {
        self.gains.len()
    }
    /// The gain at step `k` (`force_dim x nz`).
    pub fn gain(&self, k: usize) -> &DMatrix<f64> {
        &self.gains[k]
    }
    /// The LQR gain at the target.
    pub fn target_gain(&self) -> &DMatrix<f64> {
        &self.target_gain
    }
    /// The planned state at step `k`.
    pub fn planned_state(&self, k: usize) -> &[f64] {
        &self.points[k.min(self.points.len() - 1)].y
    }

    /// The force at control step `k` (the plan's time index) in state `y` (length
    /// checked by the caller), clamped to the force limit.
    pub fn force(&mut self, k: usize, y: &[f64], out: &mut [f64]) {
        debug_assert_eq!(y.len(), self.state_dim);
        let nu = G::CART;
        let (gain, base, feedforward) = if k < self.gains.len() {
            (
                &self.gains[k],
                &self.points[k],
                &self.forces[k * nu..(k + 1) * nu],
            )
        } else {
            (&self.target_gain, &self.target, &[0.0, 0.0][..nu])
        };
        local::<G, f64>(base, y, &mut self.delta);
        let u = gain * DVector::from_column_slice(&self.delta);
        for j in 0..nu {
            out[j] = (feedforward[j] - u[j]).clamp(-self.max_force, self.max_force);
        }
    }
}
