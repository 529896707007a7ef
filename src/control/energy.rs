//! Energy shaping for one link (Astrom & Furuta 2000), then the LQR catch.
//!
//! In the cart's frame the pendulum's energy is `E = m l^2 |w|^2 / 2 - m g l (e3 . q)`
//! (upright at rest: `E_up = m g l`). A cart acceleration `a` changes it at the rate
//! `dE/dt = -m l a . v`, with `v = C^T qdot` the horizontal velocity of the mass
//! relative to the cart, so the cart acceleration
//!
//! `a = k (E - E_up) v / |v|`   (planar: `k (E - E_up) sign(v)`)
//!
//! drives `E` to `E_up` from any state where the pendulum moves. The force is that
//! acceleration times the total mass, plus a weak centring term
//! `-k_x x - k_v xdot` that keeps the cart on the track, saturated at the force limit.
//! Once the link is within `catch_angle` of upright (and turning slower than
//! `catch_rate`), the target's LQR takes over (the region of attraction of a
//! saturated LQR is what makes the switch safe; see the `roa` tool).

use super::chart::{local, ChartPoint};
use super::cost::{target_lqr, CostWeights};
use super::vector::{ScalarGeometry, Vect};
use crate::error::{check_positive, InputError, Result};
use crate::model::Chain;
use nalgebra::{DMatrix, DVector};

/// Gains and switching rule of [`EnergyController`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyOptions {
    /// Energy gain `k`, (m/s^2) per J.
    pub gain: f64,
    /// Cart centring gains, N/m and N s/m.
    pub centring: f64,
    /// See `centring`.
    pub damping: f64,
    /// Largest tilt from upright at which the LQR takes over, rad.
    pub catch_angle: f64,
    /// Largest angular speed at which the LQR takes over, rad/s.
    pub catch_rate: f64,
}

impl Default for EnergyOptions {
    fn default() -> Self {
        Self {
            gain: 5.0,
            centring: 2.0,
            damping: 0.2,
            catch_angle: 0.6,
            catch_rate: 4.0,
        }
    }
}

/// The energy-shaping swing-up with its LQR catch, for a chain of one link.
#[derive(Debug, Clone)]
pub struct EnergyController<G: ScalarGeometry> {
    chain: Chain<G>,
    options: EnergyOptions,
    max_force: f64,
    target: ChartPoint,
    gain: DMatrix<f64>,
    delta: Vec<f64>,
}

impl<G: ScalarGeometry> EnergyController<G> {
    /// The controller for `chain` (one link) with the force limit `max_force`; the catch
    /// is the LQR of the planner's weights `weights` at the upright equilibrium.
    pub fn new(
        chain: &Chain<G>,
        max_force: f64,
        options: EnergyOptions,
        weights: &CostWeights,
    ) -> Result<Self> {
        if chain.n_links() != 1 {
            return Err(InputError::InvalidParameter {
                name: "n_links",
                value: chain.n_links() as f64,
                expected: "1: energy shaping swings up a single link",
            }
            .into());
        }
        check_positive("max_force", max_force)?;
        for (name, value) in [
            ("gain", options.gain),
            ("catch_angle", options.catch_angle),
            ("catch_rate", options.catch_rate),
        ] {
            check_positive(name, value)?;
        }
        let (_, gain) = target_lqr(chain, &[-1.0], weights)?;
        let dim = super::chart::ChartLayout::of::<G>(1).dim();
        Ok(Self {
            chain: chain.clone(),
            options,
            max_force,
            target: ChartPoint::new::<G>(1, &chain.equilibrium(&[-1.0])?),
            gain,
            delta: vec![0.0; dim],
        })
    }

    /// Length of a state.
    pub fn state_dim(&self) -> usize {
        self.chain.state_dim()
    }
    /// Length of a force.
    pub fn force_dim(&self) -> usize {
        G::CART
    }

    /// The pendulum's energy in the cart's frame, and `E_up`.
    pub fn energy(&self, y: &[f64]) -> (f64, f64) {
        let p = self.chain.params();
        let (m, l, g) = (p.masses()[0], p.lengths()[0], p.gravity());
        let lay = self.chain.layout();
        let q = G::LinkS::<f64>::load(&y[lay.q(0)..]);
        let w = G::SpinS::<f64>::load(&y[lay.w(0)..]);
        let e = 0.5 * m * l * l * w.norm_squared() - m * g * l * G::down_s(q);
        (e, m * g * l)
    }

    /// Whether the LQR is in charge at `y`.
    pub fn catching(&self, y: &[f64]) -> bool {
        let lay = self.chain.layout();
        let q = G::LinkS::<f64>::load(&y[lay.q(0)..]);
        let w = G::SpinS::<f64>::load(&y[lay.w(0)..]);
        let tilt = (-G::down_s(q)).clamp(-1.0, 1.0).acos();
        tilt < self.options.catch_angle && w.norm_squared().sqrt() < self.options.catch_rate
    }

    /// The force at state `y` (checked by the caller), saturated.
    pub fn force(&mut self, y: &[f64], out: &mut [f64]) {
        let nu = G::CART;
        let lay = self.chain.layout();
        if self.catching(y) {
            local::<G, f64>(&self.target, y, &mut self.delta);
            let u = &self.gain * DVector::from_column_slice(&self.delta);
            for j in 0..nu {
                out[j] = (-u[j]).clamp(-self.max_force, self.max_force);
            }
            return;
        }
        let (e, e_up) = self.energy(y);
        let q = G::LinkS::<f64>::load(&y[lay.q(0)..]);
        let w = G::SpinS::<f64>::load(&y[lay.w(0)..]);
        let mut v = [0.0; 2];
        G::horizontal_s(G::velocity_s(w, q)).store(&mut v);
        let speed = v[..nu].iter().map(|c| c * c).sum::<f64>().sqrt();
        let total = self.chain.params().total_mass();
        let (mut x, mut xdot) = ([0.0; 2], [0.0; 2]);
        x[..nu].copy_from_slice(&y[lay.x()..lay.x() + nu]);
        xdot[..nu].copy_from_slice(&y[lay.xdot()..lay.xdot() + nu]);
        for j in 0..nu {
            // From rest at hanging the pendulum does not move: a nudge starts the pumping.
            let direction = if speed > 1e-6 {
                v[j] / speed
            } else if j == 0 {
                -1.0
            } else {
                0.0
            };
            let a = self.options.gain * (e - e_up) * direction;
            let f = total * a - self.options.centring * x[j] - self.options.damping * xdot[j];
            out[j] = f.clamp(-self.max_force, self.max_force);
        }
    }
}
