//! The exact O(n) dynamics and the RK4 control step, written once for any [`Real`]
//! scalar: with `f64` they are the model's own (they agree with
//! [`Chain::derivative`] and [`crate::integrate::Stepper`] to round-off, tested), with
//! [`super::dual::Dual`] they also carry exact derivatives.
//!
//! The operations and their order follow `Chain::derivative` line for line (see
//! `src/model.rs` for the derivation: a tridiagonal solve for the rod tensions, then
//! each link's angular acceleration). A chain with real-rig effects (joint damping, cart
//! friction, an acceleration or voltage command) follows `Chain::derivative_rig` the same
//! way, so the planner, its time-varying LQR and MPC plan on the rig they are given.

use super::dual::Real;
use super::vector::{ScalarGeometry, Vect};
use crate::geometry::Layout;
use crate::model::Chain;
use crate::params::{Actuation, Motor, Rig};

/// The constants of a chain the generic dynamics read.
#[derive(Debug, Clone)]
pub struct ScalarChain<G: ScalarGeometry> {
    layout: Layout<G>,
    inv_masses: Vec<f64>,
    lengths: Vec<f64>,
    inv_lengths: Vec<f64>,
    gravity: f64,
    inv_cart_mass: f64,
    /// The chain's real-rig effects, `None` for the ideal model.
    rig: Option<Rig>,
}

/// Buffers of one derivative or step over scalar `S`, allocated once.
#[derive(Debug, Clone)]
pub struct ScalarWorkspace<G: ScalarGeometry, S: Real> {
    q: Vec<G::LinkS<S>>,
    /// The force each mass feels from the joint damping (rig path only).
    applied: Vec<G::LinkS<S>>,
    off: Vec<S>,
    tension: Vec<S>,
    stages: [Vec<S>; 4],
    trial: Vec<S>,
}

impl<G: ScalarGeometry, S: Real> ScalarWorkspace<G, S> {
    /// Buffers for a chain of `n` links.
    pub fn new(n: usize) -> Self {
        let dim = Layout::<G>::new(n).dim();
        let v = || vec![S::cst(0.0); dim];
        Self {
            q: vec![G::LinkS::<S>::zero(); n],
            applied: vec![G::LinkS::<S>::zero(); n],
            off: vec![S::cst(0.0); n],
            tension: vec![S::cst(0.0); n],
            stages: std::array::from_fn(|_| v()),
            trial: v(),
        }
    }
}

impl<G: ScalarGeometry> ScalarChain<G> {
    /// The constants of `chain`.
    pub fn new(chain: &Chain<G>) -> Self {
        let p = chain.params();
        Self {
            layout: chain.layout(),
            inv_masses: p.inv_masses().to_vec(),
            lengths: p.lengths().to_vec(),
            inv_lengths: p.lengths().iter().map(|l| 1.0 / l).collect(),
            gravity: p.gravity(),
            inv_cart_mass: 1.0 / p.cart_mass(),
            rig: chain.rig().cloned(),
        }
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.layout.n
    }
    /// The state layout.
    pub fn layout(&self) -> Layout<G> {
        self.layout
    }
    /// Length of a state.
    pub fn state_dim(&self) -> usize {
        self.layout.dim()
    }

