//! The chain model and its exact O(n) accelerations.
//!
//! Links are massless rods between point masses; the cart is a mass on a
//! horizontal rail. Newton's law for each mass plus the twice-differentiated
//! rod constraint `q_i . qdd_i = -|qdot_i|^2` give a symmetric positive-definite
//! tridiagonal system for the rod tensions `T_i` (docs/physics.md):
//!
//! ```text
//! (1/m_1 + |C^T q_1|^2/m) T_1 - (q_1.q_2/m_1) T_2          = l_1|qdot_1|^2 + g e3.q_1 - q_1.Cu/m
//! -(q_{i-1}.q_i/m_{i-1}) T_{i-1} + (1/m_i + 1/m_{i-1}) T_i
//!                                   - (q_i.q_{i+1}/m_i) T_{i+1} = l_i |qdot_i|^2
//! ```
//!
//! after which `m xdd = u + T_1 C^T q_1`, each mass's acceleration follows, and
//! `wdot_i = q_i x qdd_i`. This is algebraically the paper's eq. (ELwm) (tested
//! against [`crate::dense`]) at O(n) instead of O(n^3) cost.

use crate::error::{check_finite, check_len, InputError, Result};
use crate::geometry::{Geometry, Layout, Planar, Spatial, Vector};
use crate::params::{Actuation, ChainParams, Rig};

/// Parameters plus the constants the step loop reads; immutable once built.
#[derive(Debug, Clone)]
pub struct Chain<G: Geometry> {
    params: ChainParams,
    layout: Layout<G>,
    inv_cart_mass: f64,
    inv_lengths: Vec<f64>,
    /// `g l_i sum_{a>=i} m_a`: the gravity force on the free coordinate q_i.
    gravity_coefficients: Vec<f64>,
    /// Real-rig effects (damping, friction, actuation mode); `None` for the ideal
    /// model, which then runs exactly the original dynamics.
    rig: Option<Box<Rig>>,
}

/// The spatial chain (2-D cart, spherical joints).
pub type SpatialChain = Chain<Spatial>;
/// The planar chain (1-D cart, hinges).
pub type PlanarChain = Chain<Planar>;

/// Buffers one evaluation needs, allocated once per chain size and reused.
#[derive(Debug, Clone)]
pub struct Workspace<G: Geometry> {
    pub(crate) q: Vec<G::Link>,
    pub(crate) diag: Vec<f64>,
    pub(crate) off: Vec<f64>,
    pub(crate) tension: Vec<f64>,
    /// Forces on the masses besides gravity and the rods (joint damping's couples).
    pub(crate) applied: Vec<G::Link>,
}

impl<G: Geometry> Workspace<G> {
    /// Buffers for a chain of `n` links.
    pub fn new(n: usize) -> Self {
        Self {
            q: vec![G::Link::zero(); n],
            diag: vec![0.0; n],
            off: vec![0.0; n],
            tension: vec![0.0; n],
            applied: vec![G::Link::zero(); n],
        }
    }
}

impl<G: Geometry> Chain<G> {
    /// The chain with these (validated) parameters.
    pub fn new(params: ChainParams) -> Self {
        let n = params.n_links();
        let mut chain = Self {
            inv_cart_mass: 0.0,
            inv_lengths: vec![0.0; n],
            layout: Layout::new(n),
            gravity_coefficients: vec![0.0; n],
            params,
            rig: None,
        };
        chain.update_constants();
        chain
    }

    /// Replaces the physical parameters in place without allocating (the per-env
    /// parameters of an env batch are loaded this way before each env's step). The
    /// result is bit-identical to `Chain::new` with the same values. The caller
    /// guarantees what [`ChainParams::new`] checks: `masses` and `lengths` of length
    /// `n_links`, every value finite and > 0.
    pub(crate) fn set_params_unchecked(
        &mut self,
        cart_mass: f64,
        masses: &[f64],
        lengths: &[f64],
        gravity: f64,
    ) {
        self.params
            .assign_unchecked(cart_mass, masses, lengths, gravity);
        self.update_constants();
    }

