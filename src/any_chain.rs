//! Spatial or planar, chosen at run time: the flat-slice API that front ends
//! (the Python bindings, command-line tools) call. Every method validates its
//! inputs and returns errors; nothing here panics on bad input.

use crate::error::{
    check_finite, check_len, check_positive, ChainError, IntegrationFailure, Result,
};
use crate::geometry::{planar_to_spatial, spatial_to_planar, Planar, Spatial, Vector};
use crate::integrate::{Guard, GuardedStepper, StepOptions, StepStatus};
use crate::invariants::{Energy, Residuals};
use crate::model::Chain;
use crate::params::{ChainParams, Rig};

/// A chain in either scene.
#[derive(Debug, Clone)]
pub enum AnyChain {
    /// The spatial model (2-D cart, spherical joints).
    Spatial(Chain<Spatial>),
    /// The planar model (1-D cart, hinges in the e1-e3 plane).
    Planar(Chain<Planar>),
}

impl AnyChain {
    /// The planar or spatial chain with these parameters.
    pub fn new(params: ChainParams, planar: bool) -> Self {
        if planar {
            AnyChain::Planar(Chain::new(params))
        } else {
            AnyChain::Spatial(Chain::new(params))
        }
    }
    /// The same chain with the real-rig effects `rig` (checked for its links): its
    /// steps, plans and controllers then follow the rig ([`Chain::with_rig`]).
    pub fn with_rig(self, rig: Rig) -> Result<Self> {
        Ok(match self {
            AnyChain::Spatial(c) => AnyChain::Spatial(c.with_rig(rig)?),
            AnyChain::Planar(c) => AnyChain::Planar(c.with_rig(rig)?),
        })
    }
    /// Whether this is the planar model.
    pub fn is_planar(&self) -> bool {
        matches!(self, AnyChain::Planar(_))
    }
    /// The physical parameters.
    pub fn params(&self) -> &ChainParams {
        dispatch!(AnyChain, self, c => c.params())
    }
    /// Number of links.
    pub fn n_links(&self) -> usize {
        dispatch!(AnyChain, self, c => c.n_links())
    }
    /// Length of a state: `4 + 6n` spatial, `2 + 3n` planar.
    pub fn state_dim(&self) -> usize {
        dispatch!(AnyChain, self, c => c.state_dim())
    }
    /// The blocks of a state, each `(name, start, end)`: cart position `x`, cart
    /// velocity `xdot`, link directions `q`, angular velocities `w`.
    pub fn state_blocks(&self) -> [(&'static str, usize, usize); 4] {
        dispatch!(AnyChain, self, c => {
            let layout = c.layout();
            [
                ("x", layout.x(), layout.xdot()),
                ("xdot", layout.xdot(), layout.q(0)),
                ("q", layout.q(0), layout.w(0)),
                ("w", layout.w(0), layout.dim()),
            ]
        })
    }
    /// Length of a force: 2 spatial, 1 planar.
    pub fn force_dim(&self) -> usize {
        dispatch!(AnyChain, self, c => c.force_dim())
    }

    /// Time derivative of `state` under `force`.
    pub fn derivative(&self, state: &[f64], force: &[f64]) -> Result<Vec<f64>> {
        dispatch!(AnyChain, self, c => {
            c.check_input(state, force)?;
            let mut dy = vec![0.0; c.state_dim()];
            c.derivative(state, Vector::load(force), &mut c.workspace(), &mut dy);
            Ok(dy)
        })
    }

    /// One control period from `state`; errors on a numerical failure instead of
    /// returning a bad state.
    pub fn step(
        &self,
        state: &[f64],
        force: &[f64],
        dt: f64,
        opts: &StepOptions,
    ) -> Result<Vec<f64>> {
        let mut traj = self.simulate(state, force, 1, dt, opts)?;
        Ok(traj.split_off(self.state_dim()))
    }

    /// `steps` control periods with forces `forces[k*f..(k+1)*f]`; returns the
    /// `(steps+1) x dim` trajectory, row-major. Stops with an error naming the step
    /// at which the integration failed.
    pub fn simulate(
        &self,
        state: &[f64],
        forces: &[f64],
        steps: usize,
        dt: f64,
        opts: &StepOptions,
    ) -> Result<Vec<f64>> {
        check_positive("dt", dt)?;
        opts.validate()?;
        self.check_state(state)?;
        dispatch!(AnyChain, self, c => {
            let f = c.force_dim();
            crate::limits::check_rows("steps", steps, c.state_dim())?;
            check_len("forces", forces, steps * f)?;
            check_finite("forces", forces)?;
            let mut stepper = GuardedStepper::new(c);
            let guard = Guard::default();
            let d = c.state_dim();
            let mut traj = Vec::with_capacity((steps + 1) * d);
            traj.extend_from_slice(state);
            let mut y = state.to_vec();
            for k in 0..steps {
                let status = stepper.step(
                    c,
                    &mut y,
                    Vector::load(&forces[k * f..(k + 1) * f]),
                    dt,
                    opts,
                    &guard,
                );
                if status.is_failure() {
                    return Err(step_failure(status, k, opts, dt));
                }
                traj.extend_from_slice(&y);
            }
            Ok(traj)
        })
    }

    /// Kinetic and potential energy of a checked state.
    pub fn energy(&self, state: &[f64]) -> Result<Energy> {
        self.check_state(state)?;
        Ok(dispatch!(AnyChain, self, c => c.energy(state)))
    }
    /// Horizontal momentum of a checked state (one entry per cart axis).
    pub fn horizontal_momentum(&self, state: &[f64]) -> Result<Vec<f64>> {
        self.check_state(state)?;
        dispatch!(AnyChain, self, c => {
            let mut out = vec![0.0; c.force_dim()];
            c.horizontal_momentum(state).store(&mut out);
            Ok(out)
        })
    }
    /// Constraint residuals of a state (length and finiteness checked).
    pub fn residuals(&self, state: &[f64]) -> Result<Residuals> {
        self.check_state(state)?;
        Ok(dispatch!(AnyChain, self, c => c.residuals(state)))
    }
    /// The paper's `(e_q, e_w)` for equilibrium `s`.
    pub fn errors(&self, state: &[f64], s: &[f64]) -> Result<(f64, f64)> {
        self.check_state(state)?;
        dispatch!(AnyChain, self, c => {
            c.equilibrium(s)?;
            Ok(c.errors(state, s))
        })
    }
    /// The equilibrium state with signs `s` (cart at rest at the origin).
    pub fn equilibrium(&self, s: &[f64]) -> Result<Vec<f64>> {
        dispatch!(AnyChain, self, c => c.equilibrium(s))
    }

    /// Spatial state of a state of this chain (identity for a spatial chain).
    pub fn to_spatial(&self, state: &[f64]) -> Result<Vec<f64>> {
        self.check_state(state)?;
        Ok(match self {
            AnyChain::Spatial(_) => state.to_vec(),
            AnyChain::Planar(c) => {
                let mut out = vec![0.0; 4 + 6 * c.n_links()];
                planar_to_spatial(c.n_links(), state, &mut out);
                out
            }
        })
    }
    /// Planar part of a spatial state (for a planar chain).
    pub fn from_spatial(&self, spatial: &[f64]) -> Result<Vec<f64>> {
        let n = self.n_links();
        check_len("spatial state", spatial, 4 + 6 * n)?;
        Ok(match self {
            AnyChain::Spatial(_) => spatial.to_vec(),
            AnyChain::Planar(c) => {
                let mut out = vec![0.0; c.state_dim()];
                spatial_to_planar(n, spatial, &mut out);
                out
            }
        })
    }

    /// Checks a state's length, finiteness and constraints (`|q_i| = 1`, `w_i . q_i = 0`).
    pub fn check_state(&self, state: &[f64]) -> Result<()> {
        check_len("state", state, self.state_dim())?;
        check_finite("state", state)
    }
}

/// The error for step `k` (of `dt` each) that failed the guard.
fn step_failure(status: StepStatus, k: usize, opts: &StepOptions, dt: f64) -> ChainError {
    ChainError::integration(
        k as f64 * dt,
        IntegrationFailure::Step {
            step: k,
            status: status.describe(),
            method: opts.method.name(),
            dt,
        },
    )
}
