//! Criterion benchmarks of the Rust core (numbers quoted in README.md).
//!
//! * `accel/{fast,dense}/n`: one acceleration evaluation.
//! * `step/<method>/n`: one control step (1 substep) of the spatial model.
//! * `planar_vs_spatial/<scene>/n`: one rk4 step of each model on the same in-plane motion.
//! * `batch/N`: one step of a batch of N paper systems (5 links, rk4), throughput in env-steps.
//! * `batch_kernel/<path>/N`: the same step (1 ms, guarded) through the per-env path
//!   (`scalar`), each lane kernel this CPU runs, and the best kernel in f32 (`f32`),
//!   side by side in one run.
//! * `lane_precision/{f64,f32}/4096`: the lane stepper alone on one thread, 8 f64 or
//!   16 f32 lanes per group, best kernel.
//! * `env_batch/<variant>/n<links>/N`: one step of the RL task layer's batch (planar,
//!   default task, rk4 with 2 substeps, short episodes so resets are included) with the
//!   reality gap off, with cart mass, link masses and lengths redrawn at every reset
//!   (`randomized`), and with sensor noise plus a one-step delay (`noise_delay`).
//! * `env_lanes/<path>/<scene>/4096`: the same task (reality gap off) at N = 4096 on
//!   the paths side by side: env by env (`per_env`), the lane kernel in f64 and in f32,
//!   and the lane kernel's physics alone (`physics_f64`, `physics_f32`: a raw batch of
//!   the same chain, period and substeps), for n = 5 spatial and one planar link. The
//!   env rows minus the physics rows are the task layer's cost.

use chaincart::dense::dense_derivative;
use chaincart::engine::ChainBatch;
use chaincart::env::{AutoresetMode, EnvBatch, StepOutputs};
use chaincart::geometry::planar_to_spatial;
use chaincart::integrate::{Guard, StepStatus};
use chaincart::lanes::Precision;
use chaincart::lanes::{Kernel, LaneParams, LaneScene, LaneStepper, StepPlan};
use chaincart::{Chain, Planar, Spatial};
use chaincart::{ChainParams, Method, PlanarChain, SpatialChain, StepOptions, Stepper};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use nalgebra::Vector2;
use std::hint::black_box;

#[path = "shared/env_task.rs"]
mod env_task;
use env_task::{env_task, VARIANTS};

const SIZES: [usize; 6] = [1, 2, 5, 10, 50, 200];

/// A moving planar state of n links: tilted from hanging by growing angles, spinning.
fn moving_planar_state(n: usize) -> Vec<f64> {
    let mut planar = vec![0.0; 2 + 3 * n];
    for i in 0..n {
        let a = 0.3 + 0.2 * i as f64;
        planar[2 + 2 * i] = a.sin();
        planar[3 + 2 * i] = a.cos();
        planar[2 + 2 * n + i] = 0.5;
    }
    planar
}

/// A moving, non-degenerate spatial state: the planar one, nudged out of the plane.
fn moving_state(chain: &SpatialChain) -> Vec<f64> {
    let n = chain.n_links();
    let planar = moving_planar_state(n);
    let mut y = vec![0.0; chain.state_dim()];
    planar_to_spatial(n, &planar, &mut y);
    // Leave the plane a little so the spatial code does real 3-D work.
    for i in 0..n {
        y[4 + 3 * i + 1] = 0.1;
        y[4 + 3 * n + 3 * i] = 0.2;
    }
    chain.project(&mut y);
    y
}

/// `state` repeated for `num_envs` envs, env-major.
fn repeated(state: &[f64], num_envs: usize) -> Vec<f64> {
    state
        .iter()
        .copied()
        .cycle()
        .take(num_envs * state.len())
        .collect()
}

fn chain(n: usize) -> SpatialChain {
    SpatialChain::new(ChainParams::uniform(n, 0.5, 0.1, 0.1, 9.81).unwrap())
}

fn accelerations(c: &mut Criterion) {
    let mut group = c.benchmark_group("accel");
    for n in SIZES {
        let chain = chain(n);
        let y = moving_state(&chain);
        let mut ws = chain.workspace();
        let mut dy = vec![0.0; chain.state_dim()];
        let u = Vector2::new(0.3, -0.2);
        group.bench_with_input(BenchmarkId::new("fast", n), &n, |b, _| {
            b.iter(|| chain.derivative(black_box(&y), u, &mut ws, &mut dy))
        });
        if n <= 50 {
            group.bench_with_input(BenchmarkId::new("dense", n), &n, |b, _| {
                b.iter(|| dense_derivative(chain.params(), black_box(&y), u, &mut dy))
            });
        }
    }
    group.finish();
}

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    for method in Method::ALL {
        for n in SIZES {
            let chain = chain(n);
            let y0 = moving_state(&chain);
            let mut stepper = Stepper::new(&chain);
            let opts = StepOptions {
                method,
                ..StepOptions::default()
            };
            let mut y = y0.clone();
            group.bench_with_input(BenchmarkId::new(method.name(), n), &n, |b, _| {
                b.iter(|| {
                    y.copy_from_slice(&y0);
                    stepper
                        .step(&chain, &mut y, Vector2::zeros(), 1e-3, &opts)
                        .unwrap();
                })
            });
        }
    }
    group.finish();
}

