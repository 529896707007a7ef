//! The configuration keys of an env: the one definition of every key's name, the
//! values it accepts, its default, its help text and where its value goes. The Python
//! configuration (`ChainCartConfig`), its documentation table, the env docstring and
//! the command line's option help are all read or generated from [`CONFIG_KEYS`]; the
//! scenes (`scenes`) are named sets of values on top of these defaults.
//!
//! A key of the task carries the closure that sets its field
//! ([`Destination::Task`]); resolving a configuration applies them all in table order
//! ([`TaskConfig::apply_keys`]), so adding such a key is its entry here and the field
//! it sets. The keys read together (the chain's parameters, the task's ends, the
//! reality gap) say which group they belong to.
//!
//! The defaults are the default scene's values (the planar double inverted pendulum):
//! a scene that sets nothing is the default scene. Ranges are checked where the core
//! builds the parameters and the task ([`crate::params::ChainParams::new`],
//! `TaskConfig::validate`, `RealityGap::validate`); each key's
//! [`ConfigKey::expected`] says in words what those checks accept (a test holds the
//! two together), and `TaskConfig::new` holds the table's defaults (a test too).

use super::config::{
    RewardKind, RewardWeights, SuccessTolerances, TaskConfig, DEFAULT_MAX_ACCELERATION,
    DEFAULT_MAX_EPISODE_STEPS, DEFAULT_MAX_FORCE, DEFAULT_MAX_VOLTAGE, DEFAULT_REWARD_WEIGHTS,
    DEFAULT_START_NOISE, DEFAULT_SUCCESS_TOLERANCES, DEFAULT_TRACK_LIMIT, REWARD_NAMES,
};
use crate::env::sensors::AngleReference;
use crate::error::{ChainError, InputError, Result};
use crate::integrate::Method;
use crate::lanes::Precision;
use crate::params::{Actuation, Motor, DEFAULT_COULOMB_VELOCITY, STANDARD_GRAVITY};
use crate::render::ViewKind;
use std::sync::LazyLock;

/// A value as the key table and the scenes write it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KeyValue {
    /// Absent: the feature is off.
    None,
    /// An integer.
    Int(i64),
    /// A number.
    Float(f64),
    /// True or false.
    Bool(bool),
    /// A name (an equilibrium, an integrator, a dtype, a scene).
    Name(&'static str),
    /// A fixed number of numbers (reward weights, success tolerances).
    Floats(&'static [f64]),
    /// A relative half-width of domain randomisation per parameter name.
    Relative(&'static [(&'static str, f64)]),
}

/// What a key accepts, which decides how a Python value is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyKind {
    /// One of the scene names of [`super::scenes::SCENES`].
    Scene,
    /// An integer (an integral float such as `2.0` is accepted too).
    Integer,
    /// A real number.
    Number,
    /// True or false.
    Flag,
    /// One number for every link, or one per link.
    PerLink,
    /// One of these names.
    Choice(&'static [&'static str]),
    /// An equilibrium: one of [`super::TARGET_NAMES`] or a sign tuple.
    Equilibrium,
    /// A start: one of [`super::START_NAMES`], a sign tuple or a full state.
    Start,
    /// Named numbers: a mapping with some of these names (the others keep their
    /// defaults) or a sequence of exactly as many numbers.
    NamedNumbers(&'static [&'static str]),
    /// A sequence of exactly as many numbers as these names.
    Numbers(&'static [&'static str]),
    /// A reality-gap keyword, read by the reality-gap conversion.
    RealityGap,
    /// A list of (start, target) pairs of equilibria, each a name or a sign tuple.
    Transitions,
}

/// One configuration key.
#[derive(Debug, Clone, Copy)]
pub struct ConfigKey {
    /// The keyword.
    pub name: &'static str,
    /// What values it takes.
    pub kind: KeyKind,
    /// Its value in the default scene.
    pub default: KeyValue,
    /// The values accepted, in the words errors use.
    pub expected: &'static str,
    /// What it means (with its unit).
    pub help: &'static str,
    /// Where its value goes when a configuration is resolved.
    pub goes_to: Destination,
}

/// Where a key's value goes when a configuration is resolved.
#[derive(Debug, Clone, Copy)]
pub enum Destination {
    /// The chain's parameters, read together when the model is built.
    Model,
    /// The task's ends (`target`, `start`, `transitions`), resolved together on the
    /// chain.
    Ends,
    /// The reality gap, whose keys are converted together.
    RealityGap,
    /// The env around the task: the scene, the observation's dtype, diagnostics,
    /// rendering.
    Env,
    /// One field of the task, set by this function.
    Task(SetTask),
}

/// Sets a field of the task from a key's value. The value's type and form are checked
/// before; its range is checked once, with the whole task, by `TaskConfig::validate`.
pub type SetTask = fn(&mut TaskConfig, Setting) -> Result<()>;

/// A key's value in plain form, as the core applies it.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// Absent: the feature is off.
    Off,
    /// An integer.
    Integer(i64),
    /// A number.
    Number(f64),
    /// True or false.
    Flag(bool),
    /// A name.
    Name(String),
    /// Numbers (one per link, or a key's named numbers in order).
    Numbers(Vec<f64>),
}

impl Value {
    /// The table's default as a value (the `Relative` entries of the reality gap have no
    /// plain form and read as `Off`).
    pub fn of_default(default: KeyValue) -> Self {
        match default {
            KeyValue::Int(i) => Self::Integer(i),
            KeyValue::Float(x) => Self::Number(x),
            KeyValue::Bool(b) => Self::Flag(b),
            KeyValue::Name(s) => Self::Name(s.to_string()),
            KeyValue::Floats(v) => Self::Numbers(v.to_vec()),
            KeyValue::None | KeyValue::Relative(_) => Self::Off,
        }
    }
}

