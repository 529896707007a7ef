//! Integrators users pick between, trading speed for accuracy.
//!
//! | name          | order | keeps                                   | cost per step            |
//! |---------------|-------|-----------------------------------------|--------------------------|
//! | `rk4`         | 4     | constraints by projection after a step  | 4 evaluations            |
//! | `rkmk4`       | 4     | `|q_i| = 1` by construction (Lie group) | 4 evaluations + 4 exp    |
//! | `variational` | 2     | momentum exactly, energy bounded        | Newton solve (O(n) each) |
//! | `lie_euler`   | 1     | `|q_i| = 1`, tangency                   | 1 evaluation + 1 exp     |
//! | `adaptive`    | 5(4)  | error per step below a tolerance        | 7 evaluations per step   |
//!
//! All are O(n) per step and allocate nothing: buffers live in a [`Stepper`]. A
//! [`GuardedStepper`] judges each control step by the [`Guard`] and undoes a failed one.

mod adaptive;
mod guard;
mod lie_euler;
mod rk4;
mod rkmk4;
mod variational;

pub(crate) use guard::{swept_per_step, swept_surely_within};
pub use guard::{Guard, GuardedStepper, StepStatus, MAX_TURN_PER_STEP};

use crate::error::{check_positive, ChainError, InputError, Result};
use crate::geometry::Geometry;
use crate::model::{Chain, Workspace};

/// Which integrator; see the module table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// Classical Runge-Kutta of order 4, then projection onto the constraints.
    Rk4,
    /// Runge-Kutta-Munthe-Kaas of order 4 on the spheres.
    Rkmk4,
    /// The Lie group variational integrator (order 2, symplectic).
    Variational,
    /// Symplectic Lie-Euler (order 1).
    LieEuler,
    /// Dormand-Prince 5(4) with step-size control.
    Adaptive,
}

impl Method {
    /// Every method, in the order of the module table.
    pub const ALL: [Method; 5] = [
        Method::Rk4,
        Method::Rkmk4,
        Method::Variational,
        Method::LieEuler,
        Method::Adaptive,
    ];
    /// The accepted names, for error messages.
    pub const NAMES: [&'static str; 5] = ["rk4", "rkmk4", "variational", "lie_euler", "adaptive"];

    /// The method's name (`"rk4"`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Method::Rk4 => "rk4",
            Method::Rkmk4 => "rkmk4",
            Method::Variational => "variational",
            Method::LieEuler => "lie_euler",
            Method::Adaptive => "adaptive",
        }
    }

    /// The method with this name, or an error listing the names.
    pub fn from_name(name: &str) -> Result<Self> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                InputError::UnknownName {
                    kind: "integrator",
                    name: name.to_string(),
                    expected: &Method::NAMES,
                }
                .into()
            })
    }

    /// Order of accuracy of the fixed-step methods (the adaptive one: of its solution).
    pub fn order(self) -> u32 {
        match self {
            Method::Rk4 | Method::Rkmk4 => 4,
            Method::Variational => 2,
            Method::LieEuler => 1,
            Method::Adaptive => 5,
        }
    }
}

impl std::str::FromStr for Method {
    type Err = ChainError;
    fn from_str(s: &str) -> Result<Self> {
        Method::from_name(s)
    }
}

/// How to advance one control period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOptions {
    /// The integrator.
    pub method: Method,
    /// Integrator steps per control period (the adaptive method's first trial step is dt/substeps).
    pub substeps: usize,
    /// Adaptive method: relative and absolute error tolerance per step.
    pub tolerance: f64,
    /// Variational method: Newton stops when every `||q_i|^2 - 1| / 2` is below this.
    pub newton_tolerance: f64,
    /// Variational method: Newton iterations before the step is reported as failed.
    pub max_newton_iterations: usize,
}

impl StepOptions {
    /// Options for `method` with `substeps` steps per control period (others default).
    pub fn new(method: Method, substeps: usize) -> Result<Self> {
        let opts = Self {
            method,
            substeps,
            ..Self::default()
        };
        opts.validate()?;
        Ok(opts)
    }

    /// Checks `substeps >= 1` and positive tolerances.
    pub fn validate(&self) -> Result<()> {
        if self.substeps == 0 {
            return Err(InputError::InvalidParameter {
                name: "substeps",
                value: 0.0,
                expected: "an integer >= 1",
            }
            .into());
        }
        check_positive("tolerance", self.tolerance)?;
        check_positive("newton_tolerance", self.newton_tolerance)
    }
}

