//! The real-rig effects (joint damping, cart friction, acceleration and voltage
//! actuation) against independent oracles: the paper's dense form with the damping's
//! generalised moments, the power balance along whole runs, closed forms of damped
//! and driven motion, and the env batch's invariants (the ideal rig changes no bit,
//! a vector of envs equals the envs alone, seeds reproduce).

use super::common;

use chaincart::dense::{dense_derivative_damped, elwm_damping_moments, elwm_system};
use chaincart::env::{AutoresetMode, EnvBatch, Start, StepOutputs, TaskConfig};
use chaincart::geometry::{planar_to_spatial, Geometry, Layout, Vector};
use chaincart::lanes::{Kernel, LaneScene, Precision};
use chaincart::params::{Actuation, Motor, Rig};
use chaincart::{Chain, ChainParams, Method, Planar, Spatial, StepOptions, Stepper};
use common::*;
use nalgebra::{DVector, Vector2};
use rand::Rng;

fn damped(damping: Vec<f64>) -> Rig {
    Rig {
        joint_damping: damping,
        ..Rig::default()
    }
}

fn motor() -> Motor {
    Motor::from_array(chaincart::env::DEFAULT_MOTOR)
}

/// Every effect at once (force or voltage actuation), for `n` links.
fn full_rig(n: usize, actuation: Actuation) -> Rig {
    Rig {
        joint_damping: (0..n).map(|i| 0.01 + 0.005 * i as f64).collect(),
        cart_viscous_friction: 0.3,
        cart_coulomb_friction: 0.8,
        coulomb_velocity: 0.05,
        actuation,
    }
}

fn derivative<G: Geometry>(chain: &Chain<G>, y: &[f64], command: G::Cart) -> Vec<f64> {
    let mut dy = vec![0.0; chain.state_dim()];
    chain.derivative(y, command, &mut chain.workspace(), &mut dy);
    dy
}

#[test]
fn an_ideal_rig_leaves_the_ideal_chain() {
    let params = ChainParams::paper();
    let zeros = Rig {
        joint_damping: vec![0.0; 5],
        ..Rig::default()
    };
    for rig in [Rig::default(), zeros, damped(vec![0.0])] {
        let chain = Chain::<Spatial>::new(params.clone()).with_rig(rig).unwrap();
        assert!(chain.is_ideal() && chain.rig().is_none());
    }
    let chain = Chain::<Spatial>::new(params)
        .with_rig(damped(vec![0.1]))
        .unwrap();
    assert!(!chain.is_ideal());
}

#[test]
fn the_rig_path_with_nothing_on_is_the_ideal_derivative() {
    // The scalar rig path, forced to run with every effect off, against the fast one:
    // the same equations in another order of operations.
    let mut rng = rng(7);
    for n in [1, 2, 5] {
        let params = random_params(&mut rng, n, 10.0, 10.0);
        let chain = Chain::<Spatial>::new(params);
        for _ in 0..4 {
            let y = random_spatial_state(&mut rng, n, 3.0);
            let u = Vector2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            let fast = derivative(&chain, &y, u);
            let mut slow = vec![0.0; chain.state_dim()];
            chain.derivative_rig(&Rig::default(), &y, u, &mut chain.workspace(), &mut slow);
            let rel = max_abs_diff(&fast, &slow) / max_abs(&fast).max(1.0);
            assert!(rel < 1e-13, "n = {n}: {rel:e}");
        }
    }
}

#[test]
fn joint_damping_matches_the_dense_form_with_its_generalised_moments() {
    let mut rng = rng(11);
    for n in [1, 2, 3, 5, 8] {
        for _ in 0..4 {
            let params = random_params(&mut rng, n, 10.0, 10.0);
            let damping: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..0.5)).collect();
            let chain = Chain::<Spatial>::new(params.clone())
                .with_rig(damped(damping.clone()))
                .unwrap();
            let y = random_spatial_state(&mut rng, n, 3.0);
            let u = Vector2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            let fast = derivative(&chain, &y, u);
            let mut dense = vec![0.0; chain.state_dim()];
            dense_derivative_damped(&params, &y, u, &damping, &mut dense).unwrap();
            let rel = max_abs_diff(&fast, &dense) / max_abs(&dense).max(1.0);
            assert!(rel < 1e-11, "n = {n}: {rel:e}");
            // The damping changed the motion (the comparison is not vacuous).
            let mut ideal = vec![0.0; chain.state_dim()];
            dense_derivative_damped(&params, &y, u, &[], &mut ideal).unwrap();
            assert!(max_abs_diff(&ideal, &dense) > 1e-6);
        }
    }
}

