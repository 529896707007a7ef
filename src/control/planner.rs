//! The planner: a force sequence that drives the chain from a state (or equilibrium)
//! to an equilibrium within the force limit and the track, by control-limited iLQR
//! ([`super::ilqr`]) from several initial guesses.
//!
//! **Why iLQR.** It needs only the step and its exact derivatives (no NLP solver), the
//! force box is exact in its backward pass, its forward pass is a closed-loop rollout
//! (well conditioned towards unstable targets), and its by-products, the time-varying
//! gains and the quadratic value function along the plan, are what the tracking
//! controller and the receding-horizon controller need ([`super::tvlqr`],
//! [`super::mpc`]). Collocation or multiple shooting would handle long unstable
//! horizons more robustly, at the price of a sparse NLP solver in the core.
//!
//! **Initial guesses.** At every equilibrium the force's gradient vanishes (a saddle of
//! the cost for the hanging chain), so iLQR from zero force stays put. The planner
//! therefore starts from a kick either way (enough where the target lies downhill) and
//! several pumping guesses, `u(t) = a F sin(omega t + phi)`
//! tapered off in the last part of the horizon, at the natural frequencies of the
//! hanging chain (the chain's resonances are where a bounded force pumps energy
//! fastest), polishes each for a few iterations, keeps the best, and finishes it.
//! Deterministic: the same problem gives the same plan.

use super::cost::{target_lqr, Cost, CostWeights};
use super::ilqr::{Ilqr, IlqrOptions, SolveStatus, Trajectory};
use super::jacobian::StepModel;
use super::mpc::{Mpc, MpcOptions, Reference};
pub use super::plan::{Plan, PlanReport};
use super::tvlqr::Tracker;
use super::vector::ScalarGeometry;
use crate::analysis::Linearization;
use crate::error::{check_finite, check_len, check_positive, InputError, Result};
use crate::model::Chain;
use std::time::Instant;

/// Largest number of knots a plan may have (duration / dt).
pub const MAX_KNOTS: usize = 100_000;

/// What to plan and how hard to try.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOptions {
    /// Force limit per axis, N (> 0).
    pub max_force: f64,
    /// Track limit, m (> 0): the plan keeps `|x_c|` below it.
    pub track_limit: f64,
    /// Length of the plan, s.
    pub duration: f64,
    /// Control period, s.
    pub dt: f64,
    /// RK4 steps per control period.
    pub substeps: usize,
    /// Cost weights.
    pub weights: CostWeights,
    /// Iteration cap over all guesses.
    pub max_iterations: usize,
    /// Wall-time cap, s (`inf`: none, `max_iterations` alone bounds the work).
    pub max_time: f64,
    /// Initial guesses tried (>= 1).
    pub guesses: usize,
    /// Iterations given to each guess before the best is finished.
    pub probe_iterations: usize,
    /// Success tolerances on the paper's `e_q` and `e_w` at the end of the plan.
    pub tolerance_q: f64,
    /// See `tolerance_q`.
    pub tolerance_w: f64,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            max_force: 20.0,
            track_limit: 2.4,
            duration: 3.0,
            dt: 0.02,
            substeps: 2,
            weights: CostWeights::default(),
            max_iterations: 1000,
            max_time: 30.0,
            guesses: 10,
            probe_iterations: 25,
            tolerance_q: 0.1,
            tolerance_w: 0.5,
        }
    }
}

impl PlanOptions {
    /// Checks every option, naming a bad one.
    pub fn validate(&self) -> Result<()> {
        check_positive("max_force", self.max_force)?;
        check_positive("track_limit", self.track_limit)?;
        check_positive("duration", self.duration)?;
        check_positive("dt", self.dt)?;
        super::ilqr::check_budget("max_time", self.max_time)?;
        check_positive("tolerance_q", self.tolerance_q)?;
        check_positive("tolerance_w", self.tolerance_w)?;
        for (name, value) in [
            ("substeps", self.substeps),
            ("max_iterations", self.max_iterations),
            ("guesses", self.guesses),
        ] {
            if value == 0 {
                return Err(InputError::InvalidParameter {
                    name,
                    value: 0.0,
                    expected: "an integer >= 1",
                }
                .into());
            }
        }
        let knots = self.knots();
        if knots < 2 {
            return Err(InputError::InvalidParameter {
                name: "duration",
                value: self.duration,
                expected: "at least two control periods (duration >= 2 dt)",
            }
            .into());
        }
        crate::error::check_size("duration / dt", knots, MAX_KNOTS)?;
        self.weights.validate()
    }

