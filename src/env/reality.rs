//! How the simulated "real" system differs from the nominal model, and how it is
//! sensed and actuated: fixed parameter mismatch, domain randomisation at reset,
//! Gaussian observation noise, a control delay, a force-rate limit and a Gaussian
//! disturbance of the applied force. Everything is off by default and then costs
//! nothing.
//!
//! **Parameters.** The nominal parameters are the model's (what a controller
//! designer knows). The env's *true* parameters are the nominal ones with
//! [`RealityGap::params`] put in their place and then multiplied by
//! [`RealityGap::mismatch`]; with [`RealityGap::randomize`] each reset draws new
//! parameters around the true ones.
//!
//! **Random streams.** Every env's generator is ChaCha8 seeded with the env's seed;
//! the start state uses its stream 0 (as without any of this), parameter draws its
//! stream [`PARAM_STREAM`], observation noise its stream [`NOISE_STREAM`] and the force
//! disturbance its stream [`FORCE_NOISE_STREAM`]. Turning randomisation or either noise
//! on or off therefore changes no start state and no other feature's draws, and each
//! feature is reproducible on its own.
//!
//! **Draw order at a reset** (only for the parameters that are randomised): the cart
//! mass, the link masses (one number per link, or one shared), the link lengths
//! (likewise), gravity, then the rig's joint damping (per link or shared), its cart's
//! viscous and its Coulomb friction. Each draw is `u` uniform in `[0, 1)` mapped as
//! [`Distribution::sample`] says.
//!
//! **Rig effects.** Joint damping and cart friction ([`RigParam`]) are drawn the same
//! way, around the task's rig values, so that an agent can train on rigs with and
//! without them; their absolute forms may start at zero (no damping, no friction).

use crate::error::{check_positive, InputError, Result};
use crate::params::check_positive_links;
use crate::params::{ChainParams, Rig};
use rand::Rng;
use rand_distr::StandardNormal;

/// ChaCha8 stream number of the parameter draws of an env.
pub const PARAM_STREAM: u64 = 1;
/// ChaCha8 stream number of the observation noise of an env.
pub const NOISE_STREAM: u64 = 2;
/// ChaCha8 stream number of the force disturbance of an env.
pub const FORCE_NOISE_STREAM: u64 = 3;

/// A physical parameter that can be mismatched or randomised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Param {
    /// The cart mass.
    CartMass,
    /// The link (point) masses.
    LinkMasses,
    /// The link lengths.
    LinkLengths,
    /// The gravitational acceleration.
    Gravity,
}

impl Param {
    /// Every parameter, in documentation order.
    pub const ALL: [Param; 4] = [
        Param::CartMass,
        Param::LinkMasses,
        Param::LinkLengths,
        Param::Gravity,
    ];
    /// The accepted names, for error messages.
    pub const NAMES: [&'static str; 4] = ["cart_mass", "link_masses", "link_lengths", "gravity"];

    /// The parameter's keyword name.
    pub fn name(self) -> &'static str {
        match self {
            Param::CartMass => "cart_mass",
            Param::LinkMasses => "link_masses",
            Param::LinkLengths => "link_lengths",
            Param::Gravity => "gravity",
        }
    }

    /// The parameter named `name`; `kind` (e.g. `"randomize"`) goes into the error.
    pub fn from_name(kind: &'static str, name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == name)
            .ok_or_else(|| {
                InputError::UnknownName {
                    kind,
                    name: name.to_string(),
                    expected: &Self::NAMES,
                }
                .into()
            })
    }

    /// One value per link (masses, lengths) rather than one number.
    pub fn is_per_link(self) -> bool {
        matches!(self, Param::LinkMasses | Param::LinkLengths)
    }

    /// `"<kind>.<name>"` as a static string, for error messages.
    fn qualified(self, kind: Kind) -> &'static str {
        match (kind, self) {
            (Kind::Randomize, Param::CartMass) => "randomize.cart_mass",
            (Kind::Randomize, Param::LinkMasses) => "randomize.link_masses",
            (Kind::Randomize, Param::LinkLengths) => "randomize.link_lengths",
            (Kind::Randomize, Param::Gravity) => "randomize.gravity",
            (Kind::Params, Param::CartMass) => "params.cart_mass",
            (Kind::Params, Param::LinkMasses) => "params.link_masses",
            (Kind::Params, Param::LinkLengths) => "params.link_lengths",
            (Kind::Params, Param::Gravity) => "params.gravity",
            (Kind::Mismatch, Param::CartMass) => "mismatch.cart_mass",
            (Kind::Mismatch, Param::LinkMasses) => "mismatch.link_masses",
            (Kind::Mismatch, Param::LinkLengths) => "mismatch.link_lengths",
            (Kind::Mismatch, Param::Gravity) => "mismatch.gravity",
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Kind {
    Randomize,
    Params,
    Mismatch,
}

/// A real-rig effect that can be randomised (never mismatched: the rig's own keys set
/// its value).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RigParam {
    /// The joints' viscous damping.
    JointDamping,
    /// The cart's viscous friction.
    CartViscousFriction,
    /// The cart's Coulomb friction.
    CartCoulombFriction,
}

impl RigParam {
    /// Every rig parameter, in draw order.
    pub const ALL: [RigParam; 3] = [
        RigParam::JointDamping,
        RigParam::CartViscousFriction,
        RigParam::CartCoulombFriction,
    ];