/// The cart force that gives the cart the acceleration `a` at state `y`, from the
/// dense form: the link rows give the spins' rates for that `xdd`, the cart rows the
/// force that balances them.
fn dense_force_for_acceleration(
    params: &ChainParams,
    y: &[f64],
    damping: &[f64],
    a: Vector2<f64>,
) -> Vector2<f64> {
    let n = params.n_links();
    let (m, mut b) = elwm_system(params, y, Vector2::zeros());
    if !damping.is_empty() {
        b += elwm_damping_moments(params, y, damping);
    }
    let links = 3 * n;
    let m_ll = m.view((2, 2), (links, links)).clone_owned();
    let m_lx = m.view((2, 0), (links, 2)).clone_owned();
    let rhs: DVector<f64> = b.rows(2, links) - m_lx * a;
    let wdot = m_ll.lu().solve(&rhs).expect("link block is regular");
    let u = m.view((0, 0), (2, 2)) * a + m.view((0, 2), (2, links)) * wdot - b.rows(0, 2);
    Vector2::new(u[0], u[1])
}

#[test]
fn acceleration_mode_is_force_mode_under_the_force_that_produces_it() {
    let mut rng = rng(23);
    for n in [1, 2, 4, 6] {
        for with_damping in [false, true] {
            let params = random_params(&mut rng, n, 10.0, 10.0);
            let damping: Vec<f64> = if with_damping {
                (0..n).map(|_| rng.random_range(0.0..0.5)).collect()
            } else {
                Vec::new()
            };
            let rig = Rig {
                joint_damping: damping.clone(),
                actuation: Actuation::Acceleration,
                ..Rig::default()
            };
            let servo = Chain::<Spatial>::new(params.clone()).with_rig(rig).unwrap();
            let y = random_spatial_state(&mut rng, n, 3.0);
            let a = Vector2::new(rng.random_range(-8.0..8.0), rng.random_range(-8.0..8.0));
            let driven = derivative(&servo, &y, a);
            let lay = Layout::<Spatial>::new(n);
            assert!((lay.load_xdot(&driven) - a).norm() < 1e-14);
            let u = dense_force_for_acceleration(&params, &y, &damping, a);
            let mut pushed = vec![0.0; servo.state_dim()];
            dense_derivative_damped(&params, &y, u, &damping, &mut pushed).unwrap();
            let rel = max_abs_diff(&driven, &pushed) / max_abs(&pushed).max(1.0);
            assert!(rel < 1e-11, "n = {n}, damping {with_damping}: {rel:e}");
        }
    }
}

#[test]
fn a_servo_run_is_a_force_run_under_the_dense_forces_it_needs() {
    // Along a whole run: the servo's motion against force mode whose force, held over
    // each small step, is the dense form's force for the commanded acceleration at the
    // step's start (first order in the step: the force varies within it).
    let n = 3;
    let params = ChainParams::new(0.6, &[0.2, 0.1, 0.15], &[0.3, 0.4, 0.2], 9.81).unwrap();
    let damping = vec![0.02, 0.01, 0.03];
    let servo = Chain::<Spatial>::new(params.clone())
        .with_rig(Rig {
            joint_damping: damping.clone(),
            actuation: Actuation::Acceleration,
            ..Rig::default()
        })
        .unwrap();
    let pushed = Chain::<Spatial>::new(params.clone())
        .with_rig(damped(damping.clone()))
        .unwrap();
    let mut rng = rng(13);
    let y0 = random_spatial_state(&mut rng, n, 2.0);
    let accel = |t: f64| Vector2::new(3.0 * (4.0 * t).sin(), -2.0 * (3.0 * t).cos());
    let opts = StepOptions::new(Method::Rk4, 1).unwrap();
    let run = |h: f64| {
        let (mut ys, mut yf) = (y0.clone(), y0.clone());
        let (mut ss, mut sf) = (Stepper::new(&servo), Stepper::new(&pushed));
        let steps = (0.5 / h).round() as usize;
        for k in 0..steps {
            let a = accel(k as f64 * h);
            let u = dense_force_for_acceleration(&params, &yf, &damping, a);
            ss.step(&servo, &mut ys, a, h, &opts).unwrap();
            sf.step(&pushed, &mut yf, u, h, &opts).unwrap();
        }
        max_abs_diff(&ys, &yf) / max_abs(&ys)
    };
    let (coarse, fine) = (run(1e-3), run(2.5e-4));
    eprintln!("servo vs dense-force run after 0.5 s: {coarse:.2e} at 1 ms, {fine:.2e} at 0.25 ms");
    // First-order convergence to the same motion.
    assert!(fine < 2e-3 && coarse / fine > 3.0, "{coarse:e} {fine:e}");
}

