//! Integrators against closed-form solutions, invariants and each other.

use super::common;

use chaincart::geometry::{Geometry, Layout, Vector};
use chaincart::{ChainParams, Method, PlanarChain, SpatialChain, StepOptions, Stepper};
use common::scenes::paper_ic1;
use common::*;
use nalgebra::{Vector2, Vector3};

fn run<G: Geometry>(
    chain: &chaincart::Chain<G>,
    y: &mut [f64],
    method: Method,
    dt: f64,
    steps: usize,
) {
    let opts = StepOptions {
        method,
        ..StepOptions::default()
    };
    let mut stepper = Stepper::new(chain);
    for _ in 0..steps {
        stepper
            .step(chain, y, G::Cart::zero(), dt, &opts)
            .expect("step succeeds");
    }
}

/// Conical motion of a spherical pendulum on a free cart: with zero horizontal
/// momentum the cart circles opposite the bob, and the link keeps its angle theta
/// to the vertical while turning at `Omega^2 = g (m + m1) / (m l cos theta)`.
fn conical(theta: f64, t: f64, p: &ChainParams) -> (Vec<f64>, f64) {
    let (m, m1, l, g) = (p.cart_mass(), p.masses()[0], p.lengths()[0], p.gravity());
    let omega = (g * (m + m1) / (m * l * theta.cos())).sqrt();
    let phase = omega * t;
    let q = Vector3::new(
        theta.sin() * phase.cos(),
        theta.sin() * phase.sin(),
        theta.cos(),
    );
    let w = Spatial::tangent(Vector3::new(0.0, 0.0, omega), q);
    let radius = m1 * l * theta.sin() / (m + m1);
    let x = Vector2::new(-radius * phase.cos(), -radius * phase.sin());
    let xdot = Vector2::new(radius * omega * phase.sin(), -radius * omega * phase.cos());
    let lay = Layout::<Spatial>::new(1);
    let mut y = vec![0.0; lay.dim()];
    lay.store_x(&mut y, x);
    lay.store_xdot(&mut y, xdot);
    lay.store_q(&mut y, 0, q);
    lay.store_w(&mut y, 0, w);
    (y, 2.0 * std::f64::consts::PI / omega)
}

use chaincart::geometry::Spatial;

#[test]
fn single_link_follows_the_closed_form_conical_motion() {
    let params = ChainParams::new(0.7, &[0.3], &[0.5], 9.81).unwrap();
    let chain = SpatialChain::new(params.clone());
    let theta = 0.6;
    let (y0, period) = conical(theta, 0.0, &params);
    // Accuracy expected at dt = period/400 over three periods, per method.
    for (method, tolerance) in [
        (Method::Rk4, 1e-7),
        (Method::Rkmk4, 1e-7),
        (Method::Adaptive, 1e-6),
        (Method::Variational, 2e-3),
        (Method::LieEuler, 5e-2),
    ] {
        let steps = 1200;
        let dt = 3.0 * period / steps as f64;
        let mut y = y0.clone();
        run(&chain, &mut y, method, dt, steps);
        let (exact, _) = conical(theta, 3.0 * period, &params);
        let err = max_abs_diff(&y, &exact);
        eprintln!(
            "{:>11}: conical motion error after 3 periods = {err:.2e}",
            method.name()
        );
        assert!(
            err < tolerance,
            "{}: error {err:e} > {tolerance:e}",
            method.name()
        );
    }
}

#[test]
fn planar_model_reproduces_the_spatial_model_started_in_plane() {
    let mut rng = rng(7);
    for n in [1, 3, 6] {
        let params = random_params(&mut rng, n, 5.0, 3.0);
        let planar = PlanarChain::new(params.clone());
        let spatial = SpatialChain::new(params);
        let y_planar0 = random_planar_state(&mut rng, n, 2.0);
        let mut y_spatial = vec![0.0; spatial.state_dim()];
        chaincart::geometry::planar_to_spatial(n, &y_planar0, &mut y_spatial);
        for method in Method::ALL {
            let (mut yp, mut ys) = (y_planar0.clone(), y_spatial.clone());
            let force = 0.3;
            let opts = StepOptions {
                method,
                ..StepOptions::default()
            };
            let (mut sp, mut ss) = (Stepper::new(&planar), Stepper::new(&spatial));
            for _ in 0..200 {
                sp.step(&planar, &mut yp, force, 5e-3, &opts).unwrap();
                ss.step(&spatial, &mut ys, Vector2::new(force, 0.0), 5e-3, &opts)
                    .unwrap();
            }
            let mut back = vec![0.0; planar.state_dim()];
            chaincart::geometry::spatial_to_planar(n, &ys, &mut back);
            let diff = max_abs_diff(&yp, &back) / max_abs(&yp).max(1.0);
            // Same discretisation in both models: they differ by round-off only
            // (the adaptive method may pick different steps: integration tolerance).
            let tol = if method == Method::Adaptive {
                1e-5
            } else {
                1e-9
            };
            assert!(
                diff < tol,
                "n = {n}, {}: planar vs spatial {diff:e}",
                method.name()
            );
            // And the spatial motion stayed in the plane.
            let lay = spatial.layout();
            for i in 0..n {
                assert!(lay.load_q(&ys, i).y.abs() < 1e-12);
            }
        }
    }
}

