//! Chain parameters laid out per lane, so that every lane may carry its own chain
//! (cart mass, link masses and lengths, gravity) while sharing the link count.
//! A batch of one chain broadcasts the same values into every lane.

use super::simd::{LaneReal, Lanes};
use crate::error::{InputError, Result};
use crate::params::ChainParams;

/// The constants the lane kernel reads, one value per lane, computed exactly as
/// [`crate::model::Chain`] computes them so that lanes reproduce the scalar path.
#[derive(Debug, Clone)]
pub struct LaneParams<const L: usize, T: LaneReal = f64> {
    pub(crate) inv_cart_mass: Lanes<L, T>,
    pub(crate) gravity: Lanes<L, T>,
    pub(crate) inv_masses: Vec<Lanes<L, T>>,
    pub(crate) lengths: Vec<Lanes<L, T>>,
    pub(crate) inv_lengths: Vec<Lanes<L, T>>,
}

impl<const L: usize, T: LaneReal> LaneParams<L, T> {
    /// Every lane carries `params`.
    pub fn broadcast(params: &ChainParams) -> Self {
        let n = params.n_links();
        let mut out = Self {
            inv_cart_mass: Lanes::zero(),
            gravity: Lanes::zero(),
            inv_masses: vec![Lanes::zero(); n],
            lengths: vec![Lanes::zero(); n],
            inv_lengths: vec![Lanes::zero(); n],
        };
        for lane in 0..L {
            out.fill_lane(lane, params);
        }
        out
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.lengths.len()
    }

    /// Gives lane `lane` its own parameters (same number of links as the others).
    pub fn set_lane(&mut self, lane: usize, params: &ChainParams) -> Result<()> {
        if lane >= L {
            return Err(InputError::InvalidParameter {
                name: "lane",
                value: lane as f64,
                expected: "an index below the lane width",
            }
            .into());
        }
        if params.n_links() != self.n_links() {
            return Err(InputError::LengthMismatch {
                name: "link_masses",
                got: params.n_links(),
                expected: self.n_links(),
            }
            .into());
        }
        self.fill_lane(lane, params);
        Ok(())
    }

    fn fill_lane(&mut self, lane: usize, params: &ChainParams) {
        // Computed in f64 like the scalar path, then rounded to the lane type.
        self.inv_cart_mass.0[lane] = T::from_f64(1.0 / params.cart_mass());
        self.gravity.0[lane] = T::from_f64(params.gravity());
        for i in 0..params.n_links() {
            self.inv_masses[i].0[lane] = T::from_f64(params.inv_masses()[i]);
            self.lengths[i].0[lane] = T::from_f64(params.lengths()[i]);
            self.inv_lengths[i].0[lane] = T::from_f64(1.0 / params.lengths()[i]);
        }
    }
}
