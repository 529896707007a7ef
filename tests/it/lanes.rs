//! The lane kernel (one env per SIMD lane) against the scalar guarded rk4 step:
//! bit-identical states and statuses for every compiled kernel, lane width, chain
//! size and scene, with per-lane parameters; failures isolated to their lane.

use super::common;

use chaincart::geometry::{Geometry, Vector};
use chaincart::integrate::{Guard, GuardedStepper, StepStatus};
use chaincart::lanes::Precision;
use chaincart::lanes::{Kernel, LaneGeometry, LaneParams, LaneReal, LaneStepper, StepPlan};
use chaincart::{Chain, ChainParams, Method, Planar, Spatial, StepOptions};
use common::{random_params, random_planar_state, random_spatial_state, rng};
use rand::rngs::StdRng;
use rand::Rng;

/// A random state of scene G (spins up to `spin` rad/s).
trait RandomState: Geometry {
    fn random_state(rng: &mut StdRng, n: usize, spin: f64) -> Vec<f64>;
}
impl RandomState for Spatial {
    fn random_state(rng: &mut StdRng, n: usize, spin: f64) -> Vec<f64> {
        random_spatial_state(rng, n, spin)
    }
}
impl RandomState for Planar {
    fn random_state(rng: &mut StdRng, n: usize, spin: f64) -> Vec<f64> {
        random_planar_state(rng, n, spin)
    }
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Steps `num_envs` envs (each its own random chain, state and forces) `steps` times
/// with the lane kernel and each alone with the scalar guarded stepper, and asserts
/// identical bits and statuses. Some envs spin fast or are pushed hard so that the
/// guard fails some steps. Returns how many env-steps failed.
fn compare<G: LaneGeometry<L> + RandomState, const L: usize>(
    kernel: Kernel,
    n: usize,
    num_envs: usize,
    substeps: usize,
    seed: u64,
) -> usize {
    compare_with_ratios::<G, L>(kernel, n, num_envs, substeps, seed, 10.0)
}

/// [`compare`] with link masses and lengths spread over `ratio`.
fn compare_with_ratios<G: LaneGeometry<L> + RandomState, const L: usize>(
    kernel: Kernel,
    n: usize,
    num_envs: usize,
    substeps: usize,
    seed: u64,
    ratio: f64,
) -> usize {
    let mut rng = rng(seed);
    let (dt, steps) = (2e-3, 6);
    let guard = Guard::default();
    let opts = StepOptions::new(Method::Rk4, substeps).unwrap();
    let chains: Vec<Chain<G>> = (0..num_envs)
        .map(|_| Chain::new(random_params(&mut rng, n, ratio, ratio)))
        .collect();
    let mut params: Vec<LaneParams<L>> = (0..num_envs.div_ceil(L))
        .map(|_| LaneParams::broadcast(&ChainParams::uniform(n, 1.0, 1.0, 1.0, 1.0).unwrap()))
        .collect();
    for (k, chain) in chains.iter().enumerate() {
        params[k / L].set_lane(k % L, chain.params()).unwrap();
    }
    let mut states: Vec<f64> = (0..num_envs)
        .flat_map(|k| G::random_state(&mut rng, n, if k % 5 == 4 { 400.0 } else { 3.0 }))
        .collect();
    let mut scalar = states.clone();
    let f = G::Cart::DIM;
    let d = states.len() / num_envs;
    let mut lanes = LaneStepper::<G, L>::new(n);
    let mut worker = GuardedStepper::new(&chains[0]);
    let mut status = vec![StepStatus::Ok; num_envs];
    let mut failures = 0;
    for step in 0..steps {
        let forces: Vec<f64> = (0..num_envs * f)
            .map(|j| {
                let scale = if j % 7 == step { 1e5 } else { 10.0 };
                scale * rng.random_range(-1.0..1.0)
            })
            .collect();
        let plan = StepPlan {
            dt,
            substeps,
            guard: &guard,
        };
        lanes.step(
            kernel,
            &params,
            &mut states,
            &forces,
            None,
            plan,
            &mut status,
        );
        for (k, chain) in chains.iter().enumerate() {
            let y = &mut scalar[k * d..(k + 1) * d];
            let u = G::Cart::load(&forces[k * f..]);
            let expected = worker.step(chain, y, u, dt, &opts, &guard);
            assert_eq!(status[k], expected, "env {k} step {step} n {n} L {L}");
            failures += expected.is_failure() as usize;
        }
        assert!(
            bits(&states) == bits(&scalar),
            "{} {} n = {n}, L = {L}, step {step}",
            kernel.name(),
            G::NAME
        );
    }
    failures
}

fn available_kernels() -> Vec<Kernel> {
    Kernel::ALL
        .into_iter()
        .filter(|k| k.is_available())
        .collect()
}

#[test]
fn every_kernel_matches_the_scalar_step_bit_for_bit_for_n_1_to_16() {
    let mut failures = 0;
    for kernel in available_kernels() {
        for n in 1..=16 {
            let seed = n as u64;
            failures += compare::<Spatial, 8>(kernel, n, 19, 1, seed);
            failures += compare::<Planar, 8>(kernel, n, 19, 1, seed);
        }
    }
    // The comparison covered the guard's failure branches too.
    assert!(failures > 0);
}

#[test]
fn extreme_mass_and_length_ratios_change_no_bit() {
    for kernel in available_kernels() {
        for n in [2, 7, 16] {
            compare_with_ratios::<Spatial, 8>(kernel, n, 17, 1, 60 + n as u64, 1e4);
            compare_with_ratios::<Planar, 8>(kernel, n, 17, 2, 61 + n as u64, 1e4);
        }
    }
}

#[test]
fn lane_width_and_substeps_change_no_bit() {
    for kernel in available_kernels() {
        for n in [1, 2, 5, 9] {
            compare::<Spatial, 1>(kernel, n, 5, 1, 40 + n as u64);
            compare::<Spatial, 2>(kernel, n, 5, 2, 41 + n as u64);
            compare::<Spatial, 4>(kernel, n, 11, 3, 42 + n as u64);
            compare::<Spatial, 16>(kernel, n, 21, 1, 43 + n as u64);
            compare::<Planar, 4>(kernel, n, 11, 3, 44 + n as u64);
            compare::<Planar, 16>(kernel, n, 37, 2, 45 + n as u64);
        }
    }
}

#[test]
fn this_cpu_runs_the_kernels_its_features_allow() {
    let kernels = available_kernels();
    assert_eq!(kernels[0], Kernel::Baseline);
    assert_eq!(Kernel::detect(), *kernels.last().unwrap());
    #[cfg(target_arch = "x86_64")]
    {
        assert_eq!(
            Kernel::Avx512.is_available(),
            std::arch::is_x86_feature_detected!("avx512f")
        );
        assert_eq!(
            Kernel::Avx2.is_available(),
            std::arch::is_x86_feature_detected!("avx2")
        );
    }
    eprintln!(
        "kernels run here: {:?}",
        kernels.iter().map(|k| k.name()).collect::<Vec<_>>()
    );
}

/// Steps `L` paper systems from random states (from `seed`) once under the forces
/// `calm` and once with force component `wild` set to `push`: the env it belongs to
/// must be flagged and keep its state, every other env must get its calm result.
fn blow_up_in_one_lane<T: LaneReal, const L: usize>(seed: u64, calm: &[f64], wild: usize, push: f64)
where
    Spatial: LaneGeometry<L, T>,
{
    let chain = Chain::<Spatial>::new(ChainParams::paper());
    let params = [LaneParams::<L, T>::broadcast(chain.params())];
    let mut rng = rng(seed);
    let start: Vec<f64> = (0..L)
        .flat_map(|_| random_spatial_state(&mut rng, 5, 2.0))
        .collect();
    let guard = Guard::default();
    let plan = StepPlan {
        dt: 1e-3,
        substeps: 1,
        guard: &guard,
    };
    let mut stepper = LaneStepper::<Spatial, L, T>::new(5);
    let mut run = |forces: &[f64]| {
        let (mut y, mut status) = (start.clone(), vec![StepStatus::Ok; L]);
        let kernel = Kernel::detect();
        stepper.step(kernel, &params, &mut y, forces, None, plan, &mut status);
        (y, status)
    };
    let mut pushed = calm.to_vec();
    pushed[wild] = push;
    let (reference, ok) = run(calm);
    let (y, status) = run(&pushed);
    assert!(ok.iter().all(|s| !s.is_failure()), "{ok:?}");
    let d = chain.state_dim();
    for k in 0..L {
        let row = |v: &[f64]| bits(&v[k * d..(k + 1) * d]);
        if k == wild / 2 {
            assert!(status[k].is_failure());
            assert_eq!(row(&y), row(&start), "the failed env keeps its state");
        } else {
            assert_eq!(status[k], StepStatus::Ok);
            assert_eq!(row(&y), row(&reference), "env {k}");
        }
    }
}

#[test]
fn a_blow_up_in_one_lane_leaves_its_neighbours_unchanged() {
    let calm: Vec<f64> = (0..16).map(|j| j as f64 - 8.0).collect();
    blow_up_in_one_lane::<f64, 8>(9, &calm, 2 * 3, 1e12);
}

#[test]
fn envs_not_stepped_are_left_alone() {
    let chain = Chain::<Planar>::new(ChainParams::paper());
    let params = [LaneParams::<4>::broadcast(chain.params())];
    let mut rng = rng(10);
    let start: Vec<f64> = (0..6)
        .flat_map(|_| random_planar_state(&mut rng, 5, 2.0))
        .collect();
    let guard = Guard::default();
    let plan = StepPlan {
        dt: 1e-3,
        substeps: 1,
        guard: &guard,
    };
    let stepped = [true, false, true, false, false, true];
    let mut y = start.clone();
    let mut status = vec![StepStatus::SolverFailure; 6];
    let mut stepper = LaneStepper::<Planar, 4>::new(5);
    stepper.step(
        Kernel::Baseline,
        &params,
        &mut y,
        &[1.0; 6],
        Some(&stepped),
        plan,
        &mut status,
    );
    let d = chain.state_dim();
    for (k, &on) in stepped.iter().enumerate() {
        let same = y[k * d..(k + 1) * d] == start[k * d..(k + 1) * d];
        assert_eq!(same, !on, "env {k}");
        assert_eq!(status[k] == StepStatus::Ok, on, "env {k}");
    }
}

#[test]
fn per_lane_parameters_must_match_the_link_count() {
    let mut p = LaneParams::<8>::broadcast(&ChainParams::paper());
    assert!(p.set_lane(8, &ChainParams::paper()).is_err());
    let e = p.set_lane(0, &ChainParams::uniform(3, 1.0, 1.0, 1.0, 9.81).unwrap());
    assert!(e.unwrap_err().to_string().contains('3'));
}

/// Final states of a random paper batch after 20 rk4 steps in a pool of `threads`.
fn batch_run(
    threads: usize,
    num_envs: usize,
    kernel: Option<Kernel>,
) -> (Vec<u64>, Vec<StepStatus>) {
    batch_run_in(threads, num_envs, kernel, Precision::F64)
}

fn batch_run_in(
    threads: usize,
    num_envs: usize,
    kernel: Option<Kernel>,
    precision: Precision,
) -> (Vec<u64>, Vec<StepStatus>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let (mut batch, _) = common::batches::random_batch(num_envs, Method::Rk4, 21);
        batch.set_kernel(kernel).unwrap();
        batch.set_precision(precision).unwrap();
        assert_eq!(batch.kernel(), kernel);
        assert_eq!(batch.precision(), precision);
        let mut statuses = vec![];
        for step in 0..20 {
            let mut f = common::batches::forces(num_envs, step);
            // One env is pushed far past what a step resolves, now and then.
            f[2 * (num_envs / 2)] *= if step % 4 == 1 { 1e9 } else { 1.0 };
            batch.step(&f).unwrap();
            statuses.extend_from_slice(batch.status());
        }
        (bits(batch.states()), statuses)
    })
}

