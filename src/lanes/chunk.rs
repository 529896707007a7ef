//! The lane path of one chunk of envs behind a small trait object ([`ChunkLanes`]),
//! so that the batch engine holds one type whatever lane width and number type the
//! chunk runs in ([`chunk_lanes`] chooses them): one shared chain broadcast into every
//! lane, or one chain per env loaded lane by lane. The work done on each group right
//! after its step (`H`, see [`AfterStep`]) is compiled into the kernel.

use super::dispatch::Kernel;
use super::hook::{AfterStep, LaneHook};
use super::lane_vectors::LaneGeometry;
use super::params::LaneParams;
use super::simd::{LaneReal, Precision};
use super::stepper::{LaneStepper, StepPlan};
use super::{LaneScene, LANES, LANES_F32};
use crate::error::{InputError, Result};
use crate::integrate::StepStatus;
use crate::model::Chain;
use crate::params::ChainParams;

/// The lane kernel for one chunk, whatever its lane width and number type; `H` is
/// the work done on each group right after its step.
pub trait ChunkLanes<H>: Send + Sync {
    /// Steps the envs with `stepped[k]` (see [`LaneStepper::step`]) and, if given, runs
    /// `after` on each stepped group ([`LaneStepper::step_with`]).
    fn step(
        &mut self,
        states: &mut [f64],
        forces: &[f64],
        stepped: &[bool],
        plan: StepPlan<'_>,
        status: &mut [StepStatus],
        after: Option<&mut H>,
    );

    /// Gives env `k` of the chunk the chain `params` (same number of links). Only a
    /// chunk built with one chain per env has lanes of its own; for a shared chain
    /// this is an error naming `k`.
    fn set_env_params(&mut self, k: usize, params: &ChainParams) -> Result<()>;

    /// The compiled kernel that steps the chunk.
    fn kernel(&self) -> Kernel;

    /// The number type of the lanes.
    fn precision(&self) -> Precision;
}

/// What a chunk's lane path is built for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChunkSpec {
    /// Envs in the chunk.
    pub num_envs: usize,
    /// Whether each env gets its own chain ([`ChunkLanes::set_env_params`]); else all
    /// share the chain the chunk is built from.
    pub per_env: bool,
    /// The compiled kernel.
    pub kernel: Kernel,
    /// f64 ([`LANES`] per group) or f32 ([`LANES_F32`] per group).
    pub precision: Precision,
}

/// The lane kernel with the chunk's parameters (one broadcast entry, or one per
/// group of `L` envs).
pub struct LaneChunk<G: LaneGeometry<L, T>, const L: usize = LANES, T: LaneReal = f64> {
    kernel: Kernel,
    params: Vec<LaneParams<L, T>>,
    /// Each env has its own lane parameters (else `params` is one broadcast entry).
    per_env: bool,
    stepper: LaneStepper<G, L, T>,
}

impl<G: LaneGeometry<L, T>, const L: usize, T: LaneReal> LaneChunk<G, L, T> {
    /// `chain`'s parameters in every lane: one broadcast entry, or (`per_env`) one
    /// entry per group of `L` of the `num_envs` envs, to be changed lane by lane.
    fn filled(chain: &Chain<G>, num_envs: usize, per_env: bool, kernel: Kernel) -> Self {
        let groups = if per_env { num_envs.div_ceil(L) } else { 1 };
        Self {
            kernel,
            params: vec![LaneParams::broadcast(chain.params()); groups.max(1)],
            per_env,
            stepper: LaneStepper::new(chain.n_links()),
        }
    }

    /// The lane path for `spec` (its precision must be the one `T` is).
    pub fn for_spec(chain: &Chain<G>, spec: ChunkSpec) -> Self {
        debug_assert_eq!(spec.precision, T::PRECISION);
        Self::filled(chain, spec.num_envs, spec.per_env, spec.kernel)
    }

    /// Gives env `k` of the chunk the chain `params` (same number of links). Only a
    /// chunk built with one chain per env has lanes of its own; for a shared chain
    /// this is an error naming `k`.
    pub fn set_env_params(&mut self, k: usize, params: &ChainParams) -> Result<()> {
        match self.params.get_mut(k / L) {
            Some(group) if self.per_env => group.set_lane(k % L, params),
            _ => Err(InputError::InvalidParameter {
                name: "env index in the chunk",
                value: k as f64,
                expected: "an env of a chunk built with one chain per env",
            }
            .into()),
        }
    }
}

impl<G: LaneGeometry<LANES>> LaneChunk<G> {
    /// All envs of the chunk share `chain`'s parameters.
    pub fn shared(chain: &Chain<G>, kernel: Kernel) -> Self {
        Self::filled(chain, 1, false, kernel)
    }

    /// Env k of the chunk has the chain `params[k]` (all with the same number of
    /// links as `chain`); unused lanes of the last group carry `chain` (their results
    /// are discarded).
    pub fn per_env(chain: &Chain<G>, params: &[ChainParams], kernel: Kernel) -> Result<Self> {
        let mut chunk = Self::filled(chain, params.len(), true, kernel);
        for (k, p) in params.iter().enumerate() {
            chunk.set_env_params(k, p)?;
        }
        Ok(chunk)
    }
}

impl<G, const L: usize, T, H> ChunkLanes<H> for LaneChunk<G, L, T>
where
    G: LaneGeometry<L, T>,
    T: LaneReal,
    H: AfterStep<G, L, T>,
{
    fn step(
        &mut self,
        states: &mut [f64],
        forces: &[f64],
        stepped: &[bool],
        plan: StepPlan<'_>,
        status: &mut [StepStatus],
        after: Option<&mut H>,
    ) {
        let stepped = Some(stepped);
        let (kernel, params, stepper) = (self.kernel, &self.params[..], &mut self.stepper);
        match after {
            None => stepper.step(kernel, params, states, forces, stepped, plan, status),
            Some(h) => stepper.step_with(kernel, params, states, forces, stepped, plan, status, h),
        }
    }

    fn set_env_params(&mut self, k: usize, params: &ChainParams) -> Result<()> {
        LaneChunk::set_env_params(self, k, params)
    }

    fn kernel(&self) -> Kernel {
        self.kernel
    }

    fn precision(&self) -> Precision {
        T::PRECISION
    }
}

/// Chains of up to this many links are stepped two vector widths at a time: their
/// step is short, and a group twice as wide gives the core two independent chains of
/// operations to overlap (one planar link: +18% env steps/s on one core; with two
/// links the wider group was slower, and four widths were no better than two).
pub const MAX_LINKS_IN_DOUBLE_GROUPS: usize = 1;

/// The lane path of a chunk of envs of `chain` as `spec` says, boxed, with `H` run on
/// each group after its step.
pub fn chunk_lanes<G: LaneScene, H: LaneHook<G>>(
    chain: &Chain<G>,
    spec: ChunkSpec,
) -> Box<dyn ChunkLanes<H>> {
    let wide = chain.n_links() <= MAX_LINKS_IN_DOUBLE_GROUPS;
    match (spec.precision, wide) {
        (Precision::F64, false) => Box::new(LaneChunk::<G, LANES, f64>::for_spec(chain, spec)),
        (Precision::F64, true) => {
            Box::new(LaneChunk::<G, { 2 * LANES }, f64>::for_spec(chain, spec))
        }
        (Precision::F32, false) => Box::new(LaneChunk::<G, LANES_F32, f32>::for_spec(chain, spec)),
        (Precision::F32, true) => Box::new(LaneChunk::<G, { 2 * LANES_F32 }, f32>::for_spec(
            chain, spec,
        )),
    }
}
