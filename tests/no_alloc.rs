//! The step loop allocates nothing. Its own test binary: the counting allocator
//! sees every thread, so no other test may run beside it.

mod common;

use chaincart::batch::{Batch, Guard, GuardedStepper, CHUNK};
use chaincart::{ChainParams, Method, SpatialChain, StepOptions};
use common::*;
use nalgebra::Vector2;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Counts heap allocations, so tests can assert the step loop makes none.
struct CountingAllocator;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
thread_local! {
    // Allocations made by this thread (const-initialised: reading it never allocates).
    static THIS_THREAD: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        THIS_THREAD.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

pub fn random_batch(
    n_envs: usize,
    method: Method,
    seed: u64,
) -> (Batch<chaincart::Spatial>, Vec<Vec<f64>>) {
    let mut rng = rng(seed);
    let chain = SpatialChain::new(ChainParams::paper());
    let mut batch = Batch::new(
        chain,
        n_envs,
        2e-3,
        StepOptions {
            method,
            ..StepOptions::default()
        },
    )
    .unwrap();
    let states: Vec<Vec<f64>> = (0..n_envs)
        .map(|_| random_spatial_state(&mut rng, 5, 1.0))
        .collect();
    for (k, y) in states.iter().enumerate() {
        batch.set_state(k, y).unwrap();
    }
    (batch, states)
}

pub fn forces(n_envs: usize, step: usize) -> Vec<f64> {
    (0..2 * n_envs)
        .map(|j| ((j * 7 + step * 13) % 11) as f64 - 5.0)
        .collect()
}

#[test]
fn stepping_allocates_nothing() {
    for method in Method::ALL {
        for n_envs in [1, CHUNK, 8 * CHUNK] {
            let (mut batch, _) = random_batch(n_envs, method, 7);
            let f = forces(n_envs, 1);
            batch.step(&f).unwrap(); // warm up the thread pool
            let (before, before_here) = (
                ALLOCATIONS.load(Ordering::SeqCst),
                THIS_THREAD.with(|c| c.get()),
            );
            for _ in 0..5 {
                batch.step(&f).unwrap();
            }
            let during = ALLOCATIONS.load(Ordering::SeqCst) - before;
            let here = THIS_THREAD.with(|c| c.get()) - before_here;
            eprintln!(
                "{} N = {n_envs}: {during} allocations in 5 steps ({here} on the calling thread)",
                method.name()
            );
            // The calling thread, which steps single-chunk batches itself, allocates
            // nothing; across all threads a stray allocation or two can come from the
            // test harness, and anything that scaled with N would show far more.
            assert_eq!(here, 0, "{} N = {n_envs}", method.name());
            assert!(
                during <= 5,
                "{} N = {n_envs}: {during} allocations",
                method.name()
            );
        }
    }
    // And a single guarded step.
    let chain = SpatialChain::new(ChainParams::paper());
    let mut stepper = GuardedStepper::new(&chain);
    let mut y = chain.equilibrium(&[1.0, -1.0, 1.0, -1.0, 1.0]).unwrap();
    let (opts, guard) = (StepOptions::default(), Guard::default());
    let before = THIS_THREAD.with(|c| c.get());
    stepper.step(&chain, &mut y, Vector2::new(1.0, 0.0), 1e-3, &opts, &guard);
    assert_eq!(THIS_THREAD.with(|c| c.get()) - before, 0);
}