#[test]
fn batches_are_bit_identical_across_kernels_threads_and_sizes() {
    for num_envs in [1, 7, 33, 4097] {
        let reference = batch_run(1, num_envs, None);
        assert!(reference.1.iter().any(|s| s.is_failure()));
        for kernel in available_kernels() {
            for threads in [1, 2] {
                assert!(
                    batch_run(threads, num_envs, Some(kernel)) == reference,
                    "N = {num_envs}, {} kernel, {threads} threads",
                    kernel.name()
                );
            }
        }
    }
}

#[test]
fn rk4_batches_pick_the_lane_kernel_and_other_methods_refuse_it() {
    let (batch, _) = common::batches::random_batch(64, Method::Rk4, 1);
    assert_eq!(batch.kernel(), Some(Kernel::detect()));
    let (small, _) = common::batches::random_batch(1, Method::Rk4, 1);
    assert_eq!(small.kernel(), None);
    let (mut other, _) = common::batches::random_batch(64, Method::Rkmk4, 1);
    assert_eq!(other.kernel(), None);
    let e = other.set_kernel(Some(Kernel::Baseline)).unwrap_err();
    assert!(e.to_string().contains("rk4"), "{e}");
}

#[test]
fn a_chunk_with_a_chain_per_env_steps_each_env_as_its_own_chain() {
    use chaincart::lanes::{ChunkLanes, LaneChunk, LANES};
    let mut rng = rng(12);
    let num_envs = 2 * LANES + 3;
    let params: Vec<ChainParams> = (0..num_envs)
        .map(|_| random_params(&mut rng, 4, 10.0, 10.0))
        .collect();
    let chain = Chain::<Spatial>::new(params[0].clone());
    let mut lanes = LaneChunk::per_env(&chain, &params, Kernel::detect()).unwrap();
    let mut states: Vec<f64> = (0..num_envs)
        .flat_map(|_| random_spatial_state(&mut rng, 4, 3.0))
        .collect();
    let start = states.clone();
    let forces: Vec<f64> = (0..2 * num_envs).map(|j| (j % 7) as f64 - 3.0).collect();
    let guard = Guard::default();
    let plan = StepPlan {
        dt: 1e-3,
        substeps: 2,
        guard: &guard,
    };
    let mut status = vec![StepStatus::SolverFailure; num_envs];
    lanes.step(
        &mut states,
        &forces,
        &vec![true; num_envs],
        plan,
        &mut status,
        None::<&mut chaincart::lanes::NoHook>,
    );
    let d = chain.state_dim();
    let opts = StepOptions::new(Method::Rk4, 2).unwrap();
    for (k, p) in params.iter().enumerate() {
        let own = Chain::<Spatial>::new(p.clone());
        let mut y = start[k * d..(k + 1) * d].to_vec();
        let u = nalgebra::Vector2::new(forces[2 * k], forces[2 * k + 1]);
        let expected = GuardedStepper::new(&own).step(&own, &mut y, u, 1e-3, &opts, &guard);
        assert_eq!(status[k], expected, "env {k}");
        assert_eq!(bits(&states[k * d..(k + 1) * d]), bits(&y), "env {k}");
    }
    let other = vec![ChainParams::uniform(3, 1.0, 1.0, 1.0, 9.81).unwrap()];
    assert!(LaneChunk::per_env(&chain, &other, Kernel::Baseline).is_err());
}

