//! A struct-of-arrays batch of N states of one chain, stepped together.
//!
//! States, forces and statuses are each one contiguous array. The batch is cut
//! into fixed chunks of envs, each with its own preallocated [`Stepper`] and
//! backup buffer; chunks are stepped in parallel by rayon. The chunking does not
//! depend on the number of threads and every env is stepped by the same code on
//! its own data, so results are bit-identical whatever the thread count. Nothing
//! is allocated in [`Batch::step`].
//!
//! With rk4, batches of [`MIN_LANE_ENVS`] or more envs are stepped by the lane
//! kernel of [`crate::lanes`] (one env per SIMD lane), which gives every env the
//! same bits as the per-env path.

use crate::error::{check_finite, check_len, check_positive, InputError, Result};
use crate::geometry::{Geometry, Vector};
use crate::integrate::{Method, StepOptions, Stepper};
use crate::lanes::resident::{load_groups, store_groups};
use crate::lanes::simd::{LaneReal, Lanes};
use crate::lanes::{
    Kernel, LaneGeometry, LaneParams, LaneScene, LaneStates, LaneStepper, StepPlan, LANES,
    LANES_F32,
};
use crate::model::Chain;
use rayon::prelude::*;

/// Envs per parallel work item: large enough to amortise scheduling, small enough
/// to balance 2..64 cores at N = 4096.
pub const CHUNK: usize = 32;

/// Envs per unit of the lane kernel's work split (a multiple of [`LANES`]): a thread
/// steps a run of whole units. The lanes are independent, so this changes no result,
/// only the scheduling.
pub const LANE_CHUNK: usize = 128;

/// Smallest batch stepped by the lane kernel: below it the per-env path is faster.
pub const MIN_LANE_ENVS: usize = 4;

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
/// Shared by batches, env batches and single-state simulations.
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

/// One parallel work item: a chunk's states, forces and statuses, and its worker.
type ChunkItem<'a, G> = (
    ((&'a mut [f64], &'a [f64]), &'a mut [StepStatus]),
    &'a mut GuardedStepper<G>,
);

/// Number type of the lane physics of a [`Batch`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Precision {
    /// f64: every env bit-identical to the per-env path.
    #[default]
    F64,
    /// f32 (twice the lanes): faster, within the accuracy documented in `docs/simd.md`.
    F32,
}

impl Precision {
    /// The names of the precisions, as the configuration writes them.
    pub const NAMES: [&'static str; 2] = ["f64", "f32"];

    /// The name of this precision (`"f64"` or `"f32"`).
    pub fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::F32 => "f32",
        }
    }

    /// The precision with this name, or an error listing the names.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "f64" => Ok(Precision::F64),
            "f32" => Ok(Precision::F32),
            _ => Err(InputError::UnknownName {
                kind: "precision",
                name: name.to_string(),
                expected: &Precision::NAMES,
            }
            .into()),
        }
    }
}

/// Which copy of the states is up to date while the lane kernel steps a batch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Current {
    /// The env-major rows (written by the caller since the last step).
    Rows,
    /// The lane groups (stepped since the rows were last brought up to date).
    Lanes,
    /// Both hold the same states.
    Both,
}

/// The lane path of a batch: kernel, broadcast parameters, the states kept in lane
/// groups between steps, one stepper per work item.
struct LanePath<G: LaneGeometry<L, T>, const L: usize, T: LaneReal> {
    kernel: Kernel,
    params: [LaneParams<L, T>; 1],
    states: LaneStates<L, T>,
    current: Current,
    workers: Vec<LaneStepper<G, L, T>>,
}

impl<G: LaneGeometry<L, T>, const L: usize, T: LaneReal> LanePath<G, L, T> {
    fn new(chain: &Chain<G>, num_envs: usize, kernel: Kernel) -> Self {
        Self {
            kernel,
            params: [LaneParams::broadcast(chain.params())],
            states: LaneStates::new(chain.state_dim(), num_envs),
            current: Current::Rows,
            workers: (0..num_envs.div_ceil(LANE_CHUNK))
                .map(|_| LaneStepper::new(chain.n_links()))
                .collect(),
        }
    }

    /// Brings `rows` up to date if the lanes moved since they were, each thread
    /// moving the envs it steps.
    fn sync_rows(&mut self, rows: &mut [f64]) {
        if self.current != Current::Lanes {
            return;
        }
        self.current = Current::Both;
        let (kernel, d) = (self.kernel, self.states.dim());
        let lanes = self.states.lanes();
        let part = self.part();
        if part >= self.states.num_envs() {
            return store_groups(kernel, lanes, rows, d);
        }
        lanes
            .par_chunks(part / L * d)
            .zip(rows.par_chunks_mut(part * d))
            .for_each(|(lanes, rows)| store_groups(kernel, lanes, rows, d));
    }

