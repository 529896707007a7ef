//! Semi-implicit (symplectic) Lie-Euler: one evaluation per step.
//!
//! Velocities are kicked first, then positions drift with the new velocities,
//! the links by the exact rotation `q <- exp(h w^) q`. A rotation about w keeps
//! `w . q`, so tangency and unit length are kept up to round-off.

use super::Stepper;
use crate::geometry::Geometry;
use crate::model::Chain;

pub(super) fn step<G: Geometry>(
    chain: &Chain<G>,
    s: &mut Stepper<G>,
    y: &mut [f64],
    u: G::Cart,
    h: f64,
) {
    let lay = chain.layout();
    let k = &mut s.rk.stages[0];
    chain.derivative(y, u, &mut s.ws, k);
    let xdot = lay.load_xdot(y) + lay.load_xdot(k) * h;
    lay.store_xdot(y, xdot);
    lay.store_x(y, lay.load_x(y) + xdot * h);
    for i in 0..lay.n {
        let w = lay.load_w(y, i) + lay.load_w(k, i) * h;
        let q = G::rotate(w * h, lay.load_q(y, i));
        lay.store_q(y, i, q);
        // Only round-off separates w from the tangent plane here; removing it keeps
        // long runs from accumulating it.
        lay.store_w(y, i, G::tangent(w, q));
    }
    s.stats.evaluations += 1;
    s.stats.accepted_steps += 1;
}