/// Steps the paper's Fig. 1 start (uncontrolled, 1 ms) for `steps` steps with the f32
/// kernel and with the scalar f64 step, returning (largest mass-position difference
/// at the end, f32 energy drift, f64 energy drift, peak kinetic energy, f32 failures).
fn f32_against_f64(steps: usize) -> (f64, f64, f64, f64, usize) {
    use chaincart::env::{paper_initial_condition, PaperFigure};
    let chain = Chain::<Spatial>::new(ChainParams::paper());
    let y0 = paper_initial_condition(PaperFigure::Fig1);
    let guard = Guard::default();
    let plan = StepPlan {
        dt: 1e-3,
        substeps: 1,
        guard: &guard,
    };
    let params = [LaneParams::<16, f32>::broadcast(chain.params())];
    let mut lanes = LaneStepper::<Spatial, 16, f32>::new(5);
    let mut narrow = y0.clone();
    let mut status = [StepStatus::Ok];
    let mut wide = y0.clone();
    let mut worker = GuardedStepper::new(&chain);
    let opts = StepOptions::default();
    let e0 = chain.energy(&y0).total();
    let (mut drift32, mut drift64, mut peak, mut failures) = (0.0f64, 0.0f64, 0.0f64, 0);
    for _ in 0..steps {
        lanes.step(
            Kernel::detect(),
            &params,
            &mut narrow,
            &[0.0; 2],
            None,
            plan,
            &mut status,
        );
        failures += status[0].is_failure() as usize;
        let s = worker.step(
            &chain,
            &mut wide,
            nalgebra::Vector2::zeros(),
            1e-3,
            &opts,
            &guard,
        );
        assert!(!s.is_failure());
        drift32 = drift32.max((chain.energy(&narrow).total() - e0).abs());
        drift64 = drift64.max((chain.energy(&wide).total() - e0).abs());
        peak = peak.max(chain.energy(&wide).kinetic);
    }
    let positions = |y: &[f64]| -> Vec<f64> {
        (0..5)
            .flat_map(|i| {
                let p = chain.mass_position(y, i);
                [p.x, p.y, p.z]
            })
            .collect()
    };
    let (a, b) = (positions(&narrow), positions(&wide));
    let error = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    (error, drift32, drift64, peak, failures)
}

