//! The reality gap of the task layer: per-env parameters drawn at reset, fixed
//! mismatch, observation noise, control delay, force-rate limit and force noise.

use chaincart::engine::CHUNK;
use chaincart::env::{
    AutoresetMode, Distribution, EnvBatch, ForceNoise, Param, ParamRandomization, ParamValues,
    Randomization, RealityGap, Start, StepOutputs, TaskConfig,
};
use chaincart::error::InputError;
use chaincart::geometry::{Geometry, Vector};
use chaincart::integrate::{Guard, GuardedStepper, StepStatus};
use chaincart::lanes::LaneScene;
use chaincart::params::Rig;
use chaincart::{Chain, ChainError, ChainParams, Method, Planar, Spatial, StepOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

fn nominal(n: usize) -> ChainParams {
    ChainParams::new(1.0, &vec![0.1; n], &vec![0.5; n], 9.81).unwrap()
}

fn task(n: usize) -> TaskConfig {
    let mut t = TaskConfig::new(vec![-1.0; n], 0.02, StepOptions::default());
    t.max_episode_steps = 25;
    t.start_noise = 0.1;
    t.max_force = 20.0;
    t
}

fn relative(h: f64) -> Option<ParamRandomization> {
    Some(ParamRandomization {
        distribution: Distribution::relative(h),
        per_link: true,
    })
}

/// +-30 % masses and cart, +-20 % lengths, gravity log-uniform in [9, 10.5].
fn randomization() -> Randomization {
    Randomization {
        cart_mass: relative(0.3),
        link_masses: relative(0.3),
        link_lengths: relative(0.2),
        gravity: Some(ParamRandomization {
            distribution: Distribution::LogRange {
                low: 9.0,
                high: 10.5,
            },
            per_link: false,
        }),
        ..Default::default()
    }
}

fn batch<G: LaneScene>(
    t: TaskConfig,
    num_envs: usize,
    seed: u64,
    mode: AutoresetMode,
) -> EnvBatch<G> {
    let n = t.target.len();
    EnvBatch::new(Chain::new(nominal(n)), t, num_envs, seed, mode, false).unwrap()
}

/// The error of building a one-env batch of two spatial links with task `t`, if any.
fn batch_error(t: TaskConfig) -> Option<String> {
    EnvBatch::<Spatial>::new(
        Chain::new(nominal(2)),
        t,
        1,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .err()
    .map(|e| e.to_string())
}

/// Output buffers and a step with them.
struct Out {
    obs: Vec<f64>,
    rewards: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
}

impl Out {
    fn new<G: LaneScene>(b: &EnvBatch<G>) -> Self {
        let n = b.num_envs();
        Self {
            obs: vec![0.0; n * b.state_dim()],
            rewards: vec![0.0; n],
            terminated: vec![false; n],
            truncated: vec![false; n],
        }
    }
    fn step<G: LaneScene>(&mut self, b: &mut EnvBatch<G>, actions: &[f64]) {
        b.step(
            actions,
            StepOutputs {
                obs: &mut self.obs,
                rewards: &mut self.rewards,
                terminated: &mut self.terminated,
                truncated: &mut self.truncated,
            },
        )
        .unwrap();
    }
}

/// One control period of `chain` from `y` under the cart force `force` (one number per
/// axis), as the task `t` steps it.
fn step_chain<G: Geometry>(
    chain: &Chain<G>,
    y: &mut [f64],
    force: &[f64],
    t: &TaskConfig,
) -> StepStatus {
    GuardedStepper::new(chain).step(
        chain,
        y,
        G::Cart::load(force),
        t.dt,
        &t.step_options,
        &Guard::default(),
    )
}

fn actions(step: usize, num_envs: usize, f: usize, env0: usize) -> Vec<f64> {
    (0..num_envs * f)
        .map(|j| 1.5 * (0.3 * step as f64 + 0.9 * (env0 + j / f) as f64 + j as f64).sin())
        .collect()
}

/// Per step: every env's observation, reward and parameters.
fn history<G: LaneScene>(b: &mut EnvBatch<G>, steps: usize, env0: usize) -> Vec<Vec<f64>> {
    let mut out = Out::new(b);
    let mut h = Vec::new();
    for s in 0..steps {
        out.step(b, &actions(s, b.num_envs(), b.force_dim(), env0));
        let mut row = out.obs.clone();
        row.extend(&out.rewards);
        for k in 0..b.num_envs() {
            let p = b.env_params(k).unwrap();
            row.push(p.cart_mass());
            row.extend(p.masses());
            row.extend(p.lengths());
            row.push(p.gravity());
        }
        h.push(row);
    }
    h
}

fn everything_on(n: usize) -> TaskConfig {
    let mut t = task(n);
    t.reality.randomize = randomization();
    t.reality.obs_noise = vec![0.01];
    t.reality.action_delay = 2;
    t.reality.force_rate_limit = 400.0;
    t.reality.force_noise = ForceNoise {
        multiplicative: 0.2,
        additive: 0.5,
    };
    t.reality.mismatch.gravity = Some(1.02);
    t
}

#[test]
fn env_i_of_a_randomised_batch_is_the_single_env_seeded_seed_plus_i() {
    let num_envs = 2 * CHUNK + 3;
    let mut big = batch::<Spatial>(everything_on(2), num_envs, 100, AutoresetMode::SameStep);
    let h_big = history(&mut big, 60, 0);
    for env in [0, 1, CHUNK, 2 * CHUNK + 2] {
        let mut one = batch::<Spatial>(
            everything_on(2),
            1,
            100 + env as u64,
            AutoresetMode::SameStep,
        );
        // The single env sees env `env`'s actions.
        let mut out = Out::new(&one);
        for (s, row) in h_big.iter().enumerate() {
            let a = actions(s, num_envs, 2, 0);
            out.step(&mut one, &a[2 * env..2 * env + 2]);
            let d = one.state_dim();
            assert_eq!(
                &out.obs[..],
                &row[env * d..(env + 1) * d],
                "env {env} step {s}"
            );
            let p = one.env_params(0).unwrap();
            let q = big.env_params(env).unwrap();
            if s + 1 == h_big.len() {
                assert_eq!(p, q);
            }
        }
    }
}

#[test]
fn randomised_runs_reproduce_for_any_thread_count() {
    let num_envs = 4 * CHUNK + 1;
    // Drawn rig effects step env by env, the rest through the lane kernel.
    for task in [everything_on(3), rig_drawn(3)] {
        let go = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut b = batch::<Planar>(task.clone(), num_envs, 7, AutoresetMode::NextStep);
                history(&mut b, 70, 0)
            })
        };
        let one = go(1);
        assert_eq!(one, go(1), "same seed, same run");
        for threads in [2, 5] {
            assert!(go(threads) == one, "{threads} threads differ from 1");
        }
    }
}

