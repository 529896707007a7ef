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

/// Buffers of the variational step, one entry per link.
#[derive(Debug, Clone)]
pub(crate) struct VariationalWorkspace<G: Geometry> {
    /// Link directions at the start of the step.
    q0: Vec<G::Link>,
    /// Link directions at its end (the Newton iterate).
    q1: Vec<G::Link>,
    /// Link velocities after the first half kick, then after the second.
    velocity: Vec<G::Link>,
    /// Displacement (then velocity) response to the constraint impulses.
    response: Vec<G::Link>,
    /// Link velocity change per unit time from gravity and the cart force.
    force_velocity: Vec<G::Link>,
    /// Scaled constraint multipliers `kappa = h^2/2 lambda`.
    multipliers: Vec<f64>,
    /// Constraint residuals, overwritten by each Newton correction.
    residuals: Vec<f64>,
    /// The tridiagonal Newton (or projection) matrix and the solver's scratch.
    diag: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    scratch: Vec<f64>,
}

impl<G: Geometry> VariationalWorkspace<G> {
    pub(crate) fn new(n: usize) -> Self {
        let links = || vec![G::Link::zero(); n];
        let scalars = || vec![0.0; n];
        Self {
            q0: links(),
            q1: links(),
            velocity: links(),
            response: links(),
            force_velocity: links(),
            multipliers: scalars(),
            residuals: scalars(),
            diag: scalars(),
            lower: scalars(),
            upper: scalars(),
            scratch: scalars(),
        }
    }
}

impl<G: Geometry> VariationalWorkspace<G> {
    /// Overwrites `residuals` with the solution of the tridiagonal system held in
    /// `diag`, `lower`, `upper`.
    fn solve_residuals(&mut self) {
        let off = self.diag.len() - 1;
        tridiagonal::solve(
            &self.diag,
            &self.lower[..off],
            &self.upper[..off],
            &mut self.residuals,
            &mut self.scratch,
        );
    }
}

/// The cart's half of the step: its velocity after the first half kick and the
/// velocity change per unit time from the force.
struct CartKick<G: Geometry> {
    x0: G::Cart,
    xdot_half: G::Cart,
    xdot_force: G::Cart,
}

pub(super) fn step<G: Geometry>(
    chain: &Chain<G>,
    s: &mut Stepper<G>,
    y: &mut [f64],
    u: G::Cart,
    h: f64,
    opts: &StepOptions,
) -> Result<()> {
    let ws = &mut s.variational;
    let cart = first_half_kick(chain, ws, y, u, h);
    let (xdot_resp, iterations) = solve_positions(chain, ws, h, opts)?;
    s.stats.newton_iterations += iterations;
    finish_step(chain, ws, y, &cart, xdot_resp, h);
    s.stats.evaluations += 1;
    s.stats.accepted_steps += 1;
    Ok(())
}

/// Half kick: `v~ = v + h/2 M^{-1} F`, with `F = (u, g_i e3)` constant over the step.
fn first_half_kick<G: Geometry>(
    chain: &Chain<G>,
    ws: &mut VariationalWorkspace<G>,
    y: &[f64],
    u: G::Cart,
    h: f64,
) -> CartKick<G> {
    let lay = chain.layout();
    let gravity = chain.gravity_coefficients();
    let xdot_force = inverse_mass(
        chain,
        u,
        |i| G::down_unit() * gravity[i],
        &mut ws.force_velocity,
    );
    let xdot_half = lay.load_xdot(y) + xdot_force * (0.5 * h);
    for i in 0..lay.n {
        ws.q0[i] = lay.load_q(y, i);
        ws.velocity[i] = G::velocity(lay.load_w(y, i), ws.q0[i]) + ws.force_velocity[i] * (0.5 * h);
        ws.multipliers[i] = 0.0;
    }
    CartKick {
        x0: lay.load_x(y),
        xdot_half,
        xdot_force,
    }
}

/// Newton on `phi_i(lambda) = (|q_i + h v~_i - h^2/2 r_i(lambda)|^2 - 1)/2 = 0`, with the
/// unknown scaled as `kappa = h^2/2 lambda`, so `q1 = q0 + h v~ - r(kappa)`. Returns the
/// cart's displacement response and the number of iterations.
fn solve_positions<G: Geometry>(
    chain: &Chain<G>,
    ws: &mut VariationalWorkspace<G>,
    h: f64,
    opts: &StepOptions,
) -> Result<(G::Cart, usize)> {
    let n = chain.n_links();
    let mut iterations = 0;
    loop {
        let q0 = &ws.q0;
        let multipliers = &ws.multipliers;
        let xdot_resp = inverse_mass(
            chain,
            G::Cart::zero(),
            |j| q0[j] * multipliers[j],
            &mut ws.response,
        );
        let mut worst: f64 = 0.0;
        for i in 0..n {
            ws.q1[i] = ws.q0[i] + ws.velocity[i] * h - ws.response[i];
            ws.residuals[i] = 0.5 * (ws.q1[i].norm_squared() - 1.0);
            worst = worst.max(ws.residuals[i].abs());
        }
        if worst <= opts.newton_tolerance {
            return Ok((xdot_resp, iterations));
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
        response_matrix(
            chain,
            &ws.q0,
            &ws.q1,
            &mut ws.diag,
            &mut ws.lower,
            &mut ws.upper,
        );
        for v in ws
            .diag
            .iter_mut()
            .chain(ws.lower.iter_mut())
            .chain(ws.upper.iter_mut())
        {
            *v = -*v;
        }
        ws.solve_residuals();
        for i in 0..n {
            ws.multipliers[i] -= ws.residuals[i];
        }
        iterations += 1;
    }
}

/// Positions at k+1, the second half kick, and the projection of the velocities onto
/// `q1_i . qdot_i = 0` (linear, symmetric tridiagonal); stores the new state in `y`.
fn finish_step<G: Geometry>(
    chain: &Chain<G>,
    ws: &mut VariationalWorkspace<G>,
    y: &mut [f64],
    cart: &CartKick<G>,
    xdot_resp: G::Cart,
    h: f64,
) {
    let lay = chain.layout();
    let n = lay.n;
    let x1 = cart.x0 + (cart.xdot_half * h - xdot_resp);
    let mut xdot1 = cart.xdot_half - xdot_resp * (1.0 / h) + cart.xdot_force * (0.5 * h);
    for i in 0..n {
        ws.velocity[i] =
            ws.velocity[i] - ws.response[i] * (1.0 / h) + ws.force_velocity[i] * (0.5 * h);
        ws.residuals[i] = ws.q1[i].dot(ws.velocity[i]);
    }
    response_matrix(
        chain,
        &ws.q1,
        &ws.q1,
        &mut ws.diag,
        &mut ws.lower,
        &mut ws.upper,
    );
    ws.solve_residuals();
    let (q1, projection) = (&ws.q1, &ws.residuals);
    xdot1 -= inverse_mass(
        chain,
        G::Cart::zero(),
        |j| q1[j] * projection[j],
        &mut ws.response,
    );

    lay.store_x(y, x1);
    lay.store_xdot(y, xdot1);
    for i in 0..n {
        lay.store_q(y, i, ws.q1[i]);
        lay.store_w(y, i, G::spin(ws.q1[i], ws.velocity[i] - ws.response[i]));
    }
}
