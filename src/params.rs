//! Physical parameters of the chain pendulum on a cart, validated once.
//!
//! Everything the dynamics needs per link is precomputed here (inverse masses,
//! the mass carried below each joint, gravity torques), so the step loop only
//! reads.

use crate::error::{check_positive, InputError, Result};

/// Standard gravity, m/s^2: the default of every model and scene.
pub const STANDARD_GRAVITY: f64 = 9.81;

// The paper's example system (Lee, Leok & McClamroch, Sec. V): its three figures'
// scenes and the Python model's defaults are this system.
/// Number of links of the paper's example system.
pub const PAPER_LINKS: usize = 5;
/// Cart mass of the paper's example system, kg.
pub const PAPER_CART_MASS: f64 = 0.5;
/// Mass at the end of each link of the paper's example system, kg.
pub const PAPER_LINK_MASS: f64 = 0.1;
/// Length of each link of the paper's example system, m.
pub const PAPER_LINK_LENGTH: f64 = 0.1;

/// Validated parameters: cart mass `m`, link masses `m_i`, lengths `l_i`, gravity `g`.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainParams {
    cart_mass: f64,
    masses: Vec<f64>,
    lengths: Vec<f64>,
    gravity: f64,
    /// `1/m_i`.
    inv_masses: Vec<f64>,
    /// `sum_{a>=i} m_a`: the mass carried at and beyond link i.
    outboard_mass: Vec<f64>,
}

/// Rejects a per-link list with an entry that is not a finite number > 0, naming it.
pub(crate) fn check_positive_links(name: &'static str, values: &[f64]) -> Result<()> {
    for (link, &value) in values.iter().enumerate() {
        if !(value.is_finite() && value > 0.0) {
            return Err(InputError::InvalidLinkParameter {
                name,
                link,
                value,
                expected: "a finite number > 0",
            }
            .into());
        }
    }
    Ok(())
}

impl ChainParams {
    /// Parameters with one mass and one length per link.
    pub fn new(cart_mass: f64, masses: &[f64], lengths: &[f64], gravity: f64) -> Result<Self> {
        if masses.is_empty() {
            return Err(InputError::NoLinks.into());
        }
        crate::limits::check_links(masses.len())?;
        if lengths.len() != masses.len() {
            return Err(InputError::LengthMismatch {
                name: "link_lengths",
                got: lengths.len(),
                expected: masses.len(),
            }
            .into());
        }
        check_positive("cart_mass", cart_mass)?;
        check_positive("gravity", gravity)?;
        check_positive_links("link_masses", masses)?;
        check_positive_links("link_lengths", lengths)?;
        let n = masses.len();
        let mut params = Self {
            cart_mass,
            masses: vec![0.0; n],
            lengths: vec![0.0; n],
            gravity,
            inv_masses: vec![0.0; n],
            outboard_mass: vec![0.0; n],
        };
        params.assign_unchecked(cart_mass, masses, lengths, gravity);
        Ok(params)
    }

    /// Overwrites every value in place (no allocation), recomputing the derived
    /// constants exactly as [`ChainParams::new`] does, so that the result is
    /// bit-identical to a freshly built set. The caller guarantees what `new` checks:
    /// `masses` and `lengths` of length `n_links`, every value finite and > 0.
    pub(crate) fn assign_unchecked(
        &mut self,
        cart_mass: f64,
        masses: &[f64],
        lengths: &[f64],
        gravity: f64,
    ) {
        debug_assert_eq!(masses.len(), self.masses.len());
        debug_assert_eq!(lengths.len(), self.lengths.len());
        self.cart_mass = cart_mass;
        self.gravity = gravity;
        self.masses.copy_from_slice(masses);
        self.lengths.copy_from_slice(lengths);
        for (inv, m) in self.inv_masses.iter_mut().zip(masses) {
            *inv = 1.0 / m;
        }
        let mut acc = 0.0;
        for i in (0..masses.len()).rev() {
            acc += masses[i];
            self.outboard_mass[i] = acc;
        }
    }