#[test]
fn randomisation_leaves_the_start_states_unchanged() {
    let plain = batch::<Spatial>(task(3), 50, 3, AutoresetMode::NextStep);
    let mut t = task(3);
    t.reality.randomize = randomization();
    let randomised = batch::<Spatial>(t, 50, 3, AutoresetMode::NextStep);
    assert_eq!(plain.states(), randomised.states());
    assert_ne!(
        randomised.env_params(0).unwrap(),
        randomised.env_params(1).unwrap()
    );
    assert!(plain.per_env_params().is_none());
    assert_eq!(randomised.per_env_params().unwrap().num_envs(), 50);
}

/// Every env of a randomised batch (after several resets) steps bit for bit as a
/// single chain built with that env's parameters.
#[test]
fn an_env_of_a_randomised_batch_steps_as_a_chain_with_its_parameters() {
    let mut t = task(3);
    t.reality.randomize = randomization();
    t.max_episode_steps = 4;
    t.step_options = StepOptions::new(Method::Variational, 2).unwrap();
    let mut b = batch::<Spatial>(t.clone(), CHUNK + 2, 5, AutoresetMode::SameStep);
    let mut out = Out::new(&b);
    let d = b.state_dim();
    let mut checked = 0;
    for s in 0..20 {
        let before = b.states().to_vec();
        let params: Vec<ChainParams> = (0..b.num_envs())
            .map(|k| b.env_params(k).unwrap())
            .collect();
        let a = actions(s, b.num_envs(), 2, 0);
        out.step(&mut b, &a);
        for (k, p) in params.iter().enumerate() {
            if b.events()[k] != 0 {
                continue; // ended and reset: the state is a new episode's
            }
            let chain = Chain::<Spatial>::new(p.clone());
            let mut y = before[k * d..(k + 1) * d].to_vec();
            let force: Vec<f64> = a[2 * k..2 * k + 2]
                .iter()
                .map(|x| x.clamp(-1.0, 1.0) * t.max_force)
                .collect();
            let status = step_chain(&chain, &mut y, &force, &t);
            assert!(!status.is_failure());
            assert_eq!(&y[..], &b.states()[k * d..(k + 1) * d], "env {k} step {s}");
            checked += 1;
        }
    }
    assert!(checked > 200, "{checked}");
}

