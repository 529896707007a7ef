//! The env batch with its physics on the lane kernel against the env-by-env path:
//! every output bit-identical (observations, rewards, flags, events, errors, final
//! observations, diagnostics, states) for every compiled kernel, n = 1..16, both
//! scenes, randomised per-env parameters, observation noise, control delay, force-rate
//! limit, force noise and both autoreset modes; the same across thread counts and batch sizes;
//! a blow-up isolated to its env; and the f32 mode (deterministic, accurate on the
//! paper's scenes within the bound published in docs/simd.md).

use super::common;

use chaincart::engine::MIN_LANE_ENVS;
use chaincart::env::{
    event, AutoresetMode, Distribution, Ends, EnvBatch, ForceNoise, PaperFigure,
    ParamRandomization, Real, RewardKind, Start, StepOutputs, TaskConfig, Transitions,
};
use chaincart::lanes::Kernel;
use chaincart::lanes::LaneScene;
use chaincart::lanes::Precision;
use chaincart::{Chain, ChainParams, Method, Planar, Spatial, StepOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn available_kernels() -> Vec<Kernel> {
    Kernel::ALL
        .into_iter()
        .filter(|k| k.is_available())
        .collect()
}

/// How the envs' physics is stepped.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Path {
    /// The batch's own choice for its size.
    Default,
    /// Env by env.
    PerEnv,
    /// This lane kernel in this precision.
    Lanes(Kernel, Precision),
}

/// A short-episode task on `n` links: narrow track, large start noise, strong pushes,
/// so that resets, out-of-track ends and (for long chains) guard failures all happen.
/// With `reality`: cart mass, link masses and lengths and gravity redrawn per env at
/// every reset, observation noise, a two-step delay, a force-rate limit and force noise.
fn task(n: usize, reality: bool) -> TaskConfig {
    let signs: Vec<f64> = (0..n)
        .map(|i| if i % 3 == 1 { 1.0 } else { -1.0 })
        .collect();
    let mut t = TaskConfig::new(signs, 0.02, StepOptions::new(Method::Rk4, 2).unwrap());
    t.start_noise = 0.3;
    t.max_episode_steps = 9;
    t.track_limit = 0.4;
    // Every fourth chain length is pushed far harder than a 10 ms step resolves.
    t.max_force = if n % 4 == 3 { 3e4 } else { 60.0 };
    if reality {
        let spread = Some(ParamRandomization {
            distribution: Distribution::relative(0.3),
            per_link: true,
        });
        let r = &mut t.reality.randomize;
        (r.cart_mass, r.link_masses, r.link_lengths, r.gravity) = (spread, spread, spread, spread);
        t.reality.obs_noise = vec![0.01];
        t.reality.action_delay = 2;
        t.reality.force_rate_limit = 1500.0;
        t.reality.force_noise = ForceNoise {
            multiplicative: 0.2,
            additive: 1.0,
        };
    }
    t
}

/// A scene whose states can be given wild spins.
trait Spin: LaneScene {
    /// `y` with every link spinning at `rate` rad/s about an axis normal to it.
    fn spun_up(chain: &Chain<Self>, y: &[f64], rate: f64) -> Vec<f64>;
}

impl Spin for Planar {
    fn spun_up(chain: &Chain<Self>, y: &[f64], rate: f64) -> Vec<f64> {
        let (lay, mut y) = (chain.layout(), y.to_vec());
        for i in 0..chain.n_links() {
            lay.store_w(&mut y, i, rate);
        }
        y
    }
}

impl Spin for Spatial {
    fn spun_up(chain: &Chain<Self>, y: &[f64], rate: f64) -> Vec<f64> {
        let (lay, mut y) = (chain.layout(), y.to_vec());
        for i in 0..chain.n_links() {
            let q = lay.load_q(&y, i);
            let axis = q.cross(&nalgebra::Vector3::x()).normalize();
            lay.store_w(&mut y, i, axis * rate);
        }
        y
    }
}

fn chain<G: LaneScene>(n: usize) -> Chain<G> {
    Chain::new(ChainParams::uniform(n, 1.0, 0.1, 0.3, 9.81).unwrap())
}

/// Caller-side output buffers of a batch step.
struct Outputs<T: Real> {
    obs: Vec<T>,
    rewards: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
}

impl<T: Real + Default> Outputs<T> {
    fn new(num_envs: usize, state_dim: usize) -> Self {
        Self {
            obs: vec![T::default(); num_envs * state_dim],
            rewards: vec![0.0; num_envs],
            terminated: vec![false; num_envs],
            truncated: vec![false; num_envs],
        }
    }