#[test]
fn f32_lanes_follow_the_f64_step_on_the_paper_scene() {
    let (error, drift32, drift64, peak, failures) = f32_against_f64(1000);
    eprintln!("1 s: position error {error:e} m, energy drift f32 {:e}, f64 {:e} of the peak kinetic energy", drift32 / peak, drift64 / peak);
    let (error10, drift32_10, drift64_10, peak10, failures10) = f32_against_f64(10_000);
    eprintln!(
        "10 s: position error {error10:e} m, energy drift f32 {:e}, f64 {:e}",
        drift32_10 / peak10,
        drift64_10 / peak10
    );
    // No false failures of the guard on the paper's scene in f32.
    assert_eq!(failures + failures10, 0);
    // After 1 s the masses (0.1 m links) agree to 1e-4 m (seen: about 1.3e-5 m);
    // later the chaotic fall amplifies any difference, f64 round-off included.
    assert!(error < 1e-4, "{error}");
    // Energy drift over 10 s stays within 3e-4 of the peak kinetic energy (seen:
    // about 9e-5 in f32, 3e-5 in f64, where the integrator's own error dominates).
    assert!(drift32_10 / peak10 < 3e-4, "{}", drift32_10 / peak10);
}

#[test]
fn an_f32_blow_up_is_flagged_and_leaves_its_neighbours_unchanged() {
    blow_up_in_one_lane::<f32, 16>(19, &[1.0; 32], 2 * 5 + 1, 1e30);
}