/// Samples of many resets: every one in its range; mean and extremes as the
/// distribution says (fixed seed; tolerances stated below).
#[test]
fn sampled_parameters_lie_in_their_ranges_with_the_right_distribution() {
    let n = 2;
    let mut t = task(n);
    t.reality.randomize = randomization();
    t.reality.randomize.link_lengths = Some(ParamRandomization {
        distribution: Distribution::Range {
            low: 0.3,
            high: 0.6,
        },
        per_link: false,
    });
    let num_envs = 4000;
    let b = batch::<Planar>(t, num_envs, 123, AutoresetMode::NextStep);
    let p = b.per_env_params().unwrap();
    let (mut cart, mut mass, mut log_g) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..num_envs {
        let c = p.cart_mass[k];
        assert!((0.7..1.3).contains(&c), "cart_mass {c}");
        cart.push(c);
        for i in 0..n {
            let m = p.link_masses[k * n + i];
            assert!((0.07..0.13).contains(&m), "link_masses {m}");
            mass.push(m);
            let l = p.link_lengths[k * n + i];
            assert!((0.3..0.6).contains(&l), "link_lengths {l}");
        }
        // Shared across links: one draw.
        assert_eq!(p.link_lengths[k * n], p.link_lengths[k * n + 1]);
        assert_ne!(p.link_masses[k * n], p.link_masses[k * n + 1]);
        let g = p.gravity[k];
        assert!((9.0..=10.5).contains(&g), "gravity {g}");
        log_g.push(g.ln());
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    // Standard errors: cart 0.6/sqrt(12)/sqrt(4000) = 0.0027, link masses 0.0001,
    // log g 0.154/sqrt(12)/sqrt(4000) = 0.0007; tolerances are about 4 of them.
    assert!((mean(&cart) - 1.0).abs() < 0.011, "{}", mean(&cart));
    assert!((mean(&mass) - 0.1).abs() < 0.0005, "{}", mean(&mass));
    let mid = 0.5 * (9.0f64.ln() + 10.5f64.ln());
    assert!((mean(&log_g) - mid).abs() < 0.003, "{}", mean(&log_g));
    // The extremes of 4000 uniform draws lie within 0.5 % of the range of its ends
    // (probability of failing about 4000 * exp(-20) per end).
    let (lo, hi) = cart
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &c| (a.min(c), b.max(c)));
    assert!(lo < 0.7 + 0.003 && hi > 1.3 - 0.003, "{lo} {hi}");
}

#[test]
fn fixed_mismatch_changes_the_true_system_not_the_model() {
    let mut t = task(2);
    t.reality.params.link_lengths = Some(vec![0.4, 0.6]);
    t.reality.mismatch = ParamValues {
        cart_mass: Some(1.5),
        link_masses: Some(vec![2.0]),
        ..Default::default()
    };
    let mut b = batch::<Planar>(t.clone(), 2, 1, AutoresetMode::NextStep);
    assert_eq!(b.chain().params(), &nominal(2));
    let truth = ChainParams::new(1.5, &[0.2, 0.2], &[0.4, 0.6], 9.81).unwrap();
    assert_eq!(b.true_params(), &truth);
    assert_eq!(b.env_params(1).unwrap(), truth);
    let before = b.state(0).to_vec();
    Out::new(&b).step(&mut b, &[0.5, 0.5]);
    let chain = Chain::<Planar>::new(truth);
    let mut y = before;
    GuardedStepper::new(&chain).step(
        &chain,
        &mut y,
        0.5 * t.max_force,
        t.dt,
        &t.step_options,
        &Guard::default(),
    );
    assert_eq!(&y[..], b.state(0));
}

/// The noise of each observation component is `sigma_k z` with `z` from the env's
/// noise stream (stream 2 of its ChaCha8 generator), recomputed here independently.
#[test]
fn observation_noise_is_the_documented_gaussian() {
    let mut t = task(1);
    let sigma = [0.5, 0.0, 0.1, 0.2, 0.3];
    t.reality.obs_noise = sigma.to_vec();
    let seed = 77;
    let mut b = batch::<Planar>(t, 1, seed, AutoresetMode::NextStep);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(2);
    let mut obs = vec![0.0f64; 5];
    b.write_obs(&mut obs).unwrap();
    let mut out = Out::new(&b);
    for step in 0..4 {
        let y = b.states().to_vec();
        for k in 0..5 {
            let z: f64 = rng.sample(StandardNormal);
            assert_eq!(obs[k], y[k] + sigma[k] * z, "step {step} component {k}");
        }
        out.step(&mut b, &[0.3]);
        obs.copy_from_slice(&out.obs);
    }
    // The state itself is noise-free: the same as without noise.
    let mut quiet = batch::<Planar>(task(1), 1, seed, AutoresetMode::NextStep);
    let mut out_q = Out::new(&quiet);
    for _ in 0..4 {
        out_q.step(&mut quiet, &[0.3]);
    }
    assert_eq!(quiet.states(), b.states());
}

/// With a delay of k, step t applies the action of step t - k and zero force before.
#[test]
fn a_delay_applies_the_action_of_k_steps_before() {
    for delay in [1, 3] {
        let mut t = task(2);
        t.max_episode_steps = 500;
        t.reality.action_delay = delay;
        let mut delayed = batch::<Spatial>(t, 1, 9, AutoresetMode::NextStep);
        let mut plain = batch::<Spatial>(task(2), 1, 9, AutoresetMode::NextStep);
        let (mut o1, mut o2) = (Out::new(&delayed), Out::new(&plain));
        for s in 0..12 {
            o1.step(&mut delayed, &actions(s, 1, 2, 0));
            let shifted = if s >= delay {
                actions(s - delay, 1, 2, 0)
            } else {
                vec![0.0, 0.0]
            };
            o2.step(&mut plain, &shifted);
            assert_eq!(o1.obs, o2.obs, "delay {delay} step {s}");
            assert_eq!(o1.rewards, o2.rewards, "delay {delay} step {s}");
        }
    }
}

