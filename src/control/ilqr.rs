//! Control-limited iterative LQR (Tassa, Mansard & Todorov 2014) on the chart.
//!
//! Each iteration linearises the control step along the nominal trajectory (exact
//! Jacobians, [`super::jacobian`]), takes Gauss-Newton quadratic models of the cost
//! ([`super::cost`]), and runs the backward pass: at each knot the box-constrained QP
//! of the force increment ([`super::boxqp`]), Levenberg-Marquardt regularisation
//! `mu` on the value Hessian (raised when a QP is not convex), and the time-varying
//! feedback gain on the free inputs. The forward pass rolls the true nonlinear step out
//! with that feedback, `u_k = clamp(u_k + alpha k_k + K_k local(y_k, y'_k))`: closed-loop
//! rollouts keep unstable targets well conditioned where open-loop shooting diverges.
//! A backtracking line search on `alpha` accepts a step when the actual decrease is at
//! a small fraction of the decrease the quadratic model predicts ([`ACCEPT_RATIO`]).
//!
//! It stops when the relative decrease of the cost falls below a tolerance, when the
//! regularisation reaches its ceiling (no descent direction left), after an iteration
//! cap or at a deadline: it never hangs, and [`SolveStatus`] says which.

use super::boxqp::solve_box_qp;
use super::chart::{local, ChartPoint};
use super::cost::Cost;
use super::dual::Real;
use super::jacobian::{StepModel, StepWorkspace, D};
use super::vector::ScalarGeometry;
use nalgebra::{DMatrix, DVector};
use std::time::{Duration, Instant};

/// The instant `seconds` after `began`, or none for an infinite budget (iterations alone
/// then bound the work, so that its result does not depend on the machine's load).
pub fn deadline_after(began: Instant, seconds: f64) -> Option<Instant> {
    seconds
        .is_finite()
        .then(|| began + Duration::from_secs_f64(seconds))
}

/// Checks a wall-time budget: a number > 0, `inf` for none.
pub fn check_budget(name: &'static str, seconds: f64) -> crate::error::Result<()> {
    if seconds == f64::INFINITY {
        return Ok(());
    }
    crate::error::check_positive(name, seconds)
}

/// Stopping rules and regularisation of [`Ilqr::solve`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IlqrOptions {
    /// Iteration cap.
    pub max_iterations: usize,
    /// Stop at this instant at the latest (checked once per iteration).
    pub deadline: Option<Instant>,
    /// Converged when an accepted step lowers the cost by less than this fraction.
    pub tolerance: f64,
    /// Initial regularisation.
    pub mu_init: f64,
    /// Regularisation floor (below it, `mu` is 0).
    pub mu_min: f64,
    /// Regularisation ceiling: reaching it ends the solve.
    pub mu_max: f64,
}

impl Default for IlqrOptions {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            deadline: None,
            tolerance: 1e-6,
            mu_init: 1e-6,
            mu_min: 1e-8,
            mu_max: 1e10,
        }
    }
}

/// Why [`Ilqr::solve`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolveStatus {
    /// The relative cost decrease fell below the tolerance.
    Converged,
    /// The regularisation reached its ceiling: no descent step could be found.
    Stalled,
    /// The iteration cap was reached.
    IterationLimit,
    /// The deadline passed.
    TimeLimit,
}

impl SolveStatus {
    /// A short description.
    pub fn describe(self) -> &'static str {
        match self {
            SolveStatus::Converged => "converged",
            SolveStatus::Stalled => "stalled (no descent step found at the largest regularisation)",
            SolveStatus::IterationLimit => "iteration limit reached",
            SolveStatus::TimeLimit => "time limit reached",
        }
    }
}

/// What the terminal cost is.
#[derive(Debug, Clone)]
pub enum Terminal {
    /// The cost's own terminal residual (distance to the target and its LQR cost-to-go).
    Target,
    /// A quadratic `v + g^T d + d^T H d / 2` in the chart about a state (a value
    /// function of an earlier solution, for receding horizons).
    Quadratic {
        /// Where the quadratic is centred.
        point: ChartPoint,
        /// `v`.
        value: f64,
        /// `g`.
        gradient: DVector<f64>,
        /// `H`.
        hessian: DMatrix<f64>,
    },
}