    /// `n` identical links (scalars broadcast).
    pub fn uniform(n: usize, cart_mass: f64, mass: f64, length: f64, gravity: f64) -> Result<Self> {
        crate::limits::check_links(n)?;
        Self::new(cart_mass, &vec![mass; n], &vec![length; n], gravity)
    }

    /// The paper's example system: n = 5, m = 0.5 kg, m_i = 0.1 kg, l_i = 0.1 m, g = 9.81.
    pub fn paper() -> Self {
        Self::uniform(
            PAPER_LINKS,
            PAPER_CART_MASS,
            PAPER_LINK_MASS,
            PAPER_LINK_LENGTH,
            STANDARD_GRAVITY,
        )
        .expect("paper parameters are valid")
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.masses.len()
    }
    /// Cart mass `m`, kg.
    pub fn cart_mass(&self) -> f64 {
        self.cart_mass
    }
    /// Link masses `m_i`, kg (point masses at the links' ends).
    pub fn masses(&self) -> &[f64] {
        &self.masses
    }
    /// Link lengths `l_i`, m.
    pub fn lengths(&self) -> &[f64] {
        &self.lengths
    }
    /// Gravitational acceleration along e3, m/s^2.
    pub fn gravity(&self) -> f64 {
        self.gravity
    }
    /// `1 / m_i`, precomputed.
    pub fn inv_masses(&self) -> &[f64] {
        &self.inv_masses
    }
    /// `sum_{a>=i} m_a` for each link i (0-based).
    pub fn outboard_mass(&self) -> &[f64] {
        &self.outboard_mass
    }
    /// Total mass `M_00 = m + sum m_i`.
    pub fn total_mass(&self) -> f64 {
        self.cart_mass + self.outboard_mass[0]
    }
    /// Paper's inertia constant `M_ij = (sum_{a>=max(i,j)} m_a) l_i l_j` (0-based).
    pub fn inertia(&self, i: usize, j: usize) -> f64 {
        self.outboard_mass[i.max(j)] * self.lengths[i] * self.lengths[j]
    }
    /// Paper's `M_0i` scalar: `(sum_{a>=i} m_a) l_i` (the 2x3 block is this times C^T).
    pub fn cart_coupling(&self, i: usize) -> f64 {
        self.outboard_mass[i] * self.lengths[i]
    }
    /// Gravity coefficient of link i: `(sum_{a>=i} m_a) g l_i`.
    pub fn gravity_coefficient(&self, i: usize) -> f64 {
        self.outboard_mass[i] * self.gravity * self.lengths[i]
    }
}

/// What the action commands: a force on the cart, its acceleration (a servo axis
/// that tracks any acceleration, so the cart's mass and its friction drop out of the
/// chain's motion) or a DC motor's voltage (the force follows from the motor's
/// current, limited by back-EMF and a current limit).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Actuation {
    /// The command is the force on the cart, N per axis.
    #[default]
    Force,
    /// The command is the cart's acceleration, m/s^2 per axis.
    Acceleration,
    /// The command is a motor's terminal voltage, V per axis (one motor per axis).
    Voltage(Motor),
}

impl Actuation {
    /// The accepted names, in the order of the variants.
    pub const NAMES: [&'static str; 3] = ["force", "acceleration", "voltage"];

    /// The mode's name as the configuration writes it.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Force => "force",
            Self::Acceleration => "acceleration",
            Self::Voltage(_) => "voltage",
        }
    }

    /// The mode named `name`; `motor` is the motor a voltage mode drives.
    pub fn from_name(name: &str, motor: Motor) -> Result<Self> {
        match name {
            "force" => Ok(Self::Force),
            "acceleration" => Ok(Self::Acceleration),
            "voltage" => Ok(Self::Voltage(motor)),
            _ => Err(InputError::UnknownName {
                kind: "actuation",
                name: name.to_string(),
                expected: &Self::NAMES,
            }
            .into()),
        }
    }
}