#[test]
fn every_integrator_but_the_variational_one_steps_a_rig() {
    let params = ChainParams::new(0.8, &[0.2, 0.15, 0.1], &[0.4, 0.3, 0.25], 9.81).unwrap();
    let chain = Chain::<Spatial>::new(params)
        .with_rig(full_rig(3, Actuation::Voltage(motor())))
        .unwrap();
    let mut rng = rng(17);
    let y0 = random_spatial_state(&mut rng, 3, 2.0);
    let run = |method: Method, substeps: usize| {
        let mut y = y0.clone();
        let mut opts = StepOptions::new(method, substeps).unwrap();
        opts.tolerance = 1e-11;
        let mut stepper = Stepper::new(&chain);
        for k in 0..50 {
            let volts = Vector2::new(8.0 * (0.3 * k as f64).sin(), 5.0);
            stepper.step(&chain, &mut y, volts, 0.02, &opts).unwrap();
        }
        y
    };
    let reference = run(Method::Rk4, 200);
    for (method, substeps, bound) in [
        (Method::Rk4, 20, 1e-7),
        (Method::Rkmk4, 20, 1e-7),
        (Method::Adaptive, 1, 1e-7),
        (Method::LieEuler, 200, 1e-1),
    ] {
        let error = max_abs_diff(&run(method, substeps), &reference);
        eprintln!("{}: {error:.2e} after 1 s", method.name());
        assert!(error < bound, "{}: {error:e}", method.name());
    }
}

#[test]
fn the_planar_rig_is_the_spatial_rig_in_the_plane() {
    let mut rng = rng(31);
    let n = 3;
    let params = random_params(&mut rng, n, 10.0, 10.0);
    for actuation in [Actuation::Force, Actuation::Voltage(motor())] {
        let planar = Chain::<Planar>::new(params.clone())
            .with_rig(full_rig(n, actuation))
            .unwrap();
        let spatial = Chain::<Spatial>::new(params.clone())
            .with_rig(full_rig(n, actuation))
            .unwrap();
        for _ in 0..5 {
            let y = random_planar_state(&mut rng, n, 3.0);
            let u = rng.random_range(-10.0..10.0);
            let mut y3 = vec![0.0; spatial.state_dim()];
            planar_to_spatial(n, &y, &mut y3);
            let d2 = derivative(&planar, &y, u);
            let d3 = derivative(&spatial, &y3, Vector2::new(u, 0.0));
            let mut d2_in_3 = vec![0.0; spatial.state_dim()];
            planar_to_spatial(n, &d2, &mut d2_in_3);
            let rel = max_abs_diff(&d2_in_3, &d3) / max_abs(&d3).max(1.0);
            assert!(rel < 1e-13, "{actuation:?}: {rel:e}");
        }
    }
}

/// `sum_i c_i |w_i - w_{i-1}|^2`, the power the joints dissipate (`w_0 = 0`).
fn joint_dissipation<G: Geometry>(rig: &Rig, n: usize, y: &[f64]) -> f64 {
    let lay = Layout::<G>::new(n);
    let mut below = G::Spin::zero();
    let mut total = 0.0;
    for i in 0..n {
        let w = lay.load_w(y, i);
        total += rig.joint_damping[i] * (w - below).norm_squared();
        below = w;
    }
    total
}

/// The power into the chain and cart from outside: the drive's force and the
/// friction on the cart (per axis, by the rig's laws written out here), minus the
/// joints' dissipation.
fn external_power<G: Geometry>(rig: &Rig, n: usize, y: &[f64], command: &[f64]) -> f64 {
    let lay = Layout::<G>::new(n);
    let mut v = [0.0; 2];
    lay.load_xdot(y).store(&mut v);
    let mut power = -joint_dissipation::<G>(rig, n, y);
    for (k, &c) in command.iter().enumerate() {
        let drive = match rig.actuation {
            Actuation::Force => c,
            Actuation::Voltage(m) => {
                let k_f = m.gear_ratio * m.torque_constant / m.pulley_radius;
                let current =
                    ((c - k_f * v[k]) / m.resistance).clamp(-m.current_limit, m.current_limit);
                k_f * current
            }
            Actuation::Acceleration => unreachable!("the servo's force is not given"),
        };
        let friction = -rig.cart_viscous_friction * v[k]
            - rig.cart_coulomb_friction * (v[k] / rig.coulomb_velocity).tanh();
        power += (drive + friction) * v[k];
    }
    power
}

