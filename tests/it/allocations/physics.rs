//! The physics step loop allocates nothing.

use super::super::common::batches::{forces, random_batch};
use super::counter::allocations_of;
use chaincart::engine::CHUNK;
use chaincart::integrate::{Guard, GuardedStepper};
use chaincart::lanes::Precision;
use chaincart::{ChainParams, Method, SpatialChain, StepOptions};
use nalgebra::Vector2;

#[test]
fn stepping_allocates_nothing() {
    for method in Method::ALL {
        for num_envs in [1, CHUNK, 8 * CHUNK] {
            let (mut batch, _) = random_batch(num_envs, method, 7);
            let f = forces(num_envs, 1);
            batch.step(&f).unwrap(); // warm up the workers' scratch
            let (during, here) = allocations_of(|| {
                for _ in 0..5 {
                    batch.step(&f).unwrap();
                }
            });
            eprintln!(
                "{} N = {num_envs}: {during} allocations in 5 steps ({here} on the calling thread)",
                method.name()
            );
            // The calling thread steps single-chunk batches itself; the workers step
            // the rest: neither allocates.
            assert_eq!(here, 0, "{} N = {num_envs}", method.name());
            assert_eq!(during, 0, "{} N = {num_envs}", method.name());
        }
    }
    // The f32 lane path.
    for num_envs in [CHUNK, 8 * CHUNK] {
        let (mut batch, _) = random_batch(num_envs, Method::Rk4, 8);
        batch.set_precision(Precision::F32).unwrap();
        let f = forces(num_envs, 1);
        batch.step(&f).unwrap();
        let (during, here) = allocations_of(|| {
            for _ in 0..5 {
                batch.step(&f).unwrap();
            }
        });
        assert_eq!((during, here), (0, 0), "f32 N = {num_envs}");
    }
    // And a single guarded step.
    let chain = SpatialChain::new(ChainParams::paper());
    let mut stepper = GuardedStepper::new(&chain);
    let mut y = chain.equilibrium(&[1.0, -1.0, 1.0, -1.0, 1.0]).unwrap();
    let (opts, guard) = (StepOptions::default(), Guard::default());
    let (during, here) = allocations_of(|| {
        stepper.step(&chain, &mut y, Vector2::new(1.0, 0.0), 1e-3, &opts, &guard);
    });
    assert_eq!((during, here), (0, 0));
}
