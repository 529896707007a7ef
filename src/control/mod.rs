//! Large motions: exact derivatives of the control step, a trajectory planner
//! between any two states and equilibria, and the controllers that follow it.
//!
//! * [`dual`]: forward-mode automatic differentiation (the [`dual::Real`] scalars).
//! * [`vector`]: the scene geometry over any scalar; [`dynamics`]: the O(n) dynamics and
//!   the RK4 control step written once for values and derivatives.
//! * [`chart`]: increments on the spheres about any state; [`jacobian`]: the control
//!   step and its exact derivatives in that chart.

pub mod any;
pub mod boxqp;
pub mod chart;
pub mod cost;
pub mod dual;
pub mod dynamics;
pub mod energy;
pub mod ilqr;
pub mod jacobian;
pub mod mpc;
pub mod plan;
pub mod planner;
pub mod tvlqr;
pub mod vector;