    /// The parameter's keyword name (the rig key it draws).
    pub fn name(self) -> &'static str {
        match self {
            RigParam::JointDamping => "joint_damping",
            RigParam::CartViscousFriction => "cart_viscous_friction",
            RigParam::CartCoulombFriction => "cart_coulomb_friction",
        }
    }

    /// The parameter named `name`, if one is.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// `"randomize.<name>"`, for error messages.
    fn qualified(self) -> &'static str {
        match self {
            RigParam::JointDamping => "randomize.joint_damping",
            RigParam::CartViscousFriction => "randomize.cart_viscous_friction",
            RigParam::CartCoulombFriction => "randomize.cart_coulomb_friction",
        }
    }

    /// The rig's value that a relative draw scales (joint damping: its largest).
    fn base(self, rig: &Rig) -> f64 {
        match self {
            RigParam::JointDamping => rig.joint_damping.iter().copied().fold(0.0, f64::max),
            RigParam::CartViscousFriction => rig.cart_viscous_friction,
            RigParam::CartCoulombFriction => rig.cart_coulomb_friction,
        }
    }
}

/// Every name the `randomize` keyword takes: the physical parameters, then the rig's.
pub const RANDOMIZE_NAMES: [&str; 7] = [
    "cart_mass",
    "link_masses",
    "link_lengths",
    "gravity",
    "joint_damping",
    "cart_viscous_friction",
    "cart_coulomb_friction",
];

/// How one parameter is drawn at a reset; `u` is uniform in `[0, 1)` and `p` the
/// env's true (pre-randomisation) value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distribution {
    /// `p * (low + (high - low) u)`: a uniform relative scale. The number form `h`
    /// of the `randomize` keyword is `Scale { low: 1 - h, high: 1 + h }`.
    Scale {
        /// Lower end of the uniform relative scale.
        low: f64,
        /// Upper end of the uniform relative scale.
        high: f64,
    },
    /// `p * exp(ln low + (ln high - ln low) u)`: a log-uniform relative scale.
    LogScale {
        /// Lower end of the log-uniform relative scale.
        low: f64,
        /// Upper end of the log-uniform relative scale.
        high: f64,
    },
    /// `low + (high - low) u`: a uniform absolute range (the nominal value is ignored).
    Range {
        /// Lower end of the uniform absolute range.
        low: f64,
        /// Upper end of the uniform absolute range.
        high: f64,
    },
    /// `exp(ln low + (ln high - ln low) u)`: a log-uniform absolute range.
    LogRange {
        /// Lower end of the log-uniform absolute range.
        low: f64,
        /// Upper end of the log-uniform absolute range.
        high: f64,
    },
}

impl Distribution {
    /// The `[1 - h, 1 + h]` scale of a relative half-width `h`.
    pub fn relative(half_width: f64) -> Self {
        Self::Scale {
            low: 1.0 - half_width,
            high: 1.0 + half_width,
        }
    }

    /// `(low, high)` of the form.
    pub fn bounds(self) -> (f64, f64) {
        match self {
            Self::Scale { low, high }
            | Self::LogScale { low, high }
            | Self::Range { low, high }
            | Self::LogRange { low, high } => (low, high),
        }
    }

    /// The value for the uniform number `u` in `[0, 1)` around the true value `p`.
    #[inline]
    pub fn sample(self, p: f64, u: f64) -> f64 {
        let lerp = |a: f64, b: f64| a + (b - a) * u;
        match self {
            Self::Scale { low, high } => p * lerp(low, high),
            Self::LogScale { low, high } => p * lerp(low.ln(), high.ln()).exp(),
            Self::Range { low, high } => lerp(low, high),
            Self::LogRange { low, high } => lerp(low.ln(), high.ln()).exp(),
        }
    }

    fn validate(self, name: &'static str) -> Result<()> {
        self.validate_from(name, false)
    }

