//! The paper's controlled examples (Figs. 2 and 3): the LQR feedback of eq. (u) on the
//! 5-link system with the paper's weights, simulated with rk4 under a zero-order hold
//! (ZOH) of the force over each control period.
//!
//! What the simulations show (numbers printed by the tests):
//!
//! * **Fig. 2** (folded start IC1 -> hanging) is a violent transient: the chain falls
//!   from the folded configuration, the links spin up to `e_w ~ 190 rad/s` and the force
//!   peaks near 70 N, before the LQR catches it after ~3 s. Whether it catches it depends
//!   on the ZOH period, not on the integrator: with a 1 ms hold (at any number of rk4
//!   substeps) or 0.5 ms, the sampled feedback pumps energy into the spinning links and
//!   the chain is never caught (`e_w` in the thousands); with a hold of 0.3 ms or less it
//!   always is. So Fig. 2 runs at 0.1 ms (rk4, one step per period; rkmk4 gives the same
//!   trajectory). It settles (`e_q, e_w < 1e-3`) at ~9.7 s; across hold periods from
//!   0.3 ms down to 10 us the settle time ranges 9.4-10.3 s, so "within 10 s" holds at
//!   0.1 ms but is not a property of the continuous-time loop. The result is insensitive
//!   to perturbing the initial angle by 1e-6 rad.
//! * **Fig. 3** (partially folded) is a gentle transient, independent of the hold period
//!   (1 ms to 20 us agree), but slow: the paper's weights for it put only `I2` on the
//!   cart, and the slowest closed-loop poles are `-0.77 +- 0.56i` (double). At 10 s
//!   `e_q = 6.5e-4` but `e_w = 2.7e-3` and `|x| = 3.6e-3`; all three are below 1e-3 from
//!   ~11.3 s on. So Fig. 3 is checked over 12 s, with looser bounds at 10 s.

use chaincart::analysis::LqrController;
use chaincart::geometry::{Layout, Spatial};
use chaincart::{ChainParams, Method, SpatialChain, StepOptions, Stepper};
use nalgebra::{Vector2, Vector3};

const TOLERANCE: f64 = 1e-3;

fn deg(a: f64) -> f64 {
    a.to_radians()
}

/// State with the paper's eq. (IC1) cart and spins and the given link directions.
fn initial_state(links: [Vector3<f64>; 5]) -> Vec<f64> {
    let lay = Layout::<Spatial>::new(5);
    let mut y = vec![0.0; lay.dim()];
    lay.store_x(&mut y, Vector2::new(0.2, 0.1));
    lay.store_xdot(&mut y, Vector2::new(0.0, -0.1));
    for (i, q) in links.into_iter().enumerate() {
        lay.store_q(&mut y, i, q);
    }
    y
}

/// Eq. (IC1): `q_i = (-1)^i e3` for i = 1..4, `q_5 = [sin 1; 0; -cos 1]` (degrees).
fn ic1() -> Vec<f64> {
    let e3 = Vector3::new(0.0, 0.0, 1.0);
    initial_state([
        -e3,
        e3,
        -e3,
        e3,
        Vector3::new(deg(1.0).sin(), 0.0, -deg(1.0).cos()),
    ])
}

/// Fig. 3's initial condition, with the paper's four-entry `q_2 = q_3` read as
/// `-[0; sin 4; cos 4]` (docs/physics.md, the paper's slips).
fn fig3_ic() -> Vec<f64> {
    let (s4, c4) = deg(4.0).sin_cos();
    let (s5, c5) = deg(5.0).sin_cos();
    let (s6, c6) = deg(6.0).sin_cos();
    let (s35, c35) = deg(35.0).sin_cos();
    initial_state([
        -Vector3::new(s6, 0.0, c6),
        -Vector3::new(0.0, s4, c4),
        -Vector3::new(0.0, s4, c4),
        Vector3::new(s5 * c4, -s5 * s4, c5),
        Vector3::new(-s35, 0.0, c35),
    ])
}

/// Errors and cart offset at one instant.
#[derive(Debug, Clone, Copy)]
struct Sample {
    e_q: f64,
    e_w: f64,
    cart: f64,
}

struct Run {
    peak_force: f64,
    /// First time after which `e_q` and `e_w` stay below [`TOLERANCE`].
    settle_time: Option<f64>,
    at_10s: Sample,
    last: Sample,
}

/// `horizon` seconds of eq. (u) about `s`, the force held over each `period`.
fn simulate(s: &[f64], mut y: Vec<f64>, period: f64, horizon: f64) -> Run {
    let params = ChainParams::paper();
    let chain = SpatialChain::new(params.clone());
    let controller = LqrController::paper(&params, s).expect("LQR design");
    let mut stepper = Stepper::new(&chain);
    let opts = StepOptions::new(Method::Rk4, 1).unwrap();
    let sample = |y: &[f64]| {
        let (e_q, e_w) = chain.errors(y, s);
        let cart = chain.layout().load_x(y).norm();
        Sample { e_q, e_w, cart }
    };
    let steps = (horizon / period).round() as usize;
    let ten = (10.0 / period).round() as usize;
    let (mut peak_force, mut settle_time, mut at_10s) = (0.0f64, None, sample(&y));
    for k in 1..=steps {
        let u = controller.force(&y);
        peak_force = peak_force.max(u.norm());
        stepper
            .step(&chain, &mut y, u, period, &opts)
            .expect("rk4 step");
        let now = sample(&y);
        assert!(
            now.e_q.is_finite() && now.e_w.is_finite(),
            "diverged at step {k}"
        );
        if now.e_q < TOLERANCE && now.e_w < TOLERANCE {
            settle_time.get_or_insert(k as f64 * period);
        } else {
            settle_time = None;
        }
        if k == ten {
            at_10s = now;
        }
    }
    Run {
        peak_force,
        settle_time,
        at_10s,
        last: sample(&y),
    }
}

fn report(name: &str, run: &Run) {
    println!(
        "{name}: peak |u| = {:.2} N; e_q, e_w < {TOLERANCE} from t = {:.3} s; at 10 s {:?}; at \
         the end {:?}",
        run.peak_force,
        run.settle_time.unwrap_or(f64::NAN),
        run.at_10s,
        run.last
    );
}

#[test]
fn fig2_hanging_equilibrium_is_reached_from_the_folded_start() {
    let run = simulate(&[1.0; 5], ic1(), 1e-4, 10.0);
    report("Fig. 2 (s = hanging, IC1, hold 0.1 ms)", &run);
    let settle = run.settle_time.expect("Fig. 2 must settle within 10 s");
    assert!(settle < 10.0);
    assert!(run.last.cart < TOLERANCE, "cart at |x| = {}", run.last.cart);
}

#[test]
fn fig3_partially_folded_equilibrium_is_stabilised() {
    let run = simulate(&[-1.0, -1.0, -1.0, 1.0, 1.0], fig3_ic(), 1e-3, 12.0);
    report("Fig. 3 (s = (-1,-1,-1,1,1), hold 1 ms)", &run);
    let settle = run.settle_time.expect("Fig. 3 must settle within 12 s");
    assert!(settle < 12.0);
    assert!(run.last.cart < TOLERANCE, "cart at |x| = {}", run.last.cart);
    // At the paper's (presumed) 10 s horizon it is nearly there; see the module docs.
    let ten = run.at_10s;
    assert!(
        ten.e_q < TOLERANCE && ten.e_w < 1e-2 && ten.cart < 1e-2,
        "{ten:?}"
    );
}