#[test]
fn f32_batches_are_deterministic_across_kernels_threads_and_sizes() {
    for num_envs in [7, 33, 4097] {
        let detect = Some(Kernel::detect());
        let reference = batch_run_in(1, num_envs, detect, Precision::F32);
        let f64_run = batch_run(1, num_envs, None);
        assert!(reference != f64_run, "f32 must differ from f64 somewhere");
        // Same verdicts as f64 on these moderate states, apart from the pushed env.
        let agree = reference
            .1
            .iter()
            .zip(&f64_run.1)
            .filter(|(a, b)| a == b)
            .count();
        assert!(
            agree * 10 >= 9 * reference.1.len(),
            "{agree} of {}",
            reference.1.len()
        );
        for kernel in available_kernels() {
            for threads in [1, 2] {
                assert!(
                    batch_run_in(threads, num_envs, Some(kernel), Precision::F32) == reference,
                    "N = {num_envs}, {} kernel, {threads} threads",
                    kernel.name()
                );
            }
        }
    }
}

#[test]
fn f32_needs_the_lane_kernel() {
    let (mut batch, _) = common::batches::random_batch(64, Method::Rkmk4, 1);
    let e = batch.set_precision(Precision::F32).unwrap_err();
    assert!(e.to_string().contains("precision"), "{e}");
    batch.set_precision(Precision::F64).unwrap();
    let (mut rk4, _) = common::batches::random_batch(64, Method::Rk4, 1);
    rk4.set_precision(Precision::F32).unwrap();
    rk4.set_kernel(Some(Kernel::Baseline)).unwrap();
    assert_eq!(rk4.precision(), Precision::F32);
    rk4.set_kernel(None).unwrap();
    assert_eq!(rk4.precision(), Precision::F64);
}