    /// One step of `b` under `actions` into these buffers.
    fn step<G: LaneScene>(&mut self, b: &mut EnvBatch<G>, actions: &[f64]) {
        let out = StepOutputs {
            obs: &mut self.obs,
            rewards: &mut self.rewards,
            terminated: &mut self.terminated,
            truncated: &mut self.truncated,
        };
        b.step(actions, out).unwrap();
    }
}

/// Everything the batch produced over a run, as bit patterns, env-major per step.
#[derive(Debug, PartialEq)]
struct Trace {
    per_step: Vec<Vec<u64>>,
    events: Vec<u8>,
}

impl Trace {
    /// The part of the trace that belongs to the first `num_envs` envs.
    fn first_envs(&self, num_envs: usize, total: usize) -> Trace {
        let per_step = self
            .per_step
            .iter()
            .map(|row| {
                let width = row.len() / total;
                row[..num_envs * width].to_vec()
            })
            .collect();
        let steps = self.per_step.len();
        let events = (0..steps)
            .flat_map(|s| self.events[s * total..s * total + num_envs].to_vec())
            .collect();
        Trace { per_step, events }
    }

    fn count(&self, bit: u8) -> usize {
        self.events.iter().filter(|&&e| e & bit != 0).count()
    }
}

/// What one run is: batch shape, seed, physics path, thread count, and which
/// actions it is fed: env k gets the actions of env `first_env + k` of a stream drawn
/// for `total` envs from `action_seed` (so env i of a big batch and a single env see
/// the same actions).
#[derive(Debug, Clone, Copy)]
struct Run {
    num_envs: usize,
    seed: u64,
    action_seed: u64,
    first_env: usize,
    mode: AutoresetMode,
    path: Path,
    threads: usize,
    steps: usize,
}

