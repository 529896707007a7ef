//! Encoders of the task layer: readings on the grid, velocities estimated from the
//! counts (and filtered), the true state untouched, single envs equal to a batch's,
//! snapshots, and the checks.

use chaincart::engine::CHUNK;
use chaincart::env::{AngleReference, AutoresetMode, EnvBatch, Sensors, StepOutputs, TaskConfig};
use chaincart::lanes::LaneScene;
use chaincart::{Chain, ChainParams, Planar, Spatial, StepOptions};
use std::f64::consts::PI;

const DT: f64 = 0.02;
const ANGLE_COUNTS: u32 = 2000;
const CART_COUNTS: f64 = 5000.0;

fn task(n: usize, sensors: Sensors) -> TaskConfig {
    let mut t = TaskConfig::new(vec![-1.0; n], DT, StepOptions::default());
    t.max_episode_steps = 30;
    t.start_noise = 0.2;
    t.max_force = 20.0;
    t.sensors = sensors;
    t
}

fn encoders(velocity_filter: f64) -> Sensors {
    Sensors {
        angle_counts: Some(ANGLE_COUNTS),
        cart_counts: Some(CART_COUNTS),
        velocity_filter,
        angle_reference: AngleReference::Vertical,
    }
}

fn batch<G: LaneScene>(
    t: TaskConfig,
    num_envs: usize,
    seed: u64,
    mode: AutoresetMode,
) -> EnvBatch<G> {
    let n = t.target.len();
    let p = ChainParams::new(1.0, &vec![0.1; n], &vec![0.5; n], 9.81).unwrap();
    EnvBatch::new(Chain::new(p), t, num_envs, seed, mode, false).unwrap()
}

fn actions(step: usize, len: usize) -> Vec<f64> {
    (0..len)
        .map(|j| (0.4 * step as f64 + 1.3 * j as f64).sin())
        .collect()
}

/// Observations (the reset's first, then one per step) and events per step.
struct Run {
    obs: Vec<Vec<f64>>,
    events: Vec<Vec<u8>>,
    states: Vec<Vec<f64>>,
}

fn run<G: LaneScene>(b: &mut EnvBatch<G>, steps: usize, env0: usize) -> Run {
    let n = b.num_envs();
    let mut obs = vec![0.0; n * b.obs_dim()];
    b.write_obs(&mut obs).unwrap();
    let mut r = Run {
        obs: vec![obs.clone()],
        events: vec![vec![event_reset(); n]],
        states: vec![b.states().to_vec()],
    };
    let (mut rewards, mut terminated, mut truncated) =
        (vec![0.0; n], vec![false; n], vec![false; n]);
    let f = b.force_dim();
    for s in 0..steps {
        let a = actions(s, (env0 + n) * f);
        b.step(
            &a[env0 * f..],
            StepOutputs {
                obs: &mut obs,
                rewards: &mut rewards,
                terminated: &mut terminated,
                truncated: &mut truncated,
            },
        )
        .unwrap();
        r.obs.push(obs.clone());
        r.events.push(b.events().to_vec());
        r.states.push(b.states().to_vec());
    }
    r
}

fn event_reset() -> u8 {
    chaincart::env::event::RESET
}

fn is_integer(x: f64, tol: f64) -> bool {
    (x - x.round()).abs() <= tol
}

/// `d` wrapped into `[-pi, pi)`.
fn wrap(d: f64) -> f64 {
    d - 2.0 * PI * ((d + PI) / (2.0 * PI)).floor()
}

/// The encoder angles each link of an observation shows: planar `[theta]`, spatial
/// `[theta, phi]` with `q = (cos phi sin theta, -sin phi, cos phi cos theta)`.
fn link_angles(planar: bool, n: usize, obs: &[f64]) -> Vec<Vec<f64>> {
    let c = if planar { 1 } else { 2 };
    let l = if planar { 2 } else { 3 };
    (0..n)
        .map(|i| {
            let q = &obs[2 * c + i * l..2 * c + (i + 1) * l];
            if planar {
                vec![q[0].atan2(q[1])]
            } else {
                vec![q[0].atan2(q[2]), (-q[1]).atan2(q[0].hypot(q[2]))]
            }
        })
        .collect()
}