/// What a run did to the energy: gained, the work of the outside (drive, friction,
/// joints), the joints' share of it, and the run's largest kinetic energy.
struct EnergyBudget {
    gained: f64,
    work: f64,
    joints: f64,
    scale: f64,
}

/// Runs `seconds` of rk4 at step `h` under commands that change every 20 ms,
/// integrating the external power by the trapezoid rule per step (where the command
/// is constant).
fn energy_and_work<G: Geometry>(
    chain: &Chain<G>,
    y0: &[f64],
    seconds: f64,
    h: f64,
) -> EnergyBudget {
    let rig = chain.rig().expect("a rig").clone();
    let n = chain.n_links();
    let opts = StepOptions::new(Method::Rk4, 1).unwrap();
    let mut stepper = Stepper::new(chain);
    let mut y = y0.to_vec();
    let e0 = chain.energy(&y).total();
    let (mut work, mut joints, mut scale) = (0.0, 0.0, 0.0f64);
    let steps = (seconds / h).round() as usize;
    let per_command = (0.02 / h).round() as usize;
    let mut command = vec![0.0; G::Cart::DIM];
    for k in 0..steps {
        if k % per_command == 0 {
            let t = k as f64 * h;
            for (a, c) in command.iter_mut().enumerate() {
                *c = 6.0 * (1.7 * t + a as f64).sin();
            }
        }
        let before = external_power::<G>(&rig, n, &y, &command);
        let lost_before = joint_dissipation::<G>(&rig, n, &y);
        stepper
            .step(chain, &mut y, G::Cart::load(&command), h, &opts)
            .unwrap();
        let after = external_power::<G>(&rig, n, &y, &command);
        work += 0.5 * h * (before + after);
        joints -= 0.5 * h * (lost_before + joint_dissipation::<G>(&rig, n, &y));
        scale = scale.max(chain.energy(&y).kinetic);
    }
    EnergyBudget {
        gained: chain.energy(&y).total() - e0,
        work,
        joints,
        scale,
    }
}

fn check_power_balance<G: Geometry>(y0: &[f64], actuation: Actuation) {
    let n = 3;
    let params = ChainParams::new(0.8, &[0.2, 0.15, 0.1], &[0.4, 0.3, 0.25], 9.81).unwrap();
    let chain = Chain::<G>::new(params)
        .with_rig(full_rig(n, actuation))
        .unwrap();
    let EnergyBudget {
        gained,
        work,
        joints,
        scale,
    } = energy_and_work(&chain, y0, 2.0, 1e-4);
    let error = (gained - work).abs() / scale;
    eprintln!(
        "{} {}: energy gained {gained:.6e} J, work {work:.6e} J (joints {joints:.3e} J), error {error:.1e} of the peak kinetic energy {scale:.3e} J",
        G::NAME,
        actuation.name()
    );
    assert!(error < 1e-6, "{}: {error:e}", G::NAME);
    // The balance is not trivial: the joints took a share far above the error.
    assert!(-joints > 1e-3 * scale, "{joints}");
}

#[test]
fn energy_changes_by_the_work_of_drive_friction_and_damping() {
    let mut rng = rng(41);
    let planar = random_planar_state(&mut rng, 3, 2.0);
    let spatial = random_spatial_state(&mut rng, 3, 2.0);
    for actuation in [Actuation::Force, Actuation::Voltage(motor())] {
        check_power_balance::<Planar>(&planar, actuation);
        check_power_balance::<Spatial>(&spatial, actuation);
    }
}

/// A planar state of one link at angle `theta` from hanging, at rest.
fn one_link_state(theta: f64) -> Vec<f64> {
    let lay = Layout::<Planar>::new(1);
    let mut y = vec![0.0; lay.dim()];
    lay.store_q(&mut y, 0, Vector2::new(theta.sin(), theta.cos()));
    y
}

