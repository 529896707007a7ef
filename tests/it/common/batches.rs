//! Batches of the paper's system from random states, and deterministic force patterns.

use super::{random_spatial_state, rng};
use chaincart::engine::ChainBatch;
use chaincart::{ChainParams, Method, SpatialChain, StepOptions};

pub fn random_batch(
    num_envs: usize,
    method: Method,
    seed: u64,
) -> (ChainBatch<chaincart::Spatial>, Vec<Vec<f64>>) {
    let mut rng = rng(seed);
    let chain = SpatialChain::new(ChainParams::paper());
    let mut batch = ChainBatch::new(
        chain,
        num_envs,
        2e-3,
        StepOptions {
            method,
            ..StepOptions::default()
        },
    )
    .unwrap();
    let states: Vec<Vec<f64>> = (0..num_envs)
        .map(|_| random_spatial_state(&mut rng, 5, 1.0))
        .collect();
    for (k, y) in states.iter().enumerate() {
        batch.set_state(k, y).unwrap();
    }
    (batch, states)
}

pub fn forces(num_envs: usize, step: usize) -> Vec<f64> {
    (0..2 * num_envs)
        .map(|j| ((j * 7 + step * 13) % 11) as f64 - 5.0)
        .collect()
}