    /// Takes new states for every env: each thread copies its envs' rows and loads
    /// their lane groups from the same source, so both copies hold them after.
    fn set_rows(&mut self, rows: &mut [f64], states: &[f64]) {
        self.current = Current::Both;
        let (kernel, d) = (self.kernel, self.states.dim());
        let work = |((lanes, rows), states): SetItem<'_, L, T>| {
            rows.copy_from_slice(states);
            load_groups(kernel, lanes, states, d);
        };
        let part = self.part();
        if part >= self.states.num_envs() {
            return work(((self.states.lanes_mut(), rows), states));
        }
        self.states
            .lanes_mut()
            .par_chunks_mut(part / L * d)
            .zip(rows.par_chunks_mut(part * d))
            .zip(states.par_chunks(part * d))
            .for_each(work);
    }

    /// Envs per thread: a contiguous run of whole [`LANE_CHUNK`]s. Few large items
    /// rather than many small ones, so a thread tends to step the same envs every
    /// step (they stay in its core's cache) and the pool is woken fewer times.
    fn part(&self) -> usize {
        let chunks = self.states.num_envs().div_ceil(LANE_CHUNK);
        chunks.div_ceil(rayon::current_num_threads().max(1)) * LANE_CHUNK
    }

    /// Steps every env, each thread first loading its envs' lanes from `rows` if
    /// those were written since the last step. A thread's run of envs goes through
    /// the stepper of its first [`LANE_CHUNK`]. Lanes are independent, so no result
    /// depends on the split.
    fn step(
        &mut self,
        rows: &[f64],
        forces: &[f64],
        status: &mut [StepStatus],
        plan: StepPlan<'_>,
    ) {
        let load = self.current == Current::Rows;
        self.current = Current::Lanes;
        let num_envs = status.len();
        let (d, f) = (self.states.dim(), forces.len() / num_envs);
        let (kernel, params) = (self.kernel, &self.params[..]);
        let work = |((((lanes, rows), forces), status), workers): LaneItem<'_, G, L, T>| {
            if load {
                load_groups(kernel, lanes, rows, d);
            }
            workers[0].step_lanes(kernel, params, lanes, forces, None, plan, status);
        };
        let part = self.part();
        let lanes = self.states.lanes_mut();
        if part >= num_envs {
            work(((((lanes, rows), forces), status), &mut self.workers[..]));
        } else {
            lanes
                .par_chunks_mut(part / L * d)
                .zip(rows.par_chunks(part * d))
                .zip(forces.par_chunks(part * f))
                .zip(status.par_chunks_mut(part))
                .zip(self.workers.par_chunks_mut(part / LANE_CHUNK))
                .for_each(work);
        }
    }
}

/// One parallel work item of [`LanePath::set_rows`]: lane groups, their rows, the
/// new states.
type SetItem<'a, const L: usize, T> = ((&'a mut [Lanes<L, T>], &'a mut [f64]), &'a [f64]);

/// The lane path in the chosen precision.
enum LaneMode<G: LaneScene> {
    F64(LanePath<G, LANES, f64>),
    F32(LanePath<G, LANES_F32, f32>),
}

/// N states of one chain with one integrator setting.
pub struct Batch<G: LaneScene> {
    chain: Chain<G>,
    opts: StepOptions,
    dt: f64,
    guard: Guard,
    num_envs: usize,
    states: Vec<f64>,
    status: Vec<StepStatus>,
    workers: Vec<GuardedStepper<G>>,
    /// Set when the lane kernel steps this batch (rk4, at least [`MIN_LANE_ENVS`] envs).
    lanes: Option<LaneMode<G>>,
}

