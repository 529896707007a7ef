//! The one engine that steps the envs of a batch: the chain they share, the control
//! period, integrator and failure guard, the choice between the per-env path and the
//! lane kernel (in f64 or f32) with the rules of that choice, one worker per fixed
//! chunk of [`CHUNK`] envs, and the parallel pass over the chunks.
//!
//! The chunking does not depend on the number of threads and every env is stepped by
//! the same code on its own data, so results are bit-identical whatever the thread
//! count; in f64 the lane kernel gives every env the bits of the per-env path.
//! Nothing is allocated in a step.
//!
//! Where the states live decides how the lanes step them ([`StateHome`]): a
//! physics-only batch keeps them in lane groups between steps
//! ([`super::lane_path`]); a task, which reads and writes env rows every step, hands
//! each chunk's rows to its worker ([`ChunkLanePath`]) and runs its own per-env work
//! around that step in the same pass ([`Engine::run_chunks`]).

use super::lane_path::ResidentLanes;
use crate::error::{check_positive, InputError, Result};
use crate::geometry::{Geometry, Vector};
use crate::integrate::{Guard, GuardedStepper, Method, StepOptions, StepStatus};
use crate::lanes::{
    chunk_lanes, ChunkLanes, ChunkSpec, Kernel, LaneHook, LaneScene, Precision, StepPlan, LANES_F32,
};
use crate::model::Chain;
use crate::params::ChainParams;

/// Envs per chunk (one worker each): large enough to amortise scheduling, small
/// enough to balance 2..64 cores at N = 4096.
pub const CHUNK: usize = 32;

/// Smallest batch stepped by the lane kernel by default: below it the per-env path is
/// faster.
pub const MIN_LANE_ENVS: usize = 4;

/// Smallest guard `unit_length_tolerance` accepted in f32: after the projection,
/// `| |q_i| - 1 |` computed in f32 is a few f32 rounding errors (a few 1e-7), so a
/// tighter tolerance would fail good steps.
pub const F32_MIN_UNIT_LENGTH_TOLERANCE: f64 = 5e-7;

// A lane path steps whole groups of lanes: chunks must not split one.
const _: () = assert!(CHUNK.is_multiple_of(LANES_F32));

/// Checks that `precision` can step with `method` under `guard`: f32 needs rk4 (the
/// only integrator with an f32 lane kernel) and a unit-length tolerance of at least
/// [`F32_MIN_UNIT_LENGTH_TOLERANCE`].
pub fn check_precision(precision: Precision, method: Method, guard: &Guard) -> Result<()> {
    if precision == Precision::F64 {
        return Ok(());
    }
    if method != Method::Rk4 {
        return Err(InputError::Incompatible {
            name: "precision",
            value: precision.name(),
            expected: format!(
                "\"f64\" with integrator {:?} (only \"rk4\" has an f32 kernel)",
                method.name()
            ),
        }
        .into());
    }
    if guard.unit_length_tolerance < F32_MIN_UNIT_LENGTH_TOLERANCE {
        return Err(InputError::InvalidParameter {
            name: "guard unit_length_tolerance",
            value: guard.unit_length_tolerance,
            expected: "at least 5e-7 in f32 (its round-off alone reaches a few 1e-7 and would fail good steps), or precision f64",
        }
        .into());
    }
    Ok(())
}

/// Checks that the lane kernels can step `chain`: they step the ideal model only, so
/// a chain with real-rig effects (damping, friction, an actuation other than force)
/// steps env by env, in f64.
pub fn check_ideal_for_lanes<G: Geometry>(chain: &Chain<G>) -> Result<()> {
    if chain.is_ideal() {
        return Ok(());
    }
    Err(InputError::Incompatible {
        name: "kernel",
        value: "lanes",
        expected: "the per-env path (kernel None, precision \"f64\") with joint damping, cart \
                   friction or an actuation other than force: the SIMD lane kernels step the \
                   ideal model only"
            .to_string(),
    }
    .into())
}

/// Where the states of the envs live between steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StateHome {
    /// In the owner's env-major rows; each chunk's rows go through the lanes at each
    /// step (a task reads and writes rows every step).
    Rows,
    /// In lane groups (physics only: rows are moved out when read, in when written).
    Lanes,
}

/// What every chunk reads: the chain the envs step, the control period, integrator
/// and guard.
#[derive(Debug, Clone)]
pub struct Shared<G: Geometry> {
    /// The chain every env steps (when envs have parameters of their own, the one
    /// their lanes are filled with until they are loaded).
    pub chain: Chain<G>,
    /// Control period (s).
    pub dt: f64,
    /// Integrator and substeps.
    pub opts: StepOptions,
    /// When a step counts as failed.
    pub guard: Guard,
}

