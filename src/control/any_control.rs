//! The planner and controllers with the scene chosen at run time, on flat slices, every
//! input checked: what front ends (the Python bindings, tools) call.

use super::energy::{EnergyController, EnergyOptions};
use super::mpc::{Mpc, MpcOptions, MpcStats, Reference};
use super::planner::{Plan, PlanOptions, Planner};
use super::tvlqr::Tracker;
use crate::any_chain::AnyChain;
use crate::error::{check_finite, check_len, Result};
use crate::geometry::{Planar, Spatial};

/// A finished plan with what its controllers need.
pub enum AnyPlan {
    /// Of the spatial chain.
    Spatial(Box<PlanParts<Spatial>>),
    /// Of the planar chain.
    Planar(Box<PlanParts<Planar>>),
}

/// A plan, the planner that made it (its model, cost and options) and its reference.
pub struct PlanParts<G: super::vector::ScalarGeometry> {
    /// The plan.
    pub plan: Plan,
    planner: Planner<G>,
    reference: Reference,
}

impl<G: super::vector::ScalarGeometry> PlanParts<G> {
    fn new(
        chain: &crate::model::Chain<G>,
        start: &[f64],
        target: &[f64],
        options: &PlanOptions,
    ) -> Result<Self> {
        let mut planner = Planner::new(chain, target, options)?;
        let plan = planner.plan(start)?;
        let reference = planner.reference()?;
        Ok(Self {
            plan,
            planner,
            reference,
        })
    }
}

/// A tracking controller (TVLQR then LQR) for either scene.
pub enum AnyTracker {
    /// Spatial.
    Spatial(Tracker<Spatial>),
    /// Planar.
    Planar(Tracker<Planar>),
}

/// A receding-horizon controller for either scene.
pub enum AnyMpc {
    /// Spatial.
    Spatial(Box<Mpc<Spatial>>),
    /// Planar.
    Planar(Box<Mpc<Planar>>),
}

/// An energy-shaping controller for either scene.
pub enum AnyEnergy {
    /// Spatial.
    Spatial(EnergyController<Spatial>),
    /// Planar.
    Planar(EnergyController<Planar>),
}

impl AnyPlan {
    /// Plans for `chain` from `start` (a full state) to equilibrium `target`.
    pub fn new(
        chain: &AnyChain,
        start: &[f64],
        target: &[f64],
        options: &PlanOptions,
    ) -> Result<Self> {
        Ok(match chain {
            AnyChain::Spatial(c) => {
                AnyPlan::Spatial(Box::new(PlanParts::new(c, start, target, options)?))
            }
            AnyChain::Planar(c) => {
                AnyPlan::Planar(Box::new(PlanParts::new(c, start, target, options)?))
            }
        })
    }

    /// The plan.
    pub fn plan(&self) -> &Plan {
        dispatch!(AnyPlan, self, p => &p.plan)
    }

    /// The options it was planned with.
    pub fn options(&self) -> &PlanOptions {
        dispatch!(AnyPlan, self, p => p.planner.options())
    }

    /// TVLQR along the plan, then the target's LQR.
    pub fn tracker(&self) -> Result<AnyTracker> {
        Ok(match self {
            AnyPlan::Spatial(p) => AnyTracker::Spatial(p.planner.tracker(&p.plan)?),
            AnyPlan::Planar(p) => AnyTracker::Planar(p.planner.tracker(&p.plan)?),
        })
    }

    /// Receding-horizon iLQR along the plan.
    pub fn mpc(&self, options: MpcOptions) -> Result<AnyMpc> {
        Ok(match self {
            AnyPlan::Spatial(p) => {
                AnyMpc::Spatial(Box::new(p.planner.mpc_from(p.reference.clone(), options)?))
            }
            AnyPlan::Planar(p) => {
                AnyMpc::Planar(Box::new(p.planner.mpc_from(p.reference.clone(), options)?))
            }
        })
    }
}

fn check_state(state: &[f64], dim: usize) -> Result<()> {
    check_len("state", state, dim)?;
    check_finite("state", state)
}

impl AnyTracker {
    /// The force at control step `k` in `state` (checked).
    pub fn force(&mut self, k: usize, state: &[f64]) -> Result<Vec<f64>> {
        dispatch!(AnyTracker, self, t => {
            check_state(state, t.planned_state(0).len())?;
            let mut out = vec![0.0; t.force_dim()];
            t.force(k, state, &mut out);
            Ok(out)
        })
    }
    /// Number of planned steps.
    pub fn steps(&self) -> usize {
        dispatch!(AnyTracker, self, t => t.steps())
    }
}

impl AnyMpc {
    /// The force at control step `k` in `state` (checked).
    pub fn force(&mut self, k: usize, state: &[f64]) -> Result<Vec<f64>> {
        dispatch!(AnyMpc, self, m => {
            check_state(state, m.state_dim())?;
            let mut out = vec![0.0; m.force_dim()];
            m.force(k, state, &mut out);
            Ok(out)
        })
    }
    /// Forgets the warm start.
    pub fn reset(&mut self) {
        dispatch!(AnyMpc, self, m => m.reset())
    }
    /// Work done by the last call.
    pub fn stats(&self) -> MpcStats {
        dispatch!(AnyMpc, self, m => m.stats)
    }
    /// The options.
    pub fn options(&self) -> MpcOptions {
        dispatch!(AnyMpc, self, m => *m.options())
    }
}

impl AnyEnergy {
    /// The controller for `chain` (one link).
    pub fn new(chain: &AnyChain, max_force: f64, options: EnergyOptions) -> Result<Self> {
        let weights = PlanOptions::default().weights;
        Ok(match chain {
            AnyChain::Spatial(c) => {
                AnyEnergy::Spatial(EnergyController::new(c, max_force, options, &weights)?)
            }
            AnyChain::Planar(c) => {
                AnyEnergy::Planar(EnergyController::new(c, max_force, options, &weights)?)
            }
        })
    }
    /// The force in `state` (checked).
    pub fn force(&mut self, state: &[f64]) -> Result<Vec<f64>> {
        dispatch!(AnyEnergy, self, e => {
            check_state(state, e.state_dim())?;
            let mut out = vec![0.0; e.force_dim()];
            e.force(state, &mut out);
            Ok(out)
        })
    }
    /// Whether the LQR is in charge at `state` (checked).
    pub fn catching(&self, state: &[f64]) -> Result<bool> {
        dispatch!(AnyEnergy, self, e => {
            check_state(state, e.state_dim())?;
            Ok(e.catching(state))
        })
    }
}