/// A DC motor driving one cart axis through a gear and a pulley (or pinion): the
/// armature's inductance and the rotor's inertia are neglected, so the current
/// follows the voltage at once: `i = clamp((V - k w_m) / R, -i_max, i_max)` with the
/// motor's speed `w_m = N v / r`, and the cart feels `F = N k i / r`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motor {
    /// Torque constant `k`, N m/A (in SI also the back-EMF constant, V s/rad).
    pub torque_constant: f64,
    /// Armature resistance `R`, ohm.
    pub resistance: f64,
    /// Gear ratio `N`: motor turns per pulley turn.
    pub gear_ratio: f64,
    /// Pulley (or pinion) radius `r`, m.
    pub pulley_radius: f64,
    /// Largest current magnitude `i_max`, A (the drive's limit).
    pub current_limit: f64,
}

impl Motor {
    /// The names of the fields, in order (the `motor` keyword's).
    pub const NAMES: [&'static str; 5] = [
        "torque_constant",
        "resistance",
        "gear_ratio",
        "pulley_radius",
        "current_limit",
    ];
    /// What each field must be.
    pub const EXPECTED: &'static str = "a finite number > 0";

    /// The motor of the fields in the order of [`Motor::NAMES`].
    pub fn from_array(a: [f64; 5]) -> Self {
        Self {
            torque_constant: a[0],
            resistance: a[1],
            gear_ratio: a[2],
            pulley_radius: a[3],
            current_limit: a[4],
        }
    }

    /// The fields in the order of [`Motor::NAMES`].
    pub fn as_array(&self) -> [f64; 5] {
        [
            self.torque_constant,
            self.resistance,
            self.gear_ratio,
            self.pulley_radius,
            self.current_limit,
        ]
    }

