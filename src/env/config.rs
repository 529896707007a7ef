//! The task: which equilibrium to reach, where episodes start, how they are scored
//! and when they end. Plain data, checked once by [`TaskConfig::validate`].

use super::goals::Transitions;
use super::reality::RealityGap;
use super::sensors::Sensors;
use crate::analysis::{check_signs, named_signs};
use crate::engine::check_precision;
use crate::error::{check_finite, check_positive, ChainError, InputError, Result};
use crate::integrate::Method;
use crate::integrate::{Guard, StepOptions};
use crate::lanes::Precision;
use crate::params::{Actuation, Rig};

/// Names accepted for a target equilibrium (besides a sign tuple).
pub const TARGET_NAMES: [&str; 7] = [
    "hanging",
    "inverted",
    "folded",
    "folded_up",
    "paper-fig1",
    "paper-fig2",
    "paper-fig3",
];

/// Names accepted for a start (besides a sign tuple or a full state): `"target"`
/// and the target names.
pub const START_NAMES: [&str; 8] = {
    let mut names = ["target"; 8];
    let mut i = 0;
    while i < TARGET_NAMES.len() {
        names[i + 1] = TARGET_NAMES[i];
        i += 1;
    }
    names
};

/// Names of the rewards (`RewardKind`).
pub const REWARD_NAMES: [&str; 2] = ["exp", "tolerance"];

/// Default half-width of the start noise.
pub const DEFAULT_START_NOISE: f64 = 0.05;
/// Default track limit, m.
pub const DEFAULT_TRACK_LIMIT: f64 = 2.4;
/// Default episode length, steps.
pub const DEFAULT_MAX_EPISODE_STEPS: i64 = 500;
/// Default force of a unit action, N.
pub const DEFAULT_MAX_FORCE: f64 = 20.0;

/// Default reward weights `[q, w, x, v, u]` (see `RewardWeights`): a tilt of 0.3 rad
/// costs 9% of the reward, a hanging link (|q - s e3|^2 = 4) leaves 2%, and the cart,
/// the rates and the force only shape the reward near the target.
pub const DEFAULT_REWARD_WEIGHTS: [f64; 5] = [1.0, 0.1, 0.1, 0.1, 0.01];
/// Default success tolerances `[e_q, e_w]`: about 6 degrees of tilt and 0.5 rad/s in total.
pub const DEFAULT_SUCCESS_TOLERANCES: [f64; 2] = [0.1, 0.5];

/// Default acceleration of a unit action in the `acceleration` actuation, m/s^2.
pub const DEFAULT_MAX_ACCELERATION: f64 = 10.0;
/// Default voltage of a unit action in the `voltage` actuation, V.
pub const DEFAULT_MAX_VOLTAGE: f64 = 12.0;

/// The paper's numerical examples (Sec. V). Figs. 1 and 2 share the initial
/// condition IC1; Fig. 3 has its own. All three are defined for n = 5 links.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PaperFigure {
    /// Uncontrolled motion from IC1, near the folded equilibrium s = (-1, 1, -1, 1, -1).
    Fig1,
    /// LQR stabilisation of the hanging equilibrium from IC1.
    Fig2,
    /// LQR stabilisation of s = (-1, -1, -1, 1, 1) from the Fig. 3 initial condition.
    Fig3,
}

impl PaperFigure {
    /// The figures' names, as the configuration writes them.
    pub const NAMES: [&'static str; 3] = ["paper-fig1", "paper-fig2", "paper-fig3"];
    /// The figure with this scene name (`"paper-fig1"`, ...).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "paper-fig1" => Some(Self::Fig1),
            "paper-fig2" => Some(Self::Fig2),
            "paper-fig3" => Some(Self::Fig3),
            _ => None,
        }
    }
    /// The name of this item as the configuration writes it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Fig1 => "paper-fig1",
            Self::Fig2 => "paper-fig2",
            Self::Fig3 => "paper-fig3",
        }
    }
    /// The equilibrium the figure is about: Fig. 1 starts near it, Figs. 2-3 stabilise it.
    pub fn target(self) -> Vec<f64> {
        match self {
            Self::Fig1 => vec![-1.0, 1.0, -1.0, 1.0, -1.0],
            Self::Fig2 => vec![1.0; 5],
            Self::Fig3 => vec![-1.0, -1.0, -1.0, 1.0, 1.0],
        }
    }
}