/// Buffers of the quadratic models along a trajectory of `horizon` steps.
#[derive(Debug, Clone)]
struct Models {
    a: Vec<DMatrix<f64>>,
    b: Vec<DMatrix<f64>>,
    lx: Vec<DVector<f64>>,
    lxx: Vec<DMatrix<f64>>,
    /// Feed-forward `k_k` (force increments).
    ff: Vec<DVector<f64>>,
    /// Feedback `K_k` (`force_dim x nz`).
    gain: Vec<DMatrix<f64>>,
    vx: Vec<DVector<f64>>,
    vxx: Vec<DMatrix<f64>>,
}

impl Models {
    fn new(horizon: usize, nz: usize, nu: usize) -> Self {
        Self {
            a: vec![DMatrix::zeros(nz, nz); horizon],
            b: vec![DMatrix::zeros(nz, nu); horizon],
            lx: vec![DVector::zeros(nz); horizon + 1],
            lxx: vec![DMatrix::zeros(nz, nz); horizon + 1],
            ff: vec![DVector::zeros(nu); horizon],
            gain: vec![DMatrix::zeros(nu, nz); horizon],
            vx: vec![DVector::zeros(nz); horizon + 1],
            vxx: vec![DMatrix::zeros(nz, nz); horizon + 1],
        }
    }
}

/// Buffers of one knot of the backward pass.
#[derive(Debug, Clone)]
struct BackwardWork {
    qx: DVector<f64>,
    qu: DVector<f64>,
    qxx: DMatrix<f64>,
    va: DMatrix<f64>,
    btv: DMatrix<f64>,
    quu: DMatrix<f64>,
    qux: DMatrix<f64>,
    mk: DMatrix<f64>,
}

impl BackwardWork {
    fn new(nz: usize, nu: usize) -> Self {
        Self {
            qx: DVector::zeros(nz),
            qu: DVector::zeros(nu),
            qxx: DMatrix::zeros(nz, nz),
            va: DMatrix::zeros(nz, nz),
            btv: DMatrix::zeros(nu, nz),
            quu: DMatrix::zeros(nu, nu),
            qux: DMatrix::zeros(nu, nz),
            mk: DMatrix::zeros(nu, nz),
        }
    }
}

/// A trajectory: `horizon + 1` states (as charts) and `horizon` forces.
#[derive(Debug, Clone)]
pub struct Trajectory {
    /// The states, each with its chart.
    pub points: Vec<ChartPoint>,
    /// The forces, `force_dim` per step, flat.
    pub forces: Vec<f64>,
    /// Its cost (infinite if the rollout failed).
    pub cost: f64,
}

/// The solver: a problem (model, cost, horizon, force limit, terminal cost) and its
/// state (the nominal trajectory and the last backward pass).
#[derive(Debug, Clone)]
pub struct Ilqr<G: ScalarGeometry> {
    model: StepModel<G>,
    cost: Cost<G>,
    horizon: usize,
    max_force: f64,
    terminal: Terminal,
    /// The nominal trajectory.
    pub nominal: Trajectory,
    candidate: Trajectory,
    models: Models,
    work: BackwardWork,
    mu: f64,
    ws: StepWorkspace<G>,
    scratch: Scratch,
    /// Iterations done by the last [`Ilqr::solve`].
    pub iterations: usize,
}

#[derive(Debug, Clone)]
struct Scratch {
    residual: Vec<f64>,
    jac: DMatrix<f64>,
    duals: Vec<D>,
    z: Vec<D>,
    delta: Vec<f64>,
    state: Vec<f64>,
}

