//! Quantities conserved or constrained by the exact flow, and the paper's error
//! measures. Computed only when asked for: nothing here runs in the step loop.

use crate::geometry::{Geometry, Vector};
use crate::model::Chain;

/// Kinetic and potential energy (paper eqs. T and V); the cart's height is the zero of V.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Energy {
    /// Kinetic energy `T` of cart and masses.
    pub kinetic: f64,
    /// Potential energy `V`.
    pub potential: f64,
    /// `T_q`: the kinetic energy of the chain relative to the cart (paper eq. T2).
    pub kinetic_links: f64,
}

impl Energy {
    /// `T + V`.
    pub fn total(&self) -> f64 {
        self.kinetic + self.potential
    }
}

/// Largest violations of `|q_i| = 1` and `w_i . q_i = 0` (the latter scaled by `|w_i|`-free
/// absolute value, in rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residuals {
    /// Largest `| |q_i| - 1 |`.
    pub unit_length: f64,
    /// Largest `|w_i . q_i|`.
    pub tangency: f64,
}

impl<G: Geometry> Chain<G> {
    /// Energies of state `y`.
    pub fn energy(&self, y: &[f64]) -> Energy {
        let lay = self.layout();
        let p = self.params();
        let xdot = lay.load_xdot(y);
        let cart_velocity = G::lift(xdot);
        let mut rel_velocity = G::Link::zero();
        let mut rel_position = G::Link::zero();
        let (mut kinetic, mut kinetic_links, mut potential) =
            (0.5 * p.cart_mass() * xdot.norm_squared(), 0.0, 0.0);
        for i in 0..lay.n {
            let q = lay.load_q(y, i);
            rel_velocity += G::velocity(lay.load_w(y, i), q) * p.lengths()[i];
            rel_position += q * p.lengths()[i];
            let m = p.masses()[i];
            kinetic += 0.5 * m * (cart_velocity + rel_velocity).norm_squared();
            kinetic_links += 0.5 * m * rel_velocity.norm_squared();
            potential -= m * p.gravity() * G::down(rel_position);
        }
        Energy {
            kinetic,
            potential,
            kinetic_links,
        }
    }

    /// Total horizontal momentum `m xdot + sum_i m_i C^T v_i`, conserved when u = 0.
    pub fn horizontal_momentum(&self, y: &[f64]) -> G::Cart {
        let lay = self.layout();
        let p = self.params();
        let xdot = lay.load_xdot(y);
        let mut momentum = xdot * p.total_mass();
        let mut rel_velocity = G::Link::zero();
        for i in 0..lay.n {
            rel_velocity += G::velocity(lay.load_w(y, i), lay.load_q(y, i)) * p.lengths()[i];
            momentum += G::horizontal(rel_velocity) * p.masses()[i];
        }
        momentum
    }

    /// Constraint residuals of state `y`.
    pub fn residuals(&self, y: &[f64]) -> Residuals {
        Residuals {
            unit_length: self.unit_length_residual(y),
            tangency: self.tangency_residual(y),
        }
    }

    /// Largest `| |q_i| - 1 |` of state `y`: all the step guard needs, on its own so
    /// the guard computes nothing else when it is not inlined.
    pub fn unit_length_residual(&self, y: &[f64]) -> f64 {
        let lay = self.layout();
        (0..lay.n)
            .map(|i| (lay.load_q(y, i).norm_squared().sqrt() - 1.0).abs())
            .fold(0.0, f64::max)
    }

    /// Largest `|w_i . q_i|` of state `y` (the part of `w_i` along `q_i`).
    pub fn tangency_residual(&self, y: &[f64]) -> f64 {
        let lay = self.layout();
        (0..lay.n)
            .map(|i| {
                let (q, w) = (lay.load_q(y, i), lay.load_w(y, i));
                (w - G::tangent(w, q)).norm_squared().sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// Largest angular speed `max_i |w_i|` (rad/s).
    pub fn max_spin(&self, y: &[f64]) -> f64 {
        let lay = self.layout();
        (0..lay.n)
            .map(|i| lay.load_w(y, i).norm_squared())
            .fold(0.0, f64::max)
            .sqrt()
    }

    /// The paper's errors `e_q = sum |q_i - s_i e3|` and `e_w = sum |w_i|` (s unchecked: use
    /// [`Chain::equilibrium`] to validate a sign tuple).
    pub fn errors(&self, y: &[f64], s: &[f64]) -> (f64, f64) {
        let lay = self.layout();
        let mut e_q = 0.0;
        let mut e_w = 0.0;
        for (i, &si) in s.iter().enumerate().take(lay.n) {
            e_q += (lay.load_q(y, i) - G::down_unit() * si)
                .norm_squared()
                .sqrt();
            e_w += lay.load_w(y, i).norm_squared().sqrt();
        }
        (e_q, e_w)
    }

    /// Position of mass i relative to the cart, `sum_{a<=i} l_a q_a`.
    pub fn mass_position(&self, y: &[f64], i: usize) -> G::Link {
        let lay = self.layout();
        (0..=i).fold(G::Link::zero(), |acc, a| {
            acc + lay.load_q(y, a) * self.params().lengths()[a]
        })
    }

    /// True when every entry is finite and `|q_i|` is within `tolerance` of 1.
    pub fn is_healthy(&self, y: &[f64], tolerance: f64) -> bool {
        y.iter().all(|v| v.is_finite()) && self.unit_length_residual(y) <= tolerance
    }
}
