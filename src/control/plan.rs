//! A plan and its report: what the planner ([`super::planner`]) returns and the
//! tracking controller ([`super::tvlqr`]) follows.

use super::ilqr::SolveStatus;

/// How a plan turned out.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanReport {
    /// Final cost.
    pub cost: f64,
    /// iLQR iterations over all guesses.
    pub iterations: usize,
    /// Wall time, s.
    pub seconds: f64,
    /// Guesses tried, and the index of the one kept.
    pub guesses_tried: usize,
    /// See `guesses_tried`.
    pub best_guess: usize,
    /// How the last solve stopped.
    pub status: SolveStatus,
    /// The paper's `e_q = sum |q_i - s_i e3|` at the end of the plan.
    pub e_q: f64,
    /// The paper's `e_w = sum |w_i|` at the end of the plan.
    pub e_w: f64,
    /// Largest `|u|` component, N.
    pub peak_force: f64,
    /// Root mean square of the force, N.
    pub rms_force: f64,
    /// Largest `|x_c|`, m.
    pub max_cart: f64,
    /// Largest angular speed, rad/s.
    pub max_spin: f64,
    /// The end of the plan is within the tolerances.
    pub reaches_target: bool,
    /// The cart stays within the track.
    pub within_track: bool,
    /// The first time after which the plan stays within the tolerances, s.
    pub time_to_reach: Option<f64>,
    /// Why the plan is not converged, or "" if it is.
    pub reason: String,
}

/// A plan: states at `times`, forces held over each interval.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Number of links, and whether the chain is planar.
    pub n_links: usize,
    /// `K + 1` instants, s.
    pub times: Vec<f64>,
    /// `K + 1` states in the model's layout, flat (row-major).
    pub states: Vec<f64>,
    /// `K` forces (`force_dim` each), flat.
    pub forces: Vec<f64>,
    /// The target's sign tuple.
    pub target: Vec<f64>,
    /// The plan reaches the target within the tolerances and the track.
    pub converged: bool,
    /// Cost and feasibility.
    pub report: PlanReport,
}
