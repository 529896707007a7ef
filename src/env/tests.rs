//! Tests of the task layer that need whole batches.

use super::*;
use crate::engine::CHUNK;
use crate::geometry::{Planar, Spatial};
use crate::integrate::{Method, StepOptions};
use crate::lanes::LaneScene;
use crate::model::Chain;
use crate::params::ChainParams;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn params(n: usize) -> ChainParams {
    ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap()
}

fn task(n: usize) -> TaskConfig {
    let mut t = TaskConfig::new(vec![-1.0; n], 0.02, StepOptions::default());
    t.max_episode_steps = 40;
    t
}

/// Output buffers for `n` envs of dimension `d`.
struct Out<T: Real> {
    obs: Vec<T>,
    rewards: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
}

impl<T: Real + Default> Out<T> {
    fn new(n: usize, d: usize) -> Self {
        Self {
            obs: vec![T::default(); n * d],
            rewards: vec![0.0; n],
            terminated: vec![false; n],
            truncated: vec![false; n],
        }
    }
    fn buffers(&mut self) -> StepOutputs<'_, T> {
        StepOutputs {
            obs: &mut self.obs,
            rewards: &mut self.rewards,
            terminated: &mut self.terminated,
            truncated: &mut self.truncated,
        }
    }
}

/// Everything one step of one env produced, for comparisons.
#[derive(Debug, Clone, PartialEq)]
struct Record {
    obs: Vec<f64>,
    reward: f64,
    terminated: bool,
    truncated: bool,
    event: u8,
    final_state: Option<Vec<f64>>,
}

fn record<G: LaneScene>(b: &EnvBatch<G>, out: &Out<f64>, env: usize) -> Record {
    let d = b.state_dim();
    let ended = b.events()[env] & event::ENDED != 0;
    Record {
        obs: out.obs[env * d..(env + 1) * d].to_vec(),
        reward: out.rewards[env],
        terminated: out.terminated[env],
        truncated: out.truncated[env],
        event: b.events()[env],
        final_state: (ended && b.mode() == AutoresetMode::SameStep)
            .then(|| b.final_states()[env * d..(env + 1) * d].to_vec()),
    }
}

/// Actions for `n` envs from a stream shared by the test (not the envs), some outside
/// [-1, 1] so that clipping is exercised.
fn actions(rng: &mut ChaCha8Rng, n: usize, f: usize) -> Vec<f64> {
    (0..n * f)
        .map(|_| 3.0 * (2.0 * rng.random::<f64>() - 1.0))
        .collect()
}

/// Runs `steps` steps of a batch; returns per-step records of every env.
fn run<G: LaneScene>(
    b: &mut EnvBatch<G>,
    steps: usize,
    seed: u64,
    action_offset: usize,
    total_envs: usize,
) -> Vec<Vec<Record>> {
    let (n, d, f) = (b.num_envs(), b.state_dim(), b.force_dim());
    let mut out = Out::<f64>::new(n, d);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut history = Vec::new();
    for _ in 0..steps {
        // Every run draws the actions of all `total_envs` envs and takes its own slice,
        // so that env i of a big batch and a batch of one see the same actions.
        let all = actions(&mut rng, total_envs, f);
        let mine = &all[action_offset * f..(action_offset + n) * f];
        b.step(mine, out.buffers()).unwrap();
        history.push((0..n).map(|k| record(b, &out, k)).collect());
    }
    history
}

fn env_i_matches_a_single_env<G: LaneScene>(mode: AutoresetMode) {
    let num_envs = 2 * CHUNK + 5; // several chunks, so the parallel path runs
    let mut t = task(2);
    t.start_noise = 0.3; // large enough that some episodes leave the track
    t.max_force = 30.0;
    let seed = 1000;
    let mut big = EnvBatch::new(
        Chain::<G>::new(params(2)),
        t.clone(),
        num_envs,
        seed,
        mode,
        true,
    )
    .unwrap();
    let steps = 90; // more than two episodes of 40 steps
    let all = run(&mut big, steps, 5, 0, num_envs);
    let mut ended = 0;
    for env in [0, 1, CHUNK - 1, CHUNK, num_envs - 1] {
        let mut one = EnvBatch::new(
            Chain::<G>::new(params(2)),
            t.clone(),
            1,
            seed + env as u64,
            mode,
            true,
        )
        .unwrap();
        let mine = run(&mut one, steps, 5, env, num_envs);
        for (k, (a, b)) in all.iter().zip(&mine).enumerate() {
            assert_eq!(a[env], b[0], "env {env}, step {k}, {mode:?}");
            ended += (b[0].event & event::ENDED != 0) as usize;
        }
    }
    assert!(
        ended >= 10,
        "too few episode ends to test autoreset: {ended}"
    );
}