impl Default for StepOptions {
    fn default() -> Self {
        Self {
            method: Method::Rk4,
            substeps: 1,
            tolerance: 1e-9,
            newton_tolerance: 1e-14,
            max_newton_iterations: 50,
        }
    }
}

/// Everything an integrator needs besides the state; one per thread, reused every step.
/// Each method's buffers are named in its own workspace.
#[derive(Debug, Clone)]
pub struct Stepper<G: Geometry> {
    /// The dynamics' own buffers (tension solve).
    pub(crate) ws: Workspace<G>,
    /// Stage derivatives and intermediate states of the Runge-Kutta methods
    /// (`rk4`, `rkmk4`, `lie_euler`, `adaptive`).
    pub(crate) rk: RungeKuttaWorkspace,
    /// Lie-algebra increments of `rkmk4`.
    pub(crate) rkmk: rkmk4::RkmkWorkspace<G>,
    /// Newton and projection buffers of `variational`.
    pub(crate) variational: variational::VariationalWorkspace<G>,
    /// Statistics of the last call.
    pub stats: StepStats,
}

/// Full-state buffers of the explicit Runge-Kutta methods.
#[derive(Debug, Clone)]
pub(crate) struct RungeKuttaWorkspace {
    /// Stage derivatives `k_1..k_7` (RK4 uses four, Dormand-Prince seven).
    pub(crate) stages: [Vec<f64>; 7],
    /// The state at the start of the step (RKMK), or the FSAL stage state (adaptive).
    pub(crate) base: Vec<f64>,
    /// The stage state being evaluated, or the adaptive method's candidate result.
    pub(crate) trial: Vec<f64>,
}

/// What the last [`Stepper::step`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepStats {
    /// Derivative evaluations.
    pub evaluations: usize,
    /// Integrator steps taken.
    pub accepted_steps: usize,
    /// Steps rejected by the adaptive method's error control.
    pub rejected_steps: usize,
    /// Newton iterations of the variational method.
    pub newton_iterations: usize,
}

impl<G: Geometry> Stepper<G> {
    /// Buffers sized for `chain`.
    pub fn new(chain: &Chain<G>) -> Self {
        let (n, dim) = (chain.n_links(), chain.state_dim());
        let v = || vec![0.0; dim];
        Self {
            ws: chain.workspace(),
            rk: RungeKuttaWorkspace {
                stages: std::array::from_fn(|_| v()),
                base: v(),
                trial: v(),
            },
            rkmk: rkmk4::RkmkWorkspace::new(n),
            variational: variational::VariationalWorkspace::new(n),
            stats: StepStats::default(),
        }
    }

    /// Advances `y` by one control period `dt` under the constant force `force`.
    /// On error `y` holds the state reached so far (callers that must not lose the
    /// old state keep a copy).
    pub fn step(
        &mut self,
        chain: &Chain<G>,
        y: &mut [f64],
        force: G::Cart,
        dt: f64,
        opts: &StepOptions,
    ) -> Result<()> {
        debug_assert_eq!(y.len(), chain.state_dim());
        self.stats = StepStats::default();
        if opts.method == Method::Variational && !chain.is_ideal() {
            return Err(variational_needs_ideal_chain());
        }
        if opts.method == Method::Adaptive {
            return adaptive::integrate(chain, self, y, force, dt, opts);
        }
        let h = dt / opts.substeps as f64;
        for _ in 0..opts.substeps {
            match opts.method {
                Method::Rk4 => rk4::step(chain, self, y, force, h),
                Method::Rkmk4 => rkmk4::step(chain, self, y, force, h),
                Method::LieEuler => lie_euler::step(chain, self, y, force, h),
                Method::Variational => variational::step(chain, self, y, force, h, opts)?,
                Method::Adaptive => unreachable!(),
            }
        }
        Ok(())
    }
}

/// The error of the variational method on a chain with real-rig effects: its
/// discrete Lagrangian has no place for damping, friction or a prescribed cart motion.
pub fn variational_needs_ideal_chain() -> ChainError {
    InputError::Incompatible {
        name: "integrator",
        value: "variational",
        expected: "rk4, rkmk4, lie_euler or adaptive with joint damping, cart friction or an \
                   actuation other than force (the variational integrator models the ideal, \
                   force-driven chain only)"
            .to_string(),
    }
    .into()
}

/// `out = a + c * b`, elementwise.
#[inline(always)]
pub(crate) fn axpy(out: &mut [f64], a: &[f64], c: f64, b: &[f64]) {
    for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
        *o = a + c * b;
    }
}
