//! Env-batch throughput with the reality gap off, with per-env parameters redrawn at
//! every reset, and with sensor noise plus a one-step delay, in million env-steps per
//! second of process CPU time (so that other processes sharing the cores inflate
//! the numbers less than wall-clock timing would; Linux only), best of 3 runs of
//! about 0.3 s of CPU time each.
//!
//! `cargo run --release --example env_throughput` (set `RAYON_NUM_THREADS` to fix the
//! thread count).

use chaincart::env::{AutoresetMode, EnvBatch, StepOutputs};
use chaincart::{Chain, ChainParams, Method, Planar, StepOptions};

#[path = "../benches/shared/env_task.rs"]
mod env_task;
use env_task::{env_task as task, VARIANTS};

/// CPU time of this process so far (user + system, all threads), from /proc.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").expect("/proc/self/stat (Linux)");
    // Fields after the parenthesised command name; utime and stime are the 12th and
    // 13th of them, in clock ticks (100 per second on Linux).
    let rest = &stat[stat.rfind(')').unwrap() + 2..];
    let f: Vec<&str> = rest.split(' ').collect();
    let ticks: f64 = f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap();
    ticks / 100.0
}

/// Million env-steps per CPU second, best of `repeats` runs of about 0.3 CPU seconds.
fn rate(n: usize, num_envs: usize, variant: &str, repeats: usize) -> f64 {
    let chain = Chain::<Planar>::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap());
    let mut b = EnvBatch::new(
        chain,
        task(n, variant),
        num_envs,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let d = b.state_dim();
    let actions: Vec<f32> = (0..num_envs)
        .map(|k| ((k % 7) as f32 - 3.0) * 0.1)
        .collect();
    let mut obs = vec![0.0f32; num_envs * d];
    let mut rewards = vec![0.0; num_envs];
    let (mut terminated, mut truncated) = (vec![false; num_envs], vec![false; num_envs]);
    let steps = (4_000 / num_envs).max(1);
    let mut best: f64 = 0.0;
    for _ in 0..repeats {
        let (t0, mut done) = (cpu_seconds(), 0usize);
        while cpu_seconds() - t0 < 0.3 {
            for _ in 0..steps {
                let out = StepOutputs {
                    obs: &mut obs,
                    rewards: &mut rewards,
                    terminated: &mut terminated,
                    truncated: &mut truncated,
                };
                b.step(&actions, out).unwrap();
            }
            done += steps * num_envs;
        }
        best = best.max(done as f64 / (cpu_seconds() - t0) / 1e6);
    }
    best
}

/// Million env-steps per CPU second of the physics batch alone (no task layer).
fn raw_rate(n: usize, num_envs: usize) -> f64 {
    let chain = Chain::<Planar>::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap());
    let opts = StepOptions::new(Method::Rk4, 2).unwrap();
    let mut b = chaincart::engine::ChainBatch::new(chain, num_envs, 0.02, opts).unwrap();
    let y0: Vec<f64> = b.states().to_vec();
    let forces = vec![0.1; num_envs];
    let steps = (4_000 / num_envs).max(1);
    let mut best: f64 = 0.0;
    for _ in 0..3 {
        let (t0, mut done) = (cpu_seconds(), 0usize);
        while cpu_seconds() - t0 < 0.3 {
            b.states_mut().copy_from_slice(&y0);
            for _ in 0..steps {
                b.step(&forces).unwrap();
            }
            done += steps * num_envs;
        }
        best = best.max(done as f64 / (cpu_seconds() - t0) / 1e6);
    }
    best
}

fn main() {
    if std::env::args().nth(1).as_deref() == Some("raw") {
        for n in [2, 5] {
            println!(
                "raw batch n = {n}: {:.2} {:.2}",
                raw_rate(n, 1),
                raw_rate(n, 256)
            );
        }
        return;
    }
    let variants: Vec<String> = std::env::args().skip(1).collect();
    let variants = if variants.is_empty() {
        VARIANTS.map(String::from).to_vec()
    } else {
        variants
    };
    println!("threads: {}", rayon::current_num_threads());
    println!("| variant | n | N = 1 | N = 256 | N = 4096 |");
    println!("|---|---|---|---|---|");
    for variant in &variants {
        for n in [2, 5] {
            let r: Vec<String> = [1, 256, 4096]
                .iter()
                .map(|&num_envs| format!("{:.2}", rate(n, num_envs, variant, 3)))
                .collect();
            println!("| {variant} | {n} | {} |", r.join(" | "));
        }
    }
}