    /// Number of control steps: `round(duration / dt)`.
    pub fn knots(&self) -> usize {
        (self.duration / self.dt).round() as usize
    }
}

/// A planning problem, ready to solve or to re-solve from other guesses.
pub struct Planner<G: ScalarGeometry> {
    chain: Chain<G>,
    options: PlanOptions,
    solver: Ilqr<G>,
    target: Vec<f64>,
}

impl<G: ScalarGeometry> Planner<G> {
    /// The problem of reaching equilibrium `target` (checked) with `chain` under `options`
    /// (checked).
    pub fn new(chain: &Chain<G>, target: &[f64], options: &PlanOptions) -> Result<Self> {
        options.validate()?;
        let cost = Cost::new(
            chain,
            target,
            options.weights,
            options.dt,
            options.track_limit,
        )?;
        let model = StepModel::new(chain, options.dt, options.substeps);
        let solver = Ilqr::new(model, cost, options.knots(), options.max_force);
        Ok(Self {
            chain: chain.clone(),
            options: options.clone(),
            solver,
            target: target.to_vec(),
        })
    }

    /// The solver (its nominal trajectory is the plan after [`Planner::plan`]).
    pub fn solver(&self) -> &Ilqr<G> {
        &self.solver
    }

    /// The chain.
    pub fn chain(&self) -> &Chain<G> {
        &self.chain
    }
    /// The options.
    pub fn options(&self) -> &PlanOptions {
        &self.options
    }

    /// What a receding-horizon controller needs from the last plan: its states, forces,
    /// feedback gains and value function (recomputed at the plan itself), and the
    /// target's LQR gain.
    pub fn reference(&mut self) -> Result<Reference> {
        self.solver.refresh_policy(&IlqrOptions::default());
        let h = self.solver.horizon();
        let (_, target_gain) = target_lqr(&self.chain, &self.target, &self.options.weights)?;
        Ok(Reference {
            points: self.solver.nominal.points[..=h].to_vec(),
            forces: self.solver.nominal.forces.clone(),
            gains: self.solver.gains()[..h].to_vec(),
            value_gradient: (0..=h).map(|k| self.solver.value(k).0.clone()).collect(),
            value_hessian: (0..=h).map(|k| self.solver.value(k).1.clone()).collect(),
            target: self.solver.cost().target().clone(),
            target_gain,
        })
    }

    /// A receding-horizon controller following the last plan.
    pub fn mpc(&mut self, options: MpcOptions) -> Result<Mpc<G>> {
        let reference = self.reference()?;
        self.mpc_from(reference, options)
    }

    /// A receding-horizon controller following `reference` (from [`Planner::reference`]).
    pub fn mpc_from(&self, reference: Reference, options: MpcOptions) -> Result<Mpc<G>> {
        Mpc::new(
            self.solver.model().clone(),
            self.solver.cost().clone(),
            reference,
            self.options.max_force,
            options,
        )
    }

    /// The time-varying LQR along `plan` (planned by this planner).
    pub fn tracker(&self, plan: &Plan) -> Result<Tracker<G>> {
        Tracker::new(
            &self.chain,
            plan,
            self.solver.model(),
            &self.options.weights,
            self.options.max_force,
        )
    }

    /// Checks a start state: length, finite, unit links.
    pub fn check_start(&self, start: &[f64]) -> Result<()> {
        check_len("start", start, self.chain.state_dim())?;
        check_finite("start", start)?;
        if self.chain.unit_length_residual(start) > 1e-6 {
            return Err(InputError::InvalidParameter {
                name: "start",
                value: self.chain.unit_length_residual(start),
                expected: "a state whose link directions are unit vectors (| |q_i| - 1 | <= 1e-6)",
            }
            .into());
        }
        Ok(())
    }

