//! The step loop allocates nothing. Its own test binary: the counting allocator
//! sees every thread, so no other test may run beside it.

mod common;

use chaincart::batch::{Guard, GuardedStepper, Precision, CHUNK};
use chaincart::{ChainParams, Method, SpatialChain, StepOptions};
use common::batches::{forces, random_batch};
use nalgebra::Vector2;
#[path = "common/alloc_counter.rs"]
mod alloc_counter;

use alloc_counter::{counts, CountingAllocator};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn stepping_allocates_nothing() {
    for method in Method::ALL {
        for num_envs in [1, CHUNK, 8 * CHUNK] {
            let (mut batch, _) = random_batch(num_envs, method, 7);
            let f = forces(num_envs, 1);
            batch.step(&f).unwrap(); // warm up the thread pool
            let (before, before_here) = counts();
            for _ in 0..5 {
                batch.step(&f).unwrap();
            }
            let (after, after_here) = counts();
            let (during, here) = (after - before, after_here - before_here);
            eprintln!(
                "{} N = {num_envs}: {during} allocations in 5 steps ({here} on the calling thread)",
                method.name()
            );
            // The calling thread, which steps single-chunk batches itself, allocates
            // nothing; across all threads a stray allocation or two can come from the
            // test harness, and anything that scaled with N would show far more.
            assert_eq!(here, 0, "{} N = {num_envs}", method.name());
            assert!(
                during <= 5,
                "{} N = {num_envs}: {during} allocations",
                method.name()
            );
        }
    }
    // The f32 lane path.
    for num_envs in [CHUNK, 8 * CHUNK] {
        let (mut batch, _) = random_batch(num_envs, Method::Rk4, 8);
        batch.set_precision(Precision::F32).unwrap();
        let f = forces(num_envs, 1);
        batch.step(&f).unwrap();
        let (before, before_here) = counts();
        for _ in 0..5 {
            batch.step(&f).unwrap();
        }
        let (after, after_here) = counts();
        assert_eq!(after_here - before_here, 0, "f32 N = {num_envs}");
        assert!(
            after - before <= 5,
            "f32 N = {num_envs}: {}",
            after - before
        );
    }
    // And a single guarded step.
    let chain = SpatialChain::new(ChainParams::paper());
    let mut stepper = GuardedStepper::new(&chain);
    let mut y = chain.equilibrium(&[1.0, -1.0, 1.0, -1.0, 1.0]).unwrap();
    let (opts, guard) = (StepOptions::default(), Guard::default());
    let before = counts().1;
    stepper.step(&chain, &mut y, Vector2::new(1.0, 0.0), 1e-3, &opts, &guard);
    assert_eq!(counts().1 - before, 0);
}
