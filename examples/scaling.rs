//! Cost against the number of links: one acceleration evaluation of the O(n)
//! tension form and of the paper's dense form (eq. ELwm, an LU solve of the
//! (2+3n)-square system), and one rk4 step of the O(n) form, for n = 1 .. 256.
//!
//! `cargo run --release --example scaling [-- --quick] [-- --max-n N]`
//!
//! Prints one line per measurement, `form n seconds`, for `python -m chaincart_env
//! bench --sections scaling` to parse. Each time is the best of three runs of at
//! least `min_time` seconds (a shared machine: the least disturbed run counts).

use chaincart::dense::dense_derivative;
use chaincart::{ChainParams, Method, SpatialChain, StepOptions, Stepper};
use nalgebra::Vector2;
use std::hint::black_box;
use std::time::Instant;

/// A moving state off the plane: links tilted and spinning.
fn moving_state(chain: &SpatialChain) -> Vec<f64> {
    let n = chain.n_links();
    let mut y = vec![0.0; chain.state_dim()];
    for i in 0..n {
        let a = 0.3 + 0.2 * i as f64;
        y[4 + 3 * i] = a.sin();
        y[4 + 3 * i + 1] = 0.1;
        y[4 + 3 * i + 2] = a.cos();
        y[4 + 3 * n + 3 * i] = 0.2;
        y[4 + 3 * n + 3 * i + 1] = 0.5;
    }
    chain.project(&mut y);
    y
}

/// Best seconds per call of `f` over three runs of at least `min_time` seconds.
fn seconds_per_call(min_time: f64, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let (mut calls, mut batch) = (0u64, 1u64);
        let start = Instant::now();
        loop {
            for _ in 0..batch {
                f();
            }
            calls += batch;
            let elapsed = start.elapsed().as_secs_f64();
            if elapsed >= min_time {
                best = best.min(elapsed / calls as f64);
                break;
            }
            batch = (batch * 2).min(1 << 16);
        }
    }
    best
}

fn arg_value(args: &[String], name: &str) -> Option<usize> {
    let at = args.iter().position(|a| a == name)?;
    args.get(at + 1).and_then(|v| v.parse().ok())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let max_n = arg_value(&args, "--max-n").unwrap_or(256);
    let min_time = if quick { 0.01 } else { 0.1 };
    let sizes = std::iter::successors(Some(1usize), |n| Some(n * 2)).take_while(|&n| n <= max_n);
    let u = Vector2::new(0.3, -0.2);
    for n in sizes {
        let chain = SpatialChain::new(ChainParams::uniform(n, 0.5, 0.1, 0.1, 9.81).unwrap());
        let y = moving_state(&chain);
        let mut dy = vec![0.0; chain.state_dim()];
        let mut ws = chain.workspace();
        let fast = seconds_per_call(min_time, || {
            chain.derivative(black_box(&y), u, &mut ws, &mut dy)
        });
        println!("fast {n} {fast:.6e}");
        let params = chain.params().clone();
        let dense = seconds_per_call(min_time, || {
            dense_derivative(&params, black_box(&y), u, &mut dy).expect("dense system is regular");
        });
        println!("dense {n} {dense:.6e}");
        let opts = StepOptions {
            method: Method::Rk4,
            ..StepOptions::default()
        };
        let mut stepper = Stepper::new(&chain);
        let mut z = y.clone();
        let step = seconds_per_call(min_time, || {
            z.copy_from_slice(&y);
            stepper.step(&chain, &mut z, u, 1e-3, &opts).unwrap();
        });
        println!("fast_rk4_step {n} {step:.6e}");
    }
}