impl<G: ScalarGeometry> Ilqr<G> {
    /// A solver over `horizon` steps (>= 1) with forces limited to `+-max_force` per axis.
    pub fn new(model: StepModel<G>, cost: Cost<G>, horizon: usize, max_force: f64) -> Self {
        let (nz, nu, dim) = (model.chart().dim(), model.force_dim(), model.state_dim());
        let n = model.n_links();
        let rows = cost.running_len().max(cost.terminal_len());
        let empty = || Trajectory {
            points: vec![ChartPoint::new::<G>(n, &vec![0.0; dim]); horizon + 1],
            forces: vec![0.0; horizon * nu],
            cost: f64::INFINITY,
        };
        let ws = model.workspace();
        Self {
            nominal: empty(),
            candidate: empty(),
            models: Models::new(horizon, nz, nu),
            work: BackwardWork::new(nz, nu),
            mu: 0.0,
            scratch: Scratch {
                residual: vec![0.0; rows],
                jac: DMatrix::zeros(rows, nz),
                duals: Vec::new(),
                z: vec![D::cst(0.0); nz],
                delta: vec![0.0; nz],
                state: vec![0.0; dim],
            },
            ws,
            model,
            cost,
            horizon,
            max_force,
            terminal: Terminal::Target,
            iterations: 0,
        }
    }

    /// The step model.
    pub fn model(&self) -> &StepModel<G> {
        &self.model
    }
    /// The cost.
    pub fn cost(&self) -> &Cost<G> {
        &self.cost
    }
    /// Number of steps.
    pub fn horizon(&self) -> usize {
        self.horizon
    }
    /// The largest horizon the buffers hold.
    pub fn capacity(&self) -> usize {
        self.models.a.len()
    }
    /// Shortens (or restores) the horizon, at most [`Ilqr::capacity`] and at least 1.
    pub fn set_horizon(&mut self, horizon: usize) {
        self.horizon = horizon.clamp(1, self.capacity());
    }
    /// The force limit.
    pub fn max_force(&self) -> f64 {
        self.max_force
    }
    /// Sets the terminal cost.
    pub fn set_terminal(&mut self, terminal: Terminal) {
        self.terminal = terminal;
    }
    /// The feedback gains of the last backward pass (`force_dim x nz` each).
    pub fn gains(&self) -> &[DMatrix<f64>] {
        &self.models.gain
    }
    /// Gradient and Hessian of the value function of the last backward pass, per knot.
    pub fn value(&self, k: usize) -> (&DVector<f64>, &DMatrix<f64>) {
        (&self.models.vx[k], &self.models.vxx[k])
    }

    /// Recomputes the gains and the value function at the nominal trajectory (after a
    /// solve whose last accepted step left them one iteration behind); `false` if no
    /// backward pass succeeded below the largest regularisation.
    pub fn refresh_policy(&mut self, options: &IlqrOptions) -> bool {
        self.linearise();
        let mut mu = 0.0;
        while mu <= options.mu_max {
            if self.backward(mu).is_some() {
                return true;
            }
            mu = (mu * 4.0).max(options.mu_min);
        }
        false
    }

    /// Makes `points`, `forces` and `gains` (a trajectory of `gains.len()` steps, at most
    /// the capacity) the nominal trajectory and its feedback.
    pub fn load(&mut self, points: &[ChartPoint], forces: &[f64], gains: &[DMatrix<f64>]) {
        let nu = self.model.force_dim();
        self.set_horizon(gains.len());
        let h = self.horizon;
        for (dst, src) in self.nominal.points.iter_mut().zip(&points[..=h]) {
            dst.clone_from(src);
        }
        self.nominal.forces[..h * nu].copy_from_slice(&forces[..h * nu]);
        for (dst, src) in self.models.gain.iter_mut().zip(&gains[..h]) {
            dst.copy_from(src);
        }
        for f in &mut self.models.ff {
            f.fill(0.0);
        }
    }