    /// As `validate`, where a uniform absolute range may start at 0 (`zero_allowed`: a
    /// rig effect, which may be off).
    fn validate_from(self, name: &'static str, zero_allowed: bool) -> Result<()> {
        let (low, high) = self.bounds();
        if zero_allowed && matches!(self, Self::Range { .. }) {
            return if low.is_finite() && high.is_finite() && low >= 0.0 && low <= high {
                Ok(())
            } else {
                Err(InputError::InvalidRange {
                    name,
                    low,
                    high,
                    expected: "0 <= low <= high, finite",
                }
                .into())
            };
        }
        let expected = match self {
            Self::Scale { .. } | Self::LogScale { .. } => {
                "0 < low <= high, finite (a relative half-width must be in [0, 1): \
                 a scale of 0 or less would make the parameter non-positive)"
            }
            Self::Range { .. } | Self::LogRange { .. } => {
                "0 < low <= high, finite (a range reaching 0 or below could make the \
                 parameter non-positive)"
            }
        };
        if low.is_finite() && high.is_finite() && low > 0.0 && low <= high {
            Ok(())
        } else {
            Err(InputError::InvalidRange {
                name,
                low,
                high,
                expected,
            }
            .into())
        }
    }
}

/// The randomisation of one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamRandomization {
    /// How values are drawn.
    pub distribution: Distribution,
    /// Link masses and lengths: one draw per link (true) or one draw shared by all
    /// links (false). Ignored for the cart mass and gravity.
    pub per_link: bool,
}

/// Which parameters are redrawn at every reset (`None`: kept at the true value).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Randomization {
    /// The cart mass's randomisation.
    pub cart_mass: Option<ParamRandomization>,
    /// The link masses' randomisation.
    pub link_masses: Option<ParamRandomization>,
    /// The link lengths' randomisation.
    pub link_lengths: Option<ParamRandomization>,
    /// Gravity's randomisation.
    pub gravity: Option<ParamRandomization>,
    /// The joint damping's randomisation.
    pub joint_damping: Option<ParamRandomization>,
    /// The cart's viscous friction's randomisation.
    pub cart_viscous_friction: Option<ParamRandomization>,
    /// The cart's Coulomb friction's randomisation.
    pub cart_coulomb_friction: Option<ParamRandomization>,
}

impl Randomization {
    /// The randomisation of `p`.
    pub fn get(&self, p: Param) -> Option<ParamRandomization> {
        match p {
            Param::CartMass => self.cart_mass,
            Param::LinkMasses => self.link_masses,
            Param::LinkLengths => self.link_lengths,
            Param::Gravity => self.gravity,
        }
    }
    /// Sets the randomisation of `p`.
    pub fn set(&mut self, p: Param, value: Option<ParamRandomization>) {
        match p {
            Param::CartMass => self.cart_mass = value,
            Param::LinkMasses => self.link_masses = value,
            Param::LinkLengths => self.link_lengths = value,
            Param::Gravity => self.gravity = value,
        }
    }
    /// The randomisation of the rig effect `p`.
    pub fn get_rig(&self, p: RigParam) -> Option<ParamRandomization> {
        match p {
            RigParam::JointDamping => self.joint_damping,
            RigParam::CartViscousFriction => self.cart_viscous_friction,
            RigParam::CartCoulombFriction => self.cart_coulomb_friction,
        }
    }
    /// Sets the randomisation of the rig effect `p`.
    pub fn set_rig(&mut self, p: RigParam, value: Option<ParamRandomization>) {
        match p {
            RigParam::JointDamping => self.joint_damping = value,
            RigParam::CartViscousFriction => self.cart_viscous_friction = value,
            RigParam::CartCoulombFriction => self.cart_coulomb_friction = value,
        }
    }
    /// Nothing is randomised.
    pub fn is_off(&self) -> bool {
        Param::ALL.iter().all(|&p| self.get(p).is_none()) && !self.draws_rig()
    }
    /// Some rig effect is drawn at every reset.
    pub fn draws_rig(&self) -> bool {
        RigParam::ALL.iter().any(|&p| self.get_rig(p).is_some())
    }
    /// Checks every range (finite, non-empty, positive where values must be; a rig
    /// effect's absolute range may start at 0).
    pub fn validate(&self) -> Result<()> {
        for p in Param::ALL {
            if let Some(r) = self.get(p) {
                r.distribution.validate(p.qualified(Kind::Randomize))?;
            }
        }
        for p in RigParam::ALL {
            if let Some(r) = self.get_rig(p) {
                r.distribution.validate_from(p.qualified(), true)?;
            }
        }
        Ok(())
    }
    /// Checks the rig draws against the task's `rig`: a relative draw needs a non-zero
    /// value to scale.
    pub fn validate_rig(&self, rig: &Rig) -> Result<()> {
        for p in RigParam::ALL {
            let Some(r) = self.get_rig(p) else { continue };
            let relative = matches!(
                r.distribution,
                Distribution::Scale { .. } | Distribution::LogScale { .. }
            );
            if relative && p.base(rig) == 0.0 {
                return Err(InputError::InvalidParameter {
                    name: p.qualified(),
                    value: 0.0,
                    expected: "a relative draw of a non-zero value: the rig's value is 0, so give \
                               an absolute {\"range\": [low, high]} (low may be 0) or \"log_range\"",
                }
                .into());
            }
        }
        Ok(())
    }
}