/// max_force 10 N, 100 N/s at dt 0.02 s: the force rises by 2 N per step towards a
/// full push, 2, 4, 6, 8, 10, 10 N, then falls by 2 N per step when released. With
/// force noise the delivered force is that ramp disturbed (the limit's memory keeps the
/// commanded ramp), and the reward's action term stays the commanded force's.
#[test]
fn the_force_rate_limit_ramps_the_force() {
    for (sm, sa) in [(0.0, 0.0), (0.25, 0.5)] {
        let mut t = task(1);
        t.max_force = 10.0;
        t.max_episode_steps = 500;
        t.reality.force_rate_limit = 100.0;
        t.reality.force_noise = ForceNoise {
            multiplicative: sm,
            additive: sa,
        };
        let seed = 4;
        let mut b = batch::<Planar>(t.clone(), 1, seed, AutoresetMode::NextStep);
        let chain = Chain::<Planar>::new(nominal(1));
        let mut y = b.states().to_vec();
        let mut rng = force_stream(seed);
        let mut out = Out::new(&b);
        let pushes = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, -1.0, 0.0];
        let commanded = [2.0, 4.0, 6.0, 8.0, 10.0, 10.0, 8.0, 6.0];
        for (a, f) in pushes.iter().zip(commanded) {
            out.step(&mut b, &[*a]);
            step_chain(&chain, &mut y, &[disturbed(f, sm, sa, &mut rng)], &t);
            assert_eq!(&y[..], b.states(), "sm {sm} sa {sa} commanded {f}");
            let lay = chain.layout();
            let (x, v) = (lay.load_x(&y), lay.load_xdot(&y));
            let (q, w) = (lay.load_q(&y, 0), lay.load_w(&y, 0));
            let dq = (q + <Planar as Geometry>::down_unit()).norm_squared();
            let c = dq
                + 0.1 * w.norm_squared()
                + 0.1 * x * x
                + 0.1 * v * v
                + 0.01 * (f / 10.0) * (f / 10.0);
            let r = out.rewards[0];
            assert!(
                (r - (-c).exp()).abs() < 1e-12,
                "sm {sm} sa {sa} commanded {f}"
            );
        }
    }
}

#[test]
fn snapshots_continue_identically_with_everything_on() {
    let mut b = batch::<Spatial>(everything_on(2), CHUNK + 3, 2, AutoresetMode::SameStep);
    history(&mut b, 13, 0);
    let snap = b.snapshot();
    let after = history(&mut b, 20, 0);
    b.restore(&snap).unwrap();
    assert_eq!(history(&mut b, 20, 0), after);
}

#[test]
fn bad_reality_settings_are_errors_naming_them() {
    let check = |spoil: &dyn Fn(&mut RealityGap), needle: &str| {
        let mut t = task(2);
        spoil(&mut t.reality);
        let e = batch_error(t).unwrap_or_else(|| panic!("{needle}: accepted"));
        assert!(e.contains(needle), "{needle}: {e}");
    };
    let dist = |d| {
        Some(ParamRandomization {
            distribution: d,
            per_link: true,
        })
    };
    check(
        &|r| r.randomize.link_masses = relative(1.2),
        "randomize.link_masses range [-0.19",
    );
    check(
        &|r| r.randomize.cart_mass = relative(-0.1),
        "randomize.cart_mass range [1.1, 0.9]",
    );
    check(
        &|r| {
            r.randomize.gravity = dist(Distribution::Range {
                low: 5.0,
                high: 4.0,
            })
        },
        "randomize.gravity range [5, 4]",
    );
    check(
        &|r| {
            r.randomize.link_lengths = dist(Distribution::LogRange {
                low: -1.0,
                high: 1.0,
            })
        },
        "randomize.link_lengths",
    );
    check(&|r| r.obs_noise = vec![-0.1], "obs_noise[0] = -0.1");
    check(
        &|r| r.obs_noise = vec![0.1, 0.2],
        "obs_noise has length 2, expected 16",
    );
    check(&|r| r.force_rate_limit = 0.0, "force_rate_limit = 0");
    check(
        &|r| r.force_noise.multiplicative = -0.1,
        "force_noise.multiplicative = -0.1: expected a finite number >= 0",
    );
    check(
        &|r| r.force_noise.additive = f64::NAN,
        "force_noise.additive = NaN: expected a finite number >= 0",
    );
    check(
        &|r| r.force_noise.additive = f64::INFINITY,
        "force_noise.additive = inf",
    );
    check(
        &|r| r.params.cart_mass = Some(-1.0),
        "params.cart_mass = -1",
    );
    check(
        &|r| r.mismatch.link_lengths = Some(vec![1.0, 1.0, 1.0]),
        "mismatch.link_lengths has length 3, expected 2",
    );
    check(
        &|r| r.mismatch.link_masses = Some(vec![1.0, 0.0]),
        "mismatch.link_masses[1] = 0",
    );
    let e = RealityGap::delay_from(-1).unwrap_err().to_string();
    assert!(e.contains("action_delay = -1"), "{e}");
    assert_eq!(
        Param::from_name("randomize", "pole_mass").unwrap_err(),
        ChainError::Input(InputError::UnknownName {
            kind: "randomize",
            name: "pole_mass".into(),
            expected: &Param::NAMES,
        })
    );
}

