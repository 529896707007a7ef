use chaincart::control::{MpcOptions, PlanOptions, Planner, ScalarGeometry};
use chaincart::geometry::Vector;
use chaincart::integrate::{Method, StepOptions, Stepper};
use chaincart::{Chain, ChainParams, Planar, Spatial};
use rand::{Rng, SeedableRng};
use std::time::Instant;

fn env(k: &str, d: f64) -> f64 {
    std::env::var(k)
        .ok()
        .map(|v| v.parse().unwrap())
        .unwrap_or(d)
}

fn run<G: ScalarGeometry>(n: usize, start: &[f64], target: &[f64], opts: &PlanOptions) {
    let chain = Chain::<G>::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap());
    let y0 = chain.equilibrium(start).unwrap();
    let mut planner = Planner::new(&chain, target, opts).unwrap();
    let plan = planner.plan(&y0).unwrap();
    let r = &plan.report;
    println!("{} n={n} {:?}->{:?}: conv={} cost={:.3} it={} t={:.3}s best={} eq={:.3} ew={:.3} peak={:.1} rms={:.1} xmax={:.2} wmax={:.1} reach={:?} {}",
        G::NAME, start, target, plan.converged, r.cost, r.iterations, r.seconds, r.best_guess, r.e_q, r.e_w, r.peak_force, r.rms_force, r.max_cart, r.max_spin, r.time_to_reach, r.status.describe());
    let mut tracker = planner.tracker(&plan).unwrap();
    let mut mpc = planner
        .mpc(MpcOptions {
            horizon: env("H", 40.0) as usize,
            iterations: env("IT", 2.0) as usize,
            budget: env("BUDGET", 0.005),
            ..Default::default()
        })
        .unwrap();
    let step_opts = StepOptions::new(Method::Rk4, opts.substeps).unwrap();
    let mut stepper = Stepper::new(&chain);
    let k_plan = plan.forces.len() / G::CART;
    let hold = (env("HOLD", 1.0) / opts.dt) as usize;
    let mut rng = rand::rngs::StdRng::seed_from_u64(0);
    for mode in ["open", "tvlqr", "mpc"] {
        let trials = if mode == "open" {
            1
        } else {
            env("TRIALS", 20.0) as usize
        };
        let mut ok = 0;
        let mut worst_t = 0.0f64;
        let began = Instant::now();
        let mut steps = 0;
        for trial in 0..trials {
            let mut y = y0.clone();
            if trial > 0 || mode != "open" && env("NOISE", 0.05) > 0.0 {
                let noise = env("NOISE", 0.05);
                for v in y.iter_mut() {
                    *v += rng.random_range(-noise..noise);
                }
                chain.project(&mut y);
            }
            mpc.reset();
            let mut success_all = true;
            let mut u = vec![0.0; G::CART];
            let mut xmax = 0.0f64;
            for k in 0..k_plan + hold {
                match mode {
                    "open" => {
                        if k < k_plan {
                            u.copy_from_slice(&plan.forces[k * G::CART..(k + 1) * G::CART]);
                        } else {
                            u.fill(0.0);
                        }
                    }
                    "tvlqr" => tracker.force(k, &y, &mut u),
                    _ => {
                        mpc.force(k, &y, &mut u);
                        worst_t = worst_t.max(mpc.stats.seconds);
                    }
                }
                stepper
                    .step(&chain, &mut y, G::Cart::load(&u), opts.dt, &step_opts)
                    .unwrap();
                steps += 1;
                xmax = xmax.max(y[0].abs());
                if mode == "open" && k + 1 == k_plan {
                    let (eq, ew) = chain.errors(&y, target);
                    println!("  open-loop end: e_q {eq:.4} e_w {ew:.4}");
                }
            }
            let (eq, ew) = chain.errors(&y, target);
            if !(eq <= 0.1 && ew <= 0.5 && xmax <= opts.track_limit) {
                success_all = false;
            }
            if success_all {
                ok += 1;
            }
        }
        println!(
            "  {mode}: {ok}/{trials} ({:.1} us/step, worst mpc step {:.2} ms)",
            began.elapsed().as_secs_f64() * 1e6 / steps as f64,
            worst_t * 1e3
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(2);
    let duration: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(3.0);
    let force: f64 = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(20.0);
    let spatial = args.get(4).map(|s| s == "spatial").unwrap_or(false);
    let mut opts = PlanOptions {
        duration,
        max_force: force,
        track_limit: env("TRACK", 2.4),
        ..Default::default()
    };
    if let Some(g) = args.get(5) {
        opts.guesses = g.parse().unwrap();
    }
    opts.weights.force = env("WF", opts.weights.force);
    opts.weights.q = env("WQ", opts.weights.q);
    opts.weights.w = env("WW", opts.weights.w);
    opts.weights.x = env("WX", opts.weights.x);
    opts.weights.v = env("WV", opts.weights.v);
    opts.weights.terminal = env("WT", opts.weights.terminal);
    opts.probe_iterations = env("PROBE", opts.probe_iterations as f64) as usize;
    opts.max_iterations = env("MAXIT", opts.max_iterations as f64) as usize;
    let start: Vec<f64> = std::env::var("START")
        .map(|s| s.split(',').map(|v| v.parse().unwrap()).collect())
        .unwrap_or(vec![1.0; n]);
    let target: Vec<f64> = std::env::var("TARGET")
        .map(|s| s.split(',').map(|v| v.parse().unwrap()).collect())
        .unwrap_or(vec![-1.0; n]);
    if spatial {
        run::<Spatial>(n, &start, &target, &opts)
    } else {
        run::<Planar>(n, &start, &target, &opts)
    }
}
