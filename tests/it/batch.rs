//! Batch stepping: same results as stepping each env alone, bit-identical for any
//! thread count, failures isolated to their env (allocation: tests/it/allocations/).

use super::common;

use chaincart::engine::CHUNK;
use chaincart::integrate::StepStatus;
use chaincart::{ChainParams, Method, SpatialChain, StepOptions, Stepper};
use common::batches::{forces, random_batch};
use nalgebra::Vector2;

fn run_in_pool(threads: usize, num_envs: usize, method: Method) -> Vec<f64> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let (mut batch, _) = random_batch(num_envs, method, 3);
        for step in 0..50 {
            batch.step(&forces(num_envs, step)).unwrap();
        }
        batch.states().to_vec()
    })
}

#[test]
fn results_are_bit_identical_for_one_and_two_threads() {
    for method in Method::ALL {
        let one = run_in_pool(1, 4 * CHUNK + 3, method);
        let two = run_in_pool(2, 4 * CHUNK + 3, method);
        assert!(
            one.iter()
                .zip(&two)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{}",
            method.name()
        );
    }
}

#[test]
fn batch_equals_stepping_each_env_alone() {
    let num_envs = 2 * CHUNK + 5;
    let (mut batch, states) = random_batch(num_envs, Method::Rkmk4, 4);
    for step in 0..20 {
        batch.step(&forces(num_envs, step)).unwrap();
    }
    let chain = SpatialChain::new(ChainParams::paper());
    let opts = StepOptions {
        method: Method::Rkmk4,
        ..StepOptions::default()
    };
    let mut stepper = Stepper::new(&chain);
    for (k, y0) in states.iter().enumerate() {
        let mut y = y0.clone();
        for step in 0..20 {
            let f = forces(num_envs, step);
            stepper
                .step(
                    &chain,
                    &mut y,
                    Vector2::new(f[2 * k], f[2 * k + 1]),
                    2e-3,
                    &opts,
                )
                .unwrap();
        }
        assert_eq!(batch.state(k), &y[..], "env {k}");
    }
}

#[test]
fn a_bad_force_changes_no_env() {
    let num_envs = 40;
    let (mut batch, _) = random_batch(num_envs, Method::Rk4, 5);
    let before = batch.states().to_vec();
    let mut f = forces(num_envs, 0);
    f[2 * 17 + 1] = f64::NAN;
    let err = batch.step(&f).unwrap_err();
    assert!(err.to_string().contains("forces[35] = NaN"), "{err}");
    assert_eq!(batch.states(), &before[..]);
    assert!(batch.step(&f[..10]).is_err());
    assert_eq!(batch.states(), &before[..]);
}

#[test]
fn a_blow_up_in_one_env_leaves_the_others_untouched() {
    let num_envs = 3 * CHUNK;
    let (mut batch, states) = random_batch(num_envs, Method::Rk4, 6);
    let (mut reference, _) = random_batch(num_envs, Method::Rk4, 6);
    let mut f = forces(num_envs, 0);
    let g = f.clone();
    f[2 * 40] = 1e9; // far past what a 2 ms step resolves
    batch.step(&f).unwrap();
    reference.step(&g).unwrap();
    for (k, start) in states.iter().enumerate() {
        if k == 40 {
            assert!(batch.status()[k].is_failure());
            assert_eq!(
                batch.state(k),
                &start[..],
                "failed env keeps its last good state"
            );
        } else {
            assert_eq!(batch.status()[k], StepStatus::Ok);
            assert_eq!(batch.state(k), reference.state(k), "env {k}");
        }
    }
}
