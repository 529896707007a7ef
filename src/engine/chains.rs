//! [`ChainBatch`]: N states of one chain stepped together by the [`Engine`], physics
//! only (no task): states, forces and statuses each one contiguous array. With rk4 and
//! at least [`super::MIN_LANE_ENVS`] envs the lane kernel steps them, one env per SIMD
//! lane, with the same bits as the per-env path, and the states stay in the lanes
//! between steps.

use super::stepping::{Engine, Shared, StateHome};
use crate::error::{check_finite, check_len, InputError, Result};
use crate::integrate::{Guard, StepOptions, StepStatus};
use crate::lanes::{Kernel, LaneScene, NoHook, Precision};
use crate::model::Chain;

/// N states of one chain with one integrator setting.
pub struct ChainBatch<G: LaneScene> {
    engine: Engine<G, NoHook>,
    /// Every env's state, env-major (behind the lanes' copy while they step).
    states: Vec<f64>,
    status: Vec<StepStatus>,
}

impl<G: LaneScene> ChainBatch<G> {
    /// `num_envs` copies of the hanging equilibrium, stepped by `dt` with `opts`.
    pub fn new(chain: Chain<G>, num_envs: usize, dt: f64, opts: StepOptions) -> Result<Self> {
        let hanging = chain.equilibrium(&vec![1.0; chain.n_links()])?;
        let shared = Shared {
            chain,
            dt,
            opts,
            guard: Guard::default(),
        };
        let engine = Engine::new(
            shared,
            num_envs,
            StateHome::Lanes,
            false,
            Precision::F64,
            NoHook,
        )?;
        let states = hanging
            .iter()
            .copied()
            .cycle()
            .take(num_envs * hanging.len())
            .collect();
        Ok(Self {
            engine,
            states,
            status: vec![StepStatus::Ok; num_envs],
        })
    }

    /// The lane kernel stepping this batch, or `None` for the per-env path.
    pub fn kernel(&self) -> Option<Kernel> {
        self.engine.kernel()
    }

    /// Number type of the lane physics (f64 unless [`ChainBatch::set_precision`] chose f32).
    pub fn precision(&self) -> Precision {
        self.engine.precision()
    }

    /// Steps the lane physics in f64 or f32 (see [`Engine::set_precision`]); the
    /// states are kept.
    pub fn set_precision(&mut self, precision: Precision) -> Result<()> {
        self.engine.sync_rows(&mut self.states);
        self.engine.set_precision(precision)
    }

    /// Chooses the lane kernel (`None`: the per-env path; see [`Engine::set_kernel`]);
    /// the states are kept.
    pub fn set_kernel(&mut self, kernel: Option<Kernel>) -> Result<()> {
        self.engine.sync_rows(&mut self.states);
        self.engine.set_kernel(kernel)
    }

    /// The chain every env steps.
    pub fn chain(&self) -> &Chain<G> {
        self.engine.chain()
    }
    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.engine.num_envs()
    }
    /// Control period (s).
    pub fn dt(&self) -> f64 {
        self.engine.shared().dt
    }
    /// Integrator and substeps.
    pub fn options(&self) -> &StepOptions {
        &self.engine.shared().opts
    }
    /// Length of one env's state.
    pub fn state_dim(&self) -> usize {
        self.chain().state_dim()
    }
    /// All states, env-major: env k is `states[k*dim..(k+1)*dim]`. On the lane path
    /// the states stay in lane groups between steps; reading them after a step moves
    /// them out once (hence `&mut`), and reading again before the next step is free.
    pub fn states(&mut self) -> &[f64] {
        self.engine.sync_rows(&mut self.states);
        &self.states
    }
    /// Every env's state, env-major, for writing (the next step reads them back in).
    pub fn states_mut(&mut self) -> &mut [f64] {
        self.engine.sync_rows(&mut self.states);
        self.engine.rows_written();
        &mut self.states
    }
    /// Env `env`'s state (see [`ChainBatch::states`]).
    pub fn state(&mut self, env: usize) -> &[f64] {
        let d = self.state_dim();
        &self.states()[env * d..(env + 1) * d]
    }
    /// Statuses of the last step.
    pub fn status(&self) -> &[StepStatus] {
        &self.status
    }
    /// When a step counts as failed (default: [`Guard::default`]).
    pub fn set_guard(&mut self, guard: Guard) -> Result<()> {
        self.engine.set_guard(guard)
    }

    /// Overwrites env `env`'s state (validated: length, finiteness) and clears its status.
    pub fn set_state(&mut self, env: usize, state: &[f64]) -> Result<()> {
        if env >= self.num_envs() {
            return Err(InputError::InvalidParameter {
                name: "env index",
                value: env as f64,
                expected: "an index below num_envs",
            }
            .into());
        }
        let d = self.state_dim();
        check_len("state", state, d)?;
        check_finite("state", state)?;
        self.states_mut()[env * d..(env + 1) * d].copy_from_slice(state);
        self.status[env] = StepStatus::Ok;
        Ok(())
    }

    /// Overwrites every env's state (env-major, validated: length, finiteness) and
    /// clears the statuses. Unlike writing through [`ChainBatch::states_mut`], the old
    /// states are not moved out of the lanes first, and on the lane path the threads
    /// that step the envs also take in their new states.
    pub fn set_states(&mut self, states: &[f64]) -> Result<()> {
        check_len("states", states, self.states.len())?;
        check_finite("states", states)?;
        self.engine.set_rows(&mut self.states, states);
        self.status.fill(StepStatus::Ok);
        Ok(())
    }

    /// Checks a force array for the whole batch before anything is stepped, so a bad
    /// force for one env changes no env.
    pub fn check_forces(&self, forces: &[f64]) -> Result<()> {
        check_len("forces", forces, self.num_envs() * self.chain().force_dim())?;
        check_finite("forces", forces)
    }

    /// Advances every env by one control period; env k feels the constant force
    /// `forces[k*f..(k+1)*f]` (f = 1 planar, 2 spatial). Envs whose step fails keep
    /// their last good state and report why in [`ChainBatch::status`].
    pub fn step(&mut self, forces: &[f64]) -> Result<()> {
        self.check_forces(forces)?;
        self.engine.step(&mut self.states, forces, &mut self.status);
        Ok(())
    }
}