#[test]
fn links_started_in_any_vertical_plane_stay_in_it() {
    // Paper, "Remarks": q_i(0) . v = 0, w_i(0) x v = 0 and v . Cu = 0 keep the
    // relative motion in the plane normal to v, for any horizontal v.
    let mut rng = rng(11);
    let n = 4;
    let params = random_params(&mut rng, n, 10.0, 5.0);
    let chain = SpatialChain::new(params);
    let phi: f64 = 0.7;
    let v = Vector3::new(phi.cos(), phi.sin(), 0.0);
    let in_plane = Vector3::new(-phi.sin(), phi.cos(), 0.0);
    let lay = chain.layout();
    let mut y = vec![0.0; chain.state_dim()];
    for i in 0..n {
        let a = 0.5 + i as f64;
        lay.store_q(
            &mut y,
            i,
            in_plane * a.sin() + Vector3::new(0.0, 0.0, a.cos()),
        );
        lay.store_w(&mut y, i, v * (1.0 - 0.4 * i as f64));
    }
    let opts = StepOptions {
        method: Method::Rk4,
        ..StepOptions::default()
    };
    let mut stepper = Stepper::new(&chain);
    for k in 0..2000 {
        let force = Vector2::new(in_plane.x, in_plane.y) * (3.0 * (k as f64 * 0.01).sin());
        stepper.step(&chain, &mut y, force, 1e-3, &opts).unwrap();
    }
    for i in 0..n {
        let q = lay.load_q(&y, i);
        let w = lay.load_w(&y, i);
        assert!(q.dot(v).abs() < 1e-12, "q_{i} . v = {:e}", q.dot(v));
        assert!(
            w.cross(&v).norm() < 1e-10,
            "|w_{i} x v| = {:e}",
            w.cross(&v).norm()
        );
    }
}

fn paper_chain() -> SpatialChain {
    SpatialChain::new(ChainParams::paper())
}

/// Largest |E(t) - E(0)| / (max kinetic energy along the run) and momentum drift.
fn invariant_drift(method: Method, dt: f64, seconds: f64) -> (f64, f64, f64) {
    let chain = paper_chain();
    let mut y = paper_ic1();
    let e0 = chain.energy(&y).total();
    let p0 = chain.horizontal_momentum(&y);
    let opts = StepOptions {
        method,
        ..StepOptions::default()
    };
    let mut stepper = Stepper::new(&chain);
    let steps = (seconds / dt).round() as usize;
    let (mut worst_e, mut worst_p, mut worst_r, mut scale) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for _ in 0..steps {
        stepper
            .step(&chain, &mut y, Vector2::zeros(), dt, &opts)
            .unwrap();
        let e = chain.energy(&y);
        scale = scale.max(e.kinetic);
        worst_e = worst_e.max((e.total() - e0).abs());
        worst_p = worst_p.max((chain.horizontal_momentum(&y) - p0).norm());
        let r = chain.residuals(&y);
        worst_r = worst_r.max(r.unit_length.max(r.tangency));
    }
    (worst_e / scale, worst_p, worst_r)
}