/// A target equilibrium given by name: the four equilibrium names of
/// [`named_signs`] or a paper figure's equilibrium (n = 5 only).
pub fn target_signs(name: &str, n: usize) -> Result<Vec<f64>> {
    if let Some(fig) = PaperFigure::from_name(name) {
        check_paper_links(fig, n)?;
        return Ok(fig.target());
    }
    named_signs(name, n).map_err(|e| match e {
        ChainError::Input(InputError::UnknownName { kind, name, .. }) => InputError::UnknownName {
            kind,
            name,
            expected: &TARGET_NAMES,
        }
        .into(),
        other => other,
    })
}

pub(crate) fn check_paper_links(fig: PaperFigure, n: usize) -> Result<()> {
    if n == crate::params::PAPER_LINKS {
        return Ok(());
    }
    Err(InputError::InvalidParameter {
        name: "n_links",
        value: n as f64,
        expected: match fig {
            PaperFigure::Fig1 => "5 for the paper's Fig. 1 (\"paper-fig1\")",
            PaperFigure::Fig2 => "5 for the paper's Fig. 2 (\"paper-fig2\")",
            PaperFigure::Fig3 => "5 for the paper's Fig. 3 (\"paper-fig3\")",
        },
    }
    .into())
}

/// Where episodes start, before the noise of [`TaskConfig::start_noise`].
#[derive(Debug, Clone, PartialEq)]
pub enum Start {
    /// At the target equilibrium.
    Target,
    /// At the equilibrium with these signs (e.g. hanging, for swing-up).
    Equilibrium(Vec<f64>),
    /// The initial condition of one of the paper's figures (n = 5).
    Paper(PaperFigure),
    /// An explicit state in the scene's layout (checked: length, finite, `|q_i| = 1`,
    /// `w_i . q_i = 0`).
    State(Vec<f64>),
}

impl Start {
    /// `"target"`, a paper figure, or an equilibrium name.
    pub fn from_name(name: &str, n: usize) -> Result<Self> {
        if name == "target" {
            return Ok(Self::Target);
        }
        if let Some(fig) = PaperFigure::from_name(name) {
            return Ok(Self::Paper(fig));
        }
        named_signs(name, n)
            .map(Self::Equilibrium)
            .map_err(|e| match e {
                ChainError::Input(InputError::UnknownName { name, .. }) => {
                    InputError::UnknownName {
                        kind: "start",
                        name,
                        expected: &START_NAMES,
                    }
                    .into()
                }
                other => other,
            })
    }
}

/// Weights of the reward `r = exp(-c)`,
/// `c = q sum_i |q_i - s_i e3|^2 + w sum_i |w_i|^2 + x |x|^2 + v |xdot|^2 + u |a|^2`
/// (`a` the clipped, normalised action). All must be finite and >= 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardWeights {
    /// Weight of the link direction errors `sum_i |q_i - s_i e3|^2`.
    pub q: f64,
    /// Weight of the angular velocities `sum_i |w_i|^2`.
    pub w: f64,
    /// Weight of the cart position `|x|^2`.
    pub x: f64,
    /// Weight of the cart velocity `|xdot|^2`.
    pub v: f64,
    /// Weight of the normalised action `|a|^2`.
    pub u: f64,
}