/// A key with its value, as a [`SetTask`] receives it.
#[derive(Debug, Clone)]
pub struct Setting {
    /// The key.
    pub key: &'static ConfigKey,
    /// Its value.
    pub value: Value,
}

impl Setting {
    /// The key's default.
    pub fn default_of(key: &'static ConfigKey) -> Self {
        Self {
            key,
            value: Value::of_default(key.default),
        }
    }

    /// The error of a value of another form than the key's.
    fn wrong_form(&self, form: &'static str) -> ChainError {
        InputError::WrongForm {
            name: self.key.name,
            got: format!("{:?}", self.value),
            expected: form,
        }
        .into()
    }

    /// A number.
    pub fn number(&self) -> Result<f64> {
        match self.value {
            Value::Number(x) => Ok(x),
            Value::Integer(i) => Ok(i as f64),
            _ => Err(self.wrong_form("a number")),
        }
    }

    /// A number, or `None` for off.
    pub fn optional_number(&self) -> Result<Option<f64>> {
        match self.value {
            Value::Off => Ok(None),
            _ => self.number().map(Some),
        }
    }

    /// A count `>= 0`, or `None` for off (a negative count names the key's accepted
    /// values).
    pub fn optional_count<T: TryFrom<i64>>(&self) -> Result<Option<T>> {
        match self.value {
            Value::Off => Ok(None),
            Value::Integer(i) => T::try_from(i).map(Some).map_err(|_| {
                InputError::InvalidParameter {
                    name: self.key.name,
                    value: i as f64,
                    expected: self.key.expected,
                }
                .into()
            }),
            _ => Err(self.wrong_form("an integer")),
        }
    }

    /// A count `>= 0`.
    pub fn count<T: TryFrom<i64>>(&self) -> Result<T> {
        self.optional_count()?
            .ok_or_else(|| self.wrong_form("an integer"))
    }

    /// True or false.
    pub fn flag(&self) -> Result<bool> {
        match self.value {
            Value::Flag(b) => Ok(b),
            _ => Err(self.wrong_form("True or False")),
        }
    }

    /// A name.
    pub fn name(&self) -> Result<&str> {
        match &self.value {
            Value::Name(s) => Ok(s),
            _ => Err(self.wrong_form("a name")),
        }
    }

    /// One number for every link (a list of one), or one per link.
    pub fn per_link(&self) -> Result<Vec<f64>> {
        match &self.value {
            Value::Number(x) => Ok(vec![*x]),
            Value::Numbers(v) => Ok(v.clone()),
            _ => Err(self.wrong_form("a number or one per link")),
        }
    }

    /// Exactly `N` numbers.
    pub fn numbers<const N: usize>(&self) -> Result<[f64; N]> {
        match &self.value {
            Value::Numbers(v) => v
                .as_slice()
                .try_into()
                .map_err(|_| self.wrong_form("a fixed number of numbers")),
            _ => Err(self.wrong_form("a fixed number of numbers")),
        }
    }
}