/// Some physical parameters, each a number or (masses, lengths) one number per link
/// or a single number for all links. Used both for absolute values
/// ([`RealityGap::params`]) and for scale factors ([`RealityGap::mismatch`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamValues {
    /// The cart mass (or its factor).
    pub cart_mass: Option<f64>,
    /// The link masses (or their factors), one per link or one for all.
    pub link_masses: Option<Vec<f64>>,
    /// The link lengths (or their factors), one per link or one for all.
    pub link_lengths: Option<Vec<f64>>,
    /// Gravity (or its factor).
    pub gravity: Option<f64>,
}

impl ParamValues {
    /// Whether no parameter is given.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    /// Sets one parameter from a list of numbers (one number for the cart mass and
    /// gravity; one or one per link for the link parameters).
    pub fn set(&mut self, p: Param, values: Vec<f64>) {
        match p {
            Param::CartMass => self.cart_mass = values.first().copied(),
            Param::LinkMasses => self.link_masses = Some(values),
            Param::LinkLengths => self.link_lengths = Some(values),
            Param::Gravity => self.gravity = values.first().copied(),
        }
    }

    fn validate(&self, kind: Kind, n: usize) -> Result<()> {
        if let Some(v) = self.cart_mass {
            check_positive(Param::CartMass.qualified(kind), v)?;
        }
        if let Some(v) = self.gravity {
            check_positive(Param::Gravity.qualified(kind), v)?;
        }
        for (p, values) in [
            (Param::LinkMasses, &self.link_masses),
            (Param::LinkLengths, &self.link_lengths),
        ] {
            let Some(values) = values else { continue };
            let name = p.qualified(kind);
            if values.len() != 1 && values.len() != n {
                return Err(InputError::LengthMismatch {
                    name,
                    got: values.len(),
                    expected: n,
                }
                .into());
            }
            check_positive_links(name, values)?;
        }
        Ok(())
    }
}

/// Link value `i` of a one-or-per-link list.
fn link_value(values: &[f64], i: usize) -> f64 {
    if values.len() == 1 {
        values[0]
    } else {
        values[i]
    }
}

/// A Gaussian disturbance of the force the actuator delivers: per step and per cart
/// axis, the commanded force `f` (after clipping, delay, scaling and the rate limit)
/// becomes `f (1 + multiplicative z1) + additive z2`, `z1` and `z2` standard normal.
/// The result is not clipped to `max_force`: it is what the actuator really delivers.
/// Per axis, `z1` is drawn first (only when `multiplicative > 0`), then `z2` (only when
/// `additive > 0`). The default (both 0) is off.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ForceNoise {
    /// Relative standard deviation of the force's gain.
    pub multiplicative: f64,
    /// Standard deviation of the force added, N.
    pub additive: f64,
}

impl ForceNoise {
    /// The accepted keys of the `force_noise` keyword, in the order of the fields.
    pub const NAMES: [&'static str; 2] = ["multiplicative", "additive"];
    /// What each standard deviation must be.
    pub const EXPECTED: &'static str = "a finite number >= 0";

    /// The disturbance is on (some standard deviation is > 0).
    pub fn is_on(&self) -> bool {
        self.multiplicative > 0.0 || self.additive > 0.0
    }

    /// Checks both standard deviations (finite, >= 0).
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("force_noise.multiplicative", self.multiplicative),
            ("force_noise.additive", self.additive),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(InputError::InvalidParameter {
                    name,
                    value,
                    expected: Self::EXPECTED,
                }
                .into());
            }
        }
        Ok(())
    }

    /// The force delivered for the commanded force `f`, with draws from `rng` in the
    /// documented order.
    #[inline]
    pub fn disturb<R: Rng>(&self, f: f64, rng: &mut R) -> f64 {
        let mut out = f;
        if self.multiplicative > 0.0 {
            let z: f64 = rng.sample(StandardNormal);
            out = f * (1.0 + self.multiplicative * z);
        }
        if self.additive > 0.0 {
            let z: f64 = rng.sample(StandardNormal);
            out += self.additive * z;
        }
        out
    }
}

/// What `action_delay` accepts (the key table's words, and every check's).
pub const ACTION_DELAY_EXPECTED: &str = "an integer >= 0 (control periods), or a range (low, high) of integers with 0 <= low <= high drawn per episode";

/// What `force_rate_limit` accepts (the key table's words, and every check's).
pub const FORCE_RATE_LIMIT_EXPECTED: &str = "a number > 0 (N/s), none for no limit, or a range (low, high) with 0 < low <= high <= inf drawn per episode";