/// The angular velocity of angle rates at the observed direction, from the gimbal's
/// frame: `omega = theta' e2 + phi' R_y(theta) e1`, less its part along `q`.
fn spin_of_rates(theta: f64, phi: f64, theta_rate: f64, phi_rate: f64) -> [f64; 3] {
    let q = [phi.cos() * theta.sin(), -phi.sin(), phi.cos() * theta.cos()];
    let omega = [phi_rate * theta.cos(), theta_rate, -phi_rate * theta.sin()];
    let along: f64 = (0..3).map(|m| omega[m] * q[m]).sum();
    [
        omega[0] - along * q[0],
        omega[1] - along * q[1],
        omega[2] - along * q[2],
    ]
}

fn check_grid(planar: bool, n: usize, obs: &[f64], what: &str) {
    let c = if planar { 1 } else { 2 };
    for x in &obs[..c] {
        assert!(is_integer(x * CART_COUNTS, 1e-8), "{what}: x = {x}");
    }
    for (i, angles) in link_angles(planar, n, obs).iter().enumerate() {
        for a in angles {
            let counts = a * ANGLE_COUNTS as f64 / (2.0 * PI);
            assert!(
                is_integer(counts, 1e-8),
                "{what}: link {i} angle {a} = {counts} counts"
            );
        }
    }
}

fn readings_sit_on_the_grid<G: LaneScene>(planar: bool) {
    let n = 2;
    let mut b = batch::<G>(task(n, encoders(0.0)), 3, 21, AutoresetMode::NextStep);
    let r = run(&mut b, 70, 0);
    let d = b.obs_dim();
    for (s, obs) in r.obs.iter().enumerate() {
        for env in 0..3 {
            check_grid(
                planar,
                n,
                &obs[env * d..(env + 1) * d],
                &format!("step {s} env {env}"),
            );
        }
    }
}

#[test]
fn planar_readings_sit_on_the_grid() {
    readings_sit_on_the_grid::<Planar>(true);
}

#[test]
fn spatial_readings_sit_on_the_grid() {
    readings_sit_on_the_grid::<Spatial>(false);
}

/// The expected velocity part of `now` from the readings `before` and `now` (no
/// filter): cart `dx / dt`, links the unwrapped angle changes over `dt` (spatial:
/// mapped to the angular velocity at `now`). Zero when `now` is a first reading.
fn finite_differences(
    planar: bool,
    n: usize,
    before: &[f64],
    now: &[f64],
    first: bool,
) -> Vec<f64> {
    let c = if planar { 1 } else { 2 };
    let mut v = Vec::new();
    for k in 0..c {
        v.push(if first {
            0.0
        } else {
            (now[k] - before[k]) / DT
        });
    }
    let (a0, a1) = (link_angles(planar, n, before), link_angles(planar, n, now));
    let mut w = Vec::new();
    for i in 0..n {
        if first {
            w.extend(vec![0.0; if planar { 1 } else { 3 }]);
            continue;
        }
        let theta_rate = wrap(a1[i][0] - a0[i][0]) / DT;
        if planar {
            w.push(theta_rate);
        } else {
            let phi_rate = (a1[i][1] - a0[i][1]) / DT;
            w.extend(spin_of_rates(a1[i][0], a1[i][1], theta_rate, phi_rate));
        }
    }
    v.extend(w);
    v
}

/// The velocity components of an observation: cart velocity, then the spins.
fn velocities(planar: bool, n: usize, obs: &[f64]) -> Vec<f64> {
    let (c, l) = if planar { (1, 2) } else { (2, 3) };
    let mut v = obs[c..2 * c].to_vec();
    v.extend(&obs[2 * c + n * l..]);
    v
}

fn velocities_follow_the_counts<G: LaneScene>(planar: bool, tau: f64) {
    velocities_follow_the_counts_of::<G>(planar, encoders(tau));
}