/// Decay rate of the swing of a one-link chain: the log of the ratio of the first and
/// last peaks of the angle over the time between them.
fn swing_decay_rate(chain: &Chain<Planar>, seconds: f64) -> f64 {
    let h = 1e-3;
    let opts = StepOptions::new(Method::Rk4, 1).unwrap();
    let mut stepper = Stepper::new(chain);
    let mut y = one_link_state(0.01);
    let lay = chain.layout();
    let angle = |y: &[f64]| {
        let q = lay.load_q(y, 0);
        q.x.atan2(q.y)
    };
    let (mut prev, mut cur) = (f64::NAN, angle(&y));
    let mut peaks = Vec::new();
    for k in 1..=(seconds / h) as usize {
        stepper.step(chain, &mut y, 0.0, h, &opts).unwrap();
        let next = angle(&y);
        if cur > prev && cur >= next {
            // The parabola through the three samples: its top.
            let curvature = prev - 2.0 * cur + next;
            let shift = 0.5 * (prev - next) / curvature;
            let top = cur - 0.25 * (prev - next) * shift;
            peaks.push(((k - 1) as f64 * h + shift * h, top));
        }
        (prev, cur) = (cur, next);
    }
    let (first, last) = (peaks[0], peaks[peaks.len() - 1]);
    assert!(peaks.len() > 10);
    (first.1 / last.1).ln() / (last.0 - first.0)
}

#[test]
fn a_damped_pendulum_decays_at_the_linear_rate() {
    let (cart, mass, length, c) = (0.5, 0.2, 0.5, 0.002);
    let params = ChainParams::new(cart, &[mass], &[length], 9.81).unwrap();
    // On a free cart the swing moves the cart too: the inertia about the joint is the
    // reduced one, m l^2 M / (M + m).
    let free = Chain::<Planar>::new(params.clone())
        .with_rig(damped(vec![c]))
        .unwrap();
    let reduced = mass * length * length * cart / (cart + mass);
    let expected = c / (2.0 * reduced);
    let rate = swing_decay_rate(&free, 20.0);
    eprintln!(
        "free cart: decay rate {rate:.6} 1/s, linear theory {expected:.6} 1/s, relative difference {:.1e}",
        rate / expected - 1.0
    );
    assert!((rate / expected - 1.0).abs() < 2e-3, "{rate} vs {expected}");
    // A servo axis holding the cart still: the fixed pendulum, m l^2.
    let held = Chain::<Planar>::new(params)
        .with_rig(Rig {
            joint_damping: vec![c],
            actuation: Actuation::Acceleration,
            ..Rig::default()
        })
        .unwrap();
    let expected = c / (2.0 * mass * length * length);
    let rate = swing_decay_rate(&held, 20.0);
    eprintln!(
        "held cart: decay rate {rate:.6} 1/s, linear theory {expected:.6} 1/s, relative difference {:.1e}",
        rate / expected - 1.0
    );
    assert!((rate / expected - 1.0).abs() < 2e-3, "{rate} vs {expected}");
}

/// A hanging chain moving with its cart at `v0`, integrated `seconds` at 1 ms; returns
/// the chain and the states at the start and the end.
fn coast(rig: Rig, v0: f64, seconds: f64) -> (Chain<Planar>, Vec<f64>, Vec<f64>) {
    let params = ChainParams::new(1.0, &[0.1, 0.1], &[0.5, 0.5], 9.81).unwrap();
    let chain = Chain::<Planar>::new(params).with_rig(rig).unwrap();
    let mut y = chain.equilibrium(&[1.0, 1.0]).unwrap();
    chain.layout().store_xdot(&mut y, v0);
    let start = y.clone();
    let opts = StepOptions::new(Method::Rk4, 1).unwrap();
    let mut stepper = Stepper::new(&chain);
    for _ in 0..(seconds / 1e-3).round() as usize {
        stepper.step(&chain, &mut y, 0.0, 1e-3, &opts).unwrap();
    }
    (chain, start, y)
}

#[test]
fn viscous_cart_friction_slows_the_whole_system_at_c_over_the_total_mass() {
    let b = 0.05;
    let rig = Rig {
        cart_viscous_friction: b,
        ..Rig::default()
    };
    let (chain, start, end) = coast(rig, 1.0, 10.0);
    let (p0, p1) = (
        chain.horizontal_momentum(&start),
        chain.horizontal_momentum(&end),
    );
    // Exactly: the friction is the only horizontal force, so dP/dt = -b xdot.
    let lay = chain.layout();
    let travelled = lay.load_x(&end) - lay.load_x(&start);
    assert!(
        (p1 - p0 + b * travelled).abs() < 1e-9,
        "{p1} {p0} {travelled}"
    );
    // Closed form with the chain hanging (it tilts only by b v / (M g), quasi-statically).
    let expected = p0 * (-b * 10.0 / chain.params().total_mass()).exp();
    eprintln!("momentum after 10 s: {p1:.8}, closed form {expected:.8}");
    assert!((p1 / expected - 1.0).abs() < 1e-4, "{p1} vs {expected}");
}