    fn update_constants(&mut self) {
        let p = &self.params;
        self.inv_cart_mass = 1.0 / p.cart_mass();
        for (inv, l) in self.inv_lengths.iter_mut().zip(p.lengths()) {
            *inv = 1.0 / l;
        }
        for (i, c) in self.gravity_coefficients.iter_mut().enumerate() {
            *c = p.gravity_coefficient(i);
        }
    }

    /// The chain with the real-rig effects `rig` (checked for this chain's links). An
    /// ideal rig ([`Rig::is_ideal`]) leaves the chain the ideal model, bit for bit.
    pub fn with_rig(mut self, rig: Rig) -> Result<Self> {
        rig.validate(self.n_links())?;
        self.rig = (!rig.is_ideal()).then(|| Box::new(rig));
        Ok(self)
    }

    /// The chain with the real-rig effects `rig` kept even when they are all off, its
    /// joint damping one number per link: a chain whose envs draw their own damping and
    /// friction ([`Chain::set_rig_unchecked`]), which then always steps the rig's path.
    pub fn with_drawn_rig(mut self, mut rig: Rig) -> Result<Self> {
        let n = self.n_links();
        rig.validate(n)?;
        rig.joint_damping = (0..n).map(|i| rig.damping(i)).collect();
        self.rig = Some(Box::new(rig));
        Ok(self)
    }

    /// Replaces the rig's damping and friction in place without allocating (an env's
    /// own draws, loaded before its step). The caller guarantees a chain built by
    /// [`Chain::with_drawn_rig`] and values finite and >= 0, one damping per link.
    pub(crate) fn set_rig_unchecked(&mut self, joint_damping: &[f64], viscous: f64, coulomb: f64) {
        debug_assert!(
            self.rig.is_some(),
            "set_rig_unchecked on a chain without a rig"
        );
        if let Some(rig) = self.rig.as_deref_mut() {
            rig.joint_damping.copy_from_slice(joint_damping);
            rig.cart_viscous_friction = viscous;
            rig.cart_coulomb_friction = coulomb;
        }
    }

    /// The real-rig effects, or `None` for the ideal model.
    pub fn rig(&self) -> Option<&Rig> {
        self.rig.as_deref()
    }

    /// No real-rig effect is on: the SIMD lane kernels, which step the ideal model
    /// only, may step this chain.
    pub fn is_ideal(&self) -> bool {
        self.rig.is_none()
    }