    /// Checks that every field is finite and > 0, naming the first that is not.
    pub fn validate(&self) -> Result<()> {
        const QUALIFIED: [&str; 5] = [
            "motor.torque_constant",
            "motor.resistance",
            "motor.gear_ratio",
            "motor.pulley_radius",
            "motor.current_limit",
        ];
        for (name, value) in QUALIFIED.into_iter().zip(self.as_array()) {
            if !(value.is_finite() && value > 0.0) {
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

    /// `N k / r`: force per ampere, N/A.
    pub fn force_per_amp(&self) -> f64 {
        self.gear_ratio * self.torque_constant / self.pulley_radius
    }

    /// The force, N, on a cart moving at `velocity` (m/s) under the terminal voltage
    /// `voltage` (V).
    #[inline]
    pub fn force(&self, voltage: f64, velocity: f64) -> f64 {
        let k = self.force_per_amp();
        let current = ((voltage - k * velocity) / self.resistance)
            .clamp(-self.current_limit, self.current_limit);
        k * current
    }

    /// The force at rest: `N k min(V / R, i_max) / r` for `V >= 0`.
    pub fn stall_force(&self, voltage: f64) -> f64 {
        self.force(voltage, 0.0)
    }

    /// The speed at which the back-EMF cancels the voltage (no force): `V r / (N k)`.
    pub fn no_load_speed(&self, voltage: f64) -> f64 {
        voltage / self.force_per_amp()
    }
}

/// The effects of a real rig beyond the ideal model, each off (zero) by default: joint
/// damping, cart friction and the actuation mode. A chain with [`Rig::is_ideal`] rig
/// runs the original dynamics bit for bit (docs/physics.md, "Real-rig effects").
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// Viscous damping of each joint, N m s/rad: the torque `-c_i (w_i - w_{i-1})` on
    /// link i (`w_0 = 0`, the cart does not rotate). Empty, one number for every joint,
    /// or one per link.
    pub joint_damping: Vec<f64>,
    /// Viscous friction of the cart on each axis, N s/m: `-b v`.
    pub cart_viscous_friction: f64,
    /// Coulomb friction of the cart on each axis, N, regularised as
    /// `-F_c tanh(v / coulomb_velocity)`.
    pub cart_coulomb_friction: f64,
    /// The velocity scale of the Coulomb law's regularisation, m/s.
    pub coulomb_velocity: f64,
    /// What the command of a step is.
    pub actuation: Actuation,
}

/// Default velocity scale of the regularised Coulomb friction, m/s.
pub const DEFAULT_COULOMB_VELOCITY: f64 = 0.01;

impl Default for Rig {
    fn default() -> Self {
        Self {
            joint_damping: Vec::new(),
            cart_viscous_friction: 0.0,
            cart_coulomb_friction: 0.0,
            coulomb_velocity: DEFAULT_COULOMB_VELOCITY,
            actuation: Actuation::Force,
        }
    }
}

impl Rig {
    /// No effect is on: the ideal model (the default).
    pub fn is_ideal(&self) -> bool {
        !self.has_joint_damping() && !self.has_cart_friction() && self.actuation == Actuation::Force
    }

    /// The same rig without its Coulomb friction: the smooth effects a linear design
    /// can count on.
    pub fn without_coulomb_friction(&self) -> Rig {
        Rig {
            cart_coulomb_friction: 0.0,
            ..self.clone()
        }
    }

    /// Some joint has damping.
    pub fn has_joint_damping(&self) -> bool {
        self.joint_damping.iter().any(|&c| c != 0.0)
    }

    /// The cart has some friction.
    pub fn has_cart_friction(&self) -> bool {
        self.cart_viscous_friction != 0.0 || self.cart_coulomb_friction != 0.0
    }

    /// The damping coefficient of joint `i`.
    #[inline]
    pub fn damping(&self, i: usize) -> f64 {
        match self.joint_damping.len() {
            0 => 0.0,
            1 => self.joint_damping[0],
            _ => self.joint_damping[i],
        }
    }

    /// The friction force on one cart axis moving at `v`, N.
    #[inline]
    pub fn friction(&self, v: f64) -> f64 {
        let mut f = -self.cart_viscous_friction * v;
        if self.cart_coulomb_friction != 0.0 {
            f -= self.cart_coulomb_friction * (v / self.coulomb_velocity).tanh();
        }
        f
    }

    /// Checks every value for a chain of `n` links, naming the first bad one.
    pub fn validate(&self, n: usize) -> Result<()> {
        let len = self.joint_damping.len();
        if len > 1 && len != n {
            return Err(InputError::LengthMismatch {
                name: "joint_damping",
                got: len,
                expected: n,
            }
            .into());
        }
        for (link, &value) in self.joint_damping.iter().enumerate() {
            if !(value.is_finite() && value >= 0.0) {
                return Err(InputError::InvalidLinkParameter {
                    name: "joint_damping",
                    link,
                    value,
                    expected: "a finite number >= 0",
                }
                .into());
            }
        }
        for (name, value) in [
            ("cart_viscous_friction", self.cart_viscous_friction),
            ("cart_coulomb_friction", self.cart_coulomb_friction),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(InputError::InvalidParameter {
                    name,
                    value,
                    expected: "a finite number >= 0",
                }
                .into());
            }
        }
        check_positive("coulomb_velocity", self.coulomb_velocity)?;
        if self.actuation == Actuation::Acceleration && self.has_cart_friction() {
            return Err(InputError::Incompatible {
                name: "actuation",
                value: "acceleration",
                expected: "no cart friction (cart_viscous_friction and cart_coulomb_friction 0): \
                           a servo axis tracks its acceleration whatever the friction, so it \
                           would change nothing"
                    .to_string(),
            }
            .into());
        }
        if let Actuation::Voltage(motor) = &self.actuation {
            motor.validate()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ChainError;

    #[test]
    fn rejects_bad_values_naming_them() {
        let e = ChainParams::new(0.5, &[0.1, -1.0], &[0.1, 0.1], 9.81).unwrap_err();
        assert_eq!(
            e,
            InputError::InvalidLinkParameter {
                name: "link_masses",
                link: 1,
                value: -1.0,
                expected: "a finite number > 0"
            }
            .into()
        );
        assert!(e.to_string().contains("link_masses[1] = -1"));
        assert_eq!(
            ChainParams::new(0.5, &[], &[], 9.81).unwrap_err(),
            InputError::NoLinks.into()
        );
        assert!(matches!(
            ChainParams::new(0.5, &[0.1], &[0.1, 0.2], 9.81),
            Err(ChainError::Input(InputError::LengthMismatch { .. }))
        ));
        assert!(matches!(
            ChainParams::new(f64::NAN, &[0.1], &[0.1], 9.81),
            Err(ChainError::Input(InputError::InvalidParameter {
                name: "cart_mass",
                ..
            }))
        ));
        assert!(matches!(
            ChainParams::new(0.5, &[0.1], &[0.1], 0.0),
            Err(ChainError::Input(InputError::InvalidParameter {
                name: "gravity",
                ..
            }))
        ));
        assert!(matches!(
            ChainParams::new(0.5, &[0.1], &[f64::INFINITY], 9.81),
            Err(ChainError::Input(InputError::InvalidLinkParameter {
                name: "link_lengths",
                ..
            }))
        ));
    }

    #[test]
    fn the_motor_force_follows_its_closed_forms() {
        let m = Motor::from_array([0.02, 2.0, 5.0, 0.02, 5.0]);
        let per_amp = 5.0 * 0.02 / 0.02;
        // Below the current limit the stall force is N k V / (R r); above it, N k i_max / r.
        assert!((m.stall_force(3.0) - per_amp * 3.0 / 2.0).abs() < 1e-12);
        assert!((m.stall_force(12.0) - per_amp * 5.0).abs() < 1e-12);
        assert!((m.stall_force(-12.0) + per_amp * 5.0).abs() < 1e-12);
        let v0 = m.no_load_speed(6.0);
        assert!((v0 - 6.0 * 0.02 / (5.0 * 0.02)).abs() < 1e-12);
        assert!(m.force(6.0, v0).abs() < 1e-12);
        // Faster than no-load, the motor brakes.
        assert!(m.force(6.0, 2.0 * v0) < 0.0);
    }

    #[test]
    fn friction_and_damping_laws() {
        let rig = Rig {
            joint_damping: vec![0.3],
            cart_viscous_friction: 2.0,
            cart_coulomb_friction: 1.5,
            coulomb_velocity: 0.01,
            actuation: Actuation::Force,
        };
        assert_eq!(rig.damping(0), 0.3);
        assert_eq!(rig.damping(4), 0.3);
        assert_eq!(rig.friction(0.0), 0.0);
        // Well above the velocity scale the Coulomb part is the full force.
        assert!((rig.friction(1.0) - (-2.0 - 1.5)).abs() < 1e-12);
        assert!((rig.friction(-1.0) - (2.0 + 1.5)).abs() < 1e-12);
        assert!((rig.friction(0.01) - (-0.02 - 1.5 * 1f64.tanh())).abs() < 1e-15);
        assert!(!rig.is_ideal() && Rig::default().is_ideal());
        assert_eq!(
            Actuation::from_name("voltage", Motor::from_array([1.0; 5]))
                .unwrap()
                .name(),
            "voltage"
        );
        let e = Actuation::from_name("torque", Motor::from_array([1.0; 5]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("acceleration"), "{e}");
    }

    #[test]
    fn inertia_constants_follow_the_paper() {
        let p = ChainParams::new(0.5, &[1.0, 2.0, 3.0], &[0.1, 0.2, 0.3], 9.81).unwrap();
        assert_eq!(p.outboard_mass(), &[6.0, 5.0, 3.0]);
        assert!((p.inertia(0, 2) - 3.0 * 0.1 * 0.3).abs() < 1e-15);
        assert!((p.inertia(1, 1) - 5.0 * 0.04).abs() < 1e-15);
        assert!((p.total_mass() - 6.5).abs() < 1e-15);
    }
}