#[test]
fn coulomb_cart_friction_decelerates_at_f_over_the_total_mass_then_holds() {
    let f = 1.0;
    let rig = Rig {
        cart_coulomb_friction: f,
        coulomb_velocity: 1e-3,
        ..Rig::default()
    };
    let (chain, start, end) = coast(rig.clone(), 1.0, 0.5);
    let (p0, p1) = (
        chain.horizontal_momentum(&start),
        chain.horizontal_momentum(&end),
    );
    // While the cart slides the friction is F_c to within tanh's 1 - 1e-80.
    assert!(
        (p1 - (p0 - f * 0.5)).abs() < 1e-9,
        "{p1} vs {}",
        p0 - f * 0.5
    );
    // It stops after about M v0 / F_c = 1.2 s and stays (it creeps at a fraction of
    // the regularisation's velocity scale).
    let (chain, _, end) = coast(rig, 1.0, 4.0);
    let v = chain.layout().load_xdot(&end);
    assert!(v.abs() < 1e-3, "{v}");
}

#[test]
fn a_servo_axis_moves_the_cart_on_its_parabola() {
    let params = ChainParams::new(0.7, &[0.1, 0.2], &[0.3, 0.4], 9.81).unwrap();
    let rig = Rig {
        joint_damping: vec![0.05],
        actuation: Actuation::Acceleration,
        ..Rig::default()
    };
    let chain = Chain::<Spatial>::new(params).with_rig(rig).unwrap();
    let mut rng = rng(5);
    let mut y = random_spatial_state(&mut rng, 2, 2.0);
    let lay = chain.layout();
    let (x0, v0) = (lay.load_x(&y), lay.load_xdot(&y));
    let a = Vector2::new(1.5, -2.5);
    let opts = StepOptions::new(Method::Rk4, 10).unwrap();
    let mut stepper = Stepper::new(&chain);
    for _ in 0..50 {
        stepper.step(&chain, &mut y, a, 0.02, &opts).unwrap();
    }
    let t = 1.0;
    let expected = x0 + v0 * t + a * (0.5 * t * t);
    assert!((lay.load_x(&y) - expected).norm() < 1e-12);
    assert!((lay.load_xdot(&y) - (v0 + a * t)).norm() < 1e-12);
}

#[test]
fn the_motor_stalls_and_runs_free_as_its_closed_forms_say() {
    let m = motor();
    let k_f = m.gear_ratio * m.torque_constant / m.pulley_radius;
    let params = ChainParams::new(1.0, &[0.1, 0.1], &[0.5, 0.5], 9.81).unwrap();
    // Damping near the critical one settles the swing the start of the drive excites.
    let rig = Rig {
        joint_damping: vec![0.3],
        actuation: Actuation::Voltage(m),
        ..Rig::default()
    };
    let chain = Chain::<Planar>::new(params).with_rig(rig).unwrap();
    let y = chain.equilibrium(&[1.0, 1.0]).unwrap();
    let lay = chain.layout();
    // At rest under a hanging chain the cart alone takes the force: F = m xdd.
    for volts in [3.0, 12.0] {
        let stall = k_f * (volts / m.resistance).min(m.current_limit);
        let xdd = lay.load_xdot(&derivative(&chain, &y, volts));
        assert!(
            (xdd * 1.0 - stall).abs() < 1e-12,
            "{volts} V: {xdd} vs {stall}"
        );
        assert!((m.stall_force(volts) - stall).abs() < 1e-12);
    }
    assert!(
        m.stall_force(12.0) < k_f * 12.0 / m.resistance,
        "the limit binds at 12 V"
    );
    // Free running: the back-EMF cancels the voltage at v = V r / (N k).
    let volts = 6.0;
    let no_load = volts * m.pulley_radius / (m.gear_ratio * m.torque_constant);
    assert!((m.no_load_speed(volts) - no_load).abs() < 1e-12);
    let mut y = y;
    let opts = StepOptions::new(Method::Rk4, 10).unwrap();
    let mut stepper = Stepper::new(&chain);
    for _ in 0..500 {
        stepper.step(&chain, &mut y, volts, 0.02, &opts).unwrap();
    }
    let v = lay.load_xdot(&y);
    eprintln!("speed after 10 s at {volts} V: {v:.6} m/s, no-load speed {no_load:.6} m/s");
    assert!((v / no_load - 1.0).abs() < 1e-3, "{v} vs {no_load}");
}

