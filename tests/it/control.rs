//! The planner and its controllers on the default physical system (1 kg cart, 0.1 kg at
//! the end of each 0.5 m link), simulated by the model's own integrator (not the
//! planner's generic copy of it): plans reach their targets open-loop, and the tracking
//! and receding-horizon controllers reach them from perturbed starts.

use chaincart::control::{MpcOptions, Plan, PlanOptions, Planner, ScalarGeometry};
use chaincart::geometry::Vector;
use chaincart::integrate::{Method, StepOptions, Stepper};
use chaincart::params::{Actuation, Rig};
use chaincart::{Chain, ChainError, ChainParams, InputError, Planar, Spatial};
use rand::{Rng, SeedableRng};

fn chain<G: ScalarGeometry>(n: usize) -> Chain<G> {
    Chain::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap())
}

fn options(duration: f64) -> PlanOptions {
    PlanOptions {
        max_force: 20.0,
        track_limit: 2.4,
        duration,
        ..PlanOptions::default()
    }
}

/// Steps `y` with the model's RK4 under `force`.
fn step<G: ScalarGeometry>(
    chain: &Chain<G>,
    stepper: &mut Stepper<G>,
    y: &mut [f64],
    force: &[f64],
) {
    let opts = StepOptions::new(Method::Rk4, 2).unwrap();
    stepper
        .step(chain, y, G::Cart::load(force), 0.02, &opts)
        .unwrap();
}

fn within_tolerance<G: ScalarGeometry>(chain: &Chain<G>, y: &[f64], target: &[f64]) -> bool {
    let (e_q, e_w) = chain.errors(y, target);
    e_q <= 0.1 && e_w <= 0.5
}

/// A start `noise` away from `y` in every component (then projected).
fn perturbed<G: ScalarGeometry>(
    chain: &Chain<G>,
    y: &[f64],
    noise: f64,
    rng: &mut impl Rng,
) -> Vec<f64> {
    let mut y: Vec<f64> = y
        .iter()
        .map(|v| v + rng.random_range(-noise..noise))
        .collect();
    chain.project(&mut y);
    y
}

fn replays_open_loop<G: ScalarGeometry>(chain: &Chain<G>, plan: &Plan) {
    let dim = chain.state_dim();
    let nu = G::CART;
    let mut y = plan.states[..dim].to_vec();
    let mut stepper = Stepper::new(chain);
    for k in 0..plan.forces.len() / nu {
        step(
            chain,
            &mut stepper,
            &mut y,
            &plan.forces[k * nu..(k + 1) * nu],
        );
        let planned = &plan.states[(k + 1) * dim..(k + 2) * dim];
        let gap = y
            .iter()
            .zip(planned)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            gap < 1e-9,
            "step {k}: the model departs from the plan by {gap:e}"
        );
    }
    assert!(
        within_tolerance(chain, &y, &plan.target),
        "{:?}",
        chain.errors(&y, &plan.target)
    );
}

#[test]
fn swing_up_of_the_double_pendulum_is_planned_and_tracked_from_perturbed_starts() {
    let chain = chain::<Planar>(2);
    let mut planner = Planner::new(&chain, &[-1.0, -1.0], &options(3.0)).unwrap();
    let start = chain.equilibrium(&[1.0, 1.0]).unwrap();
    let plan = planner.plan(&start).unwrap();
    assert!(plan.converged, "{}", plan.report.reason);
    assert!(plan.report.peak_force <= 20.0 && plan.report.max_cart <= 2.4);
    replays_open_loop(&chain, &plan);

    let mut tracker = planner.tracker(&plan).unwrap();
    let mut mpc = planner.mpc(MpcOptions::default()).unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let steps = plan.forces.len() + 50; // the plan, then one second holding the target
    for trial in 0..8 {
        for use_mpc in [false, true] {
            let mut y = perturbed(&chain, &start, 0.05, &mut rng);
            let mut stepper = Stepper::new(&chain);
            let mut u = [0.0];
            let mut max_cart = 0.0f64;
            mpc.reset();
            for k in 0..steps {
                if use_mpc {
                    mpc.force(k, &y, &mut u);
                } else {
                    tracker.force(k, &y, &mut u);
                }
                step(&chain, &mut stepper, &mut y, &u);
                max_cart = max_cart.max(y[0].abs());
            }
            assert!(
                within_tolerance(&chain, &y, &[-1.0, -1.0]) && max_cart <= 2.4,
                "trial {trial} (mpc: {use_mpc}): errors {:?}, max |x| {max_cart}",
                chain.errors(&y, &[-1.0, -1.0])
            );
        }
    }
}

#[test]
fn every_transition_of_the_planar_double_pendulum_is_planned() {
    let chain = chain::<Planar>(2);
    let all = chaincart::analysis::all_signs(2).unwrap();
    for start in &all {
        for target in all.iter().filter(|t| *t != start) {
            let mut planner = Planner::new(&chain, target, &options(3.0)).unwrap();
            let plan = planner.plan(&chain.equilibrium(start).unwrap()).unwrap();
            assert!(
                plan.converged,
                "{start:?} -> {target:?}: {}",
                plan.report.reason
            );
            replays_open_loop(&chain, &plan);
        }
    }
}

