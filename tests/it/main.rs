//! The integration tests: each file of this folder is a module. `src/lib.rs` includes
//! this file as a module of the library's unit-test binary, so that the crate's generic
//! code is compiled once for the unit and the integration tests; they reach the crate by
//! its name (`chaincart::`), as users do, and their helpers by `super::`.

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
