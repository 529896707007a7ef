//! Saved trajectories of the env batch: a batch with no randomisation, mismatch,
//! noise, delay or rate limit must reproduce them bit for bit (observations,
//! rewards, flags and events as IEEE-754 bit patterns), so that changes to the task
//! layer cannot silently change existing results.
//!
//! The data file `tests/data/env_trajectories.txt` is written by running this test
//! with `CHAINCART_RECORD_TRAJECTORIES=1`; it holds one line per (case, step, env).

use chaincart::env::{AutoresetMode, EnvBatch, Start, StepOutputs, TaskConfig};
use chaincart::lanes::LaneScene;
use chaincart::{Chain, ChainParams, Method, Planar, Spatial, StepOptions};
use std::fmt::Write as _;

const DATA: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/env_trajectories.txt"
);
const N_ENVS: usize = 3;
const STEPS: usize = 30;

/// One recorded case: scene kind, integrator, autoreset mode.
struct Case {
    name: &'static str,
    planar: bool,
    method: Method,
    substeps: usize,
    mode: AutoresetMode,
}

const CASES: [Case; 4] = [
    Case {
        name: "spatial-rk4-next",
        planar: false,
        method: Method::Rk4,
        substeps: 2,
        mode: AutoresetMode::NextStep,
    },
    Case {
        name: "spatial-variational-same",
        planar: false,
        method: Method::Variational,
        substeps: 1,
        mode: AutoresetMode::SameStep,
    },
    Case {
        name: "planar-rk4-same",
        planar: true,
        method: Method::Rk4,
        substeps: 1,
        mode: AutoresetMode::SameStep,
    },
    Case {
        name: "planar-rkmk4-next",
        planar: true,
        method: Method::Rkmk4,
        substeps: 2,
        mode: AutoresetMode::NextStep,
    },
];

fn task(case: &Case) -> TaskConfig {
    let opts = StepOptions::new(case.method, case.substeps).unwrap();
    let mut t = TaskConfig::new(vec![-1.0, -1.0], 0.02, opts);
    // Short episodes and a large start noise: truncations and resets happen within
    // the recorded steps, and some episodes leave a narrow track.
    t.start = Start::Target;
    t.start_noise = 0.2;
    t.max_episode_steps = 12;
    t.track_limit = 0.3;
    t.max_force = 15.0;
    t
}

/// A deterministic action sequence, some entries outside [-1, 1].
fn action(step: usize, env: usize, axis: usize) -> f64 {
    let phase = 0.37 * step as f64 + 1.3 * env as f64 + 0.7 * axis as f64;
    1.6 * phase.sin()
}

fn record<G: LaneScene>(case: &Case, out: &mut String) {
    let params = ChainParams::new(0.8, &[0.15, 0.1], &[0.4, 0.3], 9.81).unwrap();
    let chain = Chain::<G>::new(params);
    let mut b = EnvBatch::new(chain, task(case), N_ENVS, 11, case.mode, false).unwrap();
    let (d, f) = (b.state_dim(), b.force_dim());
    let mut obs = vec![0.0f64; N_ENVS * d];
    let (mut rewards, mut terminated, mut truncated) =
        (vec![0.0; N_ENVS], vec![false; N_ENVS], vec![false; N_ENVS]);
    for step in 0..STEPS {
        let actions: Vec<f64> = (0..N_ENVS * f)
            .map(|j| action(step, j / f, j % f))
            .collect();
        let outputs = StepOutputs {
            obs: &mut obs,
            rewards: &mut rewards,
            terminated: &mut terminated,
            truncated: &mut truncated,
        };
        b.step(&actions, outputs).unwrap();
        for env in 0..N_ENVS {
            write!(out, "{} {step} {env} ", case.name).unwrap();
            for v in &obs[env * d..(env + 1) * d] {
                write!(out, "{:016x}", v.to_bits()).unwrap();
            }
            writeln!(
                out,
                " {:016x} {} {} {}",
                rewards[env].to_bits(),
                terminated[env] as u8,
                truncated[env] as u8,
                b.events()[env]
            )
            .unwrap();
        }
    }
}

fn all_trajectories() -> String {
    let mut out = String::new();
    for case in &CASES {
        if case.planar {
            record::<Planar>(case, &mut out);
        } else {
            record::<Spatial>(case, &mut out);
        }
    }
    out
}

#[test]
fn default_batches_reproduce_the_saved_trajectories_bit_for_bit() {
    let now = all_trajectories();
    if std::env::var_os("CHAINCART_RECORD_TRAJECTORIES").is_some() {
        std::fs::create_dir_all(std::path::Path::new(DATA).parent().unwrap()).unwrap();
        std::fs::write(DATA, &now).unwrap();
    }
    let saved = std::fs::read_to_string(DATA).expect("saved trajectories");
    assert_eq!(saved.lines().count(), CASES.len() * STEPS * N_ENVS);
    for (k, (a, b)) in saved.lines().zip(now.lines()).enumerate() {
        assert_eq!(a, b, "line {k} differs from the saved trajectory");
    }
    // The recorded runs do exercise resets and terminations.
    let events: Vec<u8> = saved
        .lines()
        .map(|l| l.rsplit(' ').next().unwrap().parse().unwrap())
        .collect();
    assert!(events.iter().any(|e| e & 1 != 0), "no episode ended");
    assert!(
        events.iter().any(|e| e & 4 != 0),
        "no episode left the track"
    );
}