    /// Time derivative `dy = [xdot, xdd, qdot_i, wdot_i]` of `y` under `force` (on a
    /// rig, under the command of its actuation mode).
    pub fn derivative<S: Real>(
        &self,
        y: &[S],
        force: G::CartS<S>,
        ws: &mut ScalarWorkspace<G, S>,
        dy: &mut [S],
    ) {
        if let Some(rig) = &self.rig {
            self.derivative_rig(rig, y, force, ws, dy);
            return;
        }
        let lay = self.layout;
        let n = lay.n;
        let (inv_m, lengths, inv_l) = (&self.inv_masses, &self.lengths, &self.inv_lengths);
        let g = self.gravity;
        let link = |y: &[S], i: usize| G::LinkS::<S>::load(&y[lay.q(i)..]);
        let spin = |y: &[S], i: usize| G::SpinS::<S>::load(&y[lay.w(i)..]);
        let mut pivot_inv = S::cst(0.0);
        for i in 0..n {
            let q = link(y, i);
            let qdot = G::velocity_s(spin(y, i), q);
            ws.q[i] = q;
            qdot.store(&mut dy[lay.q(i)..]);
            let mut rhs = qdot.norm_squared() * lengths[i];
            let diag;
            if i == 0 {
                let h = G::horizontal_s(q);
                diag = h.norm_squared() * self.inv_cart_mass + inv_m[0];
                rhs += G::down_s(q) * g - q.dot(G::lift_s(force)) * self.inv_cart_mass;
            } else {
                let off = -ws.q[i - 1].dot(q) * inv_m[i - 1];
                let c = off * pivot_inv;
                ws.off[i - 1] = c;
                diag = S::cst(inv_m[i] + inv_m[i - 1]) - off * c;
                rhs -= off * ws.tension[i - 1];
            }
            pivot_inv = diag.recip();
            ws.tension[i] = rhs * pivot_inv;
        }
        let mut t_next = S::cst(0.0);
        let mut acc_next = G::LinkS::<S>::zero();
        for i in (0..n).rev() {
            let t = if i + 1 < n {
                ws.tension[i] - ws.off[i] * t_next
            } else {
                ws.tension[i]
            };
            ws.tension[i] = t;
            let mut acc = ws.q[i] * (-t);
            if i + 1 < n {
                acc += ws.q[i + 1] * t_next;
            }
            acc = acc.scale(inv_m[i]);
            if i + 1 < n {
                let qdd = (acc_next - acc).scale(inv_l[i + 1]);
                G::spin_s(ws.q[i + 1], qdd).store(&mut dy[lay.w(i + 1)..]);
            }
            acc_next = acc;
            t_next = t;
        }
        let xdd = (force + G::horizontal_s(ws.q[0]) * t_next).scale(self.inv_cart_mass);
        G::CartS::<S>::load(&y[lay.xdot()..]).store(&mut dy[lay.x()..]);
        xdd.store(&mut dy[lay.xdot()..]);
        let qdd = (acc_next - G::lift_s(xdd) + G::down_unit_s::<S>().scale(g)).scale(inv_l[0]);
        G::spin_s(ws.q[0], qdd).store(&mut dy[lay.w(0)..]);
    }