/// The force noise of `sm`, `sa` on the commanded force `f` of one axis, drawn from
/// `rng` in the documented order (recomputed here independently of the core).
fn disturbed(f: f64, sm: f64, sa: f64, rng: &mut ChaCha8Rng) -> f64 {
    let z1: f64 = if sm > 0.0 {
        rng.sample(StandardNormal)
    } else {
        0.0
    };
    let z2: f64 = if sa > 0.0 {
        rng.sample(StandardNormal)
    } else {
        0.0
    };
    f * (1.0 + sm * z1) + sa * z2
}

/// The force stream (stream 3) of the env seeded `seed`.
fn force_stream(seed: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(3);
    rng
}

/// Spatial, two axes: each step's state is the chain stepped with the commanded force
/// (clipped, scaled) disturbed as documented, axis by axis, drawn from the env's force
/// stream: bit for bit; the start state is the one without force noise.
#[test]
fn force_noise_disturbs_each_axis_as_documented() {
    for (sm, sa) in [(0.3, 0.0), (0.0, 2.0), (0.3, 2.0)] {
        let mut t = task(2);
        t.max_episode_steps = 500;
        t.reality.force_noise = ForceNoise {
            multiplicative: sm,
            additive: sa,
        };
        let seed = 31;
        let mut b = batch::<Spatial>(t.clone(), 1, seed, AutoresetMode::NextStep);
        let plain = batch::<Spatial>(task(2), 1, seed, AutoresetMode::NextStep);
        assert_eq!(b.states(), plain.states(), "the start state is unchanged");
        let chain = Chain::<Spatial>::new(nominal(2));
        let mut y = b.states().to_vec();
        let mut rng = force_stream(seed);
        let mut out = Out::new(&b);
        for s in 0..12 {
            let a = actions(s, 1, 2, 0);
            out.step(&mut b, &a);
            let force: Vec<f64> = a
                .iter()
                .map(|x| disturbed(x.clamp(-1.0, 1.0) * t.max_force, sm, sa, &mut rng))
                .collect();
            step_chain(&chain, &mut y, &force, &t);
            assert_eq!(&y[..], b.states(), "sm {sm} sa {sa} step {s}");
        }
    }
}

/// The applied force seen through the horizontal momentum, which only the cart force
/// changes (`dP/dt = u`): envs put at rest hanging before every step push with the
/// same command, and the force each delivered, `P / dt` after the step, has the mean
/// of the command and the standard deviation `sqrt((sm f)^2 + sa^2)`, per axis, the
/// two axes uncorrelated.
#[test]
fn the_delivered_force_has_the_documented_mean_and_spread() {
    let num_envs = 2 * CHUNK;
    let steps = 100;
    for (sm, sa, command) in [
        (0.0, 0.0, [0.5, -0.25]),
        (0.2, 0.0, [0.5, -0.25]),
        (0.0, 1.5, [0.5, -0.25]),
        (0.2, 1.5, [-0.5, 0.0]),
    ] {
        let mut t = task(1);
        t.start = Start::Equilibrium(vec![1.0]);
        t.start_noise = 0.0;
        t.max_episode_steps = 10 * steps as u64;
        t.reality.force_noise = ForceNoise {
            multiplicative: sm,
            additive: sa,
        };
        let mut b = batch::<Spatial>(t.clone(), num_envs, 17, AutoresetMode::NextStep);
        let rest = b.state(0).to_vec();
        let chain = Chain::<Spatial>::new(nominal(1));
        assert_eq!(chain.horizontal_momentum(&rest).norm_squared(), 0.0);
        let actions: Vec<f64> = (0..num_envs).flat_map(|_| command).collect();
        let mut out = Out::new(&b);
        let mut forces = [Vec::new(), Vec::new()];
        for _ in 0..steps {
            for k in 0..num_envs {
                b.set_state(k, &rest).unwrap();
            }
            out.step(&mut b, &actions);
            for k in 0..num_envs {
                let p = chain.horizontal_momentum(b.state(k)) / t.dt;
                forces[0].push(p.x);
                forces[1].push(p.y);
            }
        }
        let samples = forces[0].len() as f64;
        let mean = |v: &[f64]| v.iter().sum::<f64>() / samples;
        let std = |v: &[f64]| {
            let m = mean(v);
            (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (samples - 1.0)).sqrt()
        };
        for axis in 0..2 {
            let f = command[axis] * t.max_force;
            let sigma = ((sm * f).powi(2) + sa * sa).sqrt();
            let (m, s) = (mean(&forces[axis]), std(&forces[axis]));
            let case = format!("sm {sm} sa {sa} axis {axis}: mean {m} std {s}");
            if sigma == 0.0 {
                // Without noise the momentum reads the command to the accuracy of RK4
                // (the momentum is not linear in the state: about 2e-7 relative).
                assert!(
                    (m - f).abs() < 1e-6 * f.abs().max(1.0) && s < 1e-9,
                    "{case}"
                );
                continue;
            }
            // Standard errors over 6400 samples: the mean sigma/80, the standard
            // deviation about sigma/113; the tolerances are about 4.5 of them.
            assert!((m - f).abs() < 4.5 * sigma / samples.sqrt(), "{case}");
            assert!(
                (s / sigma - 1.0).abs() < 4.5 / (2.0 * samples).sqrt(),
                "{case}"
            );
        }
        if sm > 0.0 || sa > 0.0 {
            let (m0, m1) = (mean(&forces[0]), mean(&forces[1]));
            let cov = forces[0]
                .iter()
                .zip(&forces[1])
                .map(|(a, b)| (a - m0) * (b - m1))
                .sum::<f64>()
                / samples;
            let corr = cov / (std(&forces[0]) * std(&forces[1]));
            assert!(corr.abs() < 4.5 / samples.sqrt(), "correlation {corr}");
        }
    }
}