/// How the env's true system, its sensors and its actuator differ from the nominal
/// model. The default is the nominal model, sensed exactly, actuated at once.
#[derive(Debug, Clone, PartialEq)]
pub struct RealityGap {
    /// True parameter values replacing the nominal ones (absent: nominal).
    pub params: ParamValues,
    /// Factors multiplying the (replaced) parameters (absent: 1).
    pub mismatch: ParamValues,
    /// Parameters redrawn at every reset around the true values.
    pub randomize: Randomization,
    /// Standard deviation of the Gaussian noise added to each observation component:
    /// empty (none), one number for every component, or one per component.
    pub obs_noise: Vec<f64>,
    /// The force applied at step t is the action of step `t - action_delay` (zero
    /// force for the first `action_delay` steps of an episode).
    pub action_delay: usize,
    /// `Some(high)`: each episode's delay is drawn uniformly from
    /// `action_delay..=high` at its reset, from the env's start stream after the start
    /// state (`None`: every episode has `action_delay`).
    pub action_delay_high: Option<usize>,
    /// Largest change of the applied force per second, per cart axis (N/s);
    /// `f64::INFINITY` is no limit. With a range, its low end.
    pub force_rate_limit: f64,
    /// `Some(high)`: each episode's limit is drawn at its reset, its inverse uniform
    /// between `1 / high` and `1 / force_rate_limit` (so that a range up to infinity
    /// draws unlimited episodes as readily as stiff ones), from the env's start stream
    /// after the delay (`None`: every episode has `force_rate_limit`).
    pub force_rate_limit_high: Option<f64>,
    /// Gaussian disturbance of the delivered force (default: none).
    pub force_noise: ForceNoise,
}

impl Default for RealityGap {
    fn default() -> Self {
        Self {
            params: ParamValues::default(),
            mismatch: ParamValues::default(),
            randomize: Randomization::default(),
            obs_noise: Vec::new(),
            action_delay: 0,
            action_delay_high: None,
            force_rate_limit: f64::INFINITY,
            force_rate_limit_high: None,
            force_noise: ForceNoise::default(),
        }
    }
}

impl RealityGap {
    /// Checks every field for a chain of `n` links whose state has `state_dim` numbers.
    pub fn validate(&self, n: usize, state_dim: usize) -> Result<()> {
        self.params.validate(Kind::Params, n)?;
        self.mismatch.validate(Kind::Mismatch, n)?;
        self.randomize.validate()?;
        if self.obs_noise.len() > 1 && self.obs_noise.len() != state_dim {
            return Err(InputError::LengthMismatch {
                name: "obs_noise",
                got: self.obs_noise.len(),
                expected: state_dim,
            }
            .into());
        }
        for (index, &value) in self.obs_noise.iter().enumerate() {
            if !(value.is_finite() && value >= 0.0) {
                return Err(InputError::InvalidLinkParameter {
                    name: "obs_noise",
                    link: index,
                    value,
                    expected: "a finite standard deviation >= 0",
                }
                .into());
            }
        }
        if let Some(high) = self.action_delay_high {
            if high < self.action_delay || u32::try_from(high).is_err() {
                return Err(InputError::InvalidParameter {
                    name: "action_delay",
                    value: high as f64,
                    expected: ACTION_DELAY_EXPECTED,
                }
                .into());
            }
        }
        let bad_rate = |value: f64| -> Result<()> {
            Err(InputError::InvalidParameter {
                name: "force_rate_limit",
                value,
                expected: FORCE_RATE_LIMIT_EXPECTED,
            }
            .into())
        };
        if self.force_rate_limit.is_nan() || self.force_rate_limit <= 0.0 {
            return bad_rate(self.force_rate_limit);
        }
        if let Some(high) = self.force_rate_limit_high {
            if !self.force_rate_limit.is_finite() {
                return bad_rate(self.force_rate_limit);
            }
            if high.is_nan() || high < self.force_rate_limit {
                return bad_rate(high);
            }
        }
        self.force_noise.validate()
    }

    /// A control delay given as a signed integer (as it arrives from a config).
    pub fn delay_from(value: i64) -> Result<usize> {
        usize::try_from(value).map_err(|_| {
            InputError::InvalidParameter {
                name: "action_delay",
                value: value as f64,
                expected: ACTION_DELAY_EXPECTED,
            }
            .into()
        })
    }

    /// The longest delay an episode can have (the delay line's length).
    pub fn max_action_delay(&self) -> usize {
        self.action_delay_high.unwrap_or(self.action_delay)
    }

    /// The control delay of a new episode: the fixed one, or one drawn from `rng`.
    pub fn draw_action_delay<R: Rng>(&self, rng: &mut R) -> usize {
        match self.action_delay_high {
            Some(high) if high > self.action_delay => rng.random_range(self.action_delay..=high),
            _ => self.action_delay,
        }
    }

    /// Observation noise is on (some component has a scale > 0).
    pub fn has_obs_noise(&self) -> bool {
        self.obs_noise.iter().any(|&s| s > 0.0)
    }