impl<G: Geometry> Shared<G> {
    /// How the lane kernel steps a control period.
    pub fn plan(&self) -> StepPlan<'_> {
        StepPlan {
            dt: self.dt,
            substeps: self.opts.substeps,
            guard: &self.guard,
        }
    }
}

/// The lane path of one chunk of rows and the buffers its step reads and writes,
/// sized for the chunk once (nothing is allocated in a step). `H` runs on each group
/// right after its step (the task's measures).
pub struct ChunkLanePath<H> {
    lanes: Box<dyn ChunkLanes<H>>,
    /// Per env, its force.
    pub forces: Vec<f64>,
    /// Per env, whether it steps.
    pub stepped: Vec<bool>,
    /// Per env, the outcome of its last step.
    pub status: Vec<StepStatus>,
    /// The work on each group after its step, and what it wrote.
    pub hook: H,
}

impl<H> ChunkLanePath<H> {
    /// Steps the first `num_envs` rows of `states` whose `stepped` is set, under
    /// `forces` (`f` numbers per env), writing `status` and running the hook.
    pub fn step(&mut self, states: &mut [f64], num_envs: usize, f: usize, plan: StepPlan<'_>) {
        self.lanes.step(
            states,
            &self.forces[..num_envs * f],
            &self.stepped[..num_envs],
            plan,
            &mut self.status[..num_envs],
            Some(&mut self.hook),
        );
    }

    /// Gives env `k` of the chunk its own chain parameters (a chunk built with one
    /// chain per env; else an error).
    pub fn set_env_params(&mut self, k: usize, params: &ChainParams) -> Result<()> {
        self.lanes.set_env_params(k, params)
    }
}

/// What steps one chunk: the per-env integrator, a chain that per-env parameters are
/// loaded into and, when the lane kernel steps the chunk's rows, its lane path.
pub struct Worker<G: Geometry, H> {
    /// The per-env path's integrator with its undo buffer.
    pub stepper: GuardedStepper<G>,
    /// Scratch chain for an env's own parameters.
    pub chain: Chain<G>,
    /// The chunk's lane path (rows home, lane kernel on).
    pub lanes: Option<ChunkLanePath<H>>,
}

/// A per-env range of data that splits at an env index, so that a chunk pass can
/// hand each chunk its part (what a task passes to [`Engine::run_chunks`]).
pub trait EnvRange: Send + Sized {
    /// Number of envs.
    fn num_envs(&self) -> usize;
    /// Envs `..at` and `at..`.
    fn split_at(self, at: usize) -> (Self, Self);
}

/// N envs of one chain stepped together (see the module docs).
pub struct Engine<G: LaneScene, H: LaneHook<G> + Clone> {
    shared: Shared<G>,
    num_envs: usize,
    home: StateHome,
    /// Each env has chain parameters of its own (rows home only).
    per_env: bool,
    /// The lane kernel and its precision, or `None` for the per-env path.
    lane: Option<(Kernel, Precision)>,
    /// A copy for each chunk's lane path.
    hook: H,
    workers: Vec<Worker<G, H>>,
    resident: Option<ResidentLanes<G>>,
}

impl<G: LaneScene, H: LaneHook<G> + Clone> Engine<G, H> {
    /// `num_envs` envs of `shared.chain` (checked: the count and every setting), on the
    /// lane kernel in `precision` where it can step them: rk4 and at least
    /// [`MIN_LANE_ENVS`] envs for f64; f32 asks for the lane kernel at any size.
    pub fn new(
        shared: Shared<G>,
        num_envs: usize,
        home: StateHome,
        per_env: bool,
        precision: Precision,
        hook: H,
    ) -> Result<Self> {
        if num_envs == 0 {
            return Err(InputError::InvalidParameter {
                name: "num_envs",
                value: 0.0,
                expected: "an integer >= 1",
            }
            .into());
        }
        crate::limits::check_rows("num_envs", num_envs, shared.chain.state_dim())?;
        check_positive("dt", shared.dt)?;
        shared.opts.validate()?;
        shared.guard.validate()?;
        let workers = (0..num_envs.div_ceil(CHUNK))
            .map(|_| Worker {
                stepper: GuardedStepper::new(&shared.chain),
                chain: shared.chain.clone(),
                lanes: None,
            })
            .collect();
        let mut engine = Self {
            shared,
            num_envs,
            home,
            per_env: per_env && home == StateHome::Rows,
            lane: None,
            hook,
            workers,
            resident: None,
        };
        if precision == Precision::F32 {
            engine.set_precision(Precision::F32)?;
        } else if engine.shared.opts.method == Method::Rk4
            && num_envs >= MIN_LANE_ENVS
            && engine.shared.chain.is_ideal()
        {
            engine.set_kernel(Some(Kernel::detect()))?;
        }
        Ok(engine)
    }