    /// [`ScalarChain::derivative`] with the real-rig effects of `rig`: the operations
    /// of `Chain::derivative_rig`, in its order (damping couples on the masses, the
    /// cart's friction and motor, or its acceleration given).
    fn derivative_rig<S: Real>(
        &self,
        rig: &Rig,
        y: &[S],
        command: G::CartS<S>,
        ws: &mut ScalarWorkspace<G, S>,
        dy: &mut [S],
    ) {
        let lay = self.layout;
        let n = lay.n;
        let (inv_m, lengths, inv_l) = (&self.inv_masses, &self.lengths, &self.inv_lengths);
        let g = self.gravity;
        let spin = |y: &[S], i: usize| G::SpinS::<S>::load(&y[lay.w(i)..]);
        let xdot = G::CartS::<S>::load(&y[lay.xdot()..]);
        let reaction = self.damping_couples(rig, y, ws);
        let (free_acc, inv_cart) = match &rig.actuation {
            Actuation::Acceleration => (command, 0.0),
            Actuation::Force => (
                (command + cart_friction::<G, S>(rig, xdot) + reaction).scale(self.inv_cart_mass),
                self.inv_cart_mass,
            ),
            Actuation::Voltage(motor) => (
                (axes::<G, S>(command, xdot, |u, v| motor_force(motor, u, v))
                    + cart_friction::<G, S>(rig, xdot)
                    + reaction)
                    .scale(self.inv_cart_mass),
                self.inv_cart_mass,
            ),
        };
        let mut pivot_inv = S::cst(0.0);
        for i in 0..n {
            let q = ws.q[i];
            let qdot = G::velocity_s(spin(y, i), q);
            qdot.store(&mut dy[lay.q(i)..]);
            let mut rhs = qdot.norm_squared() * lengths[i] + q.dot(ws.applied[i]) * inv_m[i];
            let diag;
            if i == 0 {
                let h = G::horizontal_s(q);
                diag = h.norm_squared() * inv_cart + inv_m[0];
                rhs += G::down_s(q) * g - q.dot(G::lift_s(free_acc));
            } else {
                let off = -ws.q[i - 1].dot(q) * inv_m[i - 1];
                let c = off * pivot_inv;
                ws.off[i - 1] = c;
                diag = S::cst(inv_m[i] + inv_m[i - 1]) - off * c;
                rhs -= q.dot(ws.applied[i - 1]) * inv_m[i - 1] + off * ws.tension[i - 1];
            }
            pivot_inv = diag.recip();
            ws.tension[i] = rhs * pivot_inv;
        }
        let mut t_next = S::cst(0.0);
        let mut acc_next = G::LinkS::<S>::zero();
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
            acc = acc.scale(inv_m[i]);
            if i + 1 < n {
                let qdd = (acc_next - acc).scale(inv_l[i + 1]);
                G::spin_s(ws.q[i + 1], qdd).store(&mut dy[lay.w(i + 1)..]);
            }
            acc_next = acc;
            t_next = t;
        }
        let xdd = free_acc + G::horizontal_s(ws.q[0]) * (t_next * inv_cart);
        xdot.store(&mut dy[lay.x()..]);
        xdd.store(&mut dy[lay.xdot()..]);
        let qdd = (acc_next - G::lift_s(xdd) + G::down_unit_s::<S>().scale(g)).scale(inv_l[0]);
        G::spin_s(ws.q[0], qdd).store(&mut dy[lay.w(0)..]);
    }

    /// Loads every `q_i` into `ws.q` and writes into `ws.applied` the force each mass
    /// feels from the joint damping (`Chain`'s `damping_couples`: the net damping torque
    /// on link i acts on its massless rod as a couple at its mass and its joint);
    /// returns the horizontal force the first couple puts on the cart.
    fn damping_couples<S: Real>(
        &self,
        rig: &Rig,
        y: &[S],
        ws: &mut ScalarWorkspace<G, S>,
    ) -> G::CartS<S> {
        let lay = self.layout;
        let n = lay.n;
        for i in 0..n {
            ws.q[i] = G::LinkS::<S>::load(&y[lay.q(i)..]);
            ws.applied[i] = G::LinkS::<S>::zero();
        }
        if !rig.has_joint_damping() {
            return G::CartS::<S>::zero();
        }
        let spin = |i: usize| G::SpinS::<S>::load(&y[lay.w(i)..]);
        let torque = |i: usize| {
            let below = if i > 0 {
                spin(i - 1)
            } else {
                G::SpinS::<S>::zero()
            };
            (spin(i) - below).scale(-rig.damping(i))
        };
        let mut tau = torque(0);
        let mut reaction = G::CartS::<S>::zero();
        for i in 0..n {
            let tau_next = if i + 1 < n {
                torque(i + 1)
            } else {
                G::SpinS::<S>::zero()
            };
            let couple = G::velocity_s(tau - tau_next, ws.q[i]).scale(self.inv_lengths[i]);
            ws.applied[i] += couple;
            if i > 0 {
                ws.applied[i - 1] -= couple;
            } else {
                reaction = -G::horizontal_s(couple);
            }
            tau = tau_next;
        }
        reaction
    }

    /// Restores `|q_i| = 1` and `w_i . q_i = 0`, as the model's RK4 does after each step.
    pub fn project<S: Real>(&self, y: &mut [S]) {
        let lay = self.layout;
        for i in 0..lay.n {
            let q = G::LinkS::<S>::load(&y[lay.q(i)..]);
            let q = q * q.norm_squared().sqrt().recip();
            q.store(&mut y[lay.q(i)..]);
            let w = G::SpinS::<S>::load(&y[lay.w(i)..]);
            G::tangent_s(w, q).store(&mut y[lay.w(i)..]);
        }
    }

    /// One control period `dt` of `substeps` RK4 steps with the force held, each
    /// followed by the projection: the model's `rk4` integrator.
    pub fn step<S: Real>(
        &self,
        y: &mut [S],
        force: G::CartS<S>,
        dt: f64,
        substeps: usize,
        ws: &mut ScalarWorkspace<G, S>,
    ) {
        let h = dt / substeps as f64;
        for _ in 0..substeps {
            self.rk4(y, force, h, ws);
        }
    }

    fn rk4<S: Real>(&self, y: &mut [S], u: G::CartS<S>, h: f64, ws: &mut ScalarWorkspace<G, S>) {
        let mut stages = std::mem::take(&mut ws.stages);
        let mut tmp = std::mem::take(&mut ws.trial);
        let [k1, k2, k3, k4] = &mut stages;
        self.derivative(y, u, ws, k1);
        axpy(&mut tmp, y, 0.5 * h, k1);
        self.derivative(&tmp, u, ws, k2);
        axpy(&mut tmp, y, 0.5 * h, k2);
        self.derivative(&tmp, u, ws, k3);
        axpy(&mut tmp, y, h, k3);
        self.derivative(&tmp, u, ws, k4);
        let c = h / 6.0;
        for (j, yj) in y.iter_mut().enumerate() {
            *yj += (k1[j] + (k2[j] + k3[j]) * 2.0 + k4[j]) * c;
        }
        self.project(y);
        ws.stages = stages;
        ws.trial = tmp;
    }
}

