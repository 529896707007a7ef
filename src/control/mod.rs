//! Large motions: exact derivatives of the control step, a trajectory planner
//! between any two states and equilibria, and the controllers that follow it.
//!
//! * `dual`: forward-mode automatic differentiation (the `dual::Real` scalars).
//! * `vector`: the scene geometry over any scalar; `dynamics`: the O(n) dynamics and
//!   the RK4 control step written once for values and derivatives.
//! * `chart`: increments on the spheres about any state; `jacobian`: the control
//!   step and its exact derivatives in that chart.
//! * `cost`: the planner's cost; `boxqp` and `ilqr`: control-limited iLQR on the
//!   chart.
//! * `planner`: a [`Plan`] between a state or equilibrium and an equilibrium
//!   (`plan`); `tvlqr`: the [`Tracker`] that follows it; `mpc`: receding-horizon
//!   iLQR along it ([`Mpc`]); `energy`: energy shaping for one link, then the LQR
//!   catch ([`EnergyController`]).
//! * `any_control`: all of these with the scene chosen at run time, for front ends.
//!
//! The names below are the surface others use; the modules stay public for the
//! derivatives' tests and benchmarks.

mod any_control;
mod boxqp;
mod chart;
mod cost;
mod dual;
mod dynamics;
mod energy;
mod ilqr;
mod jacobian;
mod mpc;
mod plan;
mod planner;
mod tvlqr;
mod vector;

pub use any_control::{AnyEnergy, AnyMpc, AnyPlan, AnyTracker};
pub use chart::ChartPoint;
pub use cost::CostWeights;
pub use dynamics::{ScalarChain, ScalarWorkspace};
pub use energy::{EnergyController, EnergyOptions};
pub use jacobian::StepModel;
pub use mpc::{Mpc, MpcOptions, MpcStats, Reference};
pub use plan::{Plan, PlanReport};
pub use planner::{PlanOptions, Planner};
pub use tvlqr::Tracker;
pub use vector::{ScalarGeometry, Vect};