    /// The physical parameters.
    pub fn params(&self) -> &ChainParams {
        &self.params
    }
    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.layout.n
    }
    /// Offsets into this chain's flat state.
    pub fn layout(&self) -> Layout<G> {
        self.layout
    }
    /// Length of a state vector: 4 + 6n (spatial) or 2 + 3n (planar).
    pub fn state_dim(&self) -> usize {
        self.layout.dim()
    }
    /// Length of a force vector: 2 (spatial) or 1 (planar).
    pub fn force_dim(&self) -> usize {
        G::Cart::DIM
    }
    /// Fresh buffers for [`Chain::derivative`].
    pub fn workspace(&self) -> Workspace<G> {
        Workspace::new(self.layout.n)
    }
    pub(crate) fn inv_cart_mass(&self) -> f64 {
        self.inv_cart_mass
    }
    pub(crate) fn gravity_coefficients(&self) -> &[f64] {
        &self.gravity_coefficients
    }

    /// Checks a state and a force from outside: lengths and finiteness.
    pub fn check_input(&self, state: &[f64], force: &[f64]) -> Result<()> {
        check_len("state", state, self.state_dim())?;
        check_len("force", force, self.force_dim())?;
        check_finite("state", state)?;
        check_finite("force", force)
    }

    /// Time derivative of the state: `dy = [xdot, xdd, qdot_1..n, wdot_1..n]`,
    /// `qdot_i = w_i x q_i`. Exact, O(n), no allocation.
    ///
    /// Two passes: the first builds each row of the tension system and eliminates
    /// it at once (Thomas forward sweep, one division per row); the second
    /// back-substitutes the tensions from the free end and turns each pair of
    /// neighbouring tensions into the link's angular acceleration.
    ///
    /// With real-rig effects ([`Chain::with_rig`]) `force` is the command of the rig's
    /// actuation mode and the scalar path [`Chain::derivative_rig`] runs instead.
    pub fn derivative(&self, y: &[f64], force: G::Cart, ws: &mut Workspace<G>, dy: &mut [f64]) {
        if let Some(rig) = self.rig.as_deref() {
            self.derivative_rig(rig, y, force, ws, dy);
            return;
        }
        let lay = self.layout;
        let n = lay.n;
        let p = &self.params;
        let (inv_m, lengths, inv_l) = (p.inv_masses(), p.lengths(), &self.inv_lengths);
        let g = p.gravity();
        // ws.diag holds 1/pivot, ws.off the eliminated super-diagonal, ws.tension
        // the eliminated right-hand side.
        let mut pivot_inv = 0.0;
        for i in 0..n {
            let q = lay.load_q(y, i);
            let qdot = G::velocity(lay.load_w(y, i), q);
            ws.q[i] = q;
            lay.store_q(dy, i, qdot);
            let mut rhs = lengths[i] * qdot.norm_squared();
            let mut diag;
            if i == 0 {
                let h = G::horizontal(q);
                diag = inv_m[0] + h.norm_squared() * self.inv_cart_mass;
                rhs += g * G::down(q) - q.dot(G::lift(force)) * self.inv_cart_mass;
            } else {
                let off = -ws.q[i - 1].dot(q) * inv_m[i - 1];
                let c = off * pivot_inv;
                ws.off[i - 1] = c;
                diag = inv_m[i] + inv_m[i - 1] - off * c;
                rhs -= off * ws.tension[i - 1];
            }
            pivot_inv = 1.0 / diag;
            diag = pivot_inv;
            ws.diag[i] = diag;
            ws.tension[i] = rhs * pivot_inv;
        }
        // Back substitution from the free end, where T_{n+1} = 0.
        let mut t_next = 0.0;
        let mut acc_next = G::Link::zero();
        for i in (0..n).rev() {
            let t = if i + 1 < n {
                ws.tension[i] - ws.off[i] * t_next
            } else {
                ws.tension[i]
            };
            ws.tension[i] = t;
            // Acceleration of mass i without gravity (it cancels between neighbours
            // and enters link 1 only, through the cart, which feels none).
            let mut acc = ws.q[i] * (-t);
            if i + 1 < n {
                acc += ws.q[i + 1] * t_next;
            }
            acc = acc * inv_m[i];
            if i + 1 < n {
                let qdd = (acc_next - acc) * inv_l[i + 1];
                lay.store_w(dy, i + 1, G::spin(ws.q[i + 1], qdd));
            }
            acc_next = acc;
            t_next = t;
        }
        let xdd = (force + G::horizontal(ws.q[0]) * t_next) * self.inv_cart_mass;
        lay.store_x(dy, lay.load_xdot(y));
        lay.store_xdot(dy, xdd);
        let qdd = (acc_next - G::lift(xdd) + G::down_unit() * g) * inv_l[0];
        lay.store_w(dy, 0, G::spin(ws.q[0], qdd));
    }

    /// [`Chain::derivative`] with the real-rig effects of `rig` (docs/physics.md, "Real-rig
    /// effects"): the same two passes, plus the forces each joint's damping couple
    /// puts on the masses at the ends of its link, the cart's friction and motor, or
    /// (acceleration mode) the cart's acceleration given instead of its force. Scalar,
    /// O(n), no allocation.
    pub fn derivative_rig(
        &self,
        rig: &Rig,
        y: &[f64],
        command: G::Cart,
        ws: &mut Workspace<G>,
        dy: &mut [f64],
    ) {
        let lay = self.layout;
        let n = lay.n;
        let p = &self.params;
        let (inv_m, lengths, inv_l) = (p.inv_masses(), p.lengths(), &self.inv_lengths);
        let g = p.gravity();
        let xdot = lay.load_xdot(y);
        let reaction = self.damping_couples(rig, y, ws);
        // The cart's acceleration apart from the first rod's pull, and the weight of
        // that pull (0 for a servo axis, whose acceleration is given).
        let (free_acc, inv_cart) = match &rig.actuation {
            Actuation::Acceleration => (command, 0.0),
            Actuation::Force => (
                (command + cart_friction::<G>(rig, xdot) + reaction) * self.inv_cart_mass,
                self.inv_cart_mass,
            ),
            Actuation::Voltage(motor) => (
                (axes::<G>(command, xdot, |v, u| motor.force(v, u))
                    + cart_friction::<G>(rig, xdot)
                    + reaction)
                    * self.inv_cart_mass,
                self.inv_cart_mass,
            ),
        };
        let mut pivot_inv = 0.0;
        for i in 0..n {
            let q = ws.q[i];
            let qdot = G::velocity(lay.load_w(y, i), q);
            lay.store_q(dy, i, qdot);
            let mut rhs = lengths[i] * qdot.norm_squared() + q.dot(ws.applied[i]) * inv_m[i];
            let mut diag;
            if i == 0 {
                let h = G::horizontal(q);
                diag = inv_m[0] + h.norm_squared() * inv_cart;
                rhs += g * G::down(q) - q.dot(G::lift(free_acc));
            } else {
                let off = -ws.q[i - 1].dot(q) * inv_m[i - 1];
                let c = off * pivot_inv;
                ws.off[i - 1] = c;
                diag = inv_m[i] + inv_m[i - 1] - off * c;
                rhs -= q.dot(ws.applied[i - 1]) * inv_m[i - 1] + off * ws.tension[i - 1];
            }
            pivot_inv = 1.0 / diag;
            diag = pivot_inv;
            ws.diag[i] = diag;
            ws.tension[i] = rhs * pivot_inv;
        }
        let mut t_next = 0.0;
        let mut acc_next = G::Link::zero();
        for i in (0..n).rev() {
            let t = if i + 1 < n {
                ws.tension[i] - ws.off[i] * t_next
            } else {
                ws.tension[i]
            };
            ws.tension[i] = t;
            let mut acc = ws.q[i] * (-t) + ws.applied[i];
            if i + 1 < n {
                acc += ws.q[i + 1] * t_next;
            }
            acc = acc * inv_m[i];
            if i + 1 < n {
                let qdd = (acc_next - acc) * inv_l[i + 1];
                lay.store_w(dy, i + 1, G::spin(ws.q[i + 1], qdd));
            }
            acc_next = acc;
            t_next = t;
        }
        let xdd = free_acc + G::horizontal(ws.q[0]) * (t_next * inv_cart);
        lay.store_x(dy, xdot);
        lay.store_xdot(dy, xdd);
        let qdd = (acc_next - G::lift(xdd) + G::down_unit() * g) * inv_l[0];
        lay.store_w(dy, 0, G::spin(ws.q[0], qdd));
    }

    /// Loads every `q_i` into `ws.q` and writes into `ws.applied` the force each mass
    /// feels from the joint damping: the net damping torque `N_i = tau_i - tau_{i+1}`
    /// on link i (`tau_i = -c_i (w_i - w_{i-1})`, `w_0 = 0`) acts on the massless rod as
    /// the couple `f_i = N_i x q_i / l_i` at its mass and `-f_i` at its joint. Returns
    /// the horizontal force the first couple puts on the cart.
    fn damping_couples(&self, rig: &Rig, y: &[f64], ws: &mut Workspace<G>) -> G::Cart {
        let lay = self.layout;
        let n = lay.n;
        for i in 0..n {
            ws.q[i] = lay.load_q(y, i);
            ws.applied[i] = G::Link::zero();
        }
        if !rig.has_joint_damping() {
            return G::Cart::zero();
        }
        let torque = |i: usize| {
            let below = if i > 0 {
                lay.load_w(y, i - 1)
            } else {
                G::Spin::zero()
            };
            (lay.load_w(y, i) - below) * (-rig.damping(i))
        };
        let mut tau = torque(0);
        let mut reaction = G::Cart::zero();
        for i in 0..n {
            let tau_next = if i + 1 < n {
                torque(i + 1)
            } else {
                G::Spin::zero()
            };
            let couple = G::velocity(tau - tau_next, ws.q[i]) * self.inv_lengths[i];
            ws.applied[i] += couple;
            if i > 0 {
                ws.applied[i - 1] -= couple;
            } else {
                reaction = -G::horizontal(couple);
            }
            tau = tau_next;
        }
        reaction
    }

    /// Rod tensions `T_i` from the last [`Chain::derivative`] call on `ws`.
    pub fn tensions<'a>(&self, ws: &'a Workspace<G>) -> &'a [f64] {
        &ws.tension
    }

    /// Equilibrium `s` (`s_i = +1` hanging link, `-1` upright) with the cart at the origin.
    pub fn equilibrium(&self, s: &[f64]) -> Result<Vec<f64>> {
        check_len("s", s, self.n_links())?;
        for (index, &value) in s.iter().enumerate() {
            if value != 1.0 && value != -1.0 {
                return Err(InputError::InvalidSign { index, value }.into());
            }
        }
        let mut y = vec![0.0; self.state_dim()];
        for (i, &si) in s.iter().enumerate() {
            self.layout.store_q(&mut y, i, G::down_unit() * si);
        }
        Ok(y)
    }

    /// Restores `|q_i| = 1` and `w_i . q_i = 0` (for methods that do not keep them).
    pub fn project(&self, y: &mut [f64]) {
        let lay = self.layout;
        for i in 0..lay.n {
            let q = lay.load_q(y, i);
            let q = q * (1.0 / q.norm_squared().sqrt());
            lay.store_q(y, i, q);
            lay.store_w(y, i, G::tangent(lay.load_w(y, i), q));
        }
    }
}