/// A scripted run of 40 steps of 37 envs: between steps it writes one env
/// (`set_state`), edits rows in place (`states_mut`), overwrites every env
/// (`set_states`) and changes kernel; with `read`, it also reads every state after
/// every step. Returns the final states' bits, every status and every state read.
fn scripted_run(
    kernels: [Option<Kernel>; 2],
    precision: Precision,
    read: bool,
) -> (Vec<u64>, Vec<StepStatus>, Vec<u64>) {
    let num_envs = 37;
    let (mut batch, starts) = common::batches::random_batch(num_envs, Method::Rk4, 5);
    batch.set_kernel(kernels[0]).unwrap();
    batch.set_precision(precision).unwrap();
    let (mut statuses, mut seen) = (vec![], vec![]);
    for step in 0..40 {
        match step {
            5 => batch.set_state(3, &starts[30]).unwrap(),
            10 => {
                let d = batch.state_dim();
                let rows = batch.states_mut();
                rows.copy_within(0..d, d); // env 1 becomes a copy of env 0
            }
            15 => batch.set_states(&starts.concat()).unwrap(),
            20 => batch.set_kernel(kernels[1]).unwrap(),
            _ => {}
        }
        let mut f = common::batches::forces(num_envs, step);
        f[2 * 11] *= if step % 6 == 2 { 1e9 } else { 1.0 };
        batch.step(&f).unwrap();
        statuses.extend_from_slice(batch.status());
        if read {
            seen.extend(bits(batch.states()));
            seen.extend(bits(batch.state(num_envs - 1)));
        }
    }
    (bits(batch.states()), statuses, seen)
}

#[test]
fn states_read_or_written_between_lane_steps_are_the_per_env_ones() {
    let kernels = available_kernels();
    let (first, last) = (kernels[0], *kernels.last().unwrap());
    let reference = scripted_run([None, None], Precision::F64, true);
    assert!(reference.1.iter().any(|s| s.is_failure()));
    for (a, b) in [(first, last), (last, first)] {
        let unread = scripted_run([Some(a), Some(b)], Precision::F64, false);
        assert_eq!(unread.0, reference.0, "{a:?} then {b:?}");
        assert_eq!(unread.1, reference.1, "{a:?} then {b:?}");
        let read = scripted_run([Some(a), Some(b)], Precision::F64, true);
        assert!(read == reference, "{a:?} then {b:?}, read every step");
    }
    // f32 keeps its states in f32 lanes between steps; reading them changes nothing.
    let f32_read = scripted_run([Some(last), Some(first)], Precision::F32, true);
    let f32_unread = scripted_run([Some(first), Some(last)], Precision::F32, false);
    assert_eq!(f32_read.0, f32_unread.0);
    assert_eq!(f32_read.1, f32_unread.1);
    assert!(
        f32_read.0 != reference.0,
        "f32 must differ from f64 somewhere"
    );
}

