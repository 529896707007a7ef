//! Shared helpers for the integration tests: random parameters and states.
#![allow(dead_code)]

pub mod batches;
pub mod scenes;

use chaincart::geometry::{Geometry, Layout, Vector};
use chaincart::{ChainParams, Planar, Spatial};
use nalgebra::{Vector2, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

/// Log-uniform in [lo, hi].
pub fn log_uniform(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    (rng.random_range(lo.ln()..hi.ln())).exp()
}

/// Random parameters with masses and lengths spanning the given ratio.
pub fn random_params(
    rng: &mut StdRng,
    n: usize,
    mass_ratio: f64,
    length_ratio: f64,
) -> ChainParams {
    let masses: Vec<f64> = (0..n)
        .map(|_| log_uniform(rng, 0.1, 0.1 * mass_ratio))
        .collect();
    let lengths: Vec<f64> = (0..n)
        .map(|_| log_uniform(rng, 0.1, 0.1 * length_ratio))
        .collect();
    ChainParams::new(log_uniform(rng, 0.1, 10.0), &masses, &lengths, 9.81).unwrap()
}

fn unit3(rng: &mut StdRng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let norm = v.norm();
        if norm > 0.1 && norm < 1.0 {
            return v / norm;
        }
    }
}

/// A random spatial state on the constraint manifold with spins of size ~`spin`.
pub fn random_spatial_state(rng: &mut StdRng, n: usize, spin: f64) -> Vec<f64> {
    let lay = Layout::<Spatial>::new(n);
    let mut y = vec![0.0; lay.dim()];
    lay.store_x(
        &mut y,
        Vector2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)),
    );
    lay.store_xdot(
        &mut y,
        Vector2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)),
    );
    for i in 0..n {
        let q = unit3(rng);
        let w = unit3(rng) * spin * rng.random_range(0.0..1.0);
        lay.store_q(&mut y, i, q);
        lay.store_w(&mut y, i, Spatial::tangent(w, q));
    }
    y
}

/// A random planar state.
pub fn random_planar_state(rng: &mut StdRng, n: usize, spin: f64) -> Vec<f64> {
    let lay = Layout::<Planar>::new(n);
    let mut y = vec![0.0; lay.dim()];
    lay.store_x(&mut y, rng.random_range(-1.0..1.0));
    lay.store_xdot(&mut y, rng.random_range(-1.0..1.0));
    for i in 0..n {
        let angle: f64 = rng.random_range(-3.2..3.2);
        lay.store_q(&mut y, i, Vector2::new(angle.sin(), angle.cos()));
        lay.store_w(&mut y, i, spin * rng.random_range(-1.0..1.0));
    }
    y
}

/// Largest |a - b| / (scale) over two slices.
pub fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

pub fn max_abs(a: &[f64]) -> f64 {
    a.iter().map(|x| x.abs()).fold(0.0, f64::max)
}

/// Positions of the masses relative to the cart, flattened (for comparing trajectories).
pub fn mass_positions<G: Geometry>(chain: &chaincart::Chain<G>, y: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    for i in 0..chain.n_links() {
        let p = chain.mass_position(y, i);
        let mut buf = vec![0.0; G::Link::DIM];
        p.store(&mut buf);
        out.extend(buf);
    }
    out
}