    /// Drops the first step of the nominal trajectory and appends `point` (the new last
    /// state), `force` and `gain` (the new last step's): the warm start of a receding
    /// horizon.
    pub fn shift(&mut self, point: &ChartPoint, force: &[f64], gain: &DMatrix<f64>) {
        let nu = self.model.force_dim();
        let h = self.horizon;
        self.nominal.points[..=h].rotate_left(1);
        self.nominal.points[h].clone_from(point);
        self.nominal.forces[..h * nu].rotate_left(nu);
        self.nominal.forces[(h - 1) * nu..h * nu].copy_from_slice(force);
        self.models.gain[..h].rotate_left(1);
        self.models.gain[h - 1].copy_from(gain);
        for f in &mut self.models.ff {
            f.fill(0.0);
        }
    }

    /// The first force of the nominal trajectory.
    pub fn first_force(&self) -> &[f64] {
        &self.nominal.forces[..self.model.force_dim()]
    }

    /// Rolls out `forces` (clamped to the limit) open-loop from `start` and makes the
    /// result the nominal trajectory; returns its cost.
    pub fn rollout(&mut self, start: &[f64], forces: &[f64]) -> f64 {
        let nu = self.model.force_dim();
        for (f, &v) in self.nominal.forces.iter_mut().zip(forces) {
            *f = v.clamp(-self.max_force, self.max_force);
        }
        self.scratch.state.copy_from_slice(start);
        self.nominal.points[0].set::<G>(start);
        let mut ok = true;
        for k in 0..self.horizon {
            let u = &self.nominal.forces[k * nu..(k + 1) * nu];
            self.model.step(&mut self.scratch.state, u, &mut self.ws);
            ok &= self.scratch.state.iter().all(|v| v.is_finite());
            if !ok {
                break;
            }
            self.nominal.points[k + 1].set::<G>(&self.scratch.state);
        }
        self.nominal.cost = if ok {
            trajectory_cost(
                &self.cost,
                &self.terminal,
                &self.nominal,
                self.horizon,
                &mut self.scratch,
            )
        } else {
            f64::INFINITY
        };
        self.nominal.cost
    }

    /// Resets the feedback to zero (before a new problem's first iteration).
    pub fn clear_policy(&mut self) {
        for g in &mut self.models.gain {
            g.fill(0.0);
        }
        for f in &mut self.models.ff {
            f.fill(0.0);
        }
    }

    /// Rolls the current nominal forces plus `alpha` times the feed-forward out from
    /// `start` with the feedback gains, into the candidate; returns its cost.
    pub fn rollout_with_feedback(&mut self, start: &[f64], alpha: f64) -> f64 {
        let nu = self.model.force_dim();
        let c = &mut self.candidate;
        self.scratch.state.copy_from_slice(start);
        c.points[0].set::<G>(start);
        for k in 0..self.horizon {
            local::<G, f64>(
                &self.nominal.points[k],
                &self.scratch.state,
                &mut self.scratch.delta,
            );
            let feedback = &self.models.gain[k] * DVector::from_column_slice(&self.scratch.delta);
            for j in 0..nu {
                let u =
                    self.nominal.forces[k * nu + j] + alpha * self.models.ff[k][j] + feedback[j];
                c.forces[k * nu + j] = u.clamp(-self.max_force, self.max_force);
            }
            self.model.step(
                &mut self.scratch.state,
                &c.forces[k * nu..(k + 1) * nu],
                &mut self.ws,
            );
            if !self.scratch.state.iter().all(|v| v.is_finite()) {
                c.cost = f64::INFINITY;
                return c.cost;
            }
            c.points[k + 1].set::<G>(&self.scratch.state);
        }
        c.cost = trajectory_cost(
            &self.cost,
            &self.terminal,
            c,
            self.horizon,
            &mut self.scratch,
        );
        c.cost
    }

    /// Makes the candidate the nominal trajectory.
    pub fn accept_candidate(&mut self) {
        std::mem::swap(&mut self.nominal, &mut self.candidate);
    }