/// `set_states` on a batch split between threads, where each thread takes in its
/// own envs: reading back gives the states as given in both precisions, and the
/// next step starts from them as it would from rows written in place.
#[test]
fn states_set_on_a_batch_split_between_threads_read_back_and_step_as_given() {
    use chaincart::engine::LANE_CHUNK;
    let num_envs = 2 * LANE_CHUNK + 7;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    pool.install(|| {
        let (_, starts) = common::batches::random_batch(num_envs, Method::Rk4, 9);
        let given = starts.concat();
        let forces = common::batches::forces(num_envs, 3);
        for precision in [Precision::F64, Precision::F32] {
            let (mut set, _) = common::batches::random_batch(num_envs, Method::Rk4, 10);
            let (mut written, _) = common::batches::random_batch(num_envs, Method::Rk4, 10);
            for batch in [&mut set, &mut written] {
                batch.set_precision(precision).unwrap();
                batch.step(&forces).unwrap(); // the old states now live in the lanes
            }
            set.set_states(&given).unwrap();
            written.states_mut().copy_from_slice(&given);
            assert_eq!(bits(set.states()), bits(&given), "{precision:?}");
            set.step(&forces).unwrap();
            written.step(&forces).unwrap();
            assert_eq!(bits(set.states()), bits(written.states()), "{precision:?}");
            assert_ne!(
                bits(set.states()),
                bits(&given),
                "{precision:?}: a step moves"
            );
        }
    });
}

#[test]
fn switching_precision_or_to_the_per_env_path_keeps_the_states() {
    let (mut batch, _) = common::batches::random_batch(21, Method::Rk4, 8);
    let forces = common::batches::forces(21, 0);
    batch.step(&forces).unwrap();
    let f64_states = batch.states().to_vec();
    batch.step(&forces).unwrap();
    batch.set_precision(Precision::F32).unwrap();
    batch.set_precision(Precision::F64).unwrap();
    let mut per_env = common::batches::random_batch(21, Method::Rk4, 8).0;
    per_env.set_kernel(None).unwrap();
    per_env.set_states(&f64_states).unwrap();
    per_env.step(&forces).unwrap();
    assert_eq!(bits(batch.states()), bits(per_env.states()));
    batch.step(&forces).unwrap();
    batch.set_kernel(None).unwrap();
    per_env.step(&forces).unwrap();
    assert_eq!(bits(batch.states()), bits(per_env.states()));
}