    /// The noise scale of observation component `k`.
    #[inline]
    pub fn noise_scale(&self, k: usize) -> f64 {
        link_value(&self.obs_noise, k)
    }

    /// A force-rate limit is set (fixed, or drawn per episode).
    pub fn has_rate_limit(&self) -> bool {
        self.force_rate_limit.is_finite()
    }

    /// Each episode draws its own force-rate limit.
    pub fn draws_rate_limit(&self) -> bool {
        self.force_rate_limit_high.is_some()
    }

    /// The force-rate limit of a new episode (N/s): drawn from `rng` with a range (its
    /// inverse uniform between the ends' inverses), else the fixed one.
    pub fn draw_force_rate_limit<R: Rng>(&self, rng: &mut R) -> f64 {
        match self.force_rate_limit_high {
            Some(high) => {
                let (stiff, loose) = (1.0 / self.force_rate_limit, 1.0 / high);
                let inverse = loose + (stiff - loose) * rng.random::<f64>();
                if inverse > 0.0 {
                    1.0 / inverse
                } else {
                    f64::INFINITY
                }
            }
            None => self.force_rate_limit,
        }
    }

    /// The delivered force is disturbed.
    pub fn has_force_noise(&self) -> bool {
        self.force_noise.is_on()
    }

    /// The true system differs from the nominal one before any randomisation.
    pub fn has_mismatch(&self) -> bool {
        !self.params.is_empty() || !self.mismatch.is_empty()
    }

    /// The env's true (pre-randomisation) parameters for the `nominal` ones.
    pub fn true_params(&self, nominal: &ChainParams) -> Result<ChainParams> {
        let n = nominal.n_links();
        self.params.validate(Kind::Params, n)?;
        self.mismatch.validate(Kind::Mismatch, n)?;
        let (p, s) = (&self.params, &self.mismatch);
        let scalar = |value: Option<f64>, nominal: f64, factor: Option<f64>| {
            value.unwrap_or(nominal) * factor.unwrap_or(1.0)
        };
        let links = |values: &Option<Vec<f64>>, nominal: &[f64], factors: &Option<Vec<f64>>| {
            (0..n)
                .map(|i| {
                    let v = values.as_deref().map_or(nominal[i], |v| link_value(v, i));
                    v * factors.as_deref().map_or(1.0, |f| link_value(f, i))
                })
                .collect::<Vec<f64>>()
        };
        ChainParams::new(
            scalar(p.cart_mass, nominal.cart_mass(), s.cart_mass),
            &links(&p.link_masses, nominal.masses(), &s.link_masses),
            &links(&p.link_lengths, nominal.lengths(), &s.link_lengths),
            scalar(p.gravity, nominal.gravity(), s.gravity),
        )
    }
}

/// One env's parameters inside [`EnvParams`]: mutable views of its rows.
pub struct ParamRow<'a> {
    /// The env's cart mass.
    pub cart_mass: &'a mut f64,
    /// The env's link masses.
    pub link_masses: &'a mut [f64],
    /// The env's link lengths.
    pub link_lengths: &'a mut [f64],
    /// The env's gravity.
    pub gravity: &'a mut f64,
    /// The env's rig effects (empty unless drawn).
    pub rig: RigRow<'a>,
}

/// One env's rig effects inside [`EnvParams`] (every slice empty when none is drawn).
pub struct RigRow<'a> {
    /// Joint damping, one per link.
    pub joint_damping: &'a mut [f64],
    /// Cart viscous friction (one number).
    pub cart_viscous_friction: &'a mut [f64],
    /// Cart Coulomb friction (one number).
    pub cart_coulomb_friction: &'a mut [f64],
}

impl RigRow<'_> {
    /// Whether the env draws its own rig effects.
    pub fn is_drawn(&self) -> bool {
        !self.cart_coulomb_friction.is_empty()
    }

    /// Draws the rig effects around `rig` (the true chain's, built by
    /// `Chain::with_drawn_rig`: one joint damping per link) from `rng`, after the
    /// physical parameters.
    fn sample<R: Rng>(&mut self, r: &Randomization, rig: &Rig, rng: &mut R) {
        if !self.is_drawn() {
            return;
        }
        sample_links(r.joint_damping, &rig.joint_damping, self.joint_damping, rng);
        self.cart_viscous_friction[0] =
            sample_scalar(r.cart_viscous_friction, rig.cart_viscous_friction, rng);
        self.cart_coulomb_friction[0] =
            sample_scalar(r.cart_coulomb_friction, rig.cart_coulomb_friction, rng);
    }
}

