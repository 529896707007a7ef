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
    fn inertia_constants_follow_the_paper() {
        let p = ChainParams::new(0.5, &[1.0, 2.0, 3.0], &[0.1, 0.2, 0.3], 9.81).unwrap();
        assert_eq!(p.outboard_mass(), &[6.0, 5.0, 3.0]);
        assert!((p.inertia(0, 2) - 3.0 * 0.1 * 0.3).abs() < 1e-15);
        assert!((p.inertia(1, 1) - 5.0 * 0.04).abs() < 1e-15);
        assert!((p.total_mass() - 6.5).abs() < 1e-15);
    }
}
