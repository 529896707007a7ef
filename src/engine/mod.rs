//! The batch engine: N envs of one chain stepped together, in parallel, on the lane
//! kernel or env by env, bit-identical whatever the thread count.
//!
//! * `stepping`: [`Engine`], the one engine every batch steps with: settings, the lane
//!   kernel or the per-env path and the rules of choosing, one worker per chunk of
//!   envs, the parallel pass over the chunks.
//! * `resident`: the physics-only batch's lane path, states kept in lane groups.
//! * `chains`: [`ChainBatch`], N states of one chain, physics only.
//!
//! The task (`crate::env`) builds its env batch on the same [`Engine`].

mod chains;
mod lane_path;
mod stepping;

pub use chains::ChainBatch;
pub use lane_path::LANE_CHUNK;
pub use stepping::{
    check_ideal_for_lanes, check_precision, ChunkLanePath, Engine, EnvRange, Shared, StateHome,
    Worker, CHUNK, F32_MIN_UNIT_LENGTH_TOLERANCE, MIN_LANE_ENVS,
};