    /// Exact Jacobians and Gauss-Newton cost models along the nominal trajectory.
    fn linearise(&mut self) {
        let nu = self.model.force_dim();
        for k in 0..self.horizon {
            let (a, b) = (&mut self.models.a[k], &mut self.models.b[k]);
            self.model.jacobians(
                &self.nominal.points[k],
                &self.nominal.forces[k * nu..(k + 1) * nu],
                &self.nominal.points[k + 1],
                a,
                b,
                &mut self.ws,
            );
            let (lx, lxx) = (&mut self.models.lx[k], &mut self.models.lxx[k]);
            running_model(
                &self.model,
                &self.cost,
                &self.nominal.points[k],
                &mut self.ws,
                &mut self.scratch,
                lx,
                lxx,
            );
        }
        let k = self.horizon;
        let (lx, lxx) = (&mut self.models.lx[k], &mut self.models.lxx[k]);
        terminal_model(
            &self.model,
            &self.cost,
            &self.terminal,
            &self.nominal.points[k],
            &mut self.ws,
            &mut self.scratch,
            lx,
            lxx,
        );
    }

    /// The backward pass at regularisation `mu`; the expected decrease terms
    /// `(dv1, dv2)` (cost change `alpha dv1 + alpha^2 dv2`), or `None` if a QP was not
    /// convex.
    fn backward(&mut self, mu: f64) -> Option<(f64, f64)> {
        let nu = self.model.force_dim();
        let nz = self.model.chart().dim();
        let m = &mut self.models;
        let w = &mut self.work;
        let ru = self.cost.dt() * self.cost.weights().force;
        m.vx[self.horizon].copy_from(&m.lx[self.horizon]);
        m.vxx[self.horizon].copy_from(&m.lxx[self.horizon]);
        let (mut dv1, mut dv2) = (0.0, 0.0);
        for k in (0..self.horizon).rev() {
            let (a, b) = (&m.a[k], &m.b[k]);
            let u = &self.nominal.forces[k * nu..(k + 1) * nu];
            let (head, tail) = m.vxx.split_at_mut(k + 1);
            let (vxx, vxx_next) = (&mut head[k], &tail[0]);
            let (head, tail) = m.vx.split_at_mut(k + 1);
            let (vx, vx_next) = (&mut head[k], &tail[0]);
            // Q_x = l_x + A^T V_x', Q_u = l_u + B^T V_x'.
            w.qx.copy_from(&m.lx[k]);
            w.qx.gemv_tr(1.0, a, vx_next, 1.0);
            w.qu.gemv_tr(1.0, b, vx_next, 0.0);
            // Q_xx = l_xx + A^T V_xx' A.
            w.va.gemm(1.0, vxx_next, a, 0.0);
            w.qxx.copy_from(&m.lxx[k]);
            w.qxx.gemm_tr(1.0, a, &w.va, 1.0);
            // Regularised on the value Hessian: B^T (V_xx' + mu I) B and B^T (V_xx' + mu I) A.
            w.btv.gemm_tr(1.0, b, vxx_next, 0.0);
            for j in 0..nu {
                for i in 0..nz {
                    w.btv[(j, i)] += mu * b[(i, j)];
                }
            }
            w.quu.gemm(1.0, &w.btv, b, 0.0);
            w.qux.gemm(1.0, &w.btv, a, 0.0);
            let (mut lo, mut hi) = ([0.0; 2], [0.0; 2]);
            for j in 0..nu {
                w.qu[j] += ru * u[j];
                w.quu[(j, j)] += ru;
                lo[j] = -self.max_force - u[j];
                hi[j] = self.max_force - u[j];
            }
            let sol = solve_box_qp(&w.quu, &w.qu, &lo[..nu], &hi[..nu])?;
            let ff = &mut m.ff[k];
            let gain = &mut m.gain[k];
            gain.fill(0.0);
            for j in 0..nu {
                ff[j] = sol.step[j];
            }
            let free: Vec<usize> = (0..nu).filter(|&j| sol.free[j]).collect();
            if !free.is_empty() {
                let hf = DMatrix::from_fn(free.len(), free.len(), |r, c| w.quu[(free[r], free[c])]);
                let inv = hf.try_inverse()?;
                for (r, &jr) in free.iter().enumerate() {
                    for col in 0..nz {
                        let mut acc = 0.0;
                        for (c, &jc) in free.iter().enumerate() {
                            acc -= inv[(r, c)] * w.qux[(jc, col)];
                        }
                        gain[(jr, col)] = acc;
                    }
                }
            }
            // Expected decrease and the value update:
            // V_x = Q_x + K^T (Q_uu k + Q_u) + Q_ux^T k,
            // V_xx = Q_xx + K^T (Q_uu K + Q_ux) + Q_ux^T K.
            let mut quu_k = [0.0; 2];
            for j in 0..nu {
                for i in 0..nu {
                    quu_k[j] += w.quu[(j, i)] * ff[i];
                }
                dv1 += ff[j] * w.qu[j];
                dv2 += 0.5 * ff[j] * quu_k[j];
            }
            w.mk.gemm(1.0, &w.quu, gain, 0.0);
            w.mk += &w.qux;
            vx.copy_from(&w.qx);
            for j in 0..nu {
                let weight = quu_k[j] + w.qu[j];
                for i in 0..nz {
                    vx[i] += gain[(j, i)] * weight + w.qux[(j, i)] * ff[j];
                }
            }
            vxx.copy_from(&w.qxx);
            vxx.gemm_tr(1.0, gain, &w.mk, 1.0);
            vxx.gemm_tr(1.0, &w.qux, gain, 1.0);
            for i in 0..nz {
                for l in 0..i {
                    let avg = 0.5 * (vxx[(i, l)] + vxx[(l, i)]);
                    vxx[(i, l)] = avg;
                    vxx[(l, i)] = avg;
                }
            }
        }
        Some((dv1, dv2))
    }

