//! Classical RK4 on the embedded state, then projection back onto the constraints.

use super::{axpy, Stepper};
use crate::geometry::Geometry;
use crate::model::Chain;

pub(super) fn step<G: Geometry>(
    chain: &Chain<G>,
    s: &mut Stepper<G>,
    y: &mut [f64],
    u: G::Cart,
    h: f64,
) {
    let [k1, k2, k3, k4, ..] = &mut s.rk.stages;
    let tmp = &mut s.rk.trial;
    chain.derivative(y, u, &mut s.ws, k1);
    axpy(tmp, y, 0.5 * h, k1);
    chain.derivative(tmp, u, &mut s.ws, k2);
    axpy(tmp, y, 0.5 * h, k2);
    chain.derivative(tmp, u, &mut s.ws, k3);
    axpy(tmp, y, h, k3);
    chain.derivative(tmp, u, &mut s.ws, k4);
    let c = h / 6.0;
    for (j, yj) in y.iter_mut().enumerate() {
        *yj += c * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j]);
    }
    chain.project(y);
    s.stats.evaluations += 4;
    s.stats.accepted_steps += 1;
}
