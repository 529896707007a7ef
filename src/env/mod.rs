//! The reinforcement-learning task layer, pure Rust: a target equilibrium, a start
//! distribution, reward, termination, success and autoreset for a batch of envs,
//! on top of the batch engine ([`crate::engine::Engine`]). The Python envs
//! (`chaincart_env`) are thin front ends over [`EnvBatch`].
//!
//! * `keys`, `scenes`: the one table of configuration keys and the named scenes.
//! * `config`, `reality`, `sensors`, `start`: the task's types, the reality gap,
//!   the encoders, start states.
//! * [`measure`]: what the task reads of a state (reward, errors), also in the lanes.
//! * `batch`, `step`, `outputs`: the env batch, one step of a chunk of envs, what a
//!   step hands back.
//!
//! **Action.** Normalised force `a` (2 numbers spatial, 1 planar), clipped to
//! `[-1, 1]` per axis, times [`TaskConfig::max_force`]; held for one control period
//! [`TaskConfig::dt`]. NaN or infinite actions are refused for the whole batch before
//! any env moves.
//!
//! **Observation.** The state in the scene's layout (spatial `4 + 6n`, planar
//! `2 + 3n`), cast to `f32` or `f64`; with encoders (`sensors`) the quantised
//! positions and the velocities estimated from them.
//!
//! **Reward.** `r = exp(-c)` in `(0, 1]`, with
//! `c = w_q sum_i |q_i - s_i e3|^2 + w_w sum_i |w_i|^2 + w_x |x|^2 + w_v |xdot|^2 + w_u |a|^2`
//! evaluated after the step ([`RewardWeights`], defaults `1, 0.1, 0.1, 0.1, 0.01`). It is
//! 1 exactly at the target with the cart at rest at the origin and no force, smooth
//! everywhere, and `|q_i - s_i e3|^2 = 2 (1 - cos tilt_i)`. The step on which the
//! integration fails is rewarded 0.
//!
//! **Episode end.** Terminated when `max_k |x_k| > track_limit` (out of track) or when
//! the integration fails (non-finite state, `| |q_i| - 1 | > 1e-6`, or an implicit
//! solver gives up; the env keeps its last good state, so observations stay finite),
//! and, with `fall_limit > 0`, at a fall: `e_q` beyond the limit after an earlier step
//! of the episode came within it. Truncated when the episode reaches `max_episode_steps` (both flags may be set
//! together). A success is an episode that is truncated without being terminated with
//! the paper's `e_q <= tol_q` and `e_w <= tol_w` ([`SuccessTolerances`], defaults 0.1 and
//! 0.5).
//!
//! **Start.** A base state ([`Start`]: the target, another equilibrium, a paper figure's
//! initial condition, or an explicit state) plus uniform noise in every local
//! coordinate, documented in `start`.

mod batch;
mod config;
mod goals;
mod keys;
mod measure;
mod outputs;
mod reality;
mod scenes;
mod sensors;
mod start;
mod step;

pub use batch::{CheckedTask, EnvBatch, Snapshot, RNG_BYTES};
pub use config::{
    target_signs, AutoresetMode, PaperFigure, RewardKind, RewardWeights, Start, SuccessTolerances,
    TaskConfig, START_NAMES, TARGET_NAMES,
};
pub use goals::{Ends, Transitions, MAX_DRAWN_LINKS};
pub use keys::{
    config_key, ConfigKey, Destination, KeyKind, KeyValue, SetTask, Setting, Value, ANY,
    CONFIG_KEYS, DEFAULT_MOTOR, KEY_NAMES,
};
pub use measure::{measure, MeasureInto, RewardSpec, StateMeasure};
pub use outputs::{event, EpisodeEnds, Real, StepOutputs, DIAGNOSTICS};
pub use reality::{
    Distribution, EnvParams, ForceNoise, Param, ParamRandomization, ParamValues, Randomization,
    RealityGap, RigParam, ACTION_DELAY_EXPECTED, FORCE_RATE_LIMIT_EXPECTED, RANDOMIZE_NAMES,
};
pub use scenes::{Scene, DEFAULT_SCENE, SCENES};
pub use sensors::{AngleReference, Sensors, ANGLE_COUNTS_EXPECTED};
pub use start::{base_state, paper_initial_condition, perturb};

#[cfg(test)]
mod tests;