/// Force noise draws from its own stream: turning it on changes no start state, no
/// parameter draw and no observation noise (also after a reseeded reset), and a batch
/// without it keeps no stream.
#[test]
fn force_noise_changes_no_other_random_number() {
    let mut quiet = everything_on(2);
    quiet.reality.force_noise = ForceNoise::default();
    let mut a = batch::<Spatial>(quiet, 40, 8, AutoresetMode::NextStep);
    let mut b = batch::<Spatial>(everything_on(2), 40, 8, AutoresetMode::NextStep);
    let observed = |x: &EnvBatch<Spatial>| {
        let mut obs = vec![0.0f64; x.states().len()];
        x.write_obs(&mut obs).unwrap();
        obs
    };
    let same = |a: &EnvBatch<Spatial>, b: &EnvBatch<Spatial>| {
        assert_eq!(a.states(), b.states());
        assert_eq!(observed(a), observed(b));
        assert_eq!(a.per_env_params(), b.per_env_params());
    };
    same(&a, &b);
    history(&mut a, 10, 0);
    history(&mut b, 10, 0);
    assert_ne!(a.states(), b.states(), "the force noise acted");
    let seeds: Vec<Option<u64>> = (0..40).map(|k| Some(1000 + k)).collect();
    let mut obs = vec![0.0f64; a.states().len()];
    a.reset(Some(&seeds), None, &mut obs).unwrap();
    b.reset(Some(&seeds), None, &mut obs).unwrap();
    same(&a, &b);
    assert!(a.snapshot().force_rng.is_empty());
    assert_eq!(b.snapshot().force_rng.len(), 40);
}

/// Envs 0 and `num_envs - 1` of a batch seeded `seed`, whose observations over its
/// steps are `history`, are the single envs of `task()` seeded `seed + i`.
fn assert_envs_are_single_envs(
    history: &[Vec<f64>],
    task: impl Fn() -> TaskConfig,
    num_envs: usize,
    seed: u64,
) {
    for env in [0, num_envs - 1] {
        let mut one = batch::<Spatial>(task(), 1, seed + env as u64, AutoresetMode::SameStep);
        let mut out = Out::new(&one);
        let d = one.state_dim();
        for (s, row) in history.iter().enumerate() {
            let a = actions(s, num_envs, 2, 0);
            out.step(&mut one, &a[2 * env..2 * env + 2]);
            assert_eq!(
                &out.obs[..],
                &row[env * d..(env + 1) * d],
                "env {env} step {s}"
            );
        }
    }
}

/// A delay range draws each episode's delay from `low..=high` at its reset: every value
/// comes up, env i of a batch is the single env seeded seed + i over several episodes,
/// and a snapshot keeps the drawn delays.
#[test]
fn env_a_delay_range_draws_each_episodes_delay_in_its_range() {
    let ranged = || {
        let mut t = everything_on(2);
        t.reality.action_delay = 1;
        t.reality.action_delay_high = Some(4);
        t
    };
    let num_envs = CHUNK + 5;
    let mut big = batch::<Spatial>(ranged(), num_envs, 40, AutoresetMode::SameStep);
    let drawn = big.snapshot().action_delays;
    assert!(drawn.iter().all(|&d| (1..=4).contains(&d)), "{drawn:?}");
    assert!((1..=4).all(|d| drawn.contains(&d)), "{drawn:?}");
    let h_big = history(&mut big, 60, 0); // episodes of 25 steps: three delays drawn per env
    assert_envs_are_single_envs(&h_big, ranged, num_envs, 40);
    let snap = big.snapshot();
    let after = history(&mut big, 30, 0);
    big.restore(&snap).unwrap();
    assert_eq!(history(&mut big, 30, 0), after);
    let mut backwards = task(2);
    backwards.reality.action_delay = 3;
    backwards.reality.action_delay_high = Some(2);
    let e = batch_error(backwards).expect("a range whose high end is below its low end");
    assert!(
        e.contains("action_delay = 2") && e.contains("0 <= low <= high"),
        "{e}"
    );
}