    /// Iterates from `start` (the nominal trajectory must start there and have been
    /// rolled out) until a stopping rule holds.
    pub fn solve(&mut self, start: &[f64], options: &IlqrOptions) -> SolveStatus {
        self.mu = options.mu_init;
        self.iterations = 0;
        let growth = 4.0;
        let alphas = [1.0, 0.5, 0.25, 0.1, 0.03, 0.01];
        let mut stale = true;
        loop {
            if self.iterations >= options.max_iterations {
                return SolveStatus::IterationLimit;
            }
            if options.deadline.is_some_and(|d| Instant::now() >= d) {
                return SolveStatus::TimeLimit;
            }
            self.iterations += 1;
            if stale {
                self.linearise();
                stale = false;
            }
            let (dv1, dv2) = loop {
                if let Some(dv) = self.backward(self.mu) {
                    break dv;
                }
                self.mu = (self.mu * growth).max(options.mu_min);
                if self.mu > options.mu_max {
                    return SolveStatus::Stalled;
                }
            };
            let old = self.nominal.cost;
            let mut accepted = None;
            for &alpha in &alphas {
                let new = self.rollout_with_feedback(start, alpha);
                let expected = -(alpha * dv1 + alpha * alpha * dv2);
                let ratio = if expected > 0.0 {
                    (old - new) / expected
                } else {
                    (old - new).signum()
                };
                if new.is_finite() && new < old && ratio > ACCEPT_RATIO {
                    accepted = Some(new);
                    break;
                }
            }
            match accepted {
                Some(new) => {
                    self.accept_candidate();
                    stale = true;
                    self.mu = if self.mu / growth < options.mu_min {
                        0.0
                    } else {
                        self.mu / growth
                    };
                    if (old - new) < options.tolerance * old.abs() {
                        return SolveStatus::Converged;
                    }
                }
                None => {
                    // The model predicts no decrease: a (local) minimum.
                    if -dv1 < options.tolerance * old.abs() {
                        return SolveStatus::Converged;
                    }
                    self.mu = (self.mu * growth).max(options.mu_min);
                    if self.mu > options.mu_max {
                        return SolveStatus::Stalled;
                    }
                }
            }
        }
    }
}