    /// What every chunk reads.
    pub fn shared(&self) -> &Shared<G> {
        &self.shared
    }
    /// The chain every env steps.
    pub fn chain(&self) -> &Chain<G> {
        &self.shared.chain
    }
    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.num_envs
    }
    /// When a step counts as failed (checked).
    pub fn set_guard(&mut self, guard: Guard) -> Result<()> {
        guard.validate()?;
        self.shared.guard = guard;
        Ok(())
    }

    /// The lane kernel stepping the envs, or `None` for the per-env path.
    pub fn kernel(&self) -> Option<Kernel> {
        self.lane.map(|(kernel, _)| kernel)
    }

    /// Number type of the physics (f64 unless [`Engine::set_precision`] chose f32).
    pub fn precision(&self) -> Precision {
        self.lane.map_or(Precision::F64, |(_, precision)| precision)
    }

    /// Chooses the lane kernel (`None`: the per-env path, in f64). In f64 both give
    /// the same bits; this exists to compare them. Keeps the precision. Errors if the
    /// CPU lacks the kernel or the integrator is not rk4. With states in the lanes, the
    /// owner brings its rows up to date first.
    pub fn set_kernel(&mut self, kernel: Option<Kernel>) -> Result<()> {
        let Some(kernel) = kernel else {
            self.build_lanes(None);
            return Ok(());
        };
        kernel.checked()?;
        check_ideal_for_lanes(&self.shared.chain)?;
        if self.shared.opts.method != Method::Rk4 {
            return Err(InputError::InvalidParameter {
                name: "kernel",
                value: kernel as u8 as f64,
                expected: "None (the per-env path) unless the integrator is rk4 (the only one with a lane kernel)",
            }
            .into());
        }
        match (&mut self.resident, self.lane) {
            // Same lanes, another compiled kernel: the states stay where they are.
            (Some(resident), Some((_, precision))) => {
                resident.set_kernel(kernel);
                self.lane = Some((kernel, precision));
            }
            _ => self.build_lanes(Some((kernel, self.precision()))),
        }
        Ok(())
    }

    /// Steps the physics in f64 (the default) or f32. f32 runs on the lane kernel
    /// (chosen here if the envs stepped one by one, whatever their number) and needs
    /// rk4 and a guard f32 can meet ([`check_precision`]); it gives up bit-identity
    /// with the per-env path for speed, within the accuracy documented in
    /// `docs/simd.md`. With states in the lanes, the owner brings its rows up to date
    /// first.
    pub fn set_precision(&mut self, precision: Precision) -> Result<()> {
        let kernel = self.kernel();
        if kernel.is_none() && precision == Precision::F64 {
            return Ok(());
        }
        check_precision(precision, self.shared.opts.method, &self.shared.guard)?;
        check_ideal_for_lanes(&self.shared.chain)?;
        let kernel = kernel.unwrap_or_else(Kernel::detect);
        kernel.checked()?;
        if self.lane != Some((kernel, precision)) {
            self.build_lanes(Some((kernel, precision)));
        }
        Ok(())
    }

    /// Rebuilds the lane paths for `lane` (`None`: none).
    fn build_lanes(&mut self, lane: Option<(Kernel, Precision)>) {
        self.lane = lane;
        self.resident = None;
        for worker in &mut self.workers {
            worker.lanes = None;
        }
        let Some((kernel, precision)) = lane else {
            return;
        };
        let chain = &self.shared.chain;
        if self.home == StateHome::Lanes {
            self.resident = Some(ResidentLanes::new(chain, self.num_envs, kernel, precision));
            return;
        }
        let f = chain.force_dim();
        for (i, worker) in self.workers.iter_mut().enumerate() {
            let num_envs = CHUNK.min(self.num_envs - i * CHUNK);
            let spec = ChunkSpec {
                num_envs,
                per_env: self.per_env,
                kernel,
                precision,
            };
            worker.lanes = Some(ChunkLanePath {
                lanes: chunk_lanes(chain, spec),
                forces: vec![0.0; num_envs * f],
                stepped: vec![false; num_envs],
                status: vec![StepStatus::Ok; num_envs],
                hook: self.hook.clone(),
            });
        }
    }

    /// The worker of chunk 0, whose lane path (if any) says how every chunk steps.
    pub fn first_worker(&self) -> &Worker<G, H> {
        &self.workers[0]
    }

    /// Runs `work` on every chunk of `range` (one chunk per call, with the chunk's
    /// worker): the range is halved at chunk boundaries and the halves run in
    /// parallel. No chunk reads another's data, so the split changes no result.
    pub fn run_chunks<R: EnvRange>(
        &mut self,
        range: R,
        work: impl Fn(&Shared<G>, R, &mut Worker<G, H>) + Sync,
    ) {
        debug_assert_eq!(range.num_envs(), self.num_envs);
        run_range(&self.shared, range, &mut self.workers, &work);
    }
}