impl TaskConfig {
    /// Applies every key that goes to a task field, in table order, taking each value
    /// from `value_of` (a key's value, or its default when `value_of` gives `None`).
    pub fn apply_keys(
        &mut self,
        mut value_of: impl FnMut(&'static ConfigKey) -> Option<Value>,
    ) -> Result<()> {
        for key in CONFIG_KEYS {
            if let Destination::Task(set) = key.goes_to {
                let setting = match value_of(key) {
                    Some(value) => Setting { key, value },
                    None => Setting::default_of(key),
                };
                set(self, setting)?;
            }
        }
        Ok(())
    }
}

/// The name, for `target` or `start`, of a draw at every reset among all equilibria
/// (other than the other end).
pub const ANY: &str = "any";

/// Names of the observation dtypes.
pub const OBS_DTYPE_NAMES: [&str; 2] = ["float32", "float64"];

/// Names of the reward weights, in the order of `RewardWeights::as_array`.
pub const REWARD_WEIGHT_NAMES: [&str; 5] = ["q", "w", "x", "v", "u"];

/// Names of the success tolerances.
pub const SUCCESS_TOLERANCE_NAMES: [&str; 2] = ["e_q", "e_w"];

/// Default motor `[torque_constant, resistance, gear_ratio, pulley_radius,
/// current_limit]` of the `voltage` actuation: a small 12 V motor (0.02 N m/A, 2 ohm)
/// on a 5:1 gear and a 2 cm pulley, limited to 5 A: 25 N at stall (the current limit;
/// 30 N unlimited), no-load speed 2.4 m/s at 12 V.
pub const DEFAULT_MOTOR: [f64; 5] = [0.02, 2.0, 5.0, 0.02, 5.0];

/// The scene used when none is named: the planar double inverted pendulum.
pub const DEFAULT_SCENE: &str = "inverted-2";

/// Every configuration key, in the order of `ChainCartConfig`'s fields. Adding a key
/// is one entry here (plus where its value is used).
pub const CONFIG_KEYS: &[ConfigKey] = &[
    ConfigKey {
        name: "n_links",
        kind: KeyKind::Integer,
        default: KeyValue::Int(2),
        expected: "an integer >= 1",
        help: "number of links",
        goes_to: Destination::Model,
    },
    ConfigKey {
        name: "cart_mass",
        kind: KeyKind::Number,
        default: KeyValue::Float(1.0),
        expected: "a finite number > 0",
        help: "cart mass, kg",
        goes_to: Destination::Model,
    },
    ConfigKey {
        name: "link_masses",
        kind: KeyKind::PerLink,
        default: KeyValue::Float(0.1),
        expected: "a finite number > 0, or one per link",
        help: "kg, one number or one per link (a point mass at the link's end)",
        goes_to: Destination::Model,
    },
    ConfigKey {
        name: "link_lengths",
        kind: KeyKind::PerLink,
        default: KeyValue::Float(0.5),
        expected: "a finite number > 0, or one per link",
        help: "m, one number or one per link",
        goes_to: Destination::Model,
    },
    ConfigKey {
        name: "gravity",
        kind: KeyKind::Number,
        default: KeyValue::Float(STANDARD_GRAVITY),
        expected: "a finite number > 0",
        help: "m/s^2, along e3",
        goes_to: Destination::Model,
    },
    ConfigKey {
        name: "planar",
        kind: KeyKind::Flag,
        default: KeyValue::Bool(true),
        expected: "True or False",
        help: "planar model (cart on e1, links in the e1-e3 plane); false: spatial",
        goes_to: Destination::Model,
    },
    ConfigKey {
        name: "target",
        kind: KeyKind::Equilibrium,
        default: KeyValue::Name("inverted"),
        expected: "a name (hanging, inverted, folded, folded_up, paper-fig1..3, any) or one \
                   sign +1/-1 per link",
        help: "the equilibrium to reach: a name or a sign tuple (+1 hanging, -1 upright \
               link; on the command line --target=-1,1); any: drawn at every reset among all \
               2^n (n <= 8)",
        goes_to: Destination::Ends,
    },
    ConfigKey {
        name: "start",
        kind: KeyKind::Start,
        default: KeyValue::Name("target"),
        expected: "a name (target, hanging, inverted, folded, folded_up, paper-fig1..3, \
                   any), one sign +1/-1 per link, or a full state",
        help: "where episodes start: target, an equilibrium name or sign tuple, \
               paper-fig1..3, a full state, or any: drawn at every reset among the \
               equilibria other than the target",
        goes_to: Destination::Ends,
    },
    ConfigKey {
        name: "start_noise",
        kind: KeyKind::Number,
        default: KeyValue::Float(DEFAULT_START_NOISE),
        expected: "a finite number >= 0",
        help: "half-width of the uniform start noise in every local coordinate",
        goes_to: Destination::Task(|t, s| {
            t.start_noise = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "dt",
        kind: KeyKind::Number,
        default: KeyValue::Float(0.02),
        expected: "a finite number > 0",
        help: "control period, s",
        goes_to: Destination::Task(|t, s| {
            t.dt = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "integrator",
        kind: KeyKind::Choice(&Method::NAMES),
        default: KeyValue::Name("rk4"),
        expected: "one of rk4, rkmk4, variational, lie_euler, adaptive",
        help: "integrator: rk4, rkmk4, variational, lie_euler or adaptive",
        goes_to: Destination::Task(|t, s| {
            t.step_options.method = Method::from_name(s.name()?)?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "substeps",
        kind: KeyKind::Integer,
        default: KeyValue::Int(2),
        expected: "an integer >= 1",
        help: "integrator steps per control period (the default's two 10 ms RK4 steps: with \
               single 20 ms steps random pushes whip the links past 25 rad/s and about 7% of \
               random-action episodes end flagged as under-resolved; with two, none)",
        goes_to: Destination::Task(|t, s| {
            t.step_options.substeps = s.count()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "max_force",
        kind: KeyKind::Number,
        default: KeyValue::Float(DEFAULT_MAX_FORCE),
        expected: "a finite number >= 0",
        help: "N per unit action (0: uncontrolled)",
        goes_to: Destination::Task(|t, s| {
            t.max_force = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "track_limit",
        kind: KeyKind::Number,
        default: KeyValue::Float(DEFAULT_TRACK_LIMIT),
        expected: "a finite number > 0",
        help: "m; the episode terminates when the cart goes beyond it",
        goes_to: Destination::Task(|t, s| {
            t.track_limit = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "max_episode_steps",
        kind: KeyKind::Integer,
        default: KeyValue::Int(DEFAULT_MAX_EPISODE_STEPS),
        expected: "an integer >= 1",
        help: "episode length in steps (truncation)",
        goes_to: Destination::Task(|t, s| {
            t.max_episode_steps = s.count()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "reward_weights",
        kind: KeyKind::NamedNumbers(&REWARD_WEIGHT_NAMES),
        default: KeyValue::Floats(&DEFAULT_REWARD_WEIGHTS),
        expected: "a RewardWeights, a mapping with some of q, w, x, v, u, or five numbers, \
                   each a finite number >= 0",
        help: "reward weights q, w, x, v, u (a mapping such as {\"q\": 2}, or five numbers)",
        goes_to: Destination::Task(|t, s| {
            t.reward = RewardWeights::from_array(s.numbers()?);
            Ok(())
        }),
    },
    ConfigKey {
        name: "scene",
        kind: KeyKind::Scene,
        default: KeyValue::Name(DEFAULT_SCENE),
        expected: "a scene name",
        help: "named scene whose values fill every keyword not given",
        goes_to: Destination::Env,
    },
    ConfigKey {
        name: "obs_dtype",
        kind: KeyKind::Choice(&OBS_DTYPE_NAMES),
        default: KeyValue::Name("float32"),
        expected: "'float32' or 'float64'",
        help: "dtype of the observations",
        goes_to: Destination::Env,
    },
    ConfigKey {
        name: "success_tolerances",
        kind: KeyKind::Numbers(&SUCCESS_TOLERANCE_NAMES),
        default: KeyValue::Floats(&DEFAULT_SUCCESS_TOLERANCES),
        expected: "two numbers (e_q, e_w), each a finite number > 0",
        help: "e_q, e_w bounds of a success at the time limit (is_success)",
        goes_to: Destination::Task(|t, s| {
            let [e_q, e_w] = s.numbers()?;
            t.success = SuccessTolerances { e_q, e_w };
            Ok(())
        }),
    },
    ConfigKey {
        name: "reward",
        kind: KeyKind::Choice(&REWARD_NAMES),
        default: KeyValue::Name("exp"),
        expected: "'exp' or 'tolerance'",
        help: "per-step reward: exp (exp(-c), c the weighted quadratic cost of reward_weights) \
               or tolerance (bounded in [0, 1] for large motions: the mean of the links' \
               alignment with the target and a closeness within the success tolerances, times \
               a centring and a force factor)",
        goes_to: Destination::Task(|t, s| {
            t.reward_kind = RewardKind::from_name(s.name()?)?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "success_hold",
        kind: KeyKind::Number,
        default: KeyValue::Float(0.0),
        expected: "a finite number >= 0",
        help: "s the errors must have stayed within success_tolerances at the end of an episode \
               for a success (0: the last step alone)",
        goes_to: Destination::Task(|t, s| {
            t.success_hold = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "fall_limit",
        kind: KeyKind::Number,
        default: KeyValue::Float(0.0),
        expected: "a finite number >= 0",
        help: "e_q bound of a fall: an episode whose e_q came within it terminates at the \
               first later step beyond it (info fell), so that a lost balance or a lost catch \
               ends the episode (0: never)",
        goes_to: Destination::Task(|t, s| {
            t.fall_limit = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "fall_hold",
        kind: KeyKind::Number,
        default: KeyValue::Float(0.0),
        expected: "a finite number >= 0",
        help: "s e_q must have stayed within fall_limit before a later step beyond it is a \
               fall, so that a swing passing through the limit on its way up is not a lost \
               catch (0: one step)",
        goes_to: Destination::Task(|t, s| {
            t.fall_hold = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "transitions",
        kind: KeyKind::Transitions,
        default: KeyValue::None,
        expected: "a list of (start, target) pairs, each end a name or one sign +1/-1 per link",
        help: "goal-conditioned tasks: the (start, target) equilibria every reset draws one \
               pair from (overrides start and target; none: from start and target, where \
               any draws)",
        goes_to: Destination::Ends,
    },
    ConfigKey {
        name: "goal_observation",
        kind: KeyKind::Flag,
        default: KeyValue::Bool(false),
        expected: "True or False",
        help: "observations end with the target's n signs (goal-conditioned policies)",
        goes_to: Destination::Task(|t, s| {
            t.goal_observation = s.flag()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "diagnostics",
        kind: KeyKind::Flag,
        default: KeyValue::Bool(false),
        expected: "True or False",
        help: "energies and constraint residuals in every step's info (costs time)",
        goes_to: Destination::Env,
    },
    ConfigKey {
        name: "precision",
        kind: KeyKind::Choice(&Precision::NAMES),
        default: KeyValue::Name("f64"),
        expected: "'f64' or 'f32' (f32 with integrator 'rk4' only)",
        help: "number type of the physics: f64, or f32 on the rk4 SIMD lane kernel (twice the \
               lanes: faster, within 1e-3 m of f64 after 1 s on the paper's scenes)",
        goes_to: Destination::Task(|t, s| {
            t.precision = Precision::from_name(s.name()?)?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "randomize",
        kind: KeyKind::RealityGap,
        default: KeyValue::None,
        expected: "a dict mapping some of cart_mass, link_masses, link_lengths, gravity, \
                   joint_damping, cart_viscous_friction, cart_coulomb_friction to a relative \
                   half-width or a distribution",
        help: "Domain randomisation at every reset: a dict mapping cart_mass, link_masses, \
               link_lengths, gravity (and the rig's joint_damping, cart_viscous_friction, \
               cart_coulomb_friction) to a relative half-width h (value times U[1-h, 1+h], \
               0 <= h < 1) or to a dict with one of \"scale\": h or [low, high], \
               \"log_scale\": [low, high], \"range\": [low, high] (absolute; from 0 for \
               the rig's), \"log_range\": [low, high] (absolute, log-uniform), and \
               optionally \"per_link\": false to draw one number shared by all links.",
        goes_to: Destination::RealityGap,
    },
    ConfigKey {
        name: "params",
        kind: KeyKind::RealityGap,
        default: KeyValue::None,
        expected: "a dict with some of cart_mass, link_masses, link_lengths, gravity, or a \
                   ChainCart",
        help: "The true physical parameters when they differ from the model's: a dict \
               with some of cart_mass, link_masses, link_lengths, gravity (a number, or \
               one number per link), or a ChainCart. The env's model stays nominal.",
        goes_to: Destination::RealityGap,
    },
    ConfigKey {
        name: "mismatch",
        kind: KeyKind::RealityGap,
        default: KeyValue::None,
        expected: "a dict with some of cart_mass, link_masses, link_lengths, gravity",
        help: "Scale factors from the nominal (or params) values to the true ones: a \
               dict with some of cart_mass, link_masses, link_lengths, gravity (a factor, \
               or one factor per link).",
        goes_to: Destination::RealityGap,
    },
    ConfigKey {
        name: "obs_noise",
        kind: KeyKind::RealityGap,
        default: KeyValue::None,
        expected: "a finite standard deviation >= 0: one number, or one per state component",
        help: "Standard deviation of Gaussian noise added to every observation: one \
               number for all components or one per component (state units).",
        goes_to: Destination::RealityGap,
    },
    ConfigKey {
        name: "action_delay",
        kind: KeyKind::RealityGap,
        default: KeyValue::Int(0),
        expected: crate::env::reality::ACTION_DELAY_EXPECTED,
        help: "Control delay in control periods: the force of step t comes from the \
               action of step t - action_delay (zero force before that). A range (low, high) \
               draws each episode's delay uniformly from low..=high at its reset, from the \
               env's seeded start stream (after the start state), for training that covers \
               several delays.",
        goes_to: Destination::RealityGap,
    },
    ConfigKey {
        name: "force_rate_limit",
        kind: KeyKind::RealityGap,
        default: KeyValue::None,
        expected: crate::env::reality::FORCE_RATE_LIMIT_EXPECTED,
        help: "Largest change of the applied force per second, per cart axis (N/s); \
               None for no limit. A range (low, high) draws each episode's limit at its \
               reset (its inverse uniform between 1/high and 1/low; high may be inf, \
               no limit), from the env's seeded start stream after the delay, for \
               training that covers several limits.",
        goes_to: Destination::RealityGap,
    },
    ConfigKey {
        name: "force_noise",
        kind: KeyKind::RealityGap,
        default: KeyValue::None,
        expected: "a dict with some of multiplicative, additive (standard deviations), each a \
                   finite number >= 0",
        help: "Gaussian disturbance of the force the actuator delivers, per step and cart \
               axis: a dict with some of \"multiplicative\": sm (relative) and \"additive\": sa \
               (N); the force f after delay and rate limit becomes f (1 + sm z1) + sa z2, \
               z1, z2 standard normal, not clipped to max_force. None for none.",
        goes_to: Destination::RealityGap,
    },
    ConfigKey {
        name: "render_view",
        kind: KeyKind::Choice(&ViewKind::NAMES),
        default: KeyValue::None,
        expected: "one of 3d, side, top, side+top, or none for the scene's default",
        help: "picture of rendered frames: 3d (a lit perspective view), side, top or side+top \
               (flat views); none: 3d for spatial chains, side for planar ones",
        goes_to: Destination::Env,
    },
    ConfigKey {
        name: "joint_damping",
        kind: KeyKind::PerLink,
        default: KeyValue::Float(0.0),
        expected: "a finite number >= 0, or one per link",
        help: "viscous damping of each joint, N m s/rad, one number or one per link: the \
               torque -c_i (w_i - w_{i-1}) on link i, relative to the link above (the first \
               link relative to the cart, which does not rotate); 0: none. On, the envs step \
               one by one (not on the SIMD lanes)",
        goes_to: Destination::Task(|t, s| {
            t.rig.joint_damping = s.per_link()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "cart_viscous_friction",
        kind: KeyKind::Number,
        default: KeyValue::Float(0.0),
        expected: "a finite number >= 0",
        help: "viscous friction of the cart on each axis, N s/m: the force -b v; 0: none. On, \
               the envs step one by one",
        goes_to: Destination::Task(|t, s| {
            t.rig.cart_viscous_friction = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "cart_coulomb_friction",
        kind: KeyKind::Number,
        default: KeyValue::Float(0.0),
        expected: "a finite number >= 0",
        help: "Coulomb friction of the cart on each axis, N: the force -F_c tanh(v / \
               coulomb_velocity), a smooth law; 0: none. On, the envs step one by one",
        goes_to: Destination::Task(|t, s| {
            t.rig.cart_coulomb_friction = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "coulomb_velocity",
        kind: KeyKind::Number,
        default: KeyValue::Float(DEFAULT_COULOMB_VELOCITY),
        expected: "a finite number > 0",
        help: "m/s, the velocity scale of the Coulomb friction's tanh law (76 % of the full \
               friction at this speed, 99.5 % at three times it); smaller is sharper and needs \
               smaller integrator steps",
        goes_to: Destination::Task(|t, s| {
            t.rig.coulomb_velocity = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "actuation",
        kind: KeyKind::Choice(&Actuation::NAMES),
        default: KeyValue::Name("force"),
        expected: "one of force, acceleration, voltage",
        help: "what the action commands, per cart axis: force (max_force N per unit action), \
               acceleration (a servo axis: max_acceleration m/s^2 per unit action, the cart \
               mass drops out) or voltage (a DC motor, see motor: max_voltage V per unit \
               action). Other than force, the envs step one by one, and force_rate_limit and \
               force_noise act on the command in its own unit",
        goes_to: Destination::Task(set_actuation),
    },
    ConfigKey {
        name: "max_acceleration",
        kind: KeyKind::Number,
        default: KeyValue::Float(DEFAULT_MAX_ACCELERATION),
        expected: "a finite number >= 0",
        help: "m/s^2 per unit action with actuation acceleration",
        goes_to: Destination::Task(|t, s| {
            t.max_acceleration = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "max_voltage",
        kind: KeyKind::Number,
        default: KeyValue::Float(DEFAULT_MAX_VOLTAGE),
        expected: "a finite number >= 0",
        help: "V per unit action with actuation voltage",
        goes_to: Destination::Task(|t, s| {
            t.max_voltage = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "motor",
        kind: KeyKind::NamedNumbers(&Motor::NAMES),
        default: KeyValue::Floats(&DEFAULT_MOTOR),
        expected: "a mapping with some of torque_constant, resistance, gear_ratio, \
                   pulley_radius, current_limit, or five numbers, each a finite number > 0",
        help: "the DC motor of actuation voltage, one per cart axis: torque_constant k (N m/A, \
               also the back-EMF constant in V s/rad), resistance R (ohm), gear_ratio N, \
               pulley_radius r (m), current_limit (A); force N k i / r with current i = (V - \
               k N v / r) / R clipped to the limit",
        goes_to: Destination::Task(set_motor),
    },
    ConfigKey {
        name: "angle_encoder_counts",
        kind: KeyKind::Integer,
        default: KeyValue::None,
        expected: crate::env::sensors::ANGLE_COUNTS_EXPECTED,
        help: "encoder counts per revolution of the observed link angles (a planar link's \
               angle; a spatial link's swing and tilt, the two angles of a universal joint): \
               each angle reads rounded down to the grid 2 pi / counts, and the link's \
               angular velocity is estimated from the change of the counts over dt (zero on \
               an episode's first observation); none: exact angles and velocities",
        goes_to: Destination::Task(|t, s| {
            t.sensors.angle_counts = s.optional_count()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "cart_encoder_counts",
        kind: KeyKind::Number,
        default: KeyValue::None,
        expected: crate::env::sensors::CART_COUNTS_EXPECTED,
        help: "encoder counts per metre of the observed cart position, per axis: the \
               position reads rounded down to the grid 1 / counts, and the cart velocity is \
               estimated from the change of the counts over dt (zero on an episode's first \
               observation); none: exact position and velocity",
        goes_to: Destination::Task(|t, s| {
            t.sensors.cart_counts = s.optional_number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "velocity_filter",
        kind: KeyKind::Number,
        default: KeyValue::Float(0.0),
        expected: crate::env::sensors::VELOCITY_FILTER_EXPECTED,
        help: "time constant tau (s) of a first-order low-pass filter of the encoders' \
               velocity estimates, v += (1 - exp(-dt / tau)) (raw - v); 0: the raw finite \
               differences",
        goes_to: Destination::Task(|t, s| {
            t.sensors.velocity_filter = s.number()?;
            Ok(())
        }),
    },
    ConfigKey {
        name: "angle_encoder_reference",
        kind: KeyKind::Choice(&AngleReference::NAMES),
        default: KeyValue::Name("vertical"),
        expected: crate::env::sensors::ANGLE_REFERENCE_EXPECTED,
        help: "what each angle encoder measures its link from: vertical (every link's \
               absolute angle) or joint (an encoder at each joint reads the link's angle from \
               the link above, the first link's from the vertical; each observed angle is the \
               sum of the joints' counts above it, so link i carries i joints' quantisation; \
               planar chains with angle_encoder_counts only)",
        goes_to: Destination::Task(|t, s| {
            t.sensors.angle_reference = AngleReference::from_name(s.name()?)?;
            Ok(())
        }),
    },
];

/// `actuation`: the mode, with the voltage mode's motor as it stands (`motor`, later
/// in the table, sets it).
fn set_actuation(t: &mut TaskConfig, s: Setting) -> Result<()> {
    let motor = match t.rig.actuation {
        Actuation::Voltage(motor) => motor,
        _ => Motor::from_array(DEFAULT_MOTOR),
    };
    t.rig.actuation = Actuation::from_name(s.name()?, motor)?;
    Ok(())
}

/// `motor`: checked even when the actuation does not use it, so that a bad value is
/// never kept silently.
fn set_motor(t: &mut TaskConfig, s: Setting) -> Result<()> {
    let motor = Motor::from_array(s.numbers()?);
    motor.validate()?;
    if let Actuation::Voltage(m) = &mut t.rig.actuation {
        *m = motor;
    }
    Ok(())
}

/// The key with this name.
pub fn config_key(name: &str) -> Option<&'static ConfigKey> {
    CONFIG_KEYS.iter().find(|k| k.name == name)
}

/// The names of all keys, in table order, for error messages.
pub static KEY_NAMES: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| CONFIG_KEYS.iter().map(|k| k.name).collect());

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_key_is_defined_once() {
        let mut names = KEY_NAMES.clone();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), CONFIG_KEYS.len());
        assert!(config_key("substeps").is_some() && config_key("substep").is_none());
    }

    #[test]
    fn choice_defaults_are_among_their_choices() {
        for key in CONFIG_KEYS {
            if let (KeyKind::Choice(names), KeyValue::Name(default)) = (key.kind, key.default) {
                assert!(names.contains(&default), "{}", key.name);
            }
            if let (
                KeyKind::NamedNumbers(names) | KeyKind::Numbers(names),
                KeyValue::Floats(values),
            ) = (key.kind, key.default)
            {
                assert_eq!(names.len(), values.len(), "{}", key.name);
            }
        }
    }

    /// A task with the table's defaults: the default scene's chain, control period and
    /// integrator.
    fn default_task() -> TaskConfig {
        TaskConfig::new(
            vec![-1.0; 2],
            0.02,
            crate::integrate::StepOptions::default(),
        )
    }

    /// A value of `key`'s kind other than its default.
    fn other_value(key: &ConfigKey) -> Value {
        match (key.kind, Value::of_default(key.default)) {
            (KeyKind::Integer, Value::Integer(i)) => Value::Integer(i + 1),
            (KeyKind::Integer, _) => Value::Integer(7),
            (KeyKind::Number | KeyKind::PerLink, Value::Number(x)) => Value::Number(x + 1.0),
            (KeyKind::Number, _) => Value::Number(3.0),
            (KeyKind::Flag, Value::Flag(b)) => Value::Flag(!b),
            (KeyKind::Choice(names), Value::Name(name)) => Value::Name(
                names
                    .iter()
                    .find(|n| **n != name)
                    .expect("a second choice")
                    .to_string(),
            ),
            (_, Value::Numbers(v)) => Value::Numbers(v.iter().map(|x| x + 1.0).collect()),
            (kind, value) => panic!("{}: no other value for {kind:?} {value:?}", key.name),
        }
    }

    #[test]
    fn a_new_task_holds_the_table_defaults() {
        let mut applied = default_task();
        applied.apply_keys(|_| None).unwrap();
        let mut new = default_task();
        // The integrator's options are an argument of `new`, not a default of it.
        new.step_options = applied.step_options;
        // One damping number for every joint, zero, is how the key writes no damping.
        new.rig.joint_damping = vec![0.0];
        assert_eq!(applied, new);
    }

    #[test]
    fn every_task_key_sets_its_own_part_of_the_task() {
        let base = default_task();
        let mut changed = Vec::new();
        for key in CONFIG_KEYS {
            let Destination::Task(set) = key.goes_to else {
                continue;
            };
            let mut task = base.clone();
            let value = other_value(key);
            set(
                &mut task,
                Setting {
                    key,
                    value: value.clone(),
                },
            )
            .unwrap();
            if key.name == "motor" {
                // The motor lands in the voltage actuation only.
                task.rig.actuation =
                    Actuation::from_name("voltage", Motor::from_array(DEFAULT_MOTOR)).unwrap();
                set(&mut task, Setting { key, value }).unwrap();
            }
            assert_ne!(task, base, "{} changed nothing", key.name);
            assert!(
                !changed.contains(&format!("{task:?}")),
                "{} sets what another key sets",
                key.name
            );
            changed.push(format!("{task:?}"));
        }
        assert!(changed.len() >= 20, "{} task keys", changed.len());
    }

    /// The error of setting task key `name` to `value` on the default task.
    fn refusal(name: &str, value: Value) -> String {
        let key = config_key(name).unwrap();
        let Destination::Task(set) = key.goes_to else {
            panic!("{name} goes to the task");
        };
        set(&mut default_task(), Setting { key, value })
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn a_value_of_another_form_is_refused_naming_the_key() {
        let err = refusal("max_force", Value::Name("big".into()));
        assert_eq!(err, "max_force = Name(\"big\"): expected a number");
        let err = refusal("max_episode_steps", Value::Integer(-3));
        assert!(err.contains("max_episode_steps = -3"), "{err}");
    }

    #[test]
    fn the_render_views_are_the_renderers() {
        let key = config_key("render_view").unwrap();
        let KeyKind::Choice(names) = key.kind else {
            panic!("render_view is a choice");
        };
        for name in names {
            assert_eq!(ViewKind::from_name(name).unwrap().name(), *name);
            assert!(key.expected.contains(name), "{name}");
        }
        assert!(ViewKind::from_name("3D").is_err());
    }

    #[test]
    fn the_name_lists_agree_with_the_parsers() {
        for name in crate::env::TARGET_NAMES {
            assert!(super::super::target_signs(name, 5).is_ok(), "{name}");
        }
        for name in crate::env::START_NAMES {
            assert!(super::super::Start::from_name(name, 5).is_ok(), "{name}");
        }
    }
}

#[cfg(test)]
mod expected_text {
    //! Each key's [`ConfigKey::expected`] is what the core's check of that key says.
    use super::*;
    use crate::env::TaskConfig;
    use crate::integrate::StepOptions;
    use crate::params::ChainParams;

    fn expected(name: &str) -> &'static str {
        config_key(name).unwrap().expected
    }

    type Spoiler = Box<dyn Fn(&mut TaskConfig)>;

    fn task_error(spoil: impl Fn(&mut TaskConfig)) -> String {
        let mut task = TaskConfig::new(vec![-1.0; 2], 0.02, StepOptions::default());
        spoil(&mut task);
        task.validate(2).unwrap_err().to_string()
    }

    #[test]
    fn task_checks_say_what_the_table_says() {
        let cases: [(&str, Spoiler); 8] = [
            ("start_noise", Box::new(|t| t.start_noise = -1.0)),
            ("fall_limit", Box::new(|t| t.fall_limit = -1.0)),
            ("fall_hold", Box::new(|t| t.fall_hold = -1.0)),
            ("dt", Box::new(|t| t.dt = 0.0)),
            ("max_force", Box::new(|t| t.max_force = -1.0)),
            ("track_limit", Box::new(|t| t.track_limit = 0.0)),
            ("max_episode_steps", Box::new(|t| t.max_episode_steps = 0)),
            ("substeps", Box::new(|t| t.step_options.substeps = 0)),
        ];
        for (name, spoil) in cases {
            let e = task_error(spoil);
            assert!(
                e.contains(name) && e.contains(expected(name)),
                "{name}: {e}"
            );
        }
        let e = task_error(|t| t.reward.q = -1.0);
        assert!(e.contains("a finite number >= 0"), "{e}");
        assert!(expected("reward_weights").ends_with("each a finite number >= 0"));
        let e = task_error(|t| t.success.e_q = 0.0);
        assert!(e.contains("a finite number > 0"), "{e}");
        assert!(expected("success_tolerances").ends_with("each a finite number > 0"));
    }

    #[test]
    fn parameter_checks_say_what_the_table_says() {
        let cases = [
            ("cart_mass", ChainParams::new(-1.0, &[0.1], &[0.5], 9.81)),
            ("link_masses", ChainParams::new(1.0, &[-0.1], &[0.5], 9.81)),
            ("link_lengths", ChainParams::new(1.0, &[0.1], &[0.0], 9.81)),
            ("gravity", ChainParams::new(1.0, &[0.1], &[0.5], -1.0)),
        ];
        for (name, result) in cases {
            let e = result.unwrap_err().to_string();
            let what = expected(name).trim_end_matches(", or one per link");
            assert!(e.contains(name) && e.contains(what), "{name}: {e}");
        }
    }

    #[test]
    fn rig_checks_say_what_the_table_says() {
        use crate::params::{Actuation, Motor, Rig};
        let rig_error = |rig: Rig| rig.validate(2).unwrap_err().to_string();
        let cases = [
            (
                "joint_damping",
                Rig {
                    joint_damping: vec![0.1, -1.0],
                    ..Rig::default()
                },
            ),
            (
                "cart_viscous_friction",
                Rig {
                    cart_viscous_friction: -1.0,
                    ..Rig::default()
                },
            ),
            (
                "cart_coulomb_friction",
                Rig {
                    cart_coulomb_friction: f64::INFINITY,
                    ..Rig::default()
                },
            ),
            (
                "coulomb_velocity",
                Rig {
                    coulomb_velocity: 0.0,
                    ..Rig::default()
                },
            ),
        ];
        for (name, rig) in cases {
            let e = rig_error(rig);
            let what = expected(name).trim_end_matches(", or one per link");
            assert!(e.contains(name) && e.contains(what), "{name}: {e}");
        }
        let mut motor = Motor::from_array(DEFAULT_MOTOR);
        motor.gear_ratio = 0.0;
        let e = rig_error(Rig {
            actuation: Actuation::Voltage(motor),
            ..Rig::default()
        });
        assert!(e.contains("motor.gear_ratio"), "{e}");
        assert!(expected("motor").ends_with(Motor::EXPECTED));
        for name in Motor::NAMES {
            assert!(expected("motor").contains(name), "{name}");
        }
        for name in Actuation::NAMES {
            assert!(expected("actuation").contains(name), "{name}");
        }
        let mut task = TaskConfig::new(vec![-1.0; 2], 0.02, StepOptions::default());
        for name in ["max_acceleration", "max_voltage"] {
            task.max_acceleration = if name == "max_acceleration" {
                -1.0
            } else {
                1.0
            };
            task.max_voltage = if name == "max_voltage" { -1.0 } else { 1.0 };
            let e = task.validate(2).unwrap_err().to_string();
            assert!(
                e.contains(name) && e.contains(expected(name)),
                "{name}: {e}"
            );
        }
    }

    #[test]
    fn sensor_checks_say_what_the_table_says() {
        use crate::env::Sensors;
        let mut task = TaskConfig::new(vec![-1.0; 2], 0.02, StepOptions::default());
        let cases = [
            (
                "angle_encoder_counts",
                Sensors {
                    angle_counts: Some(0),
                    ..Sensors::default()
                },
            ),
            (
                "cart_encoder_counts",
                Sensors {
                    cart_counts: Some(0.0),
                    ..Sensors::default()
                },
            ),
            (
                "velocity_filter",
                Sensors {
                    angle_counts: Some(100),
                    velocity_filter: -1.0,
                    ..Sensors::default()
                },
            ),
        ];
        for (name, sensors) in cases {
            task.sensors = sensors;
            let e = task.validate(2).unwrap_err().to_string();
            assert!(
                e.contains(name) && e.contains(expected(name)),
                "{name}: {e}"
            );
        }
    }

    #[test]
    fn reality_gap_checks_say_what_the_table_says() {
        use crate::env::RealityGap;
        let e = RealityGap::delay_from(-1).unwrap_err().to_string();
        assert!(e.contains(expected("action_delay")), "{e}");
        let rate = RealityGap {
            force_rate_limit: 0.0,
            ..RealityGap::default()
        };
        let e = rate.validate(2, 8).unwrap_err().to_string();
        assert!(e.contains(expected("force_rate_limit")), "{e}");
        let noise = RealityGap {
            obs_noise: vec![-1.0],
            ..RealityGap::default()
        };
        let e = noise.validate(2, 8).unwrap_err().to_string();
        let what = expected("obs_noise").split(':').next().unwrap();
        assert!(e.contains(what), "{e}");
        let force_noise = RealityGap {
            force_noise: crate::env::ForceNoise {
                additive: -1.0,
                ..Default::default()
            },
            ..RealityGap::default()
        };
        let e = force_noise.validate(2, 8).unwrap_err().to_string();
        assert!(e.contains("force_noise.additive"), "{e}");
        assert!(e.contains(crate::env::ForceNoise::EXPECTED), "{e}");
        assert!(expected("force_noise").ends_with(crate::env::ForceNoise::EXPECTED));
        for name in crate::env::ForceNoise::NAMES {
            assert!(expected("force_noise").contains(name), "{name}");
        }
    }

    #[test]
    fn a_rust_task_starts_from_the_key_tables_defaults() {
        let task = TaskConfig::new(vec![-1.0; 2], 0.02, StepOptions::default());
        let float = |name: &str| match config_key(name).unwrap().default {
            KeyValue::Float(x) => x,
            KeyValue::Int(i) => i as f64,
            other => panic!("{name}: {other:?}"),
        };
        let fields = [
            ("start_noise", task.start_noise),
            ("max_force", task.max_force),
            ("track_limit", task.track_limit),
            ("max_episode_steps", task.max_episode_steps as f64),
            ("max_acceleration", task.max_acceleration),
            ("max_voltage", task.max_voltage),
        ];
        for (name, value) in fields {
            assert_eq!(value, float(name), "{name}");
        }
    }
}