#[test]
fn invariants_are_kept_with_zero_force() {
    // Paper's Fig. 1 start over 10 s. Energy error relative to the peak kinetic energy.
    for (method, dt, energy_tol, momentum_tol) in [
        // Momentum is linear in (xdot, w x q), not in the state (q, w): only the
        // variational method, built on (x, q) and its momenta, keeps it exactly.
        (Method::Rk4, 1e-3, 1e-3, 1e-3),
        (Method::Rkmk4, 1e-3, 1e-3, 1e-3),
        (Method::Variational, 1e-3, 1e-2, 1e-11),
        (Method::LieEuler, 1e-4, 0.2, 0.1),
        (Method::Adaptive, 1e-2, 1e-6, 1e-6),
    ] {
        let (e, p, r) = invariant_drift(method, dt, 10.0);
        eprintln!("{:>11} dt={dt:.0e}: energy drift {e:.2e} (rel. to peak T), momentum {p:.2e}, constraints {r:.2e}", method.name());
        assert!(e < energy_tol, "{}: energy drift {e:e}", method.name());
        assert!(p < momentum_tol, "{}: momentum drift {p:e}", method.name());
        assert!(r < 1e-12, "{}: constraint residual {r:e}", method.name());
    }
}

#[test]
fn variational_energy_error_stays_bounded_over_long_runs() {
    // A symplectic method's energy error oscillates instead of growing: compare the
    // worst error in the first 20 s with that over 200 s.
    let (short, _, _) = invariant_drift(Method::Variational, 2e-3, 20.0);
    let (long, p, _) = invariant_drift(Method::Variational, 2e-3, 200.0);
    eprintln!(
        "variational: energy error over 20 s {short:.2e}, over 200 s {long:.2e}, momentum {p:.1e}"
    );
    assert!(
        long < 3.0 * short.max(1e-6),
        "energy error grew: {short:e} -> {long:e}"
    );
    assert!(p < 1e-12);
}

/// Observed order from step halving: log2(|y_h - y_{h/2}| / |y_{h/2} - y_{h/4}|).
fn observed_order(method: Method, h: f64) -> f64 {
    let chain = paper_chain();
    let mut rng = rng(5);
    let y0 = random_spatial_state(&mut rng, 5, 1.0);
    let t = 0.2;
    let solve = |dt: f64| {
        let mut y = y0.clone();
        let opts = StepOptions {
            method,
            ..StepOptions::default()
        };
        let mut stepper = Stepper::new(&chain);
        let force = Vector2::new(0.5, -0.3);
        for _ in 0..(t / dt).round() as usize {
            stepper.step(&chain, &mut y, force, dt, &opts).unwrap();
        }
        mass_positions(&chain, &y)
    };
    let (a, b, c) = (solve(h), solve(h / 2.0), solve(h / 4.0));
    (max_abs_diff(&a, &b) / max_abs_diff(&b, &c)).log2()
}

#[test]
fn fixed_step_methods_converge_at_their_order() {
    for (method, h) in [
        (Method::Rk4, 2e-3),
        (Method::Rkmk4, 2e-3),
        (Method::Variational, 1e-3),
        (Method::LieEuler, 2.5e-4),
    ] {
        let order = observed_order(method, h);
        eprintln!("{:>11}: observed order {order:.2}", method.name());
        let expected = method.order() as f64;
        assert!(
            (order - expected).abs() < 0.3,
            "{}: order {order}, expected {expected}",
            method.name()
        );
    }
}

#[test]
fn methods_agree_with_the_adaptive_reference() {
    // Paper's Fig. 1 start for 1 s: every method converges to the same motion.
    let chain = paper_chain();
    let reference = {
        let mut y = paper_ic1();
        let opts = StepOptions {
            method: Method::Adaptive,
            tolerance: 1e-12,
            ..StepOptions::default()
        };
        let mut stepper = Stepper::new(&chain);
        stepper
            .step(&chain, &mut y, Vector2::zeros(), 1.0, &opts)
            .unwrap();
        mass_positions(&chain, &y)
    };
    for (method, dt, tol) in [
        (Method::Rk4, 1e-4, 1e-6),
        (Method::Rkmk4, 1e-4, 1e-6),
        (Method::Variational, 1e-4, 3e-4),
        (Method::LieEuler, 1e-6, 1e-2),
    ] {
        let mut y = paper_ic1();
        run(&chain, &mut y, method, dt, (1.0 / dt).round() as usize);
        let err = max_abs_diff(&mass_positions(&chain, &y), &reference);
        eprintln!(
            "{:>11} dt={dt:.0e}: position error at t = 1 s: {err:.2e} m",
            method.name()
        );
        assert!(err < tol, "{}: {err:e}", method.name());
    }
}