/// The friction on the cart moving at `v`, axis by axis (`Rig::friction`).
fn cart_friction<G: ScalarGeometry, S: Real>(rig: &Rig, v: G::CartS<S>) -> G::CartS<S> {
    if !rig.has_cart_friction() {
        return G::CartS::<S>::zero();
    }
    axes::<G, S>(v, v, |v, _| {
        let mut f = v * (-rig.cart_viscous_friction);
        if rig.cart_coulomb_friction != 0.0 {
            f -= (v / S::cst(rig.coulomb_velocity)).tanh() * rig.cart_coulomb_friction;
        }
        f
    })
}

/// `Motor::force`: the force on a cart moving at `velocity` under `voltage`; a current
/// at its limit carries no derivative.
fn motor_force<S: Real>(motor: &Motor, voltage: S, velocity: S) -> S {
    let k = motor.force_per_amp();
    let current = (voltage - velocity * k) / S::cst(motor.resistance);
    let limit = motor.current_limit;
    let limited = if current.re() > limit {
        S::cst(limit)
    } else if current.re() < -limit {
        S::cst(-limit)
    } else {
        current
    };
    limited * k
}

/// `f` applied axis by axis to the components of `a` and `b`.
fn axes<G: ScalarGeometry, S: Real>(
    a: G::CartS<S>,
    b: G::CartS<S>,
    f: impl Fn(S, S) -> S,
) -> G::CartS<S> {
    let (mut sa, mut sb) = ([S::cst(0.0); 2], [S::cst(0.0); 2]);
    a.store(&mut sa);
    b.store(&mut sb);
    for k in 0..G::CartS::<S>::DIM {
        sa[k] = f(sa[k], sb[k]);
    }
    G::CartS::<S>::load(&sa)
}

