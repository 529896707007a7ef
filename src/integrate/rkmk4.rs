//! Runge-Kutta-Munthe-Kaas of order 4 on R^k x (S^2)^n.
//!
//! Each q_i moves only by rotations `exp(theta_i^) q_i(0)`, so `|q_i| = 1` holds by
//! construction; the Lie-algebra increments are RK4 stages of
//! `theta' = dexp^{-1}_theta(w)`. Cart and spin coordinates live in vector spaces,
//! where RKMK reduces to classical RK4. The spins are then made tangent to the new q_i.

use super::{axpy, Stepper};
use crate::geometry::{Geometry, Vector};
use crate::model::Chain;

/// Per-link Lie-algebra buffers of one RKMK step.
#[derive(Debug, Clone)]
pub(crate) struct RkmkWorkspace<G: Geometry> {
    /// The current stage's increment `dexpinv(theta_i, w_i)`.
    increment: Vec<G::Spin>,
    /// The RK4-weighted sum of the stage increments.
    increment_sum: Vec<G::Spin>,
    /// The rotation vector of the stage being built.
    theta: Vec<G::Spin>,
}

impl<G: Geometry> RkmkWorkspace<G> {
    pub(crate) fn new(n: usize) -> Self {
        let spins = || vec![G::Spin::zero(); n];
        Self {
            increment: spins(),
            increment_sum: spins(),
            theta: spins(),
        }
    }
}

/// Overwrites the link directions of a stage state with `exp(theta_i) q_i(0)`, and
/// returns the stage's Lie-algebra increments `dexpinv(theta_i, w_i)` into `k`.
fn rotate_stage<G: Geometry>(
    chain: &Chain<G>,
    base: &[f64],
    stage: &mut [f64],
    theta: &[G::Spin],
    k: &mut [G::Spin],
) {
    let lay = chain.layout();
    for i in 0..lay.n {
        lay.store_q(stage, i, G::rotate(theta[i], lay.load_q(base, i)));
        k[i] = G::dexpinv(theta[i], lay.load_w(stage, i));
    }
}

pub(super) fn step<G: Geometry>(
    chain: &Chain<G>,
    s: &mut Stepper<G>,
    y: &mut [f64],
    u: G::Cart,
    h: f64,
) {
    let lay = chain.layout();
    let n = lay.n;
    let [k1, k2, k3, k4, ..] = &mut s.rk.stages;
    let base = &mut s.rk.base;
    let tmp = &mut s.rk.trial;
    let RkmkWorkspace {
        increment: kq,
        increment_sum: ksum,
        theta,
    } = &mut s.rkmk;
    base.copy_from_slice(y);

    chain.derivative(base, u, &mut s.ws, k1);
    for i in 0..n {
        kq[i] = lay.load_w(base, i);
        ksum[i] = kq[i];
    }
    let weights = [(0.5, 2.0), (0.5, 2.0), (1.0, 1.0)];
    for (stage, &(a, w)) in weights.iter().enumerate() {
        let (prev, next) = match stage {
            0 => (&*k1, &mut *k2),
            1 => (&*k2, &mut *k3),
            _ => (&*k3, &mut *k4),
        };
        axpy(tmp, base, a * h, prev);
        for i in 0..n {
            theta[i] = kq[i] * (a * h);
        }
        rotate_stage(chain, base, tmp, theta, kq);
        chain.derivative(tmp, u, &mut s.ws, next);
        for (sum, k) in ksum.iter_mut().zip(kq.iter()) {
            *sum += *k * w;
        }
    }
    let c = h / 6.0;
    for (j, yj) in y.iter_mut().enumerate() {
        *yj = base[j] + c * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j]);
    }
    for (i, &sum) in ksum.iter().enumerate() {
        let q = G::rotate(sum * c, lay.load_q(base, i));
        lay.store_q(y, i, q);
        lay.store_w(y, i, G::tangent(lay.load_w(y, i), q));
    }
    s.stats.evaluations += 4;
    s.stats.accepted_steps += 1;
}