impl Default for RewardWeights {
    /// `q = 1, w = 0.1, x = 0.1, v = 0.1, u = 0.01`: a tilt of 0.3 rad costs 9% of the
    /// reward, a hanging link (|q - s e3|^2 = 4) leaves 2%, and the cart, the rates and
    /// the force only shape the reward near the target.
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl RewardWeights {
    /// The default weights (see [`Default`]).
    pub const DEFAULT: Self = Self {
        q: DEFAULT_REWARD_WEIGHTS[0],
        w: DEFAULT_REWARD_WEIGHTS[1],
        x: DEFAULT_REWARD_WEIGHTS[2],
        v: DEFAULT_REWARD_WEIGHTS[3],
        u: DEFAULT_REWARD_WEIGHTS[4],
    };
    /// `[q, w, x, v, u]`.
    pub const fn as_array(&self) -> [f64; 5] {
        [self.q, self.w, self.x, self.v, self.u]
    }
    /// From `[q, w, x, v, u]`.
    pub fn from_array(a: [f64; 5]) -> Self {
        Self {
            q: a[0],
            w: a[1],
            x: a[2],
            v: a[3],
            u: a[4],
        }
    }
    /// Checks that every weight is finite and >= 0.
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("reward_weights.q", self.q),
            ("reward_weights.w", self.w),
            ("reward_weights.x", self.x),
            ("reward_weights.v", self.v),
            ("reward_weights.u", self.u),
        ] {
            check_non_negative(name, value)?;
        }
        Ok(())
    }
}

/// An episode that reaches its time limit (and was not terminated) is a success when
/// the paper's errors `e_q = sum |q_i - s_i e3|` and `e_w = sum |w_i|` are at most these.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SuccessTolerances {
    /// Largest `e_q` of a success.
    pub e_q: f64,
    /// Largest `e_w` of a success.
    pub e_w: f64,
}

impl Default for SuccessTolerances {
    /// `e_q <= 0.1` (about 6 degrees of tilt in total) and `e_w <= 0.5` rad/s in total.
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SuccessTolerances {
    /// The default tolerances (see [`Default`]).
    pub const DEFAULT: Self = Self {
        e_q: DEFAULT_SUCCESS_TOLERANCES[0],
        e_w: DEFAULT_SUCCESS_TOLERANCES[1],
    };
    /// `[e_q, e_w]`.
    pub const fn as_array(&self) -> [f64; 2] {
        [self.e_q, self.e_w]
    }
}

/// The per-step reward of a task.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RewardKind {
    /// `exp(-c)` with the quadratic cost `c` of [`RewardWeights`]: sharp near the
    /// target, next to nothing far from it.
    #[default]
    Exp,
    /// A bounded reward in [0, 1] for large motions, the same scale in every scene:
    /// `(upright + near) / 2 * centred * gentle` (see `super::measure::tolerance_reward`).
    Tolerance,
}

impl RewardKind {
    /// The accepted names.
    pub const NAMES: [&'static str; 2] = REWARD_NAMES;
    /// The kind with this name, or an error listing the names.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "exp" => Ok(Self::Exp),
            "tolerance" => Ok(Self::Tolerance),
            _ => Err(InputError::UnknownName {
                kind: "reward",
                name: name.to_string(),
                expected: &Self::NAMES,
            }
            .into()),
        }
    }
}

/// How a vector of envs restarts episodes (Gymnasium's `AutoresetMode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AutoresetMode {
    /// The step after an episode ended resets that env (its action is ignored) and
    /// returns the first observation with reward 0 and both flags false.
    #[default]
    NextStep,
    /// An env whose episode ends is reset in the same step: the returned observation is
    /// the new episode's first, the last one is kept as the final observation.
    SameStep,
    /// Ended envs stay ended until reset explicitly; stepping one is an error.
    Disabled,
}

impl AutoresetMode {
    /// The accepted names, for error messages.
    pub const NAMES: [&'static str; 3] = ["next_step", "same_step", "disabled"];
    /// The mode with this name, or an error listing the names.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "next_step" => Ok(Self::NextStep),
            "same_step" => Ok(Self::SameStep),
            "disabled" => Ok(Self::Disabled),
            _ => Err(InputError::UnknownName {
                kind: "autoreset_mode",
                name: name.to_string(),
                expected: &Self::NAMES,
            }
            .into()),
        }
    }
    /// The name of this item as the configuration writes it.
    pub fn name(self) -> &'static str {
        match self {
            Self::NextStep => "next_step",
            Self::SameStep => "same_step",
            Self::Disabled => "disabled",
        }
    }
}