fn velocities_follow_the_counts_of<G: LaneScene>(planar: bool, sensors: Sensors) {
    let (n, tau) = (2, sensors.velocity_filter);
    let mut b = batch::<G>(task(n, sensors), 2, 5, AutoresetMode::NextStep);
    let r = run(&mut b, 75, 0);
    let d = b.obs_dim();
    let gain = if tau > 0.0 {
        1.0 - (-DT / tau).exp()
    } else {
        1.0
    };
    let mut resets = 0;
    for s in 1..r.obs.len() {
        for env in 0..2 {
            let row = |t: usize| &r.obs[t][env * d..(env + 1) * d];
            let first = r.events[s][env] & event_reset() != 0;
            resets += first as usize;
            let raw = finite_differences(planar, n, row(s - 1), row(s), first);
            let previous = velocities(planar, n, row(s - 1));
            let got = velocities(planar, n, row(s));
            for (k, (&g, &r)) in got.iter().zip(&raw).enumerate() {
                let expected = if first {
                    0.0
                } else {
                    previous[k] + gain * (r - previous[k])
                };
                assert!(
                    (g - expected).abs() < 1e-7 * (1.0 + r.abs()),
                    "tau {tau} step {s} env {env} velocity {k}: {g} vs {expected}"
                );
            }
        }
    }
    assert!(resets >= 2, "the run covers autoresets: {resets}");
}

#[test]
fn planar_velocities_are_the_finite_differences_of_the_readings() {
    velocities_follow_the_counts::<Planar>(true, 0.0);
}

#[test]
fn spatial_velocities_are_the_finite_differences_of_the_readings() {
    velocities_follow_the_counts::<Spatial>(false, 0.0);
}

#[test]
fn filtered_velocities_follow_the_first_order_recurrence() {
    velocities_follow_the_counts::<Planar>(true, 0.06);
    velocities_follow_the_counts::<Spatial>(false, 0.03);
}

#[test]
fn estimates_track_the_true_velocities() {
    // The estimate is the period's mean velocity, within a count per period (0.01 m/s
    // for the cart, 0.16 rad/s for a link).
    let mut b = batch::<Planar>(task(2, encoders(0.0)), 1, 3, AutoresetMode::NextStep);
    let r = run(&mut b, 20, 0);
    for s in 2..r.obs.len() {
        if r.events[s][0] != 0 {
            continue;
        }
        let mean = |k: usize| (r.states[s][k] + r.states[s - 1][k]) / 2.0;
        let (v, w1) = (r.obs[s][1], r.obs[s][6]);
        assert!(
            (v - mean(1)).abs() < 0.05 + 0.1 * mean(1).abs(),
            "step {s}: {v} vs {}",
            mean(1)
        );
        assert!(
            (w1 - mean(6)).abs() < 0.2 + 0.1 * mean(6).abs(),
            "step {s}: {w1} vs {}",
            mean(6)
        );
    }
}

#[test]
fn sensing_leaves_the_physics_and_the_lanes_alone() {
    let mut sensed = batch::<Spatial>(
        task(2, encoders(0.05)),
        CHUNK + 2,
        8,
        AutoresetMode::SameStep,
    );
    let mut exact = batch::<Spatial>(
        task(2, Sensors::default()),
        CHUNK + 2,
        8,
        AutoresetMode::SameStep,
    );
    assert_eq!(sensed.kernel(), exact.kernel());
    assert!(exact.kernel().is_some(), "rk4 steps on the lanes");
    let (a, b) = (run(&mut sensed, 40, 0), run(&mut exact, 40, 0));
    assert_eq!(a.states, b.states);
    assert_eq!(a.events, b.events);
    assert_ne!(a.obs, b.obs);
    // Without encoders (nor noise, nor an observed goal) the observation is the state.
    for (obs, y) in b.obs.iter().zip(&b.states) {
        assert_eq!(obs, y);
    }
}

#[test]
fn only_the_channels_with_an_encoder_are_quantised() {
    let cart_only = Sensors {
        cart_counts: Some(100.0),
        ..Sensors::default()
    };
    let mut b = batch::<Planar>(task(1, cart_only), 1, 2, AutoresetMode::NextStep);
    let r = run(&mut b, 10, 0);
    for (obs, y) in r.obs.iter().zip(&r.states) {
        assert!(is_integer(obs[0] * 100.0, 1e-9));
        assert_eq!(&obs[2..], &y[2..], "links exact");
    }
}

fn env_i_is_the_single_env<G: LaneScene>() {
    env_i_is_the_single_env_with::<G>(encoders(0.04));
}

