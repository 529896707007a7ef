//! What a step of an env batch hands back besides its state: the per-step outputs
//! written into the caller's buffers, the event bits and diagnostics of each env, and
//! the episode-end info built from them.

/// Bits of [`super::EnvBatch::events`], one byte per env, set by the last step or reset.
pub mod event {
    /// The episode ended on this step (terminated or truncated).
    pub const ENDED: u8 = 1;
    /// Ended at the time limit, not terminated, with `e_q`, `e_w` within tolerance.
    pub const SUCCESS: u8 = 2;
    /// Terminated because `max |x_k| > track_limit`.
    pub const OUT_OF_TRACK: u8 = 4;
    /// Terminated because the integration failed; the env kept its last good state.
    pub const NUMERICAL_FAILURE: u8 = 8;
    /// Next-step autoreset: this call reset the env instead of stepping it.
    pub const RESET: u8 = 16;
    /// Terminated because `e_q` left `fall_limit` after coming within it.
    pub const FELL: u8 = 32;
}

/// Diagnostics per env, in this order, when enabled: total, kinetic and potential
/// energy, largest `| |q_i| - 1 |`, largest `|w_i . q_i|` (the length of the columns of
/// [`super::EnvBatch::diagnostics`]).
pub const DIAGNOSTICS: [&str; 5] = [
    "energy",
    "kinetic_energy",
    "potential_energy",
    "residual_unit_length",
    "residual_tangency",
];

/// The episode-end info of one step, one entry per env: false / zero where the
/// episode did not end.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EpisodeEnds {
    /// The episode ended (terminated or truncated).
    pub ended: Vec<bool>,
    /// It ended at the time limit within the success tolerances.
    pub success: Vec<bool>,
    /// It was terminated by a failed integration step.
    pub numerical_failure: Vec<bool>,
    /// It was terminated by the cart leaving the track.
    pub out_of_track: Vec<bool>,
    /// It was terminated by a fall (`fall_limit`).
    pub fell: Vec<bool>,
    /// `e_q` of the state it ended in.
    pub e_q: Vec<f64>,
    /// `e_w` of the state it ended in.
    pub e_w: Vec<f64>,
}

impl EpisodeEnds {
    /// From a step's [`event`] bits and interleaved `(e_q, e_w)` errors. Reads the
    /// errors of the envs that ended only: right after a step the arrays sit in the
    /// caches of the threads that wrote them, and a few dozen ended envs are much
    /// cheaper to fetch than every env's errors.
    pub fn from_events(events: &[u8], errors: &[f64]) -> Self {
        let n = events.len();
        let mut ends = Self {
            ended: vec![false; n],
            success: vec![false; n],
            numerical_failure: vec![false; n],
            out_of_track: vec![false; n],
            fell: vec![false; n],
            e_q: vec![0.0; n],
            e_w: vec![0.0; n],
        };
        for (k, &bits) in events.iter().enumerate() {
            if bits & event::ENDED == 0 {
                continue;
            }
            ends.ended[k] = true;
            ends.success[k] = bits & event::SUCCESS != 0;
            ends.numerical_failure[k] = bits & event::NUMERICAL_FAILURE != 0;
            ends.out_of_track[k] = bits & event::OUT_OF_TRACK != 0;
            ends.fell[k] = bits & event::FELL != 0;
            ends.e_q[k] = errors[2 * k];
            ends.e_w[k] = errors[2 * k + 1];
        }
        ends
    }
}

/// Element type of caller-provided observation and action buffers.
pub trait Real: Copy + Send + Sync + 'static {
    /// The number closest to `v`.
    fn from_f64(v: f64) -> Self;
    /// The number as f64.
    fn to_f64(self) -> f64;
}
impl Real for f32 {
    /// Rounds to nearest, saturating at `+-f32::MAX`: a finite state gives a finite
    /// observation.
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v.clamp(-(f32::MAX as f64), f32::MAX as f64) as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}
impl Real for f64 {
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}

/// Per-step outputs written into caller-provided buffers, env-major.
pub struct StepOutputs<'a, T: Real> {
    /// `num_envs * state_dim` observations (the state, cast to `T`).
    pub obs: &'a mut [T],
    /// One reward per env.
    pub rewards: &'a mut [f64],
    /// Per env: the episode terminated (off track or failed).
    pub terminated: &'a mut [bool],
    /// Per env: the episode reached its time limit.
    pub truncated: &'a mut [bool],
}