/// Everything that defines the RL task on top of a chain.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskConfig {
    /// Target equilibrium `s` (`+1` hanging link, `-1` upright link).
    pub target: Vec<f64>,
    /// Where episodes start, before the noise.
    pub start: Start,
    /// Half-width of the uniform start noise in every local coordinate (see
    /// `crate::env::start`); 0 starts every episode exactly at the base state.
    pub start_noise: f64,
    /// Control period (seconds): one env step.
    pub dt: f64,
    /// Integrator and substeps per control period.
    pub step_options: StepOptions,
    /// Force (N) of a normalised action of magnitude 1, per cart axis. 0 makes the
    /// env uncontrolled.
    pub max_force: f64,
    /// The episode terminates when `max(|x_1|, |x_2|) > track_limit` (metres).
    pub track_limit: f64,
    /// The episode is truncated after this many steps.
    pub max_episode_steps: u64,
    /// Weights of the reward.
    pub reward: RewardWeights,
    /// Which reward: the quadratic cost's `exp(-c)` or the bounded tolerance reward.
    pub reward_kind: RewardKind,
    /// When an episode that reaches its time limit is a success.
    pub success: SuccessTolerances,
    /// Seconds the errors must have stayed within the tolerances at the end of an
    /// episode for a success (0: the last step alone).
    pub success_hold: f64,
    /// An episode whose `e_q` has come within this bound (for `fall_hold`) ends
    /// (terminated, "fell") at the first later step beyond it: a balance or a caught
    /// swing-up that is lost ends there instead of running on (0: never).
    pub fall_limit: f64,
    /// Seconds `e_q` must stay within `fall_limit` before a later step beyond it is a
    /// fall (0: one step), so that a swing passing through the limit on its way up
    /// does not count as a catch that was lost.
    pub fall_hold: f64,
    /// Goal-conditioned tasks: the (start, target) pairs every reset draws from (the
    /// `target` and `start` fields then hold the first pair's).
    pub transitions: Option<Transitions>,
    /// The observation ends with the target's signs (one per link).
    pub goal_observation: bool,
    /// When a step counts as a numerical failure.
    pub guard: Guard,
    /// Parameter mismatch and randomisation, sensor noise, delay and rate limit
    /// (default: none of them).
    pub reality: RealityGap,
    /// Number type of the physics: f64, or f32 on the rk4 lane kernel.
    pub precision: Precision,
    /// Real-rig effects of the true system: joint damping, cart friction and what the
    /// action commands (default: none, a force).
    pub rig: Rig,
    /// Acceleration (m/s^2) of a normalised action of magnitude 1, per cart axis, when
    /// the rig's actuation is `acceleration`.
    pub max_acceleration: f64,
    /// Motor voltage (V) of a normalised action of magnitude 1, per cart axis, when the
    /// rig's actuation is `voltage`.
    pub max_voltage: f64,
    /// The encoders of the observed state (default: none, the exact state).
    pub sensors: Sensors,
}

impl TaskConfig {
    /// A task with the configuration's defaults ([`super::keys::CONFIG_KEYS`]: start
    /// noise, force, track, episode length, reward and tolerances), starting at the
    /// target.
    pub fn new(target: Vec<f64>, dt: f64, step_options: StepOptions) -> Self {
        Self {
            target,
            start: Start::Target,
            start_noise: DEFAULT_START_NOISE,
            dt,
            step_options,
            max_force: DEFAULT_MAX_FORCE,
            track_limit: DEFAULT_TRACK_LIMIT,
            max_episode_steps: DEFAULT_MAX_EPISODE_STEPS as u64,
            reward: RewardWeights::default(),
            reward_kind: RewardKind::Exp,
            guard: Guard::default(),
            success: SuccessTolerances::default(),
            success_hold: 0.0,
            fall_limit: 0.0,
            fall_hold: 0.0,
            transitions: None,
            goal_observation: false,
            reality: RealityGap::default(),
            precision: Precision::F64,
            rig: Rig::default(),
            max_acceleration: DEFAULT_MAX_ACCELERATION,
            max_voltage: DEFAULT_MAX_VOLTAGE,
            sensors: Sensors::default(),
        }
    }