impl<G: LaneScene> Batch<G> {
    /// `num_envs` copies of `initial` (or of the hanging equilibrium if `None`).
    pub fn new(chain: Chain<G>, num_envs: usize, dt: f64, opts: StepOptions) -> Result<Self> {
        if num_envs == 0 {
            return Err(InputError::InvalidParameter {
                name: "num_envs",
                value: 0.0,
                expected: "an integer >= 1",
            }
            .into());
        }
        crate::limits::check_rows("num_envs", num_envs, chain.state_dim())?;
        check_positive("dt", dt)?;
        opts.validate()?;
        let dim = chain.state_dim();
        let hanging = chain.equilibrium(&vec![1.0; chain.n_links()])?;
        let states = hanging
            .iter()
            .copied()
            .cycle()
            .take(num_envs * dim)
            .collect();
        let workers = (0..num_envs.div_ceil(CHUNK))
            .map(|_| GuardedStepper::new(&chain))
            .collect();
        let mut batch = Self {
            chain,
            opts,
            dt,
            guard: Guard::default(),
            num_envs,
            states,
            status: vec![StepStatus::Ok; num_envs],
            workers,
            lanes: None,
        };
        if opts.method == Method::Rk4 && num_envs >= MIN_LANE_ENVS {
            batch.set_kernel(Some(Kernel::detect()))?;
        }
        Ok(batch)
    }

    /// The lane kernel stepping this batch, or `None` for the per-env path.
    pub fn kernel(&self) -> Option<Kernel> {
        self.lanes.as_ref().map(|l| match l {
            LaneMode::F64(path) => path.kernel,
            LaneMode::F32(path) => path.kernel,
        })
    }

    /// Number type of the lane physics (f64 unless [`Batch::set_precision`] chose f32).
    pub fn precision(&self) -> Precision {
        match self.lanes {
            Some(LaneMode::F32(_)) => Precision::F32,
            _ => Precision::F64,
        }
    }

    /// Steps the lane physics in f64 or f32. f32 needs the lane kernel (rk4; see
    /// [`Batch::set_kernel`]) and gives up bit-identity with the per-env path.
    pub fn set_precision(&mut self, precision: Precision) -> Result<()> {
        let kernel = match (self.kernel(), precision) {
            (Some(kernel), _) => kernel,
            (None, Precision::F64) => return Ok(()),
            (None, Precision::F32) => {
                return Err(InputError::InvalidParameter {
                    name: "precision",
                    value: 32.0,
                    expected: "f64 unless the batch steps with a lane kernel (rk4)",
                }
                .into())
            }
        };
        if precision != self.precision() {
            self.sync_rows();
            self.lanes = Some(match precision {
                Precision::F64 => LaneMode::F64(LanePath::new(&self.chain, self.num_envs, kernel)),
                Precision::F32 => LaneMode::F32(LanePath::new(&self.chain, self.num_envs, kernel)),
            });
        }
        Ok(())
    }

    /// Chooses the lane kernel (`None`: the per-env path). Both give the same bits;
    /// this exists to compare them. Errors if the CPU lacks the kernel or the
    /// integrator is not rk4.
    pub fn set_kernel(&mut self, kernel: Option<Kernel>) -> Result<()> {
        let Some(kernel) = kernel else {
            self.sync_rows();
            self.lanes = None;
            return Ok(());
        };
        kernel.checked()?;
        if self.opts.method != Method::Rk4 {
            return Err(InputError::InvalidParameter {
                name: "kernel",
                value: kernel as u8 as f64,
                expected: "None unless the integrator is rk4 (the only one with a lane kernel)",
            }
            .into());
        }
        let (chain, num_envs) = (&self.chain, self.num_envs);
        match self
            .lanes
            .get_or_insert_with(|| LaneMode::F64(LanePath::new(chain, num_envs, kernel)))
        {
            LaneMode::F64(path) => path.kernel = kernel,
            LaneMode::F32(path) => path.kernel = kernel,
        }
        Ok(())
    }