/// Steps a batch of `run.num_envs` envs of `task` with actions drawn for `total` envs
/// and records all outputs. With `blow_up`, env `blow_up` starts from a state no step
/// resolves.
fn trace<G: Spin>(
    chain: &Chain<G>,
    task: &TaskConfig,
    run: Run,
    total: usize,
    blow_up: Option<usize>,
) -> Trace {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(run.threads)
        .build()
        .unwrap();
    pool.install(|| {
        let n = run.num_envs;
        let mut b =
            EnvBatch::new(chain.clone(), task.clone(), n, run.seed, run.mode, true).unwrap();
        match run.path {
            Path::Default => {}
            Path::PerEnv => b.set_kernel(None).unwrap(),
            Path::Lanes(kernel, precision) => {
                b.set_kernel(Some(kernel)).unwrap();
                b.set_precision(precision).unwrap();
            }
        }
        let (f, od) = (b.force_dim(), b.obs_dim());
        if let Some(env) = blow_up {
            // Spins far beyond what a 10 ms step resolves: the guard must flag it.
            let y = G::spun_up(chain, b.state(env), 1e4);
            b.set_state(env, &y).unwrap();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(run.action_seed);
        let first = run.first_env * f;
        let mut o = Outputs::<f64>::new(n, od);
        let mut t = Trace {
            per_step: vec![],
            events: vec![],
        };
        for _ in 0..run.steps {
            let all: Vec<f64> = (0..total * f)
                .map(|_| rng.random_range(-1.5..1.5))
                .collect();
            o.step(&mut b, &all[first..first + n * f]);
            let mut row = vec![];
            for k in 0..n {
                let flags = [o.terminated[k], o.truncated[k]].map(|x| x as u8 as f64);
                let env_rows: [&[f64]; 7] = [
                    &o.obs[k * od..(k + 1) * od],
                    &[o.rewards[k]],
                    &flags,
                    &b.errors()[2 * k..2 * k + 2],
                    &b.final_states()[k * od..(k + 1) * od],
                    &b.diagnostics()[5 * k..5 * k + 5],
                    b.state(k),
                ];
                row.extend(env_rows.iter().flat_map(|r| r.iter().map(|v| v.to_bits())));
            }
            t.per_step.push(row);
            t.events.extend_from_slice(b.events());
        }
        t
    })
}

fn lanes_match_env_by_env<G: Spin>(n: usize, reality: bool, mode: AutoresetMode) -> Trace {
    lanes_match_env_by_env_on(chain::<G>(n), task(n, reality), reality, mode)
}

/// [`task`] made goal-conditioned: every reset draws one of all the transitions, the
/// target's signs observed, the bounded reward, success held for 3 steps.
fn goal_task(n: usize, reality: bool) -> TaskConfig {
    let mut t = task(n, reality);
    t.transitions = Some(Transitions::between(n, Ends::Any, Ends::Any, false).unwrap());
    t.start = Start::Equilibrium(t.transitions.as_ref().unwrap().start(0).to_vec());
    t.goal_observation = true;
    t.reward_kind = RewardKind::Tolerance;
    t.success_hold = 0.05;
    t.max_episode_steps = 6;
    t
}

fn lanes_match_env_by_env_on<G: Spin>(
    chain: Chain<G>,
    task: TaskConfig,
    reality: bool,
    mode: AutoresetMode,
) -> Trace {
    let n = chain.n_links();
    let num_envs = 37; // two chunks, the second not a whole lane group
    let run = Run {
        num_envs,
        seed: 100 + n as u64,
        action_seed: 1,
        first_env: 0,
        mode,
        path: Path::PerEnv,
        threads: 1,
        steps: 14,
    };
    let reference = trace(&chain, &task, run, num_envs, None);
    for kernel in available_kernels() {
        let lanes = Run {
            path: Path::Lanes(kernel, Precision::F64),
            ..run
        };
        assert!(
            trace(&chain, &task, lanes, num_envs, None) == reference,
            "{} n = {n}, reality {reality}, {mode:?}, {} kernel",
            G::NAME,
            kernel.name()
        );
    }
    reference
}

#[test]
fn every_kernel_steps_the_env_batch_bit_for_bit_like_env_by_env_for_n_1_to_16() {
    let (mut failures, mut resets, mut ended) = (0, 0, 0);
    for n in 1..=16 {
        for reality in [false, true] {
            let mode = if n % 2 == 0 {
                AutoresetMode::NextStep
            } else {
                AutoresetMode::SameStep
            };
            for t in [
                lanes_match_env_by_env::<Spatial>(n, reality, mode),
                lanes_match_env_by_env::<Planar>(n, reality, mode),
            ] {
                failures += t.count(event::NUMERICAL_FAILURE);
                resets += t.count(event::RESET);
                ended += t.count(event::ENDED);
            }
        }
    }
    // The comparison covered guard failures, next-step resets and episode ends.
    eprintln!("failures {failures}, next-step resets {resets}, episode ends {ended}");
    assert!(failures > 0 && resets > 0 && ended > 0);
}

#[test]
fn both_autoreset_modes_match_with_the_reality_gap_on() {
    for mode in [AutoresetMode::NextStep, AutoresetMode::SameStep] {
        lanes_match_env_by_env::<Spatial>(5, true, mode);
        lanes_match_env_by_env::<Planar>(2, true, mode);
    }
}

#[test]
fn goal_conditioned_tasks_step_bit_for_bit_like_env_by_env() {
    let mut pairs_seen = std::collections::BTreeSet::new();
    for (n, mode) in [
        (1, AutoresetMode::SameStep),
        (2, AutoresetMode::NextStep),
        (3, AutoresetMode::SameStep),
    ] {
        for reality in [false, true] {
            let t =
                lanes_match_env_by_env_on(chain::<Planar>(n), goal_task(n, reality), reality, mode);
            assert!(t.count(event::ENDED) > 0);
            lanes_match_env_by_env_on(chain::<Spatial>(n), goal_task(n, reality), reality, mode);
        }
        // The observation's tail is the episode's target, and the draws reach every pair.
        let task = goal_task(n, false);
        let pairs = task.transitions.clone().unwrap();
        let mut b = EnvBatch::new(
            chain::<Planar>(n),
            task,
            64,
            5,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap();
        let (d, od) = (b.state_dim(), b.obs_dim());
        assert_eq!(od, d + n);
        let mut obs = vec![0.0f64; 64 * od];
        for round in 0..4u64 {
            let seeds: Vec<Option<u64>> = (0..64).map(|k| Some(round * 100 + k)).collect();
            b.reset::<f64>(Some(&seeds), None, &mut obs).unwrap();
            let lay = b.chain().layout();
            for k in 0..64 {
                let target = b.env_target(k).unwrap().to_vec();
                assert_eq!(&obs[k * od + d..(k + 1) * od], &target[..]);
                let goal = (0..pairs.len()).find(|&g| {
                    pairs.target(g) == target && {
                        let y = b.state(k);
                        // The start is near the pair's start: every link within the noise of it.
                        let start = pairs.start(g);
                        (0..n).all(|i| y[lay.q(i) + 1] * start[i] > 0.0)
                    }
                });
                assert!(goal.is_some(), "env {k}: target {target:?} not a pair's");
                pairs_seen.insert((n, goal.unwrap()));
            }
        }
        assert_eq!(
            pairs_seen.iter().filter(|(m, _)| *m == n).count(),
            pairs.len(),
            "every one of the {} pairs drawn for n = {n}",
            pairs.len()
        );
    }
}

#[test]
fn results_do_not_depend_on_threads_batch_size_or_lane_grouping() {
    let (n, total) = (3, 4097);
    let (chain, task) = (chain::<Spatial>(n), task(n, true));
    let base = Run {
        num_envs: total,
        seed: 7,
        action_seed: 2,
        first_env: 0,
        mode: AutoresetMode::NextStep,
        path: Path::PerEnv,
        threads: 1,
        steps: 12,
    };
    let reference = trace(&chain, &task, base, total, None);
    for num_envs in [1, 7, 33, 4097] {
        let expected = reference.first_envs(num_envs, total);
        for threads in [1, 2] {
            let run = Run {
                num_envs,
                path: Path::Default,
                threads,
                ..base
            };
            assert!(
                trace(&chain, &task, run, total, None) == expected,
                "N = {num_envs}, {threads} threads"
            );
        }
    }
    // Env i of the batch is the single env seeded seed + i.
    for env in [1, 32, 4096] {
        let single = Run {
            num_envs: 1,
            seed: base.seed + env as u64,
            first_env: env,
            path: Path::Default,
            ..base
        };
        let alone = trace(&chain, &task, single, total, None);
        let width = reference.per_step[0].len() / total;
        for (step, row) in reference.per_step.iter().enumerate() {
            assert_eq!(
                alone.per_step[step],
                row[env * width..(env + 1) * width],
                "env {env}, step {step}"
            );
        }
        assert_eq!(
            alone.events,
            reference.events[env..]
                .iter()
                .step_by(total)
                .copied()
                .collect::<Vec<_>>()
        );
    }
}

#[test]
fn a_blow_up_among_lane_neighbours_leaves_them_unchanged() {
    let (chain, mut task) = (chain::<Spatial>(4), task(4, true));
    task.max_episode_steps = 1000; // no resets: the blown-up env must stay put
    task.track_limit = 1e9;
    for kernel in available_kernels() {
        for precision in [Precision::F64, Precision::F32] {
            let run = Run {
                num_envs: 16,
                seed: 3,
                action_seed: 3,
                first_env: 0,
                mode: AutoresetMode::Disabled,
                path: Path::Lanes(kernel, precision),
                threads: 1,
                steps: 1,
            };
            let calm = trace(&chain, &task, run, 16, None);
            let wild = trace(&chain, &task, run, 16, Some(5));
            let width = calm.per_step[0].len() / 16;
            let d = chain.state_dim();
            for k in 0..16 {
                let row = |t: &Trace| t.per_step[0][k * width..(k + 1) * width].to_vec();
                if k == 5 {
                    assert_eq!(
                        wild.events[k],
                        event::ENDED | event::NUMERICAL_FAILURE,
                        "{precision:?}"
                    );
                    // Its state is the one it started from (the last good one).
                    let state = &row(&wild)[width - d..];
                    assert!(state.iter().any(|&v| f64::from_bits(v).abs() >= 1e3));
                } else {
                    assert_eq!(calm.events[k], 0, "env {k} {precision:?}");
                    assert_eq!(row(&wild), row(&calm), "env {k} {precision:?}");
                }
            }
        }
    }
}

#[test]
fn batches_choose_lanes_for_rk4_from_min_lane_envs_and_f32_needs_rk4() {
    let make = |num_envs: usize, method: Method| {
        let mut t = task(2, false);
        t.step_options = StepOptions::new(method, 1).unwrap();
        EnvBatch::new(
            chain::<Planar>(2),
            t,
            num_envs,
            0,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap()
    };
    assert_eq!(make(MIN_LANE_ENVS - 1, Method::Rk4).kernel(), None);
    assert_eq!(
        make(MIN_LANE_ENVS, Method::Rk4).kernel(),
        Some(Kernel::detect())
    );
    let mut other = make(64, Method::Rkmk4);
    assert_eq!(other.kernel(), None);
    other.set_precision(Precision::F64).unwrap();
    let e = other.set_precision(Precision::F32).unwrap_err().to_string();
    assert!(e.contains("precision") && e.contains("rk4"), "{e}");
    let e = other
        .set_kernel(Some(Kernel::Baseline))
        .unwrap_err()
        .to_string();
    assert!(e.contains("kernel") && e.contains("rk4"), "{e}");
    // f32 on a batch of one switches the lane kernel on; None goes back to f64.
    let mut one = make(1, Method::Rk4);
    one.set_precision(Precision::F32).unwrap();
    assert_eq!(
        (one.kernel(), one.precision()),
        (Some(Kernel::detect()), Precision::F32)
    );
    one.set_kernel(Some(Kernel::Baseline)).unwrap();
    assert_eq!(one.precision(), Precision::F32);
    one.set_kernel(None).unwrap();
    assert_eq!(one.precision(), Precision::F64);
    // A guard tighter than f32 round-off would fail good steps: refused, by name.
    let mut t = task(2, false);
    t.guard.unit_length_tolerance = 1e-9;
    let mut tight =
        EnvBatch::new(chain::<Planar>(2), t, 8, 0, AutoresetMode::NextStep, false).unwrap();
    let e = tight.set_precision(Precision::F32).unwrap_err().to_string();
    assert!(
        e.contains("unit_length_tolerance = 0.000000001") && e.contains("5e-7"),
        "{e}"
    );
    assert_eq!(tight.precision(), Precision::F64);
}

#[test]
fn the_tasks_precision_chooses_f32_lanes_at_construction_and_is_checked() {
    let make = |num_envs: usize, method: Method| {
        let mut t = task(2, false);
        t.step_options = StepOptions::new(method, 1).unwrap();
        t.precision = Precision::F32;
        EnvBatch::new(
            chain::<Planar>(2),
            t,
            num_envs,
            0,
            AutoresetMode::NextStep,
            false,
        )
    };
    for num_envs in [1, MIN_LANE_ENVS, 33] {
        let b = make(num_envs, Method::Rk4).unwrap();
        assert_eq!(b.precision(), Precision::F32);
        assert_eq!(b.task().precision, Precision::F32);
    }
    let Err(e) = make(8, Method::Rkmk4) else {
        panic!("f32 with rkmk4 accepted")
    };
    let e = e.to_string();
    assert!(
        e.contains("precision = \"f32\"") && e.contains("rkmk4"),
        "{e}"
    );
    let mut b = make(8, Method::Rk4).unwrap();
    b.set_kernel(None).unwrap();
    assert_eq!(
        (b.precision(), b.task().precision),
        (Precision::F64, Precision::F64)
    );
}

#[test]
fn f32_env_batches_are_deterministic_across_kernels_threads_and_sizes() {
    let (n, total) = (5, 4097);
    let (chain, task) = (chain::<Spatial>(n), task(n, true));
    let base = Run {
        num_envs: total,
        seed: 11,
        action_seed: 4,
        first_env: 0,
        mode: AutoresetMode::SameStep,
        path: Path::Lanes(Kernel::detect(), Precision::F32),
        threads: 1,
        steps: 10,
    };
    let reference = trace(&chain, &task, base, total, None);
    let f64_run = trace(
        &chain,
        &task,
        Run {
            path: Path::PerEnv,
            ..base
        },
        total,
        None,
    );
    assert!(reference != f64_run, "f32 must differ from f64 somewhere");
    for num_envs in [1, 7, 33, 4097] {
        let expected = reference.first_envs(num_envs, total);
        for kernel in available_kernels() {
            for threads in [1, 2] {
                let run = Run {
                    num_envs,
                    path: Path::Lanes(kernel, Precision::F32),
                    threads,
                    ..base
                };
                assert!(
                    trace(&chain, &task, run, total, None) == expected,
                    "N = {num_envs}, {} kernel, {threads} threads",
                    kernel.name()
                );
            }
        }
    }
}

/// One of the paper's scenes as the Python configuration defines it (spatial, five
/// links of 0.1 kg and 0.1 m on a 0.5 kg cart, no start noise), with zero action.
fn paper_task(figure: PaperFigure, dt: f64) -> (Chain<Spatial>, TaskConfig) {
    let chain = Chain::new(ChainParams::paper());
    let mut t = TaskConfig::new(
        figure.target(),
        dt,
        StepOptions::new(Method::Rk4, 1).unwrap(),
    );
    t.start = Start::Paper(figure);
    t.start_noise = 0.0;
    t.max_force = 100.0;
    t.track_limit = 10.0;
    t.max_episode_steps = u64::MAX;
    (chain, t)
}

/// Steps the same batch in f64 and f32 for `steps` steps under `action(step, j)`;
/// returns the largest difference of the mass positions (m) at `compare_at` steps
/// and the number of guard failures of each precision over all `steps`.
fn f32_against_f64<G: LaneScene>(
    chain: &Chain<G>,
    task: &TaskConfig,
    num_envs: usize,
    steps: usize,
    compare_at: usize,
    action: impl Fn(usize, usize) -> f64,
) -> (f64, usize, usize) {
    let mut batches = [Precision::F64, Precision::F32].map(|p| {
        let mut b = EnvBatch::new(
            chain.clone(),
            task.clone(),
            num_envs,
            1,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap();
        b.set_precision(p).unwrap();
        b
    });
    let (d, f) = (chain.state_dim(), chain.force_dim());
    let mut o = Outputs::<f32>::new(num_envs, d);
    let (mut error, mut failures) = (0.0f64, [0, 0]);
    for step in 0..steps {
        let actions: Vec<f64> = (0..num_envs * f).map(|j| action(step, j)).collect();
        for (b, fails) in batches.iter_mut().zip(&mut failures) {
            o.step(b, &actions);
            *fails += b
                .events()
                .iter()
                .filter(|&&e| e & event::NUMERICAL_FAILURE != 0)
                .count();
        }
        if step + 1 == compare_at {
            for k in 0..num_envs {
                let [a, b] =
                    [&batches[0], &batches[1]].map(|b| common::mass_positions(chain, b.state(k)));
                error = error.max(common::max_abs_diff(&a, &b));
            }
        }
    }
    (error, failures[0], failures[1])
}

/// Published in docs/simd.md: after 1 s on the paper's scenes, every mass of the f32
/// run is within this distance (m) of where the f64 run has it (seen: 1.3e-5 m on
/// Fig. 1, 1.3e-4 m on Fig. 2 at its 0.1 ms step, 2.9e-5 m on Fig. 3, 2.2e-6 m on
/// inverted-2).
const F32_ERROR_AT_1_S: f64 = 1e-3;

#[test]
fn f32_follows_f64_on_the_papers_scenes_without_false_failures() {
    for (figure, dt, seconds) in [
        (PaperFigure::Fig1, 1e-3, 10.0),
        (PaperFigure::Fig2, 1e-4, 10.0),
        (PaperFigure::Fig3, 1e-3, 12.0),
    ] {
        let (chain, task) = paper_task(figure, dt);
        let steps = (seconds / dt) as usize;
        let one_second = (1.0 / dt) as usize;
        let (error, fails64, fails32) =
            f32_against_f64(&chain, &task, 1, steps, one_second, |_, _| 0.0);
        eprintln!("{figure:?}: f32 - f64 after 1 s: {error:.1e}; failures f64 {fails64}, f32 {fails32} in {seconds} s");
        assert_eq!((fails64, fails32), (0, 0), "{figure:?}");
        assert!(error < F32_ERROR_AT_1_S, "{figure:?}: {error}");
    }
    // The default scene, inverted-2: planar double inverted pendulum under random
    // pushes, 20 ms with two substeps, 64 envs over ten 500-step episodes' worth.
    let chain = Chain::<Planar>::new(ChainParams::uniform(2, 1.0, 0.1, 0.5, 9.81).unwrap());
    let mut task = TaskConfig::new(
        vec![-1.0; 2],
        0.02,
        StepOptions::new(Method::Rk4, 2).unwrap(),
    );
    task.max_force = 20.0;
    task.track_limit = 2.4;
    task.start_noise = 0.05;
    task.max_episode_steps = 500;
    let push = |step: usize, j: usize| (0.37 * step as f64 + 1.3 * j as f64).sin() * 0.2;
    let (error, fails64, fails32) = f32_against_f64(&chain, &task, 64, 5000, 50, push);
    eprintln!(
        "inverted-2: f32 - f64 after 1 s: {error:.1e}; failures f64 {fails64}, f32 {fails32}"
    );
    assert_eq!((fails64, fails32), (0, 0));
    assert!(error < F32_ERROR_AT_1_S, "inverted-2: {error}");
}