#[test]
fn the_variational_method_refuses_a_rig() {
    let chain = Chain::<Planar>::new(ChainParams::paper())
        .with_rig(damped(vec![0.1]))
        .unwrap();
    let mut y = chain.equilibrium(&[1.0; 5]).unwrap();
    let opts = StepOptions::new(Method::Variational, 1).unwrap();
    let e = Stepper::new(&chain)
        .step(&chain, &mut y, 0.0, 0.01, &opts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("variational") && e.contains("joint damping"),
        "{e}"
    );
}

#[test]
fn bad_rig_values_are_named() {
    let chain = || Chain::<Planar>::new(ChainParams::uniform(2, 1.0, 0.1, 0.5, 9.81).unwrap());
    let cases: [(Rig, &str); 6] = [
        (damped(vec![-0.1]), "joint_damping[0] = -0.1"),
        (damped(vec![0.1, 0.1, 0.1]), "joint_damping"),
        (
            Rig {
                cart_viscous_friction: f64::NAN,
                ..Rig::default()
            },
            "cart_viscous_friction",
        ),
        (
            Rig {
                coulomb_velocity: 0.0,
                ..Rig::default()
            },
            "coulomb_velocity",
        ),
        (
            Rig {
                cart_coulomb_friction: 1.0,
                actuation: Actuation::Acceleration,
                ..Rig::default()
            },
            "no cart friction",
        ),
        (
            Rig {
                actuation: Actuation::Voltage(Motor {
                    resistance: 0.0,
                    ..motor()
                }),
                ..Rig::default()
            },
            "motor.resistance",
        ),
    ];
    for (rig, text) in cases {
        let e = chain().with_rig(rig).unwrap_err().to_string();
        assert!(e.contains(text), "{text}: {e}");
    }
}

// ---- the env batch -------------------------------------------------------------------

fn env_task(rig: Rig) -> TaskConfig {
    let opts = StepOptions::new(Method::Rk4, 2).unwrap();
    let mut t = TaskConfig::new(vec![-1.0, -1.0], 0.02, opts);
    t.start = Start::Target;
    t.start_noise = 0.2;
    t.max_episode_steps = 12;
    t.track_limit = 0.5;
    t.max_force = 15.0;
    t.rig = rig;
    t
}

fn env_rig(n: usize) -> Rig {
    Rig {
        joint_damping: vec![0.02; n],
        cart_viscous_friction: 0.5,
        cart_coulomb_friction: 0.5,
        coulomb_velocity: 0.02,
        actuation: Actuation::Voltage(motor()),
    }
}

