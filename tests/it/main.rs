//! The integration tests, one binary: each file of this folder is a module, so the
//! crate is linked once for all of them.

mod common;

mod allocations;
mod analysis;
mod architecture;
mod batch;
mod control;
mod dense_vs_fast;
mod env_lanes;
mod env_reality;
mod env_regression;
mod env_tasks;
mod extremes;
mod integrators;
mod lanes;
mod paper_examples;
mod properties;
mod rig;
mod sensors;

/// Counts the allocations of the threads that `allocations` measures (no other's).
#[global_allocator]
static GLOBAL: allocations::counter::CountingAllocator = allocations::counter::CountingAllocator;