impl ParamRow<'_> {
    /// Draws new values around `truth` (and the rig effects around `rig`, where drawn)
    /// from `rng`, in the documented order.
    pub fn sample<R: Rng>(
        &mut self,
        r: &Randomization,
        truth: &ChainParams,
        rig: Option<&Rig>,
        rng: &mut R,
    ) {
        *self.cart_mass = sample_scalar(r.cart_mass, truth.cart_mass(), rng);
        sample_links(r.link_masses, truth.masses(), self.link_masses, rng);
        sample_links(r.link_lengths, truth.lengths(), self.link_lengths, rng);
        *self.gravity = sample_scalar(r.gravity, truth.gravity(), rng);
        if let Some(rig) = rig {
            self.rig.sample(r, rig, rng);
        }
    }
}

/// One number drawn around `truth` (kept when `r` is `None`).
fn sample_scalar<R: Rng>(r: Option<ParamRandomization>, truth: f64, rng: &mut R) -> f64 {
    match r {
        Some(d) => d.distribution.sample(truth, rng.random()),
        None => truth,
    }
}

/// One number per link drawn around `truth`: a draw per link, or one shared.
fn sample_links<R: Rng>(
    r: Option<ParamRandomization>,
    truth: &[f64],
    out: &mut [f64],
    rng: &mut R,
) {
    match r {
        None => out.copy_from_slice(truth),
        Some(d) if d.per_link => {
            for (o, &p) in out.iter_mut().zip(truth) {
                *o = d.distribution.sample(p, rng.random());
            }
        }
        Some(d) => {
            let u: f64 = rng.random();
            for (o, &p) in out.iter_mut().zip(truth) {
                *o = d.distribution.sample(p, u);
            }
        }
    }
}

/// Per-env physical parameters, struct of arrays: one contiguous vector per parameter
/// across the envs of a batch (`cart_mass[i]`, `link_masses[i*n..(i+1)*n]`, ...), so
/// that a kernel stepping several envs at once can load them lane by lane.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvParams {
    n_links: usize,
    /// Cart mass of each env.
    pub cart_mass: Vec<f64>,
    /// Link masses, `n_links` per env.
    pub link_masses: Vec<f64>,
    /// Link lengths, `n_links` per env.
    pub link_lengths: Vec<f64>,
    /// Gravity of each env.
    pub gravity: Vec<f64>,
    /// Joint damping, `n_links` per env (empty unless rig effects are drawn).
    pub joint_damping: Vec<f64>,
    /// Cart viscous friction of each env (empty unless rig effects are drawn).
    pub cart_viscous_friction: Vec<f64>,
    /// Cart Coulomb friction of each env (empty unless rig effects are drawn).
    pub cart_coulomb_friction: Vec<f64>,
}

