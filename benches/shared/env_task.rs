//! The env-batch task the Rust benchmark (`benches/dynamics.rs`) and the throughput
//! example (`examples/env_throughput.rs`) both time, so that their numbers describe
//! the same work: the default scene's task (rk4 with 2 substeps, 20 ms) with short
//! episodes, so that resets are included, and one of the reality-gap variants.

use chaincart::env::{Distribution, ParamRandomization, TaskConfig};
use chaincart::{Method, StepOptions};

/// The reality-gap variants: off; cart mass, link masses and lengths within +-25 %
/// redrawn at every reset; sensor noise 0.01 plus a one-step control delay.
pub const VARIANTS: [&str; 3] = ["off", "randomized", "noise_delay"];

/// The default-scene task on `n` links with the reality-gap variant `variant` (one
/// of [`VARIANTS`]; anything else is the "off" task).
pub fn env_task(n: usize, variant: &str) -> TaskConfig {
    let opts = StepOptions::new(Method::Rk4, 2).unwrap();
    let mut task = TaskConfig::new(vec![-1.0; n], 0.02, opts);
    task.max_episode_steps = 50;
    let scale = Some(ParamRandomization {
        distribution: Distribution::relative(0.25),
        per_link: true,
    });
    match variant {
        "randomized" => {
            task.reality.randomize.cart_mass = scale;
            task.reality.randomize.link_masses = scale;
            task.reality.randomize.link_lengths = scale;
        }
        "noise_delay" => {
            task.reality.obs_noise = vec![0.01];
            task.reality.action_delay = 1;
        }
        _ => {}
    }
    task
}
