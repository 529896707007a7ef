//! The O(n) tension form against the paper's dense eq. (ELwm), on random states,
//! forces, masses and lengths.

use super::common;

use chaincart::dense::dense_derivative;
use chaincart::SpatialChain;
use common::*;
use nalgebra::Vector2;

fn compare(n: usize, mass_ratio: f64, length_ratio: f64, seed: u64) -> f64 {
    let mut rng = rng(seed);
    let params = random_params(&mut rng, n, mass_ratio, length_ratio);
    let chain = SpatialChain::new(params.clone());
    let mut ws = chain.workspace();
    let mut worst: f64 = 0.0;
    for _ in 0..5 {
        let y = random_spatial_state(&mut rng, n, 3.0);
        let u = Vector2::new(rng_f(&mut rng) * 10.0, rng_f(&mut rng) * 10.0);
        let mut fast = vec![0.0; chain.state_dim()];
        let mut dense = vec![0.0; chain.state_dim()];
        chain.derivative(&y, u, &mut ws, &mut fast);
        dense_derivative(&params, &y, u, &mut dense).expect("dense matrix is regular");
        let rel = max_abs_diff(&fast, &dense) / max_abs(&dense).max(1.0);
        worst = worst.max(rel);
    }
    worst
}

fn rng_f(rng: &mut rand::rngs::StdRng) -> f64 {
    use rand::Rng;
    rng.random_range(-1.0..1.0)
}

#[test]
fn fast_form_equals_dense_form_for_n_1_to_64() {
    for (seed, n) in [1, 2, 3, 4, 5, 7, 10, 16, 32, 64].into_iter().enumerate() {
        let rel = compare(n, 10.0, 10.0, seed as u64);
        // The dense LU loses accuracy with n (its condition grows); the bound stays at round-off scale.
        let bound = 1e-13 * (n as f64).powi(2).max(10.0);
        assert!(
            rel < bound,
            "n = {n}: relative difference {rel:e} > {bound:e}"
        );
        eprintln!("n = {n:3}: max relative difference fast vs dense = {rel:.2e}");
    }
}

#[test]
fn fast_form_equals_dense_form_with_extreme_ratios() {
    for (seed, n) in [2usize, 5, 8].into_iter().enumerate() {
        let rel = compare(n, 1e4, 1e3, 100 + seed as u64);
        assert!(rel < 1e-8, "n = {n}: relative difference {rel:e}");
        eprintln!("n = {n}, mass ratio 1e4, length ratio 1e3: {rel:.2e}");
    }
}
