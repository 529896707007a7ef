//! Speed vs accuracy of every integrator on the paper's Fig. 1 start (5 links,
//! perturbed folded equilibrium, u = 0). Prints the Markdown table in README.md.
//!
//! `cargo run --release --example speed_accuracy [-- --quick]`
//!
//! Columns: position error of the link masses at t = 1 s against the adaptive
//! method at tolerance 1e-13; largest energy error over 10 s and 1000 s relative to
//! the largest kinetic energy seen; wall time per simulated second (from the 1 s run).

use chaincart::geometry::{Layout, Vector};
use chaincart::integrate::{Guard, GuardedStepper, StepStatus};
use chaincart::{ChainParams, Method, SpatialChain, StepOptions, Stepper};
use nalgebra::{Vector2, Vector3};
use std::time::Instant;

fn paper_ic1() -> Vec<f64> {
    let lay = Layout::<chaincart::Spatial>::new(5);
    let mut y = vec![0.0; lay.dim()];
    lay.store_x(&mut y, Vector2::new(0.2, 0.1));
    lay.store_xdot(&mut y, Vector2::new(0.0, -0.1));
    for i in 0..4 {
        let sign = if i % 2 == 0 { -1.0 } else { 1.0 };
        lay.store_q(&mut y, i, Vector3::new(0.0, 0.0, sign));
    }
    let d = 1f64.to_radians();
    lay.store_q(&mut y, 4, Vector3::new(d.sin(), 0.0, -d.cos()));
    y
}

fn positions(chain: &SpatialChain, y: &[f64]) -> Vec<f64> {
    (0..chain.n_links())
        .flat_map(|i| {
            let mut b = [0.0; 3];
            chain.mass_position(y, i).store(&mut b);
            b
        })
        .collect()
}

/// Runs to `t_end`; Err(time of failure) if the guard flags a step.
fn run(
    chain: &SpatialChain,
    opts: &StepOptions,
    dt: f64,
    t_end: f64,
    mut each: impl FnMut(&[f64]),
) -> Result<Vec<f64>, (f64, StepStatus)> {
    let mut y = paper_ic1();
    let mut stepper = GuardedStepper::new(chain);
    let steps = (t_end / dt).round() as usize;
    for k in 0..steps {
        let status = stepper.step(chain, &mut y, Vector2::zeros(), dt, opts, &Guard::default());
        if status.is_failure() {
            return Err((k as f64 * dt, status));
        }
        each(&y);
    }
    Ok(y)
}

fn energy_drift(chain: &SpatialChain, opts: &StepOptions, dt: f64, t_end: f64) -> String {
    let e0 = chain.energy(&paper_ic1()).total();
    let (mut worst, mut peak_t) = (0.0f64, 0.0f64);
    match run(chain, opts, dt, t_end, |y| {
        let e = chain.energy(y);
        worst = worst.max((e.total() - e0).abs());
        peak_t = peak_t.max(e.kinetic);
    }) {
        Ok(_) => format!("{:.1e}", worst / peak_t),
        Err((t, _)) => format!("failed at {t:.2} s"),
    }
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let chain = SpatialChain::new(ChainParams::paper());
    let reference = {
        let opts = StepOptions {
            method: Method::Adaptive,
            tolerance: 1e-13,
            substeps: 1000,
            ..StepOptions::default()
        };
        let mut y = paper_ic1();
        Stepper::new(&chain)
            .step(&chain, &mut y, Vector2::zeros(), 1.0, &opts)
            .unwrap();
        positions(&chain, &y)
    };
    let long = if quick { 100.0 } else { 1000.0 };
    println!("| integrator | step (s) | position error at 1 s (m) | energy error over 10 s | energy error over {long:.0} s | wall time per simulated s |");
    println!("|---|---|---|---|---|---|");
    let steps: &[f64] = if quick {
        &[1e-2, 1e-3, 1e-4]
    } else {
        &[1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4]
    };
    let mut rows: Vec<(Method, f64, StepOptions)> = Vec::new();
    for method in [
        Method::Rk4,
        Method::Rkmk4,
        Method::Variational,
        Method::LieEuler,
    ] {
        for &dt in steps {
            rows.push((
                method,
                dt,
                StepOptions {
                    method,
                    ..StepOptions::default()
                },
            ));
        }
    }
    for tol in [1e-6, 1e-8, 1e-10] {
        // Control period 10 ms; the method picks its own steps inside it.
        rows.push((
            Method::Adaptive,
            1e-2,
            StepOptions {
                method: Method::Adaptive,
                tolerance: tol,
                ..StepOptions::default()
            },
        ));
    }
    for (method, dt, opts) in rows {
        let start = Instant::now();
        let one = run(&chain, &opts, dt, 1.0, |_| {});
        let cost = start.elapsed().as_secs_f64();
        let error = match one {
            Ok(y) => format!(
                "{:.1e}",
                positions(&chain, &y)
                    .iter()
                    .zip(&reference)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            ),
            Err((t, s)) => format!("failed at {t:.2} s ({})", s.describe()),
        };
        let label = if method == Method::Adaptive {
            format!("adaptive (tol {:.0e})", opts.tolerance)
        } else {
            method.name().to_string()
        };
        let step = if method == Method::Adaptive {
            "auto".to_string()
        } else {
            format!("{dt:.0e}")
        };
        println!(
            "| {label} | {step} | {error} | {} | {} | {:.2} ms |",
            energy_drift(&chain, &opts, dt, 10.0),
            energy_drift(&chain, &opts, dt, long),
            cost * 1e3
        );
    }
}
