//! A per-chunk worker for batches whose code is generic over any
//! [`Geometry`]: a scalar [`GuardedStepper`] plus, when enabled, the lane kernel
//! behind a small trait object (enabled where the concrete scene is known). The
//! caller queues each env's force, runs the lane groups once, then reads each env's
//! status as if it had stepped that env alone, which gives the same bits.

use super::dispatch::Kernel;
use super::params::LaneParams;
use super::stepper::{LaneStepper, StepPlan};
use super::vector::LaneGeometry;
use super::LANES;
use crate::batch::{Guard, GuardedStepper, StepStatus};
use crate::error::Result;
use crate::geometry::{Geometry, Vector};
use crate::integrate::StepOptions;
use crate::model::Chain;
use crate::params::ChainParams;

/// The lane kernel for one chunk, seen from scene-generic code.
pub trait ChunkLanes: Send + Sync {
    /// Steps the envs with `stepped[k]` (see [`LaneStepper::step`]).
    fn step(
        &mut self,
        states: &mut [f64],
        forces: &[f64],
        stepped: &[bool],
        plan: StepPlan<'_>,
        status: &mut [StepStatus],
    );
}

/// The lane kernel with the chunk's parameters (one broadcast entry, or one per
/// group of [`LANES`] envs).
pub struct LaneChunk<G: LaneGeometry<LANES>> {
    kernel: Kernel,
    params: Vec<LaneParams<LANES>>,
    stepper: LaneStepper<G, LANES>,
}

impl<G: LaneGeometry<LANES>> LaneChunk<G> {
    /// All envs of the chunk share `chain`'s parameters.
    pub fn shared(chain: &Chain<G>, kernel: Kernel) -> Self {
        Self {
            kernel,
            params: vec![LaneParams::broadcast(chain.params())],
            stepper: LaneStepper::new(chain.n_links()),
        }
    }
}

impl<G: LaneGeometry<LANES>> LaneChunk<G> {
    /// Env k of the chunk has the chain `params[k]` (all with the same number of
    /// links as `chain`); unused lanes of the last group repeat its first env.
    pub fn per_env(chain: &Chain<G>, params: &[ChainParams], kernel: Kernel) -> Result<Self> {
        let groups = params
            .chunks(LANES)
            .map(|group| {
                let mut lanes = LaneParams::broadcast(chain.params());
                for lane in 0..LANES {
                    lanes.set_lane(lane, group.get(lane).unwrap_or(&group[0]))?;
                }
                Ok(lanes)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            kernel,
            params: groups,
            stepper: LaneStepper::new(chain.n_links()),
        })
    }
}

impl<G: LaneGeometry<LANES>> ChunkLanes for LaneChunk<G> {
    fn step(
        &mut self,
        states: &mut [f64],
        forces: &[f64],
        stepped: &[bool],
        plan: StepPlan<'_>,
        status: &mut [StepStatus],
    ) {
        let stepped = Some(stepped);
        let (kernel, params) = (self.kernel, &self.params[..]);
        self.stepper
            .step(kernel, params, states, forces, stepped, plan, status);
    }
}

/// Queued forces and results of a chunk's lane step.
struct Queue {
    lanes: Box<dyn ChunkLanes>,
    forces: Vec<f64>,
    stepped: Vec<bool>,
    status: Vec<StepStatus>,
}

/// One chunk's physics: scalar guarded steps, or queued lane steps when enabled.
pub struct ChunkWorker<G: Geometry> {
    guarded: GuardedStepper<G>,
    state_dim: usize,
    queue: Option<Queue>,
}

impl<G: Geometry> ChunkWorker<G> {
    /// A worker that steps env by env until lanes are enabled.
    pub fn new(chain: &Chain<G>) -> Self {
        Self {
            guarded: GuardedStepper::new(chain),
            state_dim: chain.state_dim(),
            queue: None,
        }
    }

    /// Steps this chunk's `chunk_len` envs with `lanes` from now on.
    pub fn enable_lanes(&mut self, lanes: Box<dyn ChunkLanes>, chunk_len: usize) {
        self.queue = Some(Queue {
            lanes,
            forces: vec![0.0; chunk_len * G::Cart::DIM],
            stepped: vec![false; chunk_len],
            status: vec![StepStatus::Ok; chunk_len],
        });
    }

    /// Whether the chunk steps through the lane kernel.
    pub fn uses_lanes(&self) -> bool {
        self.queue.is_some()
    }

    /// Lane path: env k of the chunk will be stepped under `force` (or not at all).
    pub fn queue(&mut self, k: usize, force: &[f64], stepped: bool) {
        if let Some(q) = self.queue.as_mut() {
            let f = G::Cart::DIM;
            q.forces[k * f..(k + 1) * f].copy_from_slice(&force[..f]);
            q.stepped[k] = stepped;
        }
    }

    /// Lane path: steps the queued envs of `states` (the chunk, env-major).
    pub fn run_queue(&mut self, states: &mut [f64], plan: StepPlan<'_>) {
        if let Some(q) = self.queue.as_mut() {
            let envs = states.len() / self.state_dim;
            q.lanes.step(
                states,
                &q.forces[..envs * G::Cart::DIM],
                &q.stepped[..envs],
                plan,
                &mut q.status[..envs],
            );
        }
    }

    /// Env k's guarded step: the queued lane result (the state was already
    /// advanced by [`ChunkWorker::run_queue`]), or a scalar step of `y` now.
    #[allow(clippy::too_many_arguments)]
    pub fn step_env(
        &mut self,
        k: usize,
        chain: &Chain<G>,
        y: &mut [f64],
        force: G::Cart,
        dt: f64,
        opts: &StepOptions,
        guard: &Guard,
    ) -> StepStatus {
        match &self.queue {
            Some(q) => q.status[k],
            None => self.guarded.step(chain, y, force, dt, opts, guard),
        }
    }
}