    /// The pumping guesses (see the module docs), `force_dim` per step, flat.
    pub fn guesses(&self) -> Result<Vec<Vec<f64>>> {
        let n = self.chain.n_links();
        let hanging = Linearization::new(self.chain.params(), &vec![1.0; n])?;
        let modes = hanging.modes()?;
        let mut omegas: Vec<f64> = modes
            .values
            .iter()
            .filter(|&&mu| mu > 1e-9)
            .map(|mu| mu.sqrt())
            .collect();
        omegas.dedup_by(|a, b| (*a - *b).abs() < 1e-6 * b.abs());
        let k = self.options.knots();
        let nu = G::CART;
        let dt = self.options.dt;
        let t_end = k as f64 * dt;
        let mut out = Vec::with_capacity(self.options.guesses);
        for index in 0..self.options.guesses {
            let mut forces = vec![0.0; k * nu];
            if index < 2 {
                // A kick one way or the other: enough where the target lies downhill.
                let sign = if index == 0 { 1.0 } else { -1.0 };
                let kick = ((0.1 / dt).round() as usize).clamp(1, k);
                for step in 0..kick {
                    forces[step * nu] = sign * 0.3 * self.options.max_force;
                }
                out.push(forces);
                continue;
            }
            let pump = index - 2;
            let omega =
                omegas[pump % omegas.len()] * [1.0, 0.8, 1.25][(pump / omegas.len() / 2) % 3];
            let phase = if (pump / omegas.len()).is_multiple_of(2) {
                0.0
            } else {
                std::f64::consts::PI
            };
            let amplitude = [0.5, 0.8, 0.3][(pump / (2 * omegas.len() * 3)) % 3];
            for step in 0..k {
                let t = step as f64 * dt;
                forces[step * nu] = amplitude
                    * self.options.max_force
                    * (omega * t + phase).sin()
                    * taper(t / t_end);
            }
            out.push(forces);
        }
        Ok(out)
    }

    /// Plans from `start` (checked): each guess polished for a few iterations, then the
    /// most promising finished, and the next ones while the result misses the target
    /// and the budget lasts; the best result is kept.
    pub fn plan(&mut self, start: &[f64]) -> Result<Plan> {
        self.check_start(start)?;
        let began = Instant::now();
        let deadline = super::ilqr::deadline_after(began, self.options.max_time);
        let out_of_time = || deadline.is_some_and(|d| Instant::now() >= d);
        let mut iterations = 0;
        let mut probes: Vec<(Trajectory, usize)> = Vec::new();
        let guesses = self.guesses()?;
        let mut status = SolveStatus::IterationLimit;
        for (index, guess) in guesses.iter().enumerate() {
            if out_of_time() || iterations >= self.options.max_iterations {
                break;
            }
            let budget = self
                .options
                .probe_iterations
                .min(self.options.max_iterations - iterations);
            status = self.polish(start, guess, budget, deadline, &mut iterations);
            probes.push((self.solver.nominal.clone(), index));
            // A guess that already ends well inside the tolerances is finished at once.
            if self.ends_near_target(&self.solver.nominal, 0.5) {
                let last = probes.len() - 1;
                probes.swap(0, last);
                probes.truncate(1);
                break;
            }
        }
        let tried = guesses.len().min(probes.len().max(1));
        probes.sort_by(|a, b| a.0.cost.total_cmp(&b.0.cost));
        let mut best: Option<(Trajectory, usize, SolveStatus)> = None;
        for (probe, index) in probes {
            if iterations >= self.options.max_iterations || out_of_time() {
                if best.is_none() {
                    best = Some((probe, index, status));
                }
                break;
            }
            let budget = self.options.max_iterations - iterations;
            status = self.polish(start, &probe.forces, budget, deadline, &mut iterations);
            let t = &self.solver.nominal;
            let reached = self.ends_near_target(t, 1.0);
            if best.as_ref().is_none_or(|(b, _, _)| t.cost < b.cost) || reached {
                best = Some((t.clone(), index, status));
            }
            if reached {
                break;
            }
        }
        let (trajectory, best_guess, status) = best.expect("at least one guess is tried");
        self.solver.clear_policy();
        self.solver.rollout(start, &trajectory.forces);
        Ok(self.result(
            iterations,
            began.elapsed().as_secs_f64(),
            tried,
            best_guess,
            status,
        ))
    }

