//! The Lie group variational integrator on (S^2)^n x R^2 (Lee, Leok, McClamroch,
//! IJNME 2009), solved in O(n) per Newton iteration.
//!
//! Its discrete Lagrangian is the chord form
//! `L_d = h T((x_{k+1}-x_k)/h, (q_{k+1}-q_k)/h) - h (V(q_k) + V(q_{k+1}))/2`
//! with variations `dq = xi x q` that keep each q_i on S^2. In the free coordinates
//! (x, q_i in R^3) the kinetic energy has a constant mass matrix, and variations
//! tangent to the spheres are exactly those normal to the constraints `|q_i|^2 = 1`,
//! so the discrete Euler-Lagrange equations are the RATTLE equations of that
//! constrained system. We solve them in that form: the unknowns are n constraint
//! multipliers whose Newton matrix is tridiagonal (the rods couple only neighbours),
//! so each iteration is O(n) instead of the O(n^3) of a dense Jacobian.
//!
//! Per step: half kick with gravity and the cart force, drift, Newton on the
//! position constraints, half kick, then a linear (tridiagonal) projection of the
//! velocities onto `q_i . qdot_i = 0`. Horizontal momentum is conserved exactly
//! (up to round-off) when u = 0, and energy error stays bounded.

use super::{StepOptions, Stepper};
use crate::error::{ChainError, IntegrationFailure, Result};
use crate::geometry::{Geometry, Vector};
use crate::model::Chain;
use crate::tridiagonal;

/// `(xdot, qdot) = M^{-1} (p_x, p_1..p_n)` for the constant mass matrix of the free
/// coordinates, O(n): the momentum of q_i is `l_i` times the momentum of all masses
/// beyond joint i.
fn inverse_mass<G: Geometry>(
    chain: &Chain<G>,
    px: G::Cart,
    p: impl Fn(usize) -> G::Link,
    qdot: &mut [G::Link],
) -> G::Cart {
    let prm = chain.params();
    let (lengths, inv_m) = (prm.lengths(), prm.inv_masses());
    let n = chain.n_links();
    let beyond = |i: usize| {
        if i < n {
            p(i) * (1.0 / lengths[i])
        } else {
            G::Link::zero()
        }
    };
    let mut s_i = beyond(0);
    let xdot = (px - G::horizontal(s_i)) * chain.inv_cart_mass();
    let mut v_prev = G::lift(xdot);
    for i in 0..n {
        let s_next = beyond(i + 1);
        let v = (s_i - s_next) * inv_m[i];
        qdot[i] = (v - v_prev) * (1.0 / lengths[i]);
        v_prev = v;
        s_i = s_next;
    }
    xdot
}

/// Tridiagonal matrix `B_ij = a_i . d r_i / d lambda_j`, where `r = M^{-1} G(q)^T lambda`
/// is the velocity response to constraint impulses `lambda_j q_j` at directions `q`.
fn response_matrix<G: Geometry>(
    chain: &Chain<G>,
    q: &[G::Link],
    a: &[G::Link],
    diag: &mut [f64],
    lower: &mut [f64],
    upper: &mut [f64],
) {
    let prm = chain.params();
    let (l, inv_m) = (prm.lengths(), prm.inv_masses());
    let n = q.len();
    for i in 0..n {
        let d = if i == 0 {
            (q[0] * inv_m[0] + G::lift(G::horizontal(q[0])) * chain.inv_cart_mass())
                * (1.0 / (l[0] * l[0]))
        } else {
            q[i] * ((inv_m[i] + inv_m[i - 1]) / (l[i] * l[i]))
        };
        diag[i] = a[i].dot(d);
        if i + 1 < n {
            upper[i] = -a[i].dot(q[i + 1]) * inv_m[i] / (l[i] * l[i + 1]);
            lower[i] = -a[i + 1].dot(q[i]) * inv_m[i] / (l[i + 1] * l[i]);
        }
    }
}