#[inline(always)]
fn axpy<S: Real>(out: &mut [S], a: &[S], c: f64, b: &[S]) {
    for ((o, &a), &b) in out.iter_mut().zip(a).zip(b) {
        *o = a + b * c;
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geometry::{Geometry, Planar, Spatial, Vector};
    use crate::integrate::{Method, StepOptions, Stepper};
    use crate::params::ChainParams;
    use rand::{Rng, SeedableRng};

    fn random_state<G: Geometry>(chain: &Chain<G>, rng: &mut impl Rng) -> Vec<f64> {
        let mut y: Vec<f64> = (0..chain.state_dim())
            .map(|_| rng.random_range(-2.0..2.0))
            .collect();
        chain.project(&mut y);
        y
    }

    fn agrees_with_the_model<G: ScalarGeometry>(n: usize, seed: u64) {
        agrees_with_the_model_on::<G>(n, seed, Rig::default());
    }

    fn agrees_with_the_model_on<G: ScalarGeometry>(n: usize, seed: u64, rig: Rig) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let masses: Vec<f64> = (0..n).map(|_| rng.random_range(0.05..0.5)).collect();
        let lengths: Vec<f64> = (0..n).map(|_| rng.random_range(0.1..0.8)).collect();
        let chain = Chain::<G>::new(ChainParams::new(0.7, &masses, &lengths, 9.81).unwrap())
            .with_rig(rig)
            .unwrap();
        let generic = ScalarChain::new(&chain);
        let mut sws = ScalarWorkspace::<G, f64>::new(n);
        let mut ws = chain.workspace();
        let mut stepper = Stepper::new(&chain);
        let opts = StepOptions::new(Method::Rk4, 3).unwrap();
        for _ in 0..20 {
            let y = random_state(&chain, &mut rng);
            let u: Vec<f64> = (0..G::CART).map(|_| rng.random_range(-5.0..5.0)).collect();
            let (mut dy, mut expected) = (vec![0.0; y.len()], vec![0.0; y.len()]);
            generic.derivative(&y, G::CartS::<f64>::load(&u), &mut sws, &mut dy);
            chain.derivative(&y, G::Cart::load(&u), &mut ws, &mut expected);
            for (a, b) in dy.iter().zip(&expected) {
                assert!((a - b).abs() <= 1e-13 * (1.0 + b.abs()), "{a} vs {b}");
            }
            let (mut stepped, mut expected) = (y.clone(), y.clone());
            generic.step(&mut stepped, G::CartS::<f64>::load(&u), 0.02, 3, &mut sws);
            stepper
                .step(&chain, &mut expected, G::Cart::load(&u), 0.02, &opts)
                .unwrap();
            for (a, b) in stepped.iter().zip(&expected) {
                assert!((a - b).abs() <= 1e-13 * (1.0 + b.abs()), "{a} vs {b}");
            }
        }
    }

    #[test]
    fn the_f64_instance_is_the_model_planar_and_spatial() {
        for n in [1, 2, 3, 5] {
            agrees_with_the_model::<Planar>(n, n as u64);
            agrees_with_the_model::<Spatial>(n, 10 + n as u64);
        }
    }

    /// Rigs with every effect on: damping per link, both frictions (with a Coulomb
    /// scale the test's velocities cross), a force, a motor whose current limit the
    /// random states reach, and a servo axis.
    pub(crate) fn test_rigs(n: usize) -> Vec<Rig> {
        let damping: Vec<f64> = (0..n).map(|i| 0.01 + 0.02 * i as f64).collect();
        let motor = Motor::from_array([0.05, 2.0, 4.0, 0.02, 3.0]);
        vec![
            Rig {
                joint_damping: damping.clone(),
                cart_viscous_friction: 0.4,
                cart_coulomb_friction: 0.7,
                coulomb_velocity: 0.3,
                actuation: Actuation::Force,
            },
            Rig {
                joint_damping: vec![0.02],
                cart_viscous_friction: 0.2,
                cart_coulomb_friction: 0.5,
                coulomb_velocity: 0.3,
                actuation: Actuation::Voltage(motor),
            },
            Rig {
                joint_damping: damping,
                actuation: Actuation::Acceleration,
                ..Rig::default()
            },
        ]
    }

    #[test]
    fn the_f64_instance_is_the_model_on_a_rig() {
        for n in [1, 2, 3] {
            for (k, rig) in test_rigs(n).into_iter().enumerate() {
                let seed = 100 * k as u64 + n as u64;
                agrees_with_the_model_on::<Planar>(n, seed, rig.clone());
                agrees_with_the_model_on::<Spatial>(n, 50 + seed, rig);
            }
        }
    }
}