/// A line-search step is accepted when the cost falls by at least this fraction of the
/// decrease the quadratic model predicts.
const ACCEPT_RATIO: f64 = 1e-4;

/// Gradient and Gauss-Newton Hessian of the running state cost at `point`, times `dt`.
fn running_model<G: ScalarGeometry>(
    model: &StepModel<G>,
    cost: &Cost<G>,
    point: &ChartPoint,
    ws: &mut StepWorkspace<G>,
    s: &mut Scratch,
    lx: &mut DVector<f64>,
    lxx: &mut DMatrix<f64>,
) {
    let m = cost.running_len();
    model.chart_jacobian(
        point,
        m,
        |y, r| cost.running_residual(y, r),
        &mut s.residual[..m],
        &mut s.jac,
        ws,
        &mut s.duals,
    );
    gauss_newton(
        &s.jac.rows(0, m).into_owned(),
        &s.residual[..m],
        cost.dt(),
        lx,
        lxx,
    );
}

/// Gradient and Gauss-Newton Hessian of the terminal cost at `point`.
#[allow(clippy::too_many_arguments)]
fn terminal_model<G: ScalarGeometry>(
    model: &StepModel<G>,
    cost: &Cost<G>,
    terminal: &Terminal,
    point: &ChartPoint,
    ws: &mut StepWorkspace<G>,
    s: &mut Scratch,
    lx: &mut DVector<f64>,
    lxx: &mut DMatrix<f64>,
) {
    match terminal {
        Terminal::Target => {
            let m = cost.terminal_len();
            let z = &mut s.z;
            model.chart_jacobian(
                point,
                m,
                |y, r| cost.terminal_residual(y, r, z),
                &mut s.residual[..m],
                &mut s.jac,
                ws,
                &mut s.duals,
            );
            gauss_newton(
                &s.jac.rows(0, m).into_owned(),
                &s.residual[..m],
                1.0,
                lx,
                lxx,
            );
        }
        Terminal::Quadratic {
            point: centre,
            gradient,
            hessian,
            ..
        } => {
            // d(point) = local(centre, point) ~ d0 + J e for the increment e about point.
            let nz = model.chart().dim();
            let m = nz;
            model.chart_jacobian(
                point,
                m,
                |y, r| local::<G, D>(centre, y, r),
                &mut s.residual[..m],
                &mut s.jac,
                ws,
                &mut s.duals,
            );
            let j = s.jac.rows(0, m).into_owned();
            let d0 = DVector::from_column_slice(&s.residual[..m]);
            let g = gradient + hessian * &d0;
            *lx = j.transpose() * g;
            *lxx = j.transpose() * hessian * &j;
        }
    }
}

fn gauss_newton(
    jac: &DMatrix<f64>,
    r: &[f64],
    scale: f64,
    lx: &mut DVector<f64>,
    lxx: &mut DMatrix<f64>,
) {
    let r = DVector::from_column_slice(r);
    *lx = jac.transpose() * r * scale;
    *lxx = jac.transpose() * jac * scale;
}

/// The cost of a trajectory.
fn trajectory_cost<G: ScalarGeometry>(
    cost: &Cost<G>,
    terminal: &Terminal,
    t: &Trajectory,
    horizon: usize,
    s: &mut Scratch,
) -> f64 {
    let nu = t.forces.len() / (t.points.len() - 1);
    let m = cost.running_len();
    let mut total = 0.0;
    for k in 0..horizon {
        cost.running_residual(&t.points[k].y, &mut s.residual[..m]);
        total += cost.running_cost(&s.residual[..m], &t.forces[k * nu..(k + 1) * nu]);
    }
    total + terminal_cost(cost, terminal, &t.points[horizon].y, s)
}

