//! Property-based tests (proptest): random chains, parameters and states.

use chaincart::dense::dense_derivative;
use chaincart::geometry::{planar_to_spatial, spatial_to_planar};
use chaincart::{ChainParams, Method, PlanarChain, SpatialChain, StepOptions, Stepper};
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;

/// Parameters with masses and lengths spanning up to 1e4 and 1e3 ratios.
fn params(max_links: usize) -> impl Strategy<Value = ChainParams> {
    (1..=max_links).prop_flat_map(|n| {
        (
            -1.0f64..1.0,
            prop::collection::vec(-2.0f64..2.0, n),
            prop::collection::vec(-1.5f64..1.5, n),
            0.5f64..20.0,
        )
            .prop_map(|(cart, masses, lengths, g)| {
                let masses: Vec<f64> = masses.iter().map(|e| 10f64.powf(*e)).collect();
                let lengths: Vec<f64> = lengths.iter().map(|e| 10f64.powf(*e)).collect();
                ChainParams::new(10f64.powf(cart), &masses, &lengths, g).unwrap()
            })
    })
}

/// A state on the constraint manifold from free coordinates.
fn state(n: usize, raw: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; 4 + 6 * n];
    y[..4].copy_from_slice(&raw[..4]);
    for i in 0..n {
        let r = &raw[4 + 6 * i..];
        let q = Vector3::new(r[0], r[1], r[2]);
        let q = if q.norm() < 1e-3 {
            Vector3::z()
        } else {
            q.normalize()
        };
        let w = Vector3::new(r[3], r[4], r[5]);
        let w = w - q * w.dot(&q);
        y[4 + 3 * i..7 + 3 * i].copy_from_slice(q.as_slice());
        y[4 + 3 * n + 3 * i..7 + 3 * n + 3 * i].copy_from_slice(w.as_slice());
    }
    y
}

fn params_and_state(
    max_links: usize,
) -> impl Strategy<Value = (ChainParams, Vec<f64>, Vector2<f64>)> {
    params(max_links).prop_flat_map(|p| {
        let n = p.n_links();
        (
            Just(p),
            prop::collection::vec(-3.0f64..3.0, 4 + 6 * n),
            -50.0f64..50.0,
            -50.0f64..50.0,
        )
            .prop_map(move |(p, raw, ux, uy)| (p, state(n, &raw), Vector2::new(ux, uy)))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn accelerations_are_finite_and_match_the_dense_form((p, y, u) in params_and_state(12)) {
        let chain = SpatialChain::new(p.clone());
        let mut fast = vec![0.0; y.len()];
        chain.derivative(&y, u, &mut chain.workspace(), &mut fast);
        prop_assert!(fast.iter().all(|v| v.is_finite()));
        let mut dense = vec![0.0; y.len()];
        dense_derivative(&p, &y, u, &mut dense).unwrap();
        let scale = dense.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let diff = fast.iter().zip(&dense).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        // Mass ratios up to 1e4 and length ratios up to 1e3 condition the dense LU;
        // the O(n) form is the better conditioned of the two.
        prop_assert!(diff <= 1e-7 * scale, "difference {diff:e}, scale {scale:e}");
    }

    #[test]
    fn angular_accelerations_are_tangent((p, y, u) in params_and_state(12)) {
        let chain = SpatialChain::new(p);
        let n = chain.n_links();
        let mut dy = vec![0.0; y.len()];
        chain.derivative(&y, u, &mut chain.workspace(), &mut dy);
        for i in 0..n {
            let q = Vector3::from_column_slice(&y[4 + 3 * i..7 + 3 * i]);
            let wdot = Vector3::from_column_slice(&dy[4 + 3 * n + 3 * i..7 + 3 * n + 3 * i]);
            prop_assert!(wdot.dot(&q).abs() <= 1e-9 * (1.0 + wdot.norm()));
        }
    }

    #[test]
    fn the_adaptive_reference_conserves_energy((p, y, _u) in params_and_state(4)) {
        let chain = SpatialChain::new(p);
        let e0 = chain.energy(&y);
        let mut y1 = y.clone();
        let opts = StepOptions { method: Method::Adaptive, tolerance: 1e-10, ..StepOptions::default() };
        // Short horizon: random extreme chains can be very fast.
        if Stepper::new(&chain).step(&chain, &mut y1, Vector2::zeros(), 1e-3, &opts).is_ok() {
            let e1 = chain.energy(&y1);
            let scale = e0.kinetic + e0.potential.abs() + 1e-12;
            prop_assert!((e1.total() - e0.total()).abs() <= 1e-6 * scale, "{:e} vs {:e}", e1.total(), e0.total());
        }
    }

    #[test]
    fn planar_and_spatial_derivatives_agree_in_plane(p in params(8), raw in prop::collection::vec(-3.0f64..3.0, 64), u in -20.0f64..20.0) {
        let n = p.n_links();
        let mut planar = vec![0.0; 2 + 3 * n];
        planar[0] = raw[0];
        planar[1] = raw[1];
        for i in 0..n {
            planar[2 + 2 * i] = raw[2 + i].sin();
            planar[3 + 2 * i] = raw[2 + i].cos();
            planar[2 + 2 * n + i] = raw[20 + i];
        }
        let pc = PlanarChain::new(p.clone());
        let sc = SpatialChain::new(p);
        let mut dp = vec![0.0; planar.len()];
        pc.derivative(&planar, u, &mut pc.workspace(), &mut dp);
        let mut spatial = vec![0.0; 4 + 6 * n];
        planar_to_spatial(n, &planar, &mut spatial);
        let mut ds = vec![0.0; spatial.len()];
        sc.derivative(&spatial, Vector2::new(u, 0.0), &mut sc.workspace(), &mut ds);
        let mut back = vec![0.0; planar.len()];
        spatial_to_planar(n, &ds, &mut back);
        for (a, b) in dp.iter().zip(&back) {
            prop_assert!((a - b).abs() <= 1e-12 * (1.0 + a.abs()));
        }
    }
}