/// A force-rate-limit range draws each episode's limit at its reset (kept after the
/// last forces): the limits lie in the range and spread over it, env i of a batch is the
/// single env seeded seed + i over several episodes, a snapshot keeps them, and an
/// episode with a drawn limit steps as an env whose fixed limit is that value.
#[test]
fn env_a_force_rate_limit_range_draws_each_episodes_limit() {
    let ranged = |high: f64| {
        let mut t = everything_on(2);
        t.reality.force_rate_limit = 200.0;
        t.reality.force_rate_limit_high = Some(high);
        t
    };
    let num_envs = CHUNK + 5;
    let mut big = batch::<Spatial>(ranged(f64::INFINITY), num_envs, 40, AutoresetMode::SameStep);
    let limits: Vec<f64> = big.snapshot().last_force.chunks(3).map(|c| c[2]).collect();
    assert!(limits.iter().all(|&l| l >= 200.0), "{limits:?}");
    assert!(
        limits.iter().any(|&l| l < 400.0) && limits.iter().any(|&l| l > 2000.0),
        "{limits:?}"
    );
    let h_big = history(&mut big, 60, 0); // episodes of 25 steps: three limits drawn per env
    assert_envs_are_single_envs(&h_big, || ranged(f64::INFINITY), num_envs, 40);
    let snap = big.snapshot();
    let after = history(&mut big, 30, 0);
    big.restore(&snap).unwrap();
    assert_eq!(history(&mut big, 30, 0), after);

    // The first episode with a drawn limit is the episode with that limit fixed.
    let mut drawn = batch::<Spatial>(ranged(1000.0), 1, 7, AutoresetMode::NextStep);
    let limit = drawn.snapshot().last_force[2];
    assert!((200.0..=1000.0).contains(&limit), "{limit}");
    let mut fixed_task = everything_on(2);
    fixed_task.reality.force_rate_limit = limit;
    let mut fixed = batch::<Spatial>(fixed_task, 1, 7, AutoresetMode::NextStep);
    assert_eq!(drawn.states(), fixed.states());
    assert_eq!(history(&mut drawn, 20, 0), history(&mut fixed, 20, 0));
}

#[test]
fn a_bad_force_rate_limit_range_is_an_error_naming_it() {
    for (low, high) in [
        (500.0, 200.0),
        (f64::INFINITY, f64::INFINITY),
        (100.0, f64::NAN),
    ] {
        let mut t = task(2);
        t.reality.force_rate_limit = low;
        t.reality.force_rate_limit_high = Some(high);
        let e = batch_error(t).expect("a bad range");
        assert!(
            e.contains("force_rate_limit") && e.contains("0 < low <= high <= inf"),
            "{low} {high}: {e}"
        );
    }
}

// ---- Rig effects drawn per episode -------------------------------------------------

fn absolute(low: f64, high: f64, per_link: bool) -> Option<ParamRandomization> {
    Some(ParamRandomization {
        distribution: Distribution::Range { low, high },
        per_link,
    })
}

/// Joint damping within [0, 0.05] per link, cart friction viscous within [0.1, 1] and
/// Coulomb within [0, 2], on top of `randomization()`.
fn rig_drawn(n: usize) -> TaskConfig {
    let mut t = task(n);
    t.reality.randomize = Randomization {
        joint_damping: absolute(0.0, 0.05, true),
        cart_viscous_friction: absolute(0.1, 1.0, true),
        cart_coulomb_friction: absolute(0.0, 2.0, true),
        ..randomization()
    };
    t
}

#[test]
fn an_env_with_drawn_rig_effects_steps_as_a_chain_with_its_draws() {
    let t = rig_drawn(2);
    let mut b = batch::<Spatial>(t.clone(), CHUNK + 2, 8, AutoresetMode::SameStep);
    let mut out = Out::new(&b);
    let d = b.state_dim();
    let (mut checked, mut dampings) = (0, Vec::new());
    for s in 0..40 {
        let before = b.states().to_vec();
        let systems: Vec<(ChainParams, Rig)> = (0..b.num_envs())
            .map(|k| (b.env_params(k).unwrap(), b.env_rig(k).unwrap()))
            .collect();
        let a = actions(s, b.num_envs(), 2, 0);
        out.step(&mut b, &a);
        for (k, (p, rig)) in systems.iter().enumerate() {
            dampings.push(rig.joint_damping.clone());
            if b.events()[k] != 0 {
                continue; // ended and reset: the state is a new episode's
            }
            let chain = Chain::<Spatial>::new(p.clone())
                .with_rig(rig.clone())
                .unwrap();
            let mut y = before[k * d..(k + 1) * d].to_vec();
            let force: Vec<f64> = a[2 * k..2 * k + 2]
                .iter()
                .map(|x| x.clamp(-1.0, 1.0) * t.max_force)
                .collect();
            assert!(!step_chain(&chain, &mut y, &force, &t).is_failure());
            assert_eq!(&y[..], &b.states()[k * d..(k + 1) * d], "env {k} step {s}");
            checked += 1;
        }
    }
    assert!(checked > 500, "{checked}");
    // Each env drew its own damping, one per link, and episodes redraw it.
    dampings.sort_by(|a, b| a.partial_cmp(b).unwrap());
    dampings.dedup();
    assert!(dampings.len() >= 2 * (CHUNK + 2), "{}", dampings.len());
    assert!(dampings.iter().all(|c| c.len() == 2 && c[0] != c[1]));
}