/// The cart's friction force at velocity `v`, axis by axis.
#[inline]
fn cart_friction<G: Geometry>(rig: &Rig, v: G::Cart) -> G::Cart {
    if !rig.has_cart_friction() {
        return G::Cart::zero();
    }
    axes::<G>(v, v, |v, _| rig.friction(v))
}

/// `f` applied axis by axis to the components of `a` and `b`.
#[inline]
fn axes<G: Geometry>(a: G::Cart, b: G::Cart, f: impl Fn(f64, f64) -> f64) -> G::Cart {
    let (mut sa, mut sb) = ([0.0; 2], [0.0; 2]);
    a.store(&mut sa);
    b.store(&mut sb);
    for k in 0..G::Cart::DIM {
        sa[k] = f(sa[k], sb[k]);
    }
    G::Cart::load(&sa)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ChainError;
    use nalgebra::Vector3;

    #[test]
    fn hanging_equilibrium_is_at_rest() {
        let chain = SpatialChain::new(ChainParams::paper());
        let y = chain.equilibrium(&[1.0; 5]).unwrap();
        let mut dy = vec![1.0; chain.state_dim()];
        chain.derivative(
            &y,
            nalgebra::Vector2::zeros(),
            &mut chain.workspace(),
            &mut dy,
        );
        assert!(dy.iter().all(|v| v.abs() < 1e-15), "{dy:?}");
    }

    #[test]
    fn hanging_tensions_carry_the_weight_below() {
        let chain = SpatialChain::new(ChainParams::paper());
        let y = chain.equilibrium(&[1.0; 5]).unwrap();
        let mut ws = chain.workspace();
        let mut dy = vec![0.0; chain.state_dim()];
        chain.derivative(&y, nalgebra::Vector2::zeros(), &mut ws, &mut dy);
        for (i, t) in chain.tensions(&ws).iter().enumerate() {
            let expected = 9.81 * 0.1 * (5 - i) as f64;
            assert!(
                (t - expected).abs() < 1e-12,
                "T_{i} = {t}, expected {expected}"
            );
        }
    }

    #[test]
    fn equilibrium_rejects_bad_signs() {
        let chain = SpatialChain::new(ChainParams::paper());
        assert_eq!(
            chain.equilibrium(&[1.0, 1.0, 0.5, 1.0, 1.0]).unwrap_err(),
            InputError::InvalidSign {
                index: 2,
                value: 0.5
            }
            .into()
        );
        assert!(matches!(
            chain.equilibrium(&[1.0]),
            Err(ChainError::Input(InputError::LengthMismatch { .. }))
        ));
    }

    #[test]
    fn project_restores_constraints() {
        let chain = SpatialChain::new(ChainParams::uniform(1, 1.0, 1.0, 1.0, 9.81).unwrap());
        let mut y = vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 1.0, 1.0, 1.0];
        chain.project(&mut y);
        let q = Vector3::new(y[4], y[5], y[6]);
        let w = Vector3::new(y[7], y[8], y[9]);
        assert!((q.norm() - 1.0).abs() < 1e-15);
        assert!(w.dot(q).abs() < 1e-15);
    }
}