fn env_i_is_the_single_env_with<G: LaneScene>(sensors: Sensors) {
    let mut t = task(2, sensors);
    t.reality.obs_noise = vec![0.003];
    let num_envs = CHUNK + 3;
    let mut big = batch::<G>(t.clone(), num_envs, 40, AutoresetMode::SameStep);
    let all = run(&mut big, 50, 0);
    let d = big.obs_dim();
    for env in [0, 1, CHUNK + 2] {
        let mut one = batch::<G>(t.clone(), 1, 40 + env as u64, AutoresetMode::SameStep);
        let single = run(&mut one, 50, env);
        for (s, obs) in single.obs.iter().enumerate() {
            assert_eq!(
                &obs[..],
                &all.obs[s][env * d..(env + 1) * d],
                "env {env} step {s}"
            );
        }
        let finals = one.final_states().to_vec();
        assert_eq!(&finals[..], &big.final_states()[env * d..(env + 1) * d]);
    }
}

#[test]
fn env_i_of_a_batch_is_the_single_env_seeded_seed_plus_i() {
    env_i_is_the_single_env::<Planar>();
    env_i_is_the_single_env::<Spatial>();
}

#[test]
fn noisy_readings_stay_on_the_grid_and_reproduce() {
    let mut t = task(2, encoders(0.0));
    t.reality.obs_noise = vec![0.01];
    let go = || {
        let mut b = batch::<Spatial>(t.clone(), 2, 13, AutoresetMode::NextStep);
        run(&mut b, 30, 0).obs
    };
    let obs = go();
    assert_eq!(obs, go(), "same seed, same readings");
    for (s, o) in obs.iter().enumerate() {
        for env in 0..2 {
            check_grid(false, 2, &o[env * 16..(env + 1) * 16], &format!("step {s}"));
        }
    }
    let mut quiet = t.clone();
    quiet.reality.obs_noise.clear();
    let mut b = batch::<Spatial>(quiet, 2, 13, AutoresetMode::NextStep);
    assert_ne!(
        run(&mut b, 30, 0).obs,
        obs,
        "the noise moves readings across grid lines"
    );
}

#[test]
fn a_snapshot_continues_the_readings_and_their_filter() {
    let t = task(2, encoders(0.05));
    let mut b = batch::<Planar>(t.clone(), 3, 17, AutoresetMode::NextStep);
    run(&mut b, 12, 0);
    let snap = b.snapshot();
    let ahead = run(&mut b, 20, 0);
    let mut other = batch::<Planar>(t, 3, 99, AutoresetMode::NextStep);
    other.restore(&snap).unwrap();
    assert_eq!(run(&mut other, 20, 0).obs, ahead.obs);
}

#[test]
fn set_state_is_a_first_reading() {
    let mut b = batch::<Planar>(task(1, encoders(0.0)), 1, 1, AutoresetMode::NextStep);
    run(&mut b, 5, 0);
    let theta: f64 = 2.0;
    b.set_state(0, &[0.3, 1.0, theta.sin(), theta.cos(), 2.0])
        .unwrap();
    let mut obs = vec![0.0; 5];
    b.write_obs(&mut obs).unwrap();
    assert_eq!(
        (obs[1], obs[4]),
        (0.0, 0.0),
        "no estimate without a previous count"
    );
    assert_eq!(obs[0], (0.3 * CART_COUNTS).floor() / CART_COUNTS);
}

#[test]
fn bad_sensor_values_are_named() {
    let cases = [
        (
            Sensors {
                angle_counts: Some(0),
                ..Sensors::default()
            },
            "angle_encoder_counts",
        ),
        (
            Sensors {
                cart_counts: Some(f64::INFINITY),
                ..Sensors::default()
            },
            "cart_encoder_counts",
        ),
        (
            Sensors {
                velocity_filter: 0.1,
                ..Sensors::default()
            },
            "velocity_filter",
        ),
    ];
    for (sensors, name) in cases {
        let e = refusal::<Planar>(1, sensors);
        assert!(e.contains(name) && e.contains("expected"), "{e}");
    }
}

/// The error a batch of `n` links with `sensors` is refused with.
fn refusal<G: LaneScene>(n: usize, sensors: Sensors) -> String {
    let p = ChainParams::new(1.0, &vec![0.1; n], &vec![0.5; n], 9.81).unwrap();
    EnvBatch::<G>::new(
        Chain::new(p),
        task(n, sensors),
        1,
        0,
        AutoresetMode::NextStep,
        false,
    )
    .err()
    .expect("refused")
    .to_string()
}