    /// The command of a normalised action of magnitude 1 in the rig's actuation mode:
    /// `max_force` (N), `max_acceleration` (m/s^2) or `max_voltage` (V).
    #[inline(always)]
    pub fn command_scale(&self) -> f64 {
        match self.rig.actuation {
            Actuation::Force => self.max_force,
            Actuation::Acceleration => self.max_acceleration,
            Actuation::Voltage(_) => self.max_voltage,
        }
    }

    /// Checks every field for a chain of `n` links (the start state itself is checked
    /// when it is built, see [`crate::env::start::base_state`]).
    pub fn validate(&self, n: usize) -> Result<()> {
        check_signs(&self.target, n).map_err(|e| match e {
            ChainError::Input(InputError::LengthMismatch { got, expected, .. }) => {
                InputError::LengthMismatch {
                    name: "target",
                    got,
                    expected,
                }
                .into()
            }
            other => other,
        })?;
        match &self.start {
            Start::Equilibrium(s) => {
                check_signs(s, n).map_err(|e| match e {
                    ChainError::Input(InputError::LengthMismatch { got, expected, .. }) => {
                        InputError::LengthMismatch {
                            name: "start",
                            got,
                            expected,
                        }
                        .into()
                    }
                    other => other,
                })?;
            }
            Start::Paper(fig) => check_paper_links(*fig, n)?,
            Start::State(y) => check_finite("start", y)?,
            Start::Target => {}
        }
        check_non_negative("start_noise", self.start_noise)?;
        check_positive("dt", self.dt)?;
        self.step_options.validate()?;
        self.guard.validate()?;
        check_non_negative("max_force", self.max_force)?;
        check_positive("track_limit", self.track_limit)?;
        if self.max_episode_steps == 0 {
            return Err(InputError::InvalidParameter {
                name: "max_episode_steps",
                value: 0.0,
                expected: "an integer >= 1",
            }
            .into());
        }
        self.reward.validate()?;
        check_positive("success_tolerances.e_q", self.success.e_q)?;
        check_positive("success_tolerances.e_w", self.success.e_w)?;
        check_non_negative("success_hold", self.success_hold)?;
        check_non_negative("fall_limit", self.fall_limit)?;
        check_non_negative("fall_hold", self.fall_hold)?;
        check_precision(self.precision, self.step_options.method, &self.guard)?;
        check_non_negative("max_acceleration", self.max_acceleration)?;
        check_non_negative("max_voltage", self.max_voltage)?;
        self.rig.validate(n)?;
        self.reality.randomize.validate_rig(&self.rig)?;
        self.sensors.validate()?;
        self.check_rig_stepping()
    }

    /// A rig with real effects steps env by env in f64, by an integrator other than
    /// the variational one.
    fn check_rig_stepping(&self) -> Result<()> {
        if self.rig.is_ideal() && !self.reality.randomize.draws_rig() {
            return Ok(());
        }
        if self.step_options.method == Method::Variational {
            return Err(crate::integrate::variational_needs_ideal_chain());
        }
        if self.precision != Precision::F64 {
            return Err(InputError::Incompatible {
                name: "precision",
                value: self.precision.name(),
                expected: "\"f64\" with joint damping, cart friction or an actuation other than \
                           force (f32 runs on the SIMD lane kernel, which steps the ideal model \
                           only)"
                    .to_string(),
            }
            .into());
        }
        Ok(())
    }
}

impl TaskConfig {
    /// Consecutive steps within the tolerances that end a successful episode: the
    /// hold time in control periods (rounded up), at least the last step.
    pub fn hold_steps(&self) -> u32 {
        self.periods_in(self.success_hold)
            .clamp(1.0, u32::MAX as f64) as u32
    }

    /// Consecutive steps within `fall_limit` that arm a fall: `fall_hold` in control
    /// periods (rounded up), at least one step.
    pub fn fall_arm_steps(&self) -> u16 {
        self.periods_in(self.fall_hold).clamp(1.0, u16::MAX as f64) as u16
    }

    /// Control periods that cover `seconds`, rounded up (a rounding error's worth over
    /// a whole number of periods does not add one).
    fn periods_in(&self, seconds: f64) -> f64 {
        (seconds / self.dt - 1e-9).ceil()
    }