impl EnvParams {
    /// `num_envs` copies of `p`, without rig effects of their own.
    pub fn filled(p: &ChainParams, num_envs: usize) -> Self {
        Self {
            n_links: p.n_links(),
            cart_mass: vec![p.cart_mass(); num_envs],
            link_masses: p.masses().repeat(num_envs),
            link_lengths: p.lengths().repeat(num_envs),
            gravity: vec![p.gravity(); num_envs],
            joint_damping: Vec::new(),
            cart_viscous_friction: Vec::new(),
            cart_coulomb_friction: Vec::new(),
        }
    }
    /// `num_envs` copies of `p` and of the rig effects of `rig`, which each env then
    /// draws its own of.
    pub fn filled_with_rig(p: &ChainParams, rig: &Rig, num_envs: usize) -> Self {
        let n = p.n_links();
        let damping: Vec<f64> = (0..n).map(|i| rig.damping(i)).collect();
        Self {
            joint_damping: damping.repeat(num_envs),
            cart_viscous_friction: vec![rig.cart_viscous_friction; num_envs],
            cart_coulomb_friction: vec![rig.cart_coulomb_friction; num_envs],
            ..Self::filled(p, num_envs)
        }
    }
    /// Whether each env has rig effects of its own.
    pub fn has_rig(&self) -> bool {
        !self.cart_coulomb_friction.is_empty()
    }
    /// No per-env storage (the batch shares one parameter set).
    pub fn empty(n_links: usize) -> Self {
        Self {
            n_links,
            cart_mass: Vec::new(),
            link_masses: Vec::new(),
            link_lengths: Vec::new(),
            gravity: Vec::new(),
            joint_damping: Vec::new(),
            cart_viscous_friction: Vec::new(),
            cart_coulomb_friction: Vec::new(),
        }
    }
    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.n_links
    }
    /// Number of envs stored (0 when shared).
    pub fn num_envs(&self) -> usize {
        self.cart_mass.len()
    }
    /// Env `i`'s parameters as a checked [`ChainParams`].
    pub fn get(&self, i: usize) -> Result<ChainParams> {
        let n = self.n_links;
        ChainParams::new(
            self.cart_mass[i],
            &self.link_masses[i * n..(i + 1) * n],
            &self.link_lengths[i * n..(i + 1) * n],
            self.gravity[i],
        )
    }
    /// Env `i`'s rig effects over `base` (its actuation and Coulomb velocity), checked;
    /// `base` itself when the envs have none of their own.
    pub fn rig(&self, i: usize, base: &Rig) -> Result<Rig> {
        let mut rig = base.clone();
        if self.has_rig() {
            let n = self.n_links;
            rig.joint_damping = self.joint_damping[i * n..(i + 1) * n].to_vec();
            rig.cart_viscous_friction = self.cart_viscous_friction[i];
            rig.cart_coulomb_friction = self.cart_coulomb_friction[i];
        }
        rig.validate(self.n_links)?;
        Ok(rig)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn the_randomize_names_are_the_physical_then_the_rig_parameters() {
        let names: Vec<&str> = Param::ALL
            .iter()
            .map(|p| p.name())
            .chain(RigParam::ALL.iter().map(|p| p.name()))
            .collect();
        assert_eq!(names, RANDOMIZE_NAMES);
    }

    #[test]
    fn each_form_maps_the_unit_interval_onto_its_range() {
        let p = 2.0;
        let cases = [
            (Distribution::relative(0.25), 1.5, 2.5),
            (
                Distribution::Scale {
                    low: 0.5,
                    high: 1.0,
                },
                1.0,
                2.0,
            ),
            (
                Distribution::LogScale {
                    low: 0.5,
                    high: 2.0,
                },
                1.0,
                4.0,
            ),
            (
                Distribution::Range {
                    low: 3.0,
                    high: 5.0,
                },
                3.0,
                5.0,
            ),
            (
                Distribution::LogRange {
                    low: 1.0,
                    high: 100.0,
                },
                1.0,
                100.0,
            ),
        ];
        for (d, lo, hi) in cases {
            assert!((d.sample(p, 0.0) - lo).abs() < 1e-12, "{d:?}");
            assert!((d.sample(p, 1.0) - hi).abs() < 1e-12, "{d:?}");
        }
        // Log forms are uniform in the logarithm: the midpoint is the geometric mean.
        let mid = Distribution::LogRange {
            low: 1.0,
            high: 100.0,
        }
        .sample(p, 0.5);
        assert!((mid - 10.0).abs() < 1e-12);
        assert!(
            (Distribution::Scale {
                low: 0.5,
                high: 1.0
            }
            .sample(p, 0.5)
                - 1.5)
                .abs()
                < 1e-15
        );
    }

    #[test]
    fn true_parameters_replace_then_scale() {
        let nominal = ChainParams::uniform(2, 1.0, 0.1, 0.5, 9.81).unwrap();
        let gap = RealityGap {
            params: ParamValues {
                link_masses: Some(vec![0.2, 0.3]),
                gravity: Some(10.0),
                ..Default::default()
            },
            mismatch: ParamValues {
                link_masses: Some(vec![2.0]),
                link_lengths: Some(vec![1.0, 3.0]),
                gravity: Some(0.5),
                ..Default::default()
            },
            ..Default::default()
        };
        let t = gap.true_params(&nominal).unwrap();
        assert_eq!(t.cart_mass(), 1.0);
        assert_eq!(t.masses(), &[0.4, 0.6]);
        assert_eq!(t.lengths(), &[0.5, 1.5]);
        assert_eq!(t.gravity(), 5.0);
        assert!(gap.has_mismatch() && !RealityGap::default().has_mismatch());
    }

    #[test]
    fn sampling_draws_only_the_randomised_parameters_in_order() {
        let truth = ChainParams::uniform(2, 1.0, 0.1, 0.5, 9.81).unwrap();
        let r = Randomization {
            link_lengths: Some(ParamRandomization {
                distribution: Distribution::Range {
                    low: 0.2,
                    high: 0.6,
                },
                per_link: true,
            }),
            ..Default::default()
        };
        let mut params = EnvParams::filled(&truth, 1);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut expected_rng = rng.clone();
        let mut row = ParamRow {
            cart_mass: &mut params.cart_mass[0],
            link_masses: &mut params.link_masses[..],
            link_lengths: &mut params.link_lengths[..],
            gravity: &mut params.gravity[0],
            rig: RigRow {
                joint_damping: &mut [],
                cart_viscous_friction: &mut [],
                cart_coulomb_friction: &mut [],
            },
        };
        row.sample(&r, &truth, None, &mut rng);
        let u0: f64 = expected_rng.random();
        let u1: f64 = expected_rng.random();
        let lerp = |u: f64| 0.2 + (0.6 - 0.2) * u;
        assert_eq!(params.link_lengths, vec![lerp(u0), lerp(u1)]);
        assert_eq!(params.link_masses, vec![0.1, 0.1]);
        assert_eq!((params.cart_mass[0], params.gravity[0]), (1.0, 9.81));
        // Exactly two draws were consumed.
        assert_eq!(rng, expected_rng);
    }
}