fn planar_vs_spatial(c: &mut Criterion) {
    let mut group = c.benchmark_group("planar_vs_spatial");
    for n in [1, 2, 5, 10] {
        let params = ChainParams::uniform(n, 0.5, 0.1, 0.1, 9.81).unwrap();
        let planar = PlanarChain::new(params.clone());
        let spatial = SpatialChain::new(params);
        let yp0 = moving_planar_state(n);
        let mut ys0 = vec![0.0; spatial.state_dim()];
        planar_to_spatial(n, &yp0, &mut ys0);
        let opts = StepOptions::default();
        let (mut sp, mut ss) = (Stepper::new(&planar), Stepper::new(&spatial));
        let (mut yp, mut ys) = (yp0.clone(), ys0.clone());
        group.bench_with_input(BenchmarkId::new("planar", n), &n, |b, _| {
            b.iter(|| {
                yp.copy_from_slice(&yp0);
                sp.step(&planar, &mut yp, 0.1, 1e-3, &opts).unwrap();
            })
        });
        group.bench_with_input(BenchmarkId::new("spatial", n), &n, |b, _| {
            b.iter(|| {
                ys.copy_from_slice(&ys0);
                ss.step(&spatial, &mut ys, Vector2::new(0.1, 0.0), 1e-3, &opts)
                    .unwrap();
            })
        });
    }
    group.finish();
}

fn batch(c: &mut Criterion) {
    let mut group = c.benchmark_group("batch");
    for num_envs in [1usize, 64, 4096] {
        let chain = chain(5);
        let y0 = moving_state(&chain);
        let mut batch = ChainBatch::new(chain, num_envs, 1e-3, StepOptions::default()).unwrap();
        let states = repeated(&y0, num_envs);
        let forces = vec![0.0; 2 * num_envs];
        group.throughput(Throughput::Elements(num_envs as u64));
        group.bench_with_input(BenchmarkId::from_parameter(num_envs), &num_envs, |b, _| {
            b.iter(|| {
                // Restart from the same states so every iteration does the same work.
                batch.set_states(&states).unwrap();
                batch.step(black_box(&forces)).unwrap();
            })
        });
    }
    group.finish();
}

/// Benchmarks one `EnvBatch::step` of `b` under fixed actions as `id`.
fn bench_env_step<G: LaneScene>(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: BenchmarkId,
    b: &mut EnvBatch<G>,
) {
    let (num_envs, d, f) = (b.num_envs(), b.state_dim(), b.force_dim());
    let actions: Vec<f32> = (0..num_envs * f)
        .map(|k| ((k % 7) as f32 - 3.0) * 0.1)
        .collect();
    let mut obs = vec![0.0f32; num_envs * d];
    let mut rewards = vec![0.0; num_envs];
    let (mut terminated, mut truncated) = (vec![false; num_envs], vec![false; num_envs]);
    group.throughput(Throughput::Elements(num_envs as u64));
    group.bench_function(id, |bencher| {
        bencher.iter(|| {
            let out = StepOutputs {
                obs: &mut obs,
                rewards: &mut rewards,
                terminated: &mut terminated,
                truncated: &mut truncated,
            };
            b.step(black_box(&actions), out).unwrap();
        })
    });
}

/// The benchmark chain of `n` links: the default scene's (1 kg cart, 0.1 kg, 0.5 m).
fn env_chain<G: LaneScene>(n: usize) -> Chain<G> {
    Chain::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap())
}

fn env_batch(c: &mut Criterion) {
    let mut group = c.benchmark_group("env_batch");
    for variant in VARIANTS {
        for n in [2usize, 5] {
            for num_envs in [1usize, 256, 4096] {
                let chain = env_chain::<Planar>(n);
                let task = env_task(n, variant);
                let mut b = EnvBatch::new(chain, task, num_envs, 0, AutoresetMode::NextStep, false)
                    .unwrap();
                let id = BenchmarkId::new(format!("{variant}/n{n}"), num_envs);
                bench_env_step(&mut group, id, &mut b);
            }
        }
    }
    group.finish();
}

