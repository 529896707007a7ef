//! The RL task layer's step and reset allocate nothing.

use super::counter::allocations_of;
use chaincart::engine::CHUNK;
use chaincart::env::{
    AutoresetMode, Distribution, EnvBatch, ForceNoise, ParamRandomization, StepOutputs, TaskConfig,
};
use chaincart::lanes::Precision;
use chaincart::{ChainParams, SpatialChain, StepOptions};

#[test]
fn env_steps_and_resets_allocate_nothing() {
    for mode in [
        AutoresetMode::NextStep,
        AutoresetMode::SameStep,
        AutoresetMode::Disabled,
    ] {
        // N = 1 steps env by env, the others through the lane kernel; each also in f32.
        for (n, reality, precision) in [1, CHUNK, 8 * CHUNK].into_iter().flat_map(|n| {
            [
                (false, Precision::F64),
                (true, Precision::F64),
                (true, Precision::F32),
            ]
            .map(|(reality, precision)| (n, reality, precision))
        }) {
            let mut task = TaskConfig::new(vec![-1.0; 3], 0.01, StepOptions::default());
            // Short episodes and a narrow track: every kind of episode end happens.
            task.max_episode_steps = 3;
            task.track_limit = 0.05;
            task.start_noise = 0.1;
            if reality {
                // Per-env parameters drawn at every reset, noise, delay, rate limit,
                // force noise.
                let scale = Some(ParamRandomization {
                    distribution: Distribution::relative(0.3),
                    per_link: true,
                });
                task.reality.randomize.link_masses = scale;
                task.reality.randomize.cart_mass = scale;
                task.reality.obs_noise = vec![0.01];
                task.reality.action_delay = 2;
                task.reality.force_rate_limit = 200.0;
                task.reality.force_noise = ForceNoise {
                    multiplicative: 0.1,
                    additive: 0.5,
                };
            }
            let chain = SpatialChain::new(ChainParams::uniform(3, 1.0, 0.1, 0.3, 9.81).unwrap());
            let mut batch = EnvBatch::new(chain, task, n, 1, mode, true).unwrap();
            batch.set_precision(precision).unwrap();
            assert_eq!(
                batch.kernel().is_some(),
                n > 1 || precision == Precision::F32
            );
            let d = batch.state_dim();
            let (mut obs, mut rewards) = (vec![0.0f32; n * d], vec![0.0; n]);
            let (mut terminated, mut truncated) = (vec![false; n], vec![false; n]);
            let actions: Vec<f64> = (0..2 * n).map(|j| (j % 5) as f64 * 0.5 - 1.0).collect();
            let seeds: Vec<Option<u64>> = (0..n as u64).map(Some).collect();
            let all = vec![true; n];
            let mut run = |batch: &mut EnvBatch<_>| {
                for _ in 0..4 {
                    let out = StepOutputs {
                        obs: &mut obs,
                        rewards: &mut rewards,
                        terminated: &mut terminated,
                        truncated: &mut truncated,
                    };
                    if mode == AutoresetMode::Disabled && (0..n).any(|k| batch.has_ended(k)) {
                        batch.reset(None, Some(&all), &mut obs).unwrap();
                    } else {
                        batch.step(&actions, out).unwrap();
                    }
                }
                batch.reset(Some(&seeds), None, &mut obs).unwrap();
            };
            run(&mut batch); // warm up the workers' scratch
            let (during, here) = allocations_of(|| run(&mut batch));
            eprintln!(
                "{mode:?} N = {n} reality {reality} {precision:?} (kernel {:?}): {during} allocations ({here} on the calling thread)",
                batch.kernel()
            );
            assert_eq!(here, 0, "{mode:?} N = {n} reality {reality} {precision:?}");
            assert_eq!(
                during, 0,
                "{mode:?} N = {n} reality {reality} {precision:?}"
            );
        }
    }
}

#[test]
fn drawn_rig_effects_allocate_nothing() {
    let mut task = TaskConfig::new(vec![-1.0; 3], 0.01, StepOptions::default());
    task.max_episode_steps = 3;
    task.start_noise = 0.1;
    let range = |high| {
        Some(ParamRandomization {
            distribution: Distribution::Range { low: 0.0, high },
            per_link: true,
        })
    };
    task.reality.randomize.joint_damping = range(0.05);
    task.reality.randomize.cart_coulomb_friction = range(1.0);
    let n = CHUNK + 1;
    let chain = SpatialChain::new(ChainParams::uniform(3, 1.0, 0.1, 0.3, 9.81).unwrap());
    let mut batch = EnvBatch::new(chain, task, n, 1, AutoresetMode::SameStep, true).unwrap();
    let d = batch.state_dim();
    let (mut obs, mut rewards) = (vec![0.0f32; n * d], vec![0.0; n]);
    let (mut terminated, mut truncated) = (vec![false; n], vec![false; n]);
    let actions: Vec<f64> = (0..2 * n).map(|j| (j % 5) as f64 * 0.5 - 1.0).collect();
    let mut run = |batch: &mut EnvBatch<_>| {
        for _ in 0..7 {
            let out = StepOutputs {
                obs: &mut obs,
                rewards: &mut rewards,
                terminated: &mut terminated,
                truncated: &mut truncated,
            };
            batch.step(&actions, out).unwrap();
        }
        batch.reset(None, None, &mut obs).unwrap();
    };
    run(&mut batch); // warm up the workers' scratch
    assert_eq!(allocations_of(|| run(&mut batch)), (0, 0));
}