    /// Rolls `forces` out from `start` and runs at most `budget` iterations on it.
    fn polish(
        &mut self,
        start: &[f64],
        forces: &[f64],
        budget: usize,
        deadline: Option<Instant>,
        iterations: &mut usize,
    ) -> SolveStatus {
        self.solver.clear_policy();
        self.solver.rollout(start, forces);
        let options = IlqrOptions {
            max_iterations: budget,
            deadline,
            ..IlqrOptions::default()
        };
        let status = self.solver.solve(start, &options);
        *iterations += self.solver.iterations;
        status
    }

    /// Whether trajectory `t` ends within `fraction` of the tolerances, on the track.
    fn ends_near_target(&self, t: &Trajectory, fraction: f64) -> bool {
        let end = &t.points[t.points.len() - 1].y;
        let (e_q, e_w) = self.chain.errors(end, &self.target);
        let lay = self.chain.layout();
        let on_track = t.points.iter().all(|p| {
            p.y[lay.x()..lay.xdot()]
                .iter()
                .all(|x| x.abs() <= self.options.track_limit)
        });
        t.cost.is_finite()
            && on_track
            && e_q <= fraction * self.options.tolerance_q
            && e_w <= fraction * self.options.tolerance_w
    }

    fn result(
        &self,
        iterations: usize,
        seconds: f64,
        guesses_tried: usize,
        best_guess: usize,
        status: SolveStatus,
    ) -> Plan {
        let t = &self.solver.nominal;
        let k = t.points.len() - 1;
        let dim = self.chain.state_dim();
        let lay = self.chain.layout();
        let mut states = Vec::with_capacity((k + 1) * dim);
        for p in &t.points {
            states.extend_from_slice(&p.y);
        }
        let times: Vec<f64> = (0..=k).map(|i| i as f64 * self.options.dt).collect();
        let (e_q, e_w) = self.chain.errors(&t.points[k].y, &self.target);
        let peak_force = t.forces.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let rms_force = (t.forces.iter().map(|v| v * v).sum::<f64>() / k as f64).sqrt();
        let max_cart = t
            .points
            .iter()
            .flat_map(|p| p.y[lay.x()..lay.xdot()].to_vec())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let max_spin = t
            .points
            .iter()
            .map(|p| self.chain.max_spin(&p.y))
            .fold(0.0, f64::max);
        let within = |p: &[f64]| {
            let (q, w) = self.chain.errors(p, &self.target);
            q <= self.options.tolerance_q && w <= self.options.tolerance_w
        };
        let reaches_target = within(&t.points[k].y);
        let time_to_reach = reaches_target.then(|| {
            let first_outside = t.points.iter().rposition(|p| !within(&p.y));
            first_outside.map_or(0.0, |i| times[i + 1])
        });
        let within_track = max_cart <= self.options.track_limit;
        let mut reasons = Vec::new();
        if !t.cost.is_finite() {
            reasons.push("every rollout failed numerically".to_string());
        }
        if !reaches_target {
            reasons.push(format!(
                "the plan ends at e_q = {e_q:.3}, e_w = {e_w:.3}, outside the tolerances \
                 ({}, {}) after {iterations} iterations ({}); expected a longer duration \
                 (duration = {} s) or a larger max_force (max_force = {} N)",
                self.options.tolerance_q,
                self.options.tolerance_w,
                status.describe(),
                self.options.duration,
                self.options.max_force
            ));
        }
        if !within_track {
            reasons.push(format!(
                "the cart reaches |x| = {max_cart:.3} m, beyond track_limit = {} m",
                self.options.track_limit
            ));
        }
        Plan {
            n_links: self.chain.n_links(),
            times,
            states,
            forces: t.forces.clone(),
            target: self.target.clone(),
            converged: reasons.is_empty(),
            report: PlanReport {
                cost: t.cost,
                iterations,
                seconds,
                guesses_tried,
                best_guess,
                status,
                e_q,
                e_w,
                peak_force,
                rms_force,
                max_cart,
                max_spin,
                reaches_target,
                within_track,
                time_to_reach,
                reason: reasons.join("; "),
            },
        }
    }
}

/// 1 over the first 55 % of the horizon, then a half-cosine down to 0 at 75 %.
fn taper(s: f64) -> f64 {
    if s < 0.55 {
        1.0
    } else if s < 0.75 {
        0.5 * (1.0 + (std::f64::consts::PI * (s - 0.55) / 0.2).cos())
    } else {
        0.0
    }
}