#[test]
fn encoders_count_what_the_noisy_sensor_sees() {
    // The same noise draws as without encoders: an encoder's reading is the noisy
    // value rounded down, and a channel without an encoder is the noisy value itself.
    let mut noisy = task(1, Sensors::default());
    noisy.reality.obs_noise = vec![0.02];
    let mut counted = noisy.clone();
    counted.sensors = Sensors {
        angle_counts: Some(ANGLE_COUNTS),
        ..Sensors::default()
    };
    let a = run(
        &mut batch::<Planar>(noisy, 1, 6, AutoresetMode::NextStep),
        25,
        0,
    );
    let b = run(
        &mut batch::<Planar>(counted, 1, 6, AutoresetMode::NextStep),
        25,
        0,
    );
    let step = 2.0 * PI / ANGLE_COUNTS as f64;
    for (s, (seen, read)) in a.obs.iter().zip(&b.obs).enumerate() {
        assert_eq!(
            &read[..2],
            &seen[..2],
            "step {s}: the cart is read as without encoders"
        );
        let count = (seen[2].atan2(seen[3]) / step).floor();
        assert_eq!(read[2], (count * step).sin(), "step {s}");
        assert_eq!(read[3], (count * step).cos(), "step {s}");
    }
}

fn joint_encoders(velocity_filter: f64) -> Sensors {
    Sensors {
        angle_reference: AngleReference::Joint,
        ..encoders(velocity_filter)
    }
}

#[test]
fn joint_encoder_velocities_are_the_finite_differences_of_the_readings() {
    for tau in [0.0, 0.05] {
        velocities_follow_the_counts_of::<Planar>(true, joint_encoders(tau));
    }
}

/// Joint encoders: each joint's angle (a reading less the reading above) sits on the
/// grid, each reading lags the true angle by less than one count per joint above it
/// (the first link reads as a vertical encoder does), and the cart reads as before.
#[test]
fn joint_encoders_read_env_i_of_a_batch_as_the_single_env() {
    env_i_is_the_single_env_with::<Planar>(joint_encoders(0.04));
}

#[test]
fn joint_readings_sum_the_counts_of_the_joints_above() {
    let n = 3;
    let step = 2.0 * PI / ANGLE_COUNTS as f64;
    let mut joint = batch::<Planar>(task(n, joint_encoders(0.0)), 2, 8, AutoresetMode::NextStep);
    let mut vertical = batch::<Planar>(task(n, encoders(0.0)), 2, 8, AutoresetMode::NextStep);
    let (r, v) = (run(&mut joint, 60, 0), run(&mut vertical, 60, 0));
    let (d, sd) = (joint.obs_dim(), joint.state_dim());
    let mut lags = vec![0.0f64; n];
    for s in 0..r.obs.len() {
        for env in 0..2 {
            let obs = &r.obs[s][env * d..(env + 1) * d];
            let reads = link_angles(true, n, obs);
            let truth = link_angles(true, n, &r.states[s][env * sd..(env + 1) * sd]);
            let mut above = 0.0;
            for i in 0..n {
                let joint_angle = wrap(reads[i][0] - above);
                assert!(
                    is_integer(joint_angle / step, 1e-7),
                    "step {s} joint {i}: {joint_angle}"
                );
                let lag = wrap(truth[i][0] - reads[i][0]);
                assert!(
                    (-1e-9..(i + 1) as f64 * step).contains(&lag),
                    "step {s} link {i}: lags {lag} with {} joints above",
                    i + 1
                );
                lags[i] = lags[i].max(lag);
                above = reads[i][0];
            }
            let same = &v.obs[s][env * d..(env + 1) * d];
            assert_eq!(
                obs[..4],
                same[..4],
                "step {s}: the cart and the first link read as before"
            );
        }
    }
    assert!(
        lags[2] > step,
        "a third link carries more than one count: {lags:?}"
    );
}

#[test]
fn joint_encoders_are_refused_without_counts_and_on_spatial_chains() {
    let without_counts = Sensors {
        angle_counts: None,
        ..joint_encoders(0.0)
    };
    let e = refusal::<Planar>(2, without_counts);
    assert!(
        e.contains("angle_encoder_reference") && e.contains("angle_encoder_counts"),
        "{e}"
    );
    let e = refusal::<Spatial>(2, joint_encoders(0.0));
    assert!(
        e.contains("angle_encoder_reference") && e.contains("planar chain"),
        "{e}"
    );
}
