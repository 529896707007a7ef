//! One env per SIMD lane: the guarded rk4 control step of many independent chains
//! at once, with the state laid out component-major across lanes.
//!
//! * `simd`: `L` numbers per value, plain arrays that LLVM vectorises.
//! * `lane_vectors`: lane vectors and the spatial/planar scene operations on them.
//! * `params`: chain parameters per lane (a shared chain is a broadcast).
//! * `exp`: `exp` written once for scalar and lane code (the task's reward).
//! * `hook`: [`AfterStep`], work a layer above does on each group right after its step
//!   (how the task measures states in the lanes without the lanes knowing the task).
//! * `guarded_rk4`: the kernel, a transcription of the scalar path operation for operation.
//! * `dispatch`: the kernel compiled for baseline, AVX2 and AVX-512, chosen at run time.
//! * `stepper`: stepping envs in lane groups, from env-major rows or in place.
//! * `resident_groups`: states kept in lane groups between steps (no transposes).
//! * `transpose`: moving env rows into lanes and back (8 x 8 blocks on AVX-512).
//! * `chunk`: the lane path of one chunk of envs behind a trait object (the batch engine).
//!
//! Each lane computes exactly what the scalar code computes for its env (no fused
//! multiply-adds, same operation order), so results do not depend on the lane width,
//! the kernel chosen or which envs share a group. See `docs/simd.md`.

mod chunk;
mod dispatch;
mod exp;
mod guarded_rk4;
mod hook;
mod lane_vectors;
mod params;
mod resident_groups;
mod simd;
mod stepper;
mod transpose;

pub use chunk::{chunk_lanes, ChunkLanes, ChunkSpec, LaneChunk};
pub use dispatch::Kernel;
pub use exp::exp;
pub use hook::{room, AfterStep, LaneHook, NoHook};
pub use lane_vectors::LaneGeometry;
pub use lane_vectors::LaneVector;
pub use params::LaneParams;
pub use resident_groups::LaneStates;
pub use resident_groups::{load_groups, store_groups};
pub use simd::{LaneReal, Lanes, Precision};
pub use stepper::{LaneStepper, StepPlan};

/// Lanes per group in f64: one AVX-512 register, two AVX2 registers, four SSE2 ones.
pub const LANES: usize = 8;

/// Lanes per group in f32 (the same registers, twice the numbers).
pub const LANES_F32: usize = 16;

/// A scene with lane kernels in both precisions (the spatial and the planar one).
pub trait LaneScene:
    LaneGeometry<LANES>
    + LaneGeometry<LANES_F32, f32>
    + LaneGeometry<{ 2 * LANES }>
    + LaneGeometry<{ 2 * LANES_F32 }, f32>
{
}
impl<G> LaneScene for G where
    G: LaneGeometry<LANES>
        + LaneGeometry<LANES_F32, f32>
        + LaneGeometry<{ 2 * LANES }>
        + LaneGeometry<{ 2 * LANES_F32 }, f32>
{
}