#[test]
fn the_spatial_double_pendulum_swings_up_from_an_out_of_plane_start() {
    let chain = chain::<Spatial>(2);
    let mut planner = Planner::new(&chain, &[-1.0, -1.0], &options(3.0)).unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(9);
    let start = perturbed(
        &chain,
        &chain.equilibrium(&[1.0, 1.0]).unwrap(),
        0.05,
        &mut rng,
    );
    let plan = planner.plan(&start).unwrap();
    assert!(plan.converged, "{}", plan.report.reason);
    replays_open_loop(&chain, &plan);
    let mut tracker = planner.tracker(&plan).unwrap();
    let mut y = perturbed(&chain, &start, 0.03, &mut rng);
    let mut stepper = Stepper::new(&chain);
    let mut u = [0.0; 2];
    for k in 0..plan.forces.len() / 2 + 50 {
        tracker.force(k, &y, &mut u);
        step(&chain, &mut stepper, &mut y, &u);
    }
    assert!(
        within_tolerance(&chain, &y, &[-1.0, -1.0]),
        "{:?}",
        chain.errors(&y, &[-1.0, -1.0])
    );
}

#[test]
fn a_horizon_too_short_is_reported_not_hidden() {
    let chain = chain::<Planar>(2);
    let mut short = options(0.4);
    short.max_time = 5.0;
    let mut planner = Planner::new(&chain, &[-1.0, -1.0], &short).unwrap();
    let plan = planner
        .plan(&chain.equilibrium(&[1.0, 1.0]).unwrap())
        .unwrap();
    assert!(!plan.converged);
    assert!(
        plan.report.reason.contains("duration = 0.4"),
        "{}",
        plan.report.reason
    );
}

#[test]
fn bad_input_is_named() {
    let chain = chain::<Planar>(2);
    let target = [-1.0, -1.0];
    let name = |options: PlanOptions| match Planner::new(&chain, &target, &options) {
        Err(ChainError::Input(InputError::InvalidParameter { name, .. })) => name,
        other => panic!("expected an invalid parameter, got {:?}", other.err()),
    };
    assert_eq!(
        name(PlanOptions {
            max_force: 0.0,
            ..options(3.0)
        }),
        "max_force"
    );
    assert_eq!(
        name(PlanOptions {
            duration: 0.02,
            ..options(3.0)
        }),
        "duration"
    );
    assert_eq!(
        name(PlanOptions {
            max_time: 0.0,
            ..options(3.0)
        }),
        "max_time"
    );
    assert!(matches!(
        Planner::new(&chain, &[-1.0, 0.5], &options(3.0)),
        Err(ChainError::Input(InputError::InvalidSign { index: 1, .. }))
    ));
    let mut planner = Planner::new(&chain, &target, &options(3.0)).unwrap();
    let mut start = chain.equilibrium(&[1.0, 1.0]).unwrap();
    start[3] = f64::NAN;
    assert!(matches!(
        planner.plan(&start),
        Err(ChainError::Input(InputError::NonFinite {
            name: "start",
            index: 3,
            ..
        }))
    ));
    let plan = planner
        .plan(&chain.equilibrium(&[1.0, 1.0]).unwrap())
        .unwrap();
    let reference = planner.reference().unwrap();
    let budget = MpcOptions {
        budget: 0.0,
        ..MpcOptions::default()
    };
    assert!(matches!(
        planner.mpc_from(reference.clone(), budget),
        Err(ChainError::Input(InputError::InvalidParameter {
            name: "budget",
            ..
        }))
    ));
    let zero_iterations = MpcOptions {
        iterations: 0,
        ..MpcOptions::default()
    };
    assert!(planner.mpc_from(reference, zero_iterations).is_err());
    assert!(plan.converged);
}

/// A chain with joint damping and viscous cart friction, driven by a force or, as a
/// servo axis, by its acceleration.
fn rig_chain(actuation: Actuation) -> Chain<Planar> {
    let (viscous, damping) = match actuation {
        Actuation::Acceleration => (0.0, vec![0.01, 0.02]), // a servo axis has no cart friction to feel
        _ => (2.0, vec![0.01, 0.02]),
    };
    chain::<Planar>(2)
        .with_rig(Rig {
            joint_damping: damping,
            cart_viscous_friction: viscous,
            actuation,
            ..Rig::default()
        })
        .unwrap()
}

#[test]
fn a_plan_on_a_rig_replays_on_that_rig_and_its_tracker_holds_it() {
    for (actuation, bound) in [(Actuation::Force, 20.0), (Actuation::Acceleration, 40.0)] {
        let rig = rig_chain(actuation);
        let limits = PlanOptions {
            max_force: bound,
            ..options(3.0)
        };
        let mut planner = Planner::new(&rig, &[-1.0, -1.0], &limits).unwrap();
        let start = rig.equilibrium(&[1.0, 1.0]).unwrap();
        let plan = planner.plan(&start).unwrap();
        assert!(plan.converged, "{actuation:?}: {}", plan.report.reason);
        assert!(plan.report.peak_force <= bound);
        // The plan's states are the rig's motion under its commands, step for step.
        replays_open_loop(&rig, &plan);
        // The same commands on the ideal chain miss the target: the rig was planned on.
        let ideal = chain::<Planar>(2);
        if actuation == Actuation::Force {
            let mut y = start.clone();
            let mut stepper = Stepper::new(&ideal);
            for u in plan.forces.chunks(1) {
                step(&ideal, &mut stepper, &mut y, u);
            }
            assert!(!within_tolerance(&ideal, &y, &[-1.0, -1.0]));
        }
        let mut tracker = planner.tracker(&plan).unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        for trial in 0..4 {
            let mut y = perturbed(&rig, &start, 0.05, &mut rng);
            let mut stepper = Stepper::new(&rig);
            let mut u = [0.0];
            for k in 0..plan.forces.len() + 50 {
                tracker.force(k, &y, &mut u);
                step(&rig, &mut stepper, &mut y, &u);
            }
            assert!(
                within_tolerance(&rig, &y, &[-1.0, -1.0]),
                "{actuation:?} trial {trial}: errors {:?}",
                rig.errors(&y, &[-1.0, -1.0])
            );
        }
    }
}