#[test]
fn rig_draws_lie_in_their_ranges_and_shared_draws_are_shared() {
    let mut t = rig_drawn(3);
    t.reality.randomize.joint_damping = absolute(0.01, 0.03, false);
    let mut b = batch::<Planar>(t, 400, 3, AutoresetMode::SameStep);
    let rigs: Vec<Rig> = (0..400).map(|k| b.env_rig(k).unwrap()).collect();
    let (mut lowest, mut highest) = (f64::INFINITY, 0.0f64);
    for rig in &rigs {
        let c = rig.joint_damping[0];
        assert!(
            rig.joint_damping.iter().all(|&x| x == c),
            "{:?}",
            rig.joint_damping
        );
        assert!((0.01..0.03).contains(&c), "{c}");
        assert!((0.1..1.0).contains(&rig.cart_viscous_friction));
        assert!((0.0..2.0).contains(&rig.cart_coulomb_friction));
        lowest = lowest.min(rig.cart_coulomb_friction);
        highest = highest.max(rig.cart_coulomb_friction);
    }
    // 400 uniform draws on [0, 2) reach within 0.05 of both ends.
    assert!(lowest < 0.05 && highest > 1.95, "{lowest} {highest}");
    // A reset draws anew.
    let mut obs = vec![0.0; 400 * b.state_dim()];
    b.reset(None, None, &mut obs).unwrap();
    assert_ne!(b.env_rig(0).unwrap(), rigs[0]);
}

#[test]
fn rig_draws_leave_the_start_states_and_the_physical_draws_unchanged() {
    let mut physical = task(2);
    physical.reality.randomize = randomization();
    let mut a = batch::<Spatial>(physical, 9, 11, AutoresetMode::SameStep);
    let mut b = batch::<Spatial>(rig_drawn(2), 9, 11, AutoresetMode::SameStep);
    assert_eq!(a.states(), b.states());
    for k in 0..9 {
        assert_eq!(a.env_params(k).unwrap(), b.env_params(k).unwrap());
        assert!(a.env_rig(k).unwrap().is_ideal() && !b.env_rig(k).unwrap().is_ideal());
    }
    let mut out = (Out::new(&a), Out::new(&b));
    out.0.step(&mut a, &actions(0, 9, 2, 0));
    out.1.step(&mut b, &actions(0, 9, 2, 0));
    assert_ne!(
        a.states(),
        b.states(),
        "the drawn damping and friction acted"
    );
}

#[test]
fn drawn_rig_effects_reproduce_per_env_and_across_snapshots() {
    let num_envs = CHUNK + 1;
    let mut big = batch::<Spatial>(rig_drawn(2), num_envs, 40, AutoresetMode::SameStep);
    let h = history(&mut big, 60, 0);
    assert_envs_are_single_envs(&h, || rig_drawn(2), num_envs, 40);
    let snap = big.snapshot();
    let rigs: Vec<Rig> = (0..num_envs).map(|k| big.env_rig(k).unwrap()).collect();
    let after = history(&mut big, 30, 0);
    big.restore(&snap).unwrap();
    assert_eq!(
        (0..num_envs)
            .map(|k| big.env_rig(k).unwrap())
            .collect::<Vec<_>>(),
        rigs
    );
    assert_eq!(history(&mut big, 30, 0), after);
}

#[test]
fn bad_rig_draws_are_errors_naming_them() {
    let check = |spoil: &dyn Fn(&mut TaskConfig), needle: &str| {
        let mut t = task(2);
        spoil(&mut t);
        let e = batch_error(t).unwrap_or_else(|| panic!("{needle}: accepted"));
        assert!(e.contains(needle), "{needle}: {e}");
    };
    // A relative draw of a rig without damping would draw nothing but zeros.
    check(
        &|t| t.reality.randomize.joint_damping = relative(0.5),
        "randomize.joint_damping = 0: expected a relative draw of a non-zero value",
    );
    check(
        &|t| t.reality.randomize.cart_coulomb_friction = absolute(-0.1, 1.0, true),
        "randomize.cart_coulomb_friction range [-0.1, 1]: expected 0 <= low <= high",
    );
    check(
        &|t| {
            t.reality.randomize.cart_viscous_friction = absolute(0.0, 1.0, true);
            t.step_options = StepOptions::new(Method::Variational, 1).unwrap();
        },
        "variational",
    );
    // Scaled around a rig that has damping, a relative draw is accepted.
    let mut t = task(2);
    t.rig.joint_damping = vec![0.01];
    t.reality.randomize.joint_damping = relative(0.5);
    assert_eq!(batch_error(t), None);
}