/// Steps `num_envs` random envs of scene `G` through a chunk's lane path with measuring
/// on, and checks every successful env's measures (the reward included) against the
/// scalar ones of the state it reached, bit for bit.
fn lane_measures_match<G: chaincart::lanes::LaneScene + RandomState>(
    n: usize,
    precision: Precision,
    kernel: Kernel,
    kind: chaincart::env::RewardKind,
    per_env_targets: bool,
) {
    use chaincart::env::RewardWeights;
    use chaincart::env::{measure, MeasureInto, RewardSpec};
    use chaincart::lanes::{chunk_lanes, room, ChunkSpec};
    let num_envs = 29;
    let mut rng = rng(40 + n as u64);
    let chain = Chain::<G>::new(random_params(&mut rng, n, 10.0, 10.0));
    let spec = ChunkSpec {
        num_envs,
        per_env: false,
        kernel,
        precision,
    };
    let mut lanes = chunk_lanes::<G, MeasureInto>(&chain, spec);
    let mut states: Vec<f64> = (0..num_envs)
        .flat_map(|_| G::random_state(&mut rng, n, 3.0))
        .collect();
    let f = chain.force_dim();
    let forces: Vec<f64> = (0..f * num_envs).map(|j| (j % 7) as f64 - 3.0).collect();
    let target: Vec<f64> = (0..n)
        .map(|i| if i % 3 == 1 { -1.0 } else { 1.0 })
        .collect();
    let guard = Guard::default();
    let plan = StepPlan {
        dt: 2e-3,
        substeps: 2,
        guard: &guard,
    };
    let mut status = vec![StepStatus::SolverFailure; num_envs];
    // Weights large enough that rewards are not all 0 or 1, and an action per env.
    let weights = RewardWeights {
        q: 0.3,
        w: 0.02,
        x: 0.1,
        v: 0.05,
        u: 0.7,
    };
    let a2: Vec<f64> = (0..room(num_envs)).map(|k| (k % 5) as f64 * 0.4).collect();
    // Tolerances and track of the size of the random states' errors and offsets.
    let spec = RewardSpec {
        kind,
        weights,
        inv_tolerance: [1.0 / (0.5 * n as f64), 1.0 / (3.0 * n as f64)],
        inv_track2: 1.0 / 4.0,
        inv_4n: 1.0 / (4.0 * n as f64),
    };
    let mut into = MeasureInto::new(&target, spec, num_envs, per_env_targets);
    into.task.a2.copy_from_slice(&a2);
    // Goal-conditioned: each env its own target (env k flips link k % n).
    let env_target = |k: usize| -> Vec<f64> {
        let mut t = target.clone();
        if per_env_targets {
            t[k % n] = -t[k % n];
        }
        t
    };
    for k in 0..num_envs {
        into.set_target(k, &env_target(k));
    }
    let stepped: Vec<bool> = (0..num_envs).map(|k| k != 4).collect();
    lanes.step(
        &mut states,
        &forces,
        &stepped,
        plan,
        &mut status,
        Some(&mut into),
    );
    let out = into.out;
    let d = chain.state_dim();
    let what = format!("{} n = {n}, {precision:?}, {kernel:?}", G::NAME);
    let (mut checked, mut graded) = (0, 0);
    for k in 0..num_envs {
        if !stepped[k] || status[k].is_failure() {
            continue;
        }
        let y = &states[k * d..(k + 1) * d];
        let scalar = measure(chain.layout(), y, &env_target(k), &spec, a2[k]);
        if kind == chaincart::env::RewardKind::Tolerance {
            assert!((0.0..=1.0).contains(&scalar.reward), "{}", scalar.reward);
        }
        let lane = out.get(k);
        let fields = |m: &chaincart::env::StateMeasure| {
            bits(&[m.q2, m.w2, m.e_q, m.e_w, m.x2, m.v2, m.reward])
        };
        assert_eq!(fields(&lane), fields(&scalar), "env {k}, {what}");
        assert_eq!(lane.x_max, scalar.x_max, "env {k}, {what}");
        if lane.reward > 1e-300 && lane.reward < 1.0 {
            graded += 1;
        }
        checked += 1;
    }
    assert!(checked >= num_envs - 3, "{checked} envs checked, {what}");
    assert!(
        graded >= checked / 2,
        "{graded} rewards strictly between 0 and 1, {what}"
    );
}

#[test]
fn lanes_measure_each_stepped_state_as_the_scalar_code_does() {
    for kernel in available_kernels() {
        for precision in [Precision::F64, Precision::F32] {
            for n in [1, 2, 5] {
                use chaincart::env::RewardKind::{Exp, Tolerance};
                for (kind, per_env) in [(Exp, false), (Tolerance, false), (Tolerance, true)] {
                    lane_measures_match::<Spatial>(n, precision, kernel, kind, per_env);
                    lane_measures_match::<Planar>(n, precision, kernel, kind, per_env);
                }
            }
        }
    }
}