/// The `env_lanes` rows of one scene: env by env, lanes f64/f32, physics alone.
fn env_lanes_scene<G: chaincart::lanes::LaneScene>(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    scene: &str,
    n: usize,
) {
    let num_envs = 4096;
    let paths = [
        ("per_env", None),
        ("lanes_f64", Some(Precision::F64)),
        ("lanes_f32", Some(Precision::F32)),
    ];
    for (name, precision) in paths {
        let task = env_task(n, "off");
        let mut b = EnvBatch::new(
            env_chain::<G>(n),
            task,
            num_envs,
            0,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap();
        match precision {
            None => b.set_kernel(None).unwrap(),
            Some(p) => b.set_precision(p).unwrap(),
        }
        bench_env_step(
            group,
            BenchmarkId::new(format!("{name}/{scene}"), num_envs),
            &mut b,
        );
    }
    for (name, precision) in [
        ("physics_f64", Precision::F64),
        ("physics_f32", Precision::F32),
    ] {
        let task = env_task(n, "off");
        let mut batch =
            ChainBatch::new(env_chain::<G>(n), num_envs, task.dt, task.step_options).unwrap();
        batch.set_precision(precision).unwrap();
        let forces = vec![0.1; num_envs * batch.chain().force_dim()];
        group.throughput(Throughput::Elements(num_envs as u64));
        let id = BenchmarkId::new(format!("{name}/{scene}"), num_envs);
        group.bench_function(id, |bencher| {
            bencher.iter(|| batch.step(black_box(&forces)).unwrap())
        });
    }
}

fn env_lanes(c: &mut Criterion) {
    let mut group = c.benchmark_group("env_lanes");
    env_lanes_scene::<Spatial>(&mut group, "spatial_n5", 5);
    env_lanes_scene::<Planar>(&mut group, "planar_n1", 1);
    group.finish();
}

fn batch_kernels(c: &mut Criterion) {
    let mut group = c.benchmark_group("batch_kernel");
    let paths = std::iter::once(None).chain(
        Kernel::ALL
            .into_iter()
            .filter(|k| k.is_available())
            .map(Some),
    );
    let f32_path = (Some(Kernel::detect()), Precision::F32);
    let paths = paths
        .map(|k| (k, Precision::F64))
        .chain(std::iter::once(f32_path));
    for (kernel, precision) in paths {
        let name = match precision {
            Precision::F32 => "f32",
            Precision::F64 => kernel.map_or("scalar", Kernel::name),
        };
        for num_envs in [1usize, 4096] {
            let chain = chain(5);
            let y0 = moving_state(&chain);
            let mut batch = ChainBatch::new(chain, num_envs, 1e-3, StepOptions::default()).unwrap();
            batch.set_kernel(kernel).unwrap();
            batch.set_precision(precision).unwrap();
            let states = repeated(&y0, num_envs);
            let forces = vec![0.0; 2 * num_envs];
            batch.set_states(&states).unwrap();
            group.throughput(Throughput::Elements(num_envs as u64));
            group.bench_with_input(BenchmarkId::new(name, num_envs), &num_envs, |b, _| {
                // Keep stepping the same (slowly moving) states: no copy in the timed loop.
                b.iter(|| batch.step(black_box(&forces)).unwrap())
            });
        }
    }
    group.finish();
}

/// One thread's lane stepper over `num_envs` paper systems in lanes of `T`.
fn bench_lane_precision<T: chaincart::lanes::LaneReal, const L: usize>(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    num_envs: usize,
) where
    Spatial: chaincart::lanes::LaneGeometry<L, T>,
{
    let chain = chain(5);
    let y0 = moving_state(&chain);
    let mut states = repeated(&y0, num_envs);
    let forces = vec![0.0; 2 * num_envs];
    let params = [LaneParams::<L, T>::broadcast(chain.params())];
    let mut stepper = LaneStepper::<Spatial, L, T>::new(5);
    let mut status = vec![StepStatus::Ok; num_envs];
    let guard = Guard::default();
    let plan = StepPlan {
        dt: 1e-3,
        substeps: 1,
        guard: &guard,
    };
    group.throughput(Throughput::Elements(num_envs as u64));
    group.bench_with_input(BenchmarkId::new(name, num_envs), &num_envs, |b, _| {
        b.iter(|| {
            let kernel = Kernel::detect();
            stepper.step(
                kernel,
                &params,
                &mut states,
                &forces,
                None,
                plan,
                &mut status,
            )
        })
    });
}

fn lane_precision(c: &mut Criterion) {
    let mut group = c.benchmark_group("lane_precision");
    bench_lane_precision::<f64, 8>(&mut group, "f64", 4096);
    bench_lane_precision::<f32, 16>(&mut group, "f32", 4096);
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).warm_up_time(std::time::Duration::from_millis(300)).measurement_time(std::time::Duration::from_millis(800));
    targets = accelerations, steps, planar_vs_spatial, batch, batch_kernels, lane_precision, env_batch, env_lanes
}
criterion_main!(benches);
