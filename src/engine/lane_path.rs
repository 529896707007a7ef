//! The lane path of a physics-only batch: the states kept component-major in lane
//! groups between steps (no transposes while stepping again and again; rows are moved
//! in or out only when the owner reads or writes them), each thread stepping one
//! contiguous run of whole [`LANE_CHUNK`]s of envs. The task reads and writes rows
//! every step, so env batches step chunk by chunk on rows instead (see [`super::Engine`]).

use crate::integrate::StepStatus;
use crate::lanes::{load_groups, store_groups};
use crate::lanes::{
    Kernel, LaneGeometry, LaneParams, LaneScene, LaneStates, LaneStepper, Precision, StepPlan,
    LANES, LANES_F32,
};
use crate::lanes::{LaneReal, Lanes};
use crate::model::Chain;
use rayon::prelude::*;

/// Envs per unit of the resident lane path's work split (a multiple of the lane
/// width): a thread steps a run of whole units. The lanes are independent, so this
/// changes no result, only the scheduling.
pub const LANE_CHUNK: usize = 128;

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

/// A physics-only batch's states in lane groups, in the chosen precision.
pub(super) struct ResidentLanes<G: LaneScene>(LaneMode<G>);

impl<G: LaneScene> ResidentLanes<G> {
    /// Lanes for `num_envs` envs of `chain` (their states are read from the rows at
    /// the first step).
    pub fn new(chain: &Chain<G>, num_envs: usize, kernel: Kernel, precision: Precision) -> Self {
        Self(match precision {
            Precision::F64 => LaneMode::F64(LanePath::new(chain, num_envs, kernel)),
            Precision::F32 => LaneMode::F32(LanePath::new(chain, num_envs, kernel)),
        })
    }

    /// Steps with `kernel` from now on (same bits, another compiled kernel).
    pub fn set_kernel(&mut self, kernel: Kernel) {
        match &mut self.0 {
            LaneMode::F64(path) => path.kernel = kernel,
            LaneMode::F32(path) => path.kernel = kernel,
        }
    }

    /// Brings the env-major `rows` up to date with the lanes.
    pub fn sync_rows(&mut self, rows: &mut [f64]) {
        match &mut self.0 {
            LaneMode::F64(path) => path.sync_rows(rows),
            LaneMode::F32(path) => path.sync_rows(rows),
        }
    }

    /// The env-major rows were written: the next step starts from them.
    pub fn rows_written(&mut self) {
        match &mut self.0 {
            LaneMode::F64(path) => path.current = Current::Rows,
            LaneMode::F32(path) => path.current = Current::Rows,
        }
    }

    /// Takes new states for every env into `rows` and the lanes at once.
    pub fn set_rows(&mut self, rows: &mut [f64], states: &[f64]) {
        match &mut self.0 {
            LaneMode::F64(path) => path.set_rows(rows, states),
            LaneMode::F32(path) => path.set_rows(rows, states),
        }
    }

    /// Steps every env (see [`LanePath::step`]).
    pub fn step(
        &mut self,
        rows: &[f64],
        forces: &[f64],
        status: &mut [StepStatus],
        plan: StepPlan<'_>,
    ) {
        match &mut self.0 {
            LaneMode::F64(path) => path.step(rows, forces, status, plan),
            LaneMode::F32(path) => path.step(rows, forces, status, plan),
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