pub(super) fn step<G: Geometry>(
    chain: &Chain<G>,
    s: &mut Stepper<G>,
    y: &mut [f64],
    u: G::Cart,
    h: f64,
    opts: &StepOptions,
) -> Result<()> {
    let lay = chain.layout();
    let n = lay.n;
    let [q0, q1, vel, resp, force_vel] = &mut s.links;
    let [lambda, phi, diag, lower, upper, scratch] = &mut s.scalars;
    let gravity = chain.gravity_coefficients();

    // Half kick: v~ = v + h/2 M^{-1} F, with F = (u, g_i e3) constant over the step.
    let xdot_force = inverse_mass(chain, u, |i| G::down_unit() * gravity[i], force_vel);
    let xdot_half = lay.load_xdot(y) + xdot_force * (0.5 * h);
    for i in 0..n {
        q0[i] = lay.load_q(y, i);
        vel[i] = G::velocity(lay.load_w(y, i), q0[i]) + force_vel[i] * (0.5 * h);
        lambda[i] = 0.0;
    }
    let x0 = lay.load_x(y);

    // Newton on phi_i(lambda) = (|q_i + h v~_i - h^2/2 r_i(lambda)|^2 - 1)/2 = 0.
    // We scale the unknown as kappa = h^2/2 lambda, so q1 = q0 + h v~ - r(kappa).
    let mut iterations = 0;
    let mut xdot_resp;
    loop {
        xdot_resp = inverse_mass(chain, G::Cart::zero(), |j| q0[j] * lambda[j], resp);
        let mut worst: f64 = 0.0;
        for i in 0..n {
            q1[i] = q0[i] + vel[i] * h - resp[i];
            phi[i] = 0.5 * (q1[i].norm_squared() - 1.0);
            worst = worst.max(phi[i].abs());
        }
        if worst <= opts.newton_tolerance {
            break;
        }
        if iterations >= opts.max_newton_iterations || !worst.is_finite() {
            return Err(ChainError::integration(
                0.0,
                IntegrationFailure::NoConvergence {
                    method: "variational Newton solve",
                    iterations,
                    residual: worst,
                    tolerance: opts.newton_tolerance,
                },
            ));
        }
        // d phi_i / d kappa_j = -q1_i . d r_i / d kappa_j.
        response_matrix(chain, q0, q1, diag, lower, upper);
        for v in diag
            .iter_mut()
            .chain(lower.iter_mut())
            .chain(upper.iter_mut())
        {
            *v = -*v;
        }
        tridiagonal::solve(diag, &lower[..n - 1], &upper[..n - 1], phi, scratch);
        for i in 0..n {
            lambda[i] -= phi[i];
        }
        iterations += 1;
    }
    s.stats.newton_iterations += iterations;

    // Positions at k+1 and velocities after the second half kick (before projection).
    let x1 = x0 + (xdot_half * h - xdot_resp);
    let mut xdot1 = xdot_half - xdot_resp * (1.0 / h) + xdot_force * (0.5 * h);
    for i in 0..n {
        vel[i] = vel[i] - resp[i] * (1.0 / h) + force_vel[i] * (0.5 * h);
        phi[i] = q1[i].dot(vel[i]);
    }
    // Velocity constraint q1_i . qdot_i = 0: linear, symmetric tridiagonal.
    response_matrix(chain, q1, q1, diag, lower, upper);
    tridiagonal::solve(diag, &lower[..n - 1], &upper[..n - 1], phi, scratch);
    xdot1 -= inverse_mass(chain, G::Cart::zero(), |j| q1[j] * phi[j], resp);

    lay.store_x(y, x1);
    lay.store_xdot(y, xdot1);
    for i in 0..n {
        lay.store_q(y, i, q1[i]);
        lay.store_w(y, i, G::spin(q1[i], vel[i] - resp[i]));
    }
    s.stats.evaluations += 1;
    s.stats.accepted_steps += 1;
    Ok(())
}
