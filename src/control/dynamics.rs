//! The exact O(n) dynamics and the RK4 control step, written once for any [`Real`]
//! scalar: with `f64` they are the model's own (they agree with
//! [`Chain::derivative`] and [`crate::integrate::Stepper`] to round-off, tested), with
//! [`super::dual::Dual`] they also carry exact derivatives.
//!
//! The operations and their order follow `Chain::derivative` line for line (see
//! `src/model.rs` for the derivation: a tridiagonal solve for the rod tensions, then
//! each link's angular acceleration).

use super::dual::Real;
use super::vector::{ScalarGeometry, Vect};
use crate::geometry::Layout;
use crate::model::Chain;

/// The constants of a chain the generic dynamics read.
#[derive(Debug, Clone)]
pub struct ScalarChain<G: ScalarGeometry> {
    layout: Layout<G>,
    inv_masses: Vec<f64>,
    lengths: Vec<f64>,
    inv_lengths: Vec<f64>,
    gravity: f64,
    inv_cart_mass: f64,
}

/// Buffers of one derivative or step over scalar `S`, allocated once.
#[derive(Debug, Clone)]
pub struct ScalarWorkspace<G: ScalarGeometry, S: Real> {
    q: Vec<G::LinkS<S>>,
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

    /// Time derivative `dy = [xdot, xdd, qdot_i, wdot_i]` of `y` under `force`.
    pub fn derivative<S: Real>(
        &self,
        y: &[S],
        force: G::CartS<S>,
        ws: &mut ScalarWorkspace<G, S>,
        dy: &mut [S],
    ) {
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

#[inline(always)]
fn axpy<S: Real>(out: &mut [S], a: &[S], c: f64, b: &[S]) {
    for ((o, &a), &b) in out.iter_mut().zip(a).zip(b) {
        *o = a + b * c;
    }
}

#[cfg(test)]
mod tests {
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
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let masses: Vec<f64> = (0..n).map(|_| rng.random_range(0.05..0.5)).collect();
        let lengths: Vec<f64> = (0..n).map(|_| rng.random_range(0.1..0.8)).collect();
        let chain = Chain::<G>::new(ChainParams::new(0.7, &masses, &lengths, 9.81).unwrap());
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
}