/// Steps every chunk of `range` with `work`, halving at chunk boundaries; a range of
/// one chunk runs on this thread.
fn run_range<G: Geometry, H: Send + Sync, R: EnvRange>(
    shared: &Shared<G>,
    range: R,
    workers: &mut [Worker<G, H>],
    work: &(impl Fn(&Shared<G>, R, &mut Worker<G, H>) + Sync),
) {
    let len = range.num_envs();
    if len <= CHUNK {
        work(shared, range, &mut workers[0]);
        return;
    }
    let chunks = len.div_ceil(CHUNK);
    let mid = chunks / 2 * CHUNK;
    let (range_a, range_b) = range.split_at(mid);
    let (workers_a, workers_b) = workers.split_at_mut(chunks / 2);
    let first = || run_range(shared, range_a, workers_a, work);
    let second = || run_range(shared, range_b, workers_b, work);
    if rayon::current_num_threads() > 1 {
        rayon::join(first, second);
    } else {
        // A one-thread pool gains nothing from `join`, and handing the work to its
        // thread (waking it on every step) costs more than stepping a chunk here.
        first();
        second();
    }
}

/// A physics-only step's per-env data: states, forces, statuses.
struct PhysicsRange<'a> {
    states: &'a mut [f64],
    forces: &'a [f64],
    status: &'a mut [StepStatus],
    d: usize,
    f: usize,
}

impl EnvRange for PhysicsRange<'_> {
    fn num_envs(&self) -> usize {
        self.status.len()
    }
    fn split_at(self, at: usize) -> (Self, Self) {
        let (s1, s2) = self.states.split_at_mut(at * self.d);
        let (f1, f2) = self.forces.split_at(at * self.f);
        let (t1, t2) = self.status.split_at_mut(at);
        let (d, f) = (self.d, self.f);
        (
            PhysicsRange {
                states: s1,
                forces: f1,
                status: t1,
                d,
                f,
            },
            PhysicsRange {
                states: s2,
                forces: f2,
                status: t2,
                d,
                f,
            },
        )
    }
}

/// Physics only (no task): every env stepped under given forces, and the owner's rows
/// kept in step with the lanes when they hold the states ([`StateHome::Lanes`]).
impl<G: LaneScene, H: LaneHook<G> + Clone> Engine<G, H> {
    /// Advances every env by one control period; env k feels the constant force
    /// `forces[k*f..(k+1)*f]` (checked by the caller). Envs whose step fails keep their
    /// last good state and say why in `status`. `rows` are the states (the lanes' copy
    /// when they hold the states).
    pub fn step(&mut self, rows: &mut [f64], forces: &[f64], status: &mut [StepStatus]) {
        if let Some(resident) = self.resident.as_mut() {
            resident.step(rows, forces, status, self.shared.plan());
            return;
        }
        let (d, f) = (self.shared.chain.state_dim(), self.shared.chain.force_dim());
        let range = PhysicsRange {
            states: rows,
            forces,
            status,
            d,
            f,
        };
        self.run_chunks(range, |shared, r, worker| {
            let (chain, dt, opts, guard) = (&shared.chain, shared.dt, &shared.opts, &shared.guard);
            for ((y, u), st) in r
                .states
                .chunks_exact_mut(d)
                .zip(r.forces.chunks_exact(f))
                .zip(r.status.iter_mut())
            {
                *st = worker
                    .stepper
                    .step(chain, y, G::Cart::load(u), dt, opts, guard);
            }
        });
    }

    /// Brings `rows` up to date if the lanes hold newer states.
    pub fn sync_rows(&mut self, rows: &mut [f64]) {
        if let Some(resident) = self.resident.as_mut() {
            resident.sync_rows(rows);
        }
    }

    /// The rows were written: the next step starts from them.
    pub fn rows_written(&mut self) {
        if let Some(resident) = self.resident.as_mut() {
            resident.rows_written();
        }
    }

    /// Copies `states` into `rows` (and into the lanes when they hold the states, each
    /// thread taking in the envs it steps).
    pub fn set_rows(&mut self, rows: &mut [f64], states: &[f64]) {
        match self.resident.as_mut() {
            Some(resident) => resident.set_rows(rows, states),
            None => rows.copy_from_slice(states),
        }
    }
}