    /// The target of pair `goal` of a goal-conditioned task, else the target.
    #[inline(always)]
    pub fn target_of(&self, goal: u16) -> &[f64] {
        match &self.transitions {
            Some(t) => t.target(goal as usize),
            None => &self.target,
        }
    }

    /// Numbers per observation: the state, then the target's signs if observed.
    pub fn obs_dim(&self, state_dim: usize) -> usize {
        state_dim
            + if self.goal_observation {
                self.target.len()
            } else {
                0
            }
    }
}

fn check_non_negative(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(InputError::InvalidParameter {
            name,
            value,
            expected: "a finite number >= 0",
        }
        .into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn task(n: usize) -> TaskConfig {
        TaskConfig::new(vec![-1.0; n], 0.02, StepOptions::default())
    }

    type Spoiler = Box<dyn Fn(&mut TaskConfig)>;

    #[test]
    fn names_resolve_to_signs() {
        assert_eq!(target_signs("inverted", 2).unwrap(), vec![-1.0, -1.0]);
        assert_eq!(
            target_signs("paper-fig3", 5).unwrap(),
            vec![-1.0, -1.0, -1.0, 1.0, 1.0]
        );
        assert_eq!(
            target_signs("paper-fig1", 5).unwrap(),
            named_signs("folded_up", 5).unwrap()
        );
        assert_eq!(Start::from_name("target", 3).unwrap(), Start::Target);
        assert_eq!(
            Start::from_name("hanging", 2).unwrap(),
            Start::Equilibrium(vec![1.0, 1.0])
        );
        assert_eq!(
            Start::from_name("paper-fig2", 5).unwrap(),
            Start::Paper(PaperFigure::Fig2)
        );
    }

    #[test]
    fn bad_names_say_what_is_accepted() {
        let e = target_signs("upright", 2).unwrap_err().to_string();
        assert!(e.contains("\"upright\"") && e.contains("paper-fig3"), "{e}");
        let e = Start::from_name("upside", 2).unwrap_err().to_string();
        assert!(e.contains("start") && e.contains("\"target\""), "{e}");
        let e = target_signs("paper-fig3", 2).unwrap_err().to_string();
        assert!(e.contains("n_links = 2") && e.contains("Fig. 3"), "{e}");
        let e = AutoresetMode::from_name("sometimes")
            .unwrap_err()
            .to_string();
        assert!(e.contains("same_step"), "{e}");
    }

    #[test]
    fn validation_names_the_bad_field() {
        assert!(task(2).validate(2).is_ok());
        let e = task(2).validate(3).unwrap_err();
        assert_eq!(
            e,
            InputError::LengthMismatch {
                name: "target",
                got: 2,
                expected: 3
            }
            .into()
        );
        let mut t = task(1);
        t.target = vec![0.5];
        assert!(matches!(
            t.validate(1),
            Err(ChainError::Input(InputError::InvalidSign { index: 0, .. }))
        ));
        let cases: Vec<(&str, Spoiler)> = vec![
            ("start_noise", Box::new(|t| t.start_noise = -0.1)),
            ("dt", Box::new(|t| t.dt = 0.0)),
            ("max_force", Box::new(|t| t.max_force = f64::NAN)),
            ("track_limit", Box::new(|t| t.track_limit = -1.0)),
            ("max_episode_steps", Box::new(|t| t.max_episode_steps = 0)),
            ("reward_weights.u", Box::new(|t| t.reward.u = -1.0)),
            ("success_tolerances.e_w", Box::new(|t| t.success.e_w = 0.0)),
        ];
        for (name, spoil) in cases {
            let mut t = task(1);
            spoil(&mut t);
            let e = t.validate(1).unwrap_err().to_string();
            assert!(e.contains(name), "{name}: {e}");
        }
        let mut t = task(2);
        t.start = Start::Equilibrium(vec![1.0]);
        assert!(t.validate(2).unwrap_err().to_string().contains("start"));
        t.start = Start::Paper(PaperFigure::Fig1);
        assert!(t.validate(2).unwrap_err().to_string().contains("n_links"));
        // max_force = 0 is an uncontrolled env, not an error.
        let mut t = task(1);
        t.max_force = 0.0;
        assert!(t.validate(1).is_ok());
    }
}
