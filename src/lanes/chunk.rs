//! The lane path of one chunk of envs behind a small trait object ([`ChunkLanes`]),
//! so that code generic over any geometry can step a chunk whose concrete scene is
//! known only where the chunk is built: [`LaneChunk::shared`] for envs of one chain,
//! [`LaneChunk::per_env`] for envs with their own parameters.

use super::dispatch::Kernel;
use super::params::LaneParams;
use super::stepper::{LaneStepper, StepPlan};
use super::vector::LaneGeometry;
use super::LANES;
use crate::batch::StepStatus;
use crate::error::Result;
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