/// Observations and rewards of `steps` steps of `num_envs` envs seeded `seed`, as bits.
/// Env k of the batch acts as env `first + k` of the action pattern, so that an env
/// stepped alone can be given the actions it had in a batch.
fn rollout<G: LaneScene>(
    task: &TaskConfig,
    num_envs: usize,
    seed: u64,
    steps: usize,
    first: usize,
) -> Vec<u64> {
    let params = ChainParams::new(0.8, &[0.15, 0.1], &[0.4, 0.3], 9.81).unwrap();
    let mut b = EnvBatch::new(
        Chain::<G>::new(params),
        task.clone(),
        num_envs,
        seed,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let (d, f) = (b.state_dim(), b.force_dim());
    let mut obs = vec![0.0f64; num_envs * d];
    let (mut rewards, mut terminated, mut truncated) = (
        vec![0.0; num_envs],
        vec![false; num_envs],
        vec![false; num_envs],
    );
    let mut bits = Vec::new();
    for step in 0..steps {
        let actions: Vec<f64> = (0..num_envs * f)
            .map(|j| {
                let env = first + j / f;
                1.6 * (0.37 * step as f64 + 1.3 * env as f64 + 0.7 * (j % f) as f64).sin()
            })
            .collect();
        b.step(
            &actions,
            StepOutputs {
                obs: &mut obs,
                rewards: &mut rewards,
                terminated: &mut terminated,
                truncated: &mut truncated,
            },
        )
        .unwrap();
        bits.extend(obs.iter().chain(&rewards).map(|v| v.to_bits()));
    }
    bits
}

/// Env `env`'s rows of a rollout of `num_envs` envs (observations then rewards per step).
fn env_rows(bits: &[u64], num_envs: usize, d: usize, env: usize) -> Vec<u64> {
    bits.chunks(num_envs * (d + 1))
        .flat_map(|step| {
            let obs = &step[env * d..(env + 1) * d];
            let reward = step[num_envs * d + env];
            obs.iter().copied().chain(std::iter::once(reward))
        })
        .collect()
}

fn check_env_batch<G: LaneScene>() {
    let d = Layout::<G>::new(2).dim();
    // Coefficients of 0 are the ideal model, bit for bit, on the lane kernel too.
    let zeros = Rig {
        joint_damping: vec![0.0, 0.0],
        ..Rig::default()
    };
    assert_eq!(
        rollout::<G>(&env_task(Rig::default()), 6, 3, 30, 0),
        rollout::<G>(&env_task(zeros), 6, 3, 30, 0)
    );
    // With the rig on: a vector of envs is the envs alone (seeds seed + i), seeds
    // reproduce, and another seed gives another run.
    let task = env_task(env_rig(2));
    let batch = rollout::<G>(&task, 5, 17, 30, 0);
    for env in 0..5 {
        let alone = rollout::<G>(&task, 1, 17 + env as u64, 30, env);
        assert_eq!(env_rows(&batch, 5, d, env), alone, "{} env {env}", G::NAME);
    }
    assert_eq!(batch, rollout::<G>(&task, 5, 17, 30, 0));
    assert_ne!(batch, rollout::<G>(&task, 5, 18, 30, 0));
    // The rig changed the run.
    assert_ne!(batch, rollout::<G>(&env_task(Rig::default()), 5, 17, 30, 0));
}

#[test]
fn env_batches_with_a_rig_are_reproducible_and_cut_independent() {
    check_env_batch::<Planar>();
    check_env_batch::<Spatial>();
}

#[test]
fn env_batches_with_a_rig_step_env_by_env() {
    let params = ChainParams::new(0.8, &[0.15, 0.1], &[0.4, 0.3], 9.81).unwrap();
    let build = |task: TaskConfig| {
        EnvBatch::new(
            Chain::<Planar>::new(params.clone()),
            task,
            8,
            0,
            AutoresetMode::NextStep,
            false,
        )
    };
    let ideal = build(env_task(Rig::default())).unwrap();
    assert!(ideal.kernel().is_some() || Kernel::detect().checked().is_err());
    let mut rigged = build(env_task(env_rig(2))).unwrap();
    assert!(rigged.kernel().is_none());
    let e = rigged
        .set_kernel(Some(Kernel::detect()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("per-env path"), "{e}");
    let e = rigged
        .set_precision(Precision::F32)
        .unwrap_err()
        .to_string();
    assert!(e.contains("precision") || e.contains("per-env path"), "{e}");
    let mut task = env_task(env_rig(2));
    task.precision = Precision::F32;
    let e = build(task).err().unwrap().to_string();
    assert!(e.contains("f64") && e.contains("joint damping"), "{e}");
    let mut task = env_task(env_rig(2));
    task.step_options = StepOptions::new(Method::Variational, 1).unwrap();
    let e = build(task).err().unwrap().to_string();
    assert!(e.contains("variational"), "{e}");
}

#[test]
fn the_action_scales_by_the_actuation_modes_maximum() {
    // One env at the hanging rest, one step of action 0.5: the first step's cart
    // velocity follows the mode's own scale.
    let params = ChainParams::new(0.8, &[0.15, 0.1], &[0.4, 0.3], 9.81).unwrap();
    let mut task = env_task(Rig {
        actuation: Actuation::Acceleration,
        ..Rig::default()
    });
    task.start = Start::Equilibrium(vec![1.0, 1.0]);
    task.start_noise = 0.0;
    task.max_acceleration = 4.0;
    let mut b = EnvBatch::new(
        Chain::<Planar>::new(params),
        task,
        1,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let d = b.state_dim();
    let mut obs = vec![0.0f64; d];
    let (mut r, mut te, mut tr) = (vec![0.0], vec![false], vec![false]);
    b.step(
        &[0.5f64],
        StepOutputs {
            obs: &mut obs,
            rewards: &mut r,
            terminated: &mut te,
            truncated: &mut tr,
        },
    )
    .unwrap();
    let v = Layout::<Planar>::new(2).load_xdot(b.state(0));
    assert!((v - 0.5 * 4.0 * 0.02).abs() < 1e-12, "{v}");
}