#[test]
fn env_i_of_a_batch_is_the_single_env_seeded_seed_plus_i() {
    for mode in [AutoresetMode::NextStep, AutoresetMode::SameStep] {
        env_i_matches_a_single_env::<Planar>(mode);
        env_i_matches_a_single_env::<Spatial>(mode);
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let num_envs = 5 * CHUNK + 3;
    let go = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut t = task(3);
            t.start_noise = 0.2;
            let mut b = EnvBatch::new(
                Chain::<Spatial>::new(params(3)),
                t,
                num_envs,
                42,
                AutoresetMode::SameStep,
                false,
            )
            .unwrap();
            let h = run(&mut b, 60, 9, 0, num_envs);
            (h, b.states().to_vec())
        })
    };
    let one = go(1);
    for threads in [2, 3, 8] {
        assert!(go(threads) == one, "{threads} threads differ from 1");
    }
}

#[test]
fn reward_is_one_at_the_target_and_decreases_away_from_it() {
    let mut t = task(2);
    t.start_noise = 0.0;
    t.max_force = 10.0; // a half action, 5 N, barely moves the chain in one step
    let mut b = EnvBatch::new(
        Chain::<Planar>::new(params(2)),
        t.clone(),
        1,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let mut out = Out::<f64>::new(1, b.state_dim());
    // The inverted equilibrium is a fixed point: zero force keeps it, reward exactly 1.
    for _ in 0..5 {
        b.step(&[0.0], out.buffers()).unwrap();
        assert_eq!(out.rewards[0], 1.0);
    }
    assert_eq!(b.states(), b.base_state());
    // Any force costs w_u a^2 at once (the state has barely moved after one step).
    b.step(&[0.5], out.buffers()).unwrap();
    let r = out.rewards[0];
    assert!(r < (-0.01f64 * 0.25).exp() && r > 0.99, "{r}");
    // Tilting the links lowers the reward with the tilt.
    let mut last = 1.0;
    for tilt in [0.05f64, 0.2, 0.5, 1.0] {
        let mut t = t.clone();
        let (s, c) = tilt.sin_cos();
        t.start = Start::State(vec![0.0, 0.0, s, -c, s, -c, 0.0, 0.0]);
        let mut b = EnvBatch::new(
            Chain::<Planar>::new(params(2)),
            t,
            1,
            0,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap();
        b.step(&[0.0], out.buffers()).unwrap();
        assert!(out.rewards[0] < last, "tilt {tilt}: {}", out.rewards[0]);
        last = out.rewards[0];
    }
}

#[test]
fn reward_follows_the_documented_formula() {
    let mut t = task(1);
    t.reward = RewardWeights {
        q: 0.7,
        w: 0.3,
        x: 0.2,
        v: 0.5,
        u: 0.4,
    };
    t.start_noise = 0.3;
    let chain = Chain::<Spatial>::new(params(1));
    let mut b = EnvBatch::new(
        chain.clone(),
        t.clone(),
        1,
        3,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let mut out = Out::<f64>::new(1, b.state_dim());
    b.step(&[0.3, -2.0], out.buffers()).unwrap();
    let y = b.states();
    let lay = chain.layout();
    let q = lay.load_q(y, 0);
    let dq = (q + nalgebra::Vector3::new(0.0, 0.0, 1.0)).norm_squared();
    let c = 0.7 * dq
        + 0.3 * lay.load_w(y, 0).norm_squared()
        + 0.2 * lay.load_x(y).norm_squared()
        + 0.5 * lay.load_xdot(y).norm_squared()
        + 0.4 * (0.3 * 0.3 + 1.0);
    assert!((out.rewards[0] - (-c).exp()).abs() < 1e-15);
    let (e_q, e_w) = chain.errors(y, &t.target);
    assert_eq!(b.errors(), &[e_q, e_w]);
}

#[test]
fn clipping_and_zero_max_force() {
    let chain = Chain::<Planar>::new(params(1));
    let mut t = task(1);
    t.start_noise = 0.1;
    let go = |t: &TaskConfig, a: f64| {
        let mut b = EnvBatch::new(
            chain.clone(),
            t.clone(),
            1,
            11,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap();
        let mut out = Out::<f64>::new(1, b.state_dim());
        for _ in 0..10 {
            b.step(&[a], out.buffers()).unwrap();
        }
        b.states().to_vec()
    };
    assert_eq!(go(&t, 7.0), go(&t, 1.0));
    assert_eq!(go(&t, -1e300), go(&t, -1.0));
    assert_ne!(go(&t, 0.5), go(&t, 1.0));
    t.max_force = 0.0;
    assert_eq!(go(&t, 1.0), go(&t, -0.3));
}

#[test]
fn truncation_success_and_next_step_autoreset() {
    let mut t = task(1);
    t.start_noise = 0.0;
    t.max_episode_steps = 3;
    let mut b = EnvBatch::new(
        Chain::<Planar>::new(params(1)),
        t,
        1,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let mut out = Out::<f64>::new(1, b.state_dim());
    for k in 1..=3 {
        assert_eq!(b.step(&[0.0], out.buffers()).unwrap(), (k == 3) as usize);
        assert_eq!(b.step_count(0), k);
        assert_eq!(out.truncated[0], k == 3);
        assert!(!out.terminated[0]);
    }
    assert_eq!(b.events()[0], event::ENDED | event::SUCCESS);
    assert!(b.has_ended(0));
    // The next step resets instead of stepping: reward 0, no flags, the action ignored.
    b.step(&[1.0], out.buffers()).unwrap();
    assert_eq!(b.events()[0], event::RESET);
    assert_eq!(
        (out.rewards[0], out.terminated[0], out.truncated[0]),
        (0.0, false, false)
    );
    assert_eq!(b.states(), b.base_state());
    assert_eq!(b.step_count(0), 0);
}

#[test]
fn leaving_the_track_terminates_without_success() {
    let mut t = task(1);
    t.start = Start::State(vec![2.35, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0]);
    t.start_noise = 0.0;
    t.target = vec![-1.0];
    let mut b = EnvBatch::new(
        Chain::<Spatial>::new(params(1)),
        t,
        2,
        0,
        AutoresetMode::SameStep,
        false,
    )
    .unwrap();
    let d = b.state_dim();
    let mut out = Out::<f64>::new(2, d);
    let mut ended_at = None;
    for k in 0..40 {
        // Env 0 pushes towards +x, env 1 does nothing and stays at its equilibrium.
        b.step(&[1.0, 0.0, 0.0, 0.0], out.buffers()).unwrap();
        if out.terminated[0] {
            ended_at = Some(k);
            break;
        }
    }
    assert!(ended_at.is_some());
    assert_eq!(b.events()[0], event::ENDED | event::OUT_OF_TRACK);
    assert!(!out.terminated[1] && b.events()[1] == 0);
    // Same-step: the final state is past the limit, the returned obs is a fresh start.
    assert!(b.final_states()[0] > 2.4);
    assert_eq!(&out.obs[..d], b.base_state());
    assert!(!b.has_ended(0));
}

#[test]
fn a_numerical_failure_ends_the_episode_with_finite_observations() {
    let mut t = task(2);
    t.step_options = StepOptions::new(Method::LieEuler, 1).unwrap();
    t.dt = 5.0;
    t.max_force = 1e6;
    t.track_limit = 1e300;
    t.start_noise = 0.3;
    let mut b = EnvBatch::new(
        Chain::<Spatial>::new(params(2)),
        t,
        3,
        0,
        AutoresetMode::NextStep,
        true,
    )
    .unwrap();
    let mut out = Out::<f32>::new(3, b.state_dim());
    let mut failed = false;
    for _ in 0..50 {
        b.step(&[1.0, -1.0, 1.0, 1.0, -1.0, 0.5], out.buffers())
            .unwrap();
        assert!(out.obs.iter().all(|v| v.is_finite()));
        assert!(b.states().iter().all(|v| v.is_finite()));
        for env in 0..3 {
            if b.events()[env] & event::NUMERICAL_FAILURE != 0 {
                failed = true;
                assert!(out.terminated[env]);
                assert_eq!(out.rewards[env], 0.0);
                assert_eq!(b.events()[env] & event::SUCCESS, 0);
            }
        }
    }
    assert!(failed, "the huge step never failed");
}

#[test]
fn bad_actions_change_no_env() {
    let mut t = task(1);
    t.start_noise = 0.2;
    let mut b = EnvBatch::new(
        Chain::<Spatial>::new(params(1)),
        t,
        40,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let mut out = Out::<f32>::new(40, b.state_dim());
    let before = b.snapshot();
    let mut a = vec![0.5; 80];
    a[57] = f64::NAN;
    let e = b.step(&a, out.buffers()).unwrap_err();
    assert!(
        e.to_string()
            .contains("actions[28, 1] = NaN: expected a finite number (env 28, component 1)"),
        "{e}"
    );
    a[57] = f64::INFINITY;
    assert!(b.step(&a, out.buffers()).is_err());
    let e = b.step(&a[..79], out.buffers()).unwrap_err();
    assert!(
        e.to_string().contains("actions has length 79, expected 80"),
        "{e}"
    );
    assert_eq!(b.snapshot(), before);
    let e = b
        .step(&[0.0f32; 80], Out::<f32>::new(40, 3).buffers())
        .unwrap_err();
    assert!(e.to_string().contains("obs"), "{e}");
    assert_eq!(b.snapshot(), before);
}

#[test]
fn disabled_autoreset_refuses_ended_envs_until_reset() {
    let mut t = task(1);
    t.max_episode_steps = 2;
    let mut b = EnvBatch::new(
        Chain::<Planar>::new(params(1)),
        t,
        3,
        5,
        AutoresetMode::Disabled,
        false,
    )
    .unwrap();
    let d = b.state_dim();
    let mut out = Out::<f64>::new(3, d);
    b.step(&[0.0; 3], out.buffers()).unwrap();
    b.step(&[0.0; 3], out.buffers()).unwrap();
    assert!(out.truncated.iter().all(|&t| t));
    let before = b.snapshot();
    let e = b.step(&[0.0; 3], out.buffers()).unwrap_err().to_string();
    assert!(e.contains("reset_mask"), "{e}");
    assert_eq!(b.snapshot(), before);
    // Reset envs 0 and 2 only: env 1 keeps its state and stays ended.
    let mut obs = vec![0.0; 3 * d];
    b.reset(None, Some(&[true, false, true]), &mut obs).unwrap();
    assert_eq!(&obs[d..2 * d], b.state(1));
    assert_eq!(b.state(1), &before.states[d..2 * d]);
    assert!(b.has_ended(1) && !b.has_ended(0) && !b.has_ended(2));
    assert!(b.step(&[0.0; 3], out.buffers()).is_err());
    b.reset(None, Some(&[false, true, false]), &mut obs)
        .unwrap();
    b.step(&[0.0; 3], out.buffers()).unwrap();
}

#[test]
fn reset_seeds_reproduce_and_streams_continue() {
    let mut t = task(2);
    t.start_noise = 0.1;
    let mk = || {
        EnvBatch::new(
            Chain::<Spatial>::new(params(2)),
            t.clone(),
            2,
            77,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap()
    };
    let mut b = mk();
    let d = b.state_dim();
    let mut first = vec![0.0; 2 * d];
    b.reset(Some(&[Some(5), Some(6)]), None, &mut first)
        .unwrap();
    let mut second = vec![0.0; 2 * d];
    b.reset(None, None, &mut second).unwrap();
    assert_ne!(first, second);
    let mut c = mk();
    let mut again = vec![0.0; 2 * d];
    c.reset(Some(&[Some(5), Some(6)]), None, &mut again)
        .unwrap();
    assert_eq!(first, again);
    c.reset(None, None, &mut again).unwrap();
    assert_eq!(second, again);
    // Construction seeds env i with seed + i and resets once.
    let mut d1 = EnvBatch::new(
        Chain::<Spatial>::new(params(2)),
        t.clone(),
        1,
        78,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    assert_eq!(mk().state(1), d1.state(0));
    let mut obs = vec![0.0; d];
    d1.reset(Some(&[Some(6)]), None, &mut obs).unwrap();
    assert_eq!(&obs[..], &first[d..]);
}

#[test]
fn snapshots_continue_identically() {
    let mut t = task(2);
    t.start_noise = 0.25;
    t.max_episode_steps = 7;
    let mk = || {
        EnvBatch::new(
            Chain::<Planar>::new(params(2)),
            t.clone(),
            CHUNK + 3,
            1,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap()
    };
    let mut a = mk();
    run(&mut a, 10, 3, 0, CHUNK + 3);
    let snap = a.snapshot();
    let mut b = mk();
    b.restore(&snap).unwrap();
    assert_eq!(
        run(&mut a, 20, 4, 0, CHUNK + 3),
        run(&mut b, 20, 4, 0, CHUNK + 3)
    );
    let mut bad = snap.clone();
    bad.states[3] = f64::NAN;
    assert!(b.restore(&bad).is_err());
    bad.states.pop();
    assert!(b.restore(&bad).is_err());
}

#[test]
fn observations_are_the_states_in_the_requested_precision() {
    let mut t = task(2);
    t.start_noise = 0.2;
    let mut b = EnvBatch::new(
        Chain::<Spatial>::new(params(2)),
        t,
        3,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let d = b.state_dim();
    assert_eq!((d, b.force_dim()), (16, 2));
    let mut out = Out::<f32>::new(3, d);
    b.step(&[0.1; 6], out.buffers()).unwrap();
    for (o, s) in out.obs.iter().zip(b.states()) {
        assert_eq!(*o, *s as f32);
    }
    let mut obs64 = vec![0.0f64; 3 * d];
    b.write_obs(&mut obs64).unwrap();
    assert_eq!(obs64, b.states());
}

#[test]
fn construction_errors_name_the_problem() {
    let chain = || Chain::<Planar>::new(params(1));
    let t = task(1);
    let e = EnvBatch::new(chain(), t.clone(), 0, 0, AutoresetMode::NextStep, false)
        .err()
        .unwrap();
    assert!(e.to_string().contains("num_envs"), "{e}");
    let mut bad = t.clone();
    bad.target = vec![-1.0, -1.0];
    let e = EnvBatch::new(chain(), bad, 1, 0, AutoresetMode::NextStep, false)
        .err()
        .unwrap();
    assert!(
        e.to_string().contains("target has length 2, expected 1"),
        "{e}"
    );
    let mut bad = t;
    bad.start = Start::Paper(PaperFigure::Fig2);
    let e = EnvBatch::new(chain(), bad, 1, 0, AutoresetMode::NextStep, false)
        .err()
        .unwrap();
    assert!(e.to_string().contains("n_links = 1"), "{e}");
}

#[test]
fn episode_ends_report_the_envs_that_ended_and_nothing_else() {
    use super::event::{ENDED, NUMERICAL_FAILURE, OUT_OF_TRACK, RESET, SUCCESS};
    let events = [
        0,
        ENDED | SUCCESS,
        RESET,
        ENDED | OUT_OF_TRACK,
        ENDED | NUMERICAL_FAILURE,
        SUCCESS,
    ];
    let errors: Vec<f64> = (0..2 * events.len()).map(|i| i as f64 + 0.5).collect();
    let ends = super::EpisodeEnds::from_events(&events, &errors);
    assert_eq!(ends.ended, [false, true, false, true, true, false]);
    assert_eq!(ends.success, [false, true, false, false, false, false]);
    assert_eq!(ends.out_of_track, [false, false, false, true, false, false]);
    assert_eq!(
        ends.numerical_failure,
        [false, false, false, false, true, false]
    );
    assert_eq!(ends.e_q, [0.0, 2.5, 0.0, 6.5, 8.5, 0.0]);
    assert_eq!(ends.e_w, [0.0, 3.5, 0.0, 7.5, 9.5, 0.0]);
}

#[test]
fn a_batch_from_a_checked_task_is_the_batch_new_builds_and_a_bad_task_fails_its_check() {
    use crate::env::CheckedTask;
    let chain = Chain::<Planar>::new(params(2));
    let mut t = task(2);
    t.start_noise = 0.2;
    let checked = CheckedTask::new(chain.clone(), t.clone()).unwrap();
    assert_eq!(checked.task(), &t);
    let run = |mut b: EnvBatch<Planar>| {
        let mut out = Out::<f64>::new(3, b.state_dim());
        for k in 0..50 {
            let a = [0.3 * (k as f64).sin(), -0.7, 1.0];
            b.step(&a, out.buffers()).unwrap();
        }
        (b.states().to_vec(), out.obs.clone(), out.rewards.clone())
    };
    let mode = AutoresetMode::NextStep;
    let new = EnvBatch::new(chain.clone(), t.clone(), 3, 5, mode, false).unwrap();
    let from_checked = EnvBatch::from_checked(checked, 3, 5, mode, false).unwrap();
    assert_eq!(run(new), run(from_checked));
    t.dt = -0.01;
    let by_new = EnvBatch::new(chain.clone(), t.clone(), 3, 5, mode, false)
        .err()
        .unwrap();
    let by_check = CheckedTask::new(chain, t).err().unwrap();
    assert_eq!(by_new.to_string(), by_check.to_string());
    assert!(by_check.to_string().contains("dt"), "{by_check}");
}

/// Steps two unforced envs of a planar double pendulum from `start` toward the upright
/// target with `fall_limit` until the first termination (or 300 steps); the step
/// index, events and `e_q` of each env at its end.
fn unforced_until_ended(start: Start, fall_limit: f64) -> Vec<(Option<usize>, u8, f64)> {
    unforced_until_ended_held(start, fall_limit, 0.0)
}

/// [`unforced_until_ended`] with a `fall_hold` of `hold` seconds.
fn unforced_until_ended_held(
    start: Start,
    fall_limit: f64,
    hold: f64,
) -> Vec<(Option<usize>, u8, f64)> {
    let mut t = task(2);
    t.fall_hold = hold;
    t.start = start;
    t.start_noise = 0.05;
    t.max_episode_steps = 1000;
    t.track_limit = 1e300;
    t.fall_limit = fall_limit;
    let mut b = EnvBatch::new(
        Chain::<Planar>::new(params(2)),
        t,
        2,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let mut out = Out::<f64>::new(2, b.state_dim());
    let mut ends = vec![(None, 0, 0.0); 2];
    for k in 0..300 {
        b.step(&[0.0, 0.0], out.buffers()).unwrap();
        for (i, end) in ends.iter_mut().enumerate() {
            if end.0.is_none() && out.terminated[i] {
                *end = (Some(k), b.events()[i], b.errors()[2 * i]);
            }
        }
    }
    ends
}

#[test]
fn a_lost_balance_ends_the_episode_as_a_fall() {
    for (k, events, e_q) in unforced_until_ended(Start::Target, 0.5) {
        assert!(k.is_some_and(|k| k > 0), "fell at {k:?}");
        assert_eq!(events, event::ENDED | event::FELL);
        // The first state beyond the limit ends it: the falling chain is still near it.
        assert!(e_q > 0.5 && e_q < 1.0, "e_q {e_q}");
    }
    // Without the limit the same chains fall over and the episodes run on.
    for (k, ..) in unforced_until_ended(Start::Target, 0.0) {
        assert_eq!(k, None);
    }
}

#[test]
fn a_fall_counts_only_after_the_chain_stayed_within_the_limit_for_the_hold() {
    let dt = task(2).dt;
    let unheld = unforced_until_ended(Start::Target, 0.5);
    // Step k ends the episode: steps 0..k (k of them) were within the limit.
    let within: Vec<usize> = unheld.iter().map(|end| end.0.unwrap()).collect();
    let shortest = *within.iter().min().unwrap();
    assert!(shortest > 2, "fell after {shortest} steps");
    // A hold the chains met: the same falls at the same steps.
    let met = unforced_until_ended_held(Start::Target, 0.5, (shortest as f64 - 0.5) * dt);
    assert_eq!(met, unheld);
    // A hold longer than every chain stayed within: no fall is ever armed.
    let longest = *within.iter().max().unwrap();
    for (k, ..) in unforced_until_ended_held(Start::Target, 0.5, (longest as f64 + 0.5) * dt) {
        assert_eq!(k, None);
    }
}

#[test]
fn a_chain_that_never_came_within_the_fall_limit_does_not_fall() {
    // Hanging, the upright target's e_q is about 4: far outside, never caught.
    for (k, ..) in unforced_until_ended(Start::Equilibrium(vec![1.0, 1.0]), 0.5) {
        assert_eq!(k, None);
    }
}