/// The terminal cost of state `y`.
fn terminal_cost<G: ScalarGeometry>(
    cost: &Cost<G>,
    terminal: &Terminal,
    y: &[f64],
    s: &mut Scratch,
) -> f64 {
    match terminal {
        Terminal::Target => {
            let m = cost.terminal_len();
            let mut z = vec![0.0; s.delta.len()];
            cost.terminal_residual(y, &mut s.residual[..m], &mut z);
            0.5 * s.residual[..m].iter().map(|v| v * v).sum::<f64>()
        }
        Terminal::Quadratic {
            point,
            value,
            gradient,
            hessian,
        } => {
            local::<G, f64>(point, y, &mut s.delta);
            let d = DVector::from_column_slice(&s.delta);
            value + gradient.dot(&d) + 0.5 * (d.transpose() * hessian * &d)[0]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::chart::retract;
    use crate::control::cost::CostWeights;
    use crate::geometry::Planar;
    use crate::model::Chain;
    use crate::params::ChainParams;
    use rand::{Rng, SeedableRng};

    fn problem(horizon: usize, max_force: f64) -> (Ilqr<Planar>, Vec<f64>) {
        let chain = Chain::<Planar>::new(ChainParams::uniform(2, 1.0, 0.1, 0.5, 9.81).unwrap());
        let cost = Cost::new(&chain, &[-1.0, -1.0], CostWeights::default(), 0.02, 2.4).unwrap();
        let model = StepModel::new(&chain, 0.02, 2);
        let start = chain.equilibrium(&[1.0, 1.0]).unwrap();
        (Ilqr::new(model, cost, horizon, max_force), start)
    }

    #[test]
    fn cost_models_match_central_differences() {
        let (mut s, start) = problem(10, 20.0);
        let mut rng = rand::rngs::StdRng::seed_from_u64(1);
        let forces: Vec<f64> = (0..10).map(|_| rng.random_range(-15.0..15.0)).collect();
        s.rollout(&start, &forces);
        s.linearise();
        let nz = s.model.chart().dim();
        for k in [3, 10] {
            let point = s.nominal.points[k].clone();
            let f = |s: &mut Ilqr<Planar>, delta: &[f64]| {
                let mut y = vec![0.0; point.y.len()];
                retract::<Planar, f64>(&point, delta, &mut y);
                let m = if k == 10 {
                    s.cost.terminal_len()
                } else {
                    s.cost.running_len()
                };
                let mut r = vec![0.0; m];
                if k == 10 {
                    s.cost.terminal_residual(&y, &mut r, &mut vec![0.0; nz]);
                    0.5 * r.iter().map(|v| v * v).sum::<f64>()
                } else {
                    s.cost.running_residual(&y, &mut r);
                    s.cost.running_cost(&r, &[0.0])
                }
            };
            let h = 1e-6;
            for col in 0..nz {
                let mut d = vec![0.0; nz];
                d[col] = h;
                let up = f(&mut s, &d);
                d[col] = -h;
                let down = f(&mut s, &d);
                let fd = (up - down) / (2.0 * h);
                let exact = s.models.lx[k][col];
                assert!(
                    (fd - exact).abs() < 1e-5 * (1.0 + exact.abs()),
                    "k {k} col {col}: {exact} vs {fd}"
                );
            }
        }
    }

    #[test]
    fn the_expected_decrease_is_the_slope_of_the_closed_loop_rollout() {
        let (mut s, start) = problem(40, 1e6);
        let mut rng = rand::rngs::StdRng::seed_from_u64(2);
        let forces: Vec<f64> = (0..40).map(|_| rng.random_range(-2.0..2.0)).collect();
        let old = s.rollout(&start, &forces);
        s.linearise();
        let (dv1, _) = s.backward(0.0).unwrap();
        let a = 1e-6;
        let new = s.rollout_with_feedback(&start, a);
        let slope = (new - old) / a;
        assert!(
            (slope - dv1).abs() < 1e-3 * dv1.abs(),
            "slope {slope} vs dv1 {dv1}"
        );
    }
}
