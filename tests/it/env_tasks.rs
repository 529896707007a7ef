//! The task options for large motions: the bounded reward, success held over the last
//! seconds, and goal-conditioned tasks (pairs drawn per reset, the target observed,
//! saved and restored with the rest of a batch).

use chaincart::env::{
    event, AutoresetMode, Ends, EnvBatch, RewardKind, Start, StepOutputs, TaskConfig, Transitions,
};
use chaincart::{Chain, ChainParams, Method, Planar, Spatial, StepOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn chain<G: chaincart::lanes::LaneScene>(n: usize) -> Chain<G> {
    Chain::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap())
}

fn upright(n: usize) -> TaskConfig {
    let mut t = TaskConfig::new(
        vec![-1.0; n],
        0.02,
        StepOptions::new(Method::Rk4, 2).unwrap(),
    );
    t.max_force = 20.0;
    t
}

/// Steps `b` `steps` times with the actions `action(step, env)`; returns per step the
/// rewards and events.
fn run<G: chaincart::lanes::LaneScene>(
    b: &mut EnvBatch<G>,
    steps: usize,
    action: impl Fn(usize, usize) -> f64,
) -> Vec<(Vec<f64>, Vec<u8>, Vec<f64>)> {
    let (n, f, od) = (b.num_envs(), b.force_dim(), b.obs_dim());
    let mut obs = vec![0.0f64; n * od];
    let (mut rewards, mut terminated, mut truncated) =
        (vec![0.0; n], vec![false; n], vec![false; n]);
    (0..steps)
        .map(|s| {
            let actions: Vec<f64> = (0..n * f).map(|j| action(s, j / f)).collect();
            let out = StepOutputs {
                obs: &mut obs,
                rewards: &mut rewards,
                terminated: &mut terminated,
                truncated: &mut truncated,
            };
            b.step(&actions, out).unwrap();
            (rewards.clone(), b.events().to_vec(), obs.clone())
        })
        .collect()
}

/// Every reward of 64 envs of `task` pushed at random for 400 steps.
fn pushed_rewards<G: chaincart::lanes::LaneScene>(chain: Chain<G>, task: &TaskConfig) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let pushes: Vec<f64> = (0..400 * 64).map(|_| rng.random_range(-1.5..1.5)).collect();
    let mut b = EnvBatch::new(chain, task.clone(), 64, 1, AutoresetMode::SameStep, false).unwrap();
    run(&mut b, 400, |s, k| pushes[s * 64 + k])
        .into_iter()
        .flat_map(|r| r.0)
        .collect()
}

#[test]
fn the_tolerance_reward_is_one_at_rest_on_the_target_and_stays_in_zero_one() {
    let mut task = upright(2);
    task.reward_kind = RewardKind::Tolerance;
    task.start_noise = 0.0;
    let mut b = EnvBatch::new(
        chain::<Planar>(2),
        task.clone(),
        1,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let (rewards, _, _) = &run(&mut b, 1, |_, _| 0.0)[0];
    // One step from rest at the (unstable) equilibrium: still at rest on it.
    assert!((rewards[0] - 1.0).abs() < 1e-9, "{}", rewards[0]);
    // Random pushes from everywhere: every reward within [0, 1], many far below 1.
    task.start = Start::Equilibrium(vec![1.0, 1.0]);
    task.start_noise = 1.0;
    task.max_episode_steps = 50;
    for spatial in [false, true] {
        let rewards = if spatial {
            pushed_rewards(chain::<Spatial>(2), &task)
        } else {
            pushed_rewards(chain::<Planar>(2), &task)
        };
        assert!(rewards.iter().all(|r| (0.0..=1.0).contains(r)));
        let low = rewards.iter().filter(|&&r| r < 0.3).count();
        assert!(
            low > rewards.len() / 10,
            "{low} of {} below 0.3",
            rewards.len()
        );
    }
}

#[test]
fn success_needs_the_errors_held_within_tolerance_for_the_hold_time() {
    // At rest at the hanging equilibrium: within tolerance on every one of 30 steps
    // (0.6 s). A success when 0, 0.3 or 0.6 s must be held, not when 0.62 or 1 s.
    for (hold, success) in [
        (0.0, true),
        (0.3, true),
        (0.6, true),
        (0.62, false),
        (1.0, false),
    ] {
        let mut task = upright(2);
        task.target = vec![1.0, 1.0];
        task.start_noise = 0.0;
        task.max_episode_steps = 30;
        task.success_hold = hold;
        let mut b = EnvBatch::new(
            chain::<Planar>(2),
            task,
            1,
            0,
            AutoresetMode::NextStep,
            false,
        )
        .unwrap();
        let trace = run(&mut b, 30, |_, _| 0.0);
        let last = trace.last().unwrap().1[0];
        assert!(last & event::ENDED != 0);
        assert_eq!(last & event::SUCCESS != 0, success, "hold {hold} s");
    }
    // Pushed at 0.4 s: the undamped swing leaves the tolerance, and the episode that
    // succeeds without the push fails.
    let mut task = upright(1);
    task.target = vec![1.0];
    task.start_noise = 0.0;
    task.max_episode_steps = 150;
    task.success_hold = 2.0;
    let mut b = EnvBatch::new(
        chain::<Planar>(1),
        task.clone(),
        1,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let pushed = run(&mut b, 150, |s, _| if s == 20 { 1.0 } else { 0.0 });
    // Without the push the same episode succeeds (the hold is within the 3 s).
    let mut b = EnvBatch::new(
        chain::<Planar>(1),
        task,
        1,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .unwrap();
    let calm = run(&mut b, 150, |_, _| 0.0);
    assert!(calm.last().unwrap().1[0] & event::SUCCESS != 0);
    assert!(pushed.last().unwrap().1[0] & event::SUCCESS == 0);
}

#[test]
fn a_restored_goal_conditioned_batch_continues_identically() {
    let mut task = upright(2);
    task.transitions = Some(Transitions::between(2, Ends::Any, Ends::Any, false).unwrap());
    task.goal_observation = true;
    task.reward_kind = RewardKind::Tolerance;
    task.success_hold = 0.1;
    task.max_episode_steps = 7;
    task.start_noise = 0.2;
    let mut b = EnvBatch::new(
        chain::<Spatial>(2),
        task,
        9,
        4,
        AutoresetMode::SameStep,
        false,
    )
    .unwrap();
    let push = |s: usize, k: usize| ((s * 7 + k * 3) % 11) as f64 / 5.0 - 1.0;
    run(&mut b, 5, push);
    let snap = b.snapshot();
    let first = run(&mut b, 20, push);
    b.restore(&snap).unwrap();
    let again = run(&mut b, 20, push);
    assert_eq!(first, again);
    // Same-step resets drew new pairs during the run: the targets differ across envs.
    let targets: std::collections::BTreeSet<Vec<i64>> = (0..9)
        .map(|k| b.env_target(k).unwrap().iter().map(|&s| s as i64).collect())
        .collect();
    assert!(targets.len() > 1);
}