    /// The chain every env steps.
    pub fn chain(&self) -> &Chain<G> {
        &self.chain
    }
    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.num_envs
    }
    /// Control period (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// Integrator and substeps.
    pub fn options(&self) -> &StepOptions {
        &self.opts
    }
    /// Length of one env's state.
    pub fn state_dim(&self) -> usize {
        self.chain.state_dim()
    }
    /// All states, env-major: env k is `states[k*dim..(k+1)*dim]`. On the lane path
    /// the states stay in lane groups between steps; reading them after a step moves
    /// them out once (hence `&mut`), and reading again before the next step is free.
    pub fn states(&mut self) -> &[f64] {
        self.sync_rows();
        &self.states
    }
    /// Every env's state, env-major, for writing (the next step reads them back in).
    pub fn states_mut(&mut self) -> &mut [f64] {
        self.sync_rows();
        self.rows_written();
        &mut self.states
    }
    /// Env `env`'s state (see [`Batch::states`]).
    pub fn state(&mut self, env: usize) -> &[f64] {
        let d = self.state_dim();
        &self.states()[env * d..(env + 1) * d]
    }

    /// Brings the env-major states up to date with the lanes.
    fn sync_rows(&mut self) {
        let rows = &mut self.states[..];
        match self.lanes.as_mut() {
            Some(LaneMode::F64(path)) => path.sync_rows(rows),
            Some(LaneMode::F32(path)) => path.sync_rows(rows),
            None => {}
        }
    }

    /// The env-major states were written: the next lane step starts from them.
    fn rows_written(&mut self) {
        match self.lanes.as_mut() {
            Some(LaneMode::F64(path)) => path.current = Current::Rows,
            Some(LaneMode::F32(path)) => path.current = Current::Rows,
            None => {}
        }
    }
    /// Statuses of the last step.
    pub fn status(&self) -> &[StepStatus] {
        &self.status
    }
    /// When a step counts as failed (default: [`Guard::default`]).
    pub fn set_guard(&mut self, guard: Guard) -> Result<()> {
        guard.validate()?;
        self.guard = guard;
        Ok(())
    }

    /// Overwrites env `env`'s state (validated: length, finiteness) and clears its status.
    pub fn set_state(&mut self, env: usize, state: &[f64]) -> Result<()> {
        if env >= self.num_envs {
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
    /// clears the statuses. Unlike writing through [`Batch::states_mut`], the old
    /// states are not moved out of the lanes first, and on the lane path the threads
    /// that step the envs also take in their new states.
    pub fn set_states(&mut self, states: &[f64]) -> Result<()> {
        check_len("states", states, self.states.len())?;
        check_finite("states", states)?;
        let rows = &mut self.states[..];
        match self.lanes.as_mut() {
            Some(LaneMode::F64(path)) => path.set_rows(rows, states),
            Some(LaneMode::F32(path)) => path.set_rows(rows, states),
            None => rows.copy_from_slice(states),
        }
        self.status.fill(StepStatus::Ok);
        Ok(())
    }

    /// Checks a force array for the whole batch before anything is stepped, so a bad
    /// force for one env changes no env.
    pub fn check_forces(&self, forces: &[f64]) -> Result<()> {
        check_len("forces", forces, self.num_envs * self.chain.force_dim())?;
        check_finite("forces", forces)
    }

    /// Advances every env by one control period; env k feels the constant force
    /// `forces[k*f..(k+1)*f]` (f = 1 planar, 2 spatial). Envs whose step fails keep
    /// their last good state and report why in [`Batch::status`].
    pub fn step(&mut self, forces: &[f64]) -> Result<()> {
        self.check_forces(forces)?;
        if self.lanes.is_some() {
            self.step_lanes(forces);
            return Ok(());
        }
        let d = self.state_dim();
        let f = self.chain.force_dim();
        let (chain, opts, dt, guard) = (&self.chain, &self.opts, self.dt, &self.guard);
        let work = |(((states, forces), status), worker): ChunkItem<'_, G>| {
            for ((y, u), st) in states
                .chunks_exact_mut(d)
                .zip(forces.chunks_exact(f))
                .zip(status.iter_mut())
            {
                *st = worker.step(chain, y, G::Cart::load(u), dt, opts, guard);
            }
        };
        if self.num_envs <= CHUNK {
            // One chunk: step it on this thread and skip the pool's wake-up cost.
            work((
                ((&mut self.states[..], forces), &mut self.status[..]),
                &mut self.workers[0],
            ));
        } else {
            self.states
                .par_chunks_mut(CHUNK * d)
                .zip(forces.par_chunks(CHUNK * f))
                .zip(self.status.par_chunks_mut(CHUNK))
                .zip(self.workers.par_iter_mut())
                .for_each(work);
        }
        Ok(())
    }

    /// [`Batch::step`] through the lane kernel.
    fn step_lanes(&mut self, forces: &[f64]) {
        let plan = StepPlan {
            dt: self.dt,
            substeps: self.opts.substeps,
            guard: &self.guard,
        };
        let (states, status) = (&self.states[..], &mut self.status[..]);
        match self.lanes.as_mut() {
            Some(LaneMode::F64(path)) => path.step(states, forces, status, plan),
            Some(LaneMode::F32(path)) => path.step(states, forces, status, plan),
            None => {}
        }
    }
}

/// One parallel work item of the lane path: lane groups, their rows, forces,
/// statuses, steppers.
type LaneItem<'a, G, const L: usize, T> = (
    (
        ((&'a mut [Lanes<L, T>], &'a [f64]), &'a [f64]),
        &'a mut [StepStatus],
    ),
    &'a mut [LaneStepper<G, L, T>],
);

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
