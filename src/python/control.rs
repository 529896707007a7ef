//! The planner and the large-motion controllers from Python: `ChainCart.plan` returns a
//! `Plan`, whose `tracker()` and `mpc()` give the controllers (the energy controller
//! of one link is in `energy`).

use super::convert::{contiguous, error, signs, Floats};
use crate::any_chain::AnyChain;
use crate::control::CostWeights;
use crate::control::MpcOptions;
use crate::control::PlanOptions;
use crate::control::{AnyMpc, AnyPlan, AnyTracker};
use crate::error::InputError;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

/// A start given as an equilibrium name, a sign tuple or a full state.
fn start_state(chain: &AnyChain, start: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let n = chain.n_links();
    if !start.is_instance_of::<PyString>() {
        if let Ok(values) = start.extract::<Vec<f64>>() {
            if values.len() == chain.state_dim() {
                return Ok(values);
            }
            if values.len() != n {
                return Err(error(format!(
                    "start has length {}: expected an equilibrium name, {n} signs +1/-1 or a \
                     full state of length {}",
                    values.len(),
                    chain.state_dim()
                )));
            }
        }
    }
    let s = signs(start, n)?;
    crate::analysis::check_signs(&s, n)?;
    Ok(chain.equilibrium(&s)?)
}

fn weights_from(dict: Option<&Bound<'_, PyDict>>) -> PyResult<CostWeights> {
    let mut w = CostWeights::default();
    let Some(dict) = dict else { return Ok(w) };
    for (key, value) in dict.iter() {
        let key: String = key.extract()?;
        let value: f64 = value
            .extract()
            .map_err(|_| error(format!("weights[{key:?}] = {value}: expected a number")))?;
        let Some(slot) = w.by_name_mut(&key) else {
            return Err(InputError::UnknownName {
                kind: "cost weight",
                name: key,
                expected: &CostWeights::NAMES,
            }
            .into());
        };
        *slot = value;
    }
    Ok(w)
}

/// `check_plan_weights`: every cost weight of the planner (the defaults for those not
/// given), checked as a plan checks them; an error names the first bad one.
#[pyfunction]
#[pyo3(signature = (weights=None))]
pub fn check_plan_weights<'py>(
    py: Python<'py>,
    weights: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let w = weights_from(weights)?;
    w.validate()?;
    let out = PyDict::new(py);
    for (name, value) in w.named() {
        out.set_item(name, value)?;
    }
    Ok(out)
}

/// The arguments of `ChainCart.plan`.
pub struct PlanArguments<'py> {
    pub start: Bound<'py, PyAny>,
    pub target: Bound<'py, PyAny>,
    pub options: PlanOptions,
    pub weights: Option<Bound<'py, PyDict>>,
}

/// `ChainCart.plan`: plans with the GIL released.
pub fn plan(py: Python<'_>, chain: &AnyChain, args: PlanArguments<'_>) -> PyResult<Plan> {
    let start = start_state(chain, &args.start)?;
    let target = signs(&args.target, chain.n_links())?;
    crate::analysis::check_signs(&target, chain.n_links())?;
    let mut options = args.options;
    options.weights = weights_from(args.weights.as_ref())?;
    let planned = py.detach(|| AnyPlan::new(chain, &start, &target, &options))?;
    Ok(Plan {
        inner: planned,
        planar: chain.is_planar(),
        state_dim: chain.state_dim(),
    })
}

/// A plan: `times` (K + 1), `states` (K + 1 rows), `forces` (K rows, each held over its
/// interval), `converged`, and a `report`.
#[pyclass(frozen, module = "chaincart_env._core", name = "Plan")]
pub struct Plan {
    inner: AnyPlan,
    planar: bool,
    state_dim: usize,
}

#[pymethods]
impl Plan {
    /// Instants, s, shape `(K + 1,)`.
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.plan().times)
    }
    /// States in the model's layout, shape `(K + 1, state_dim)`.
    #[getter]
    fn states<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let p = self.inner.plan();
        let rows = p.times.len();
        Ok(PyArray1::from_slice(py, &p.states)
            .reshape([rows, self.state_dim])?
            .into_any())
    }
    /// Forces, N, shape `(K, force_dim)`.
    #[getter]
    fn forces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let p = self.inner.plan();
        let rows = p.times.len() - 1;
        let f = if self.planar { 1 } else { 2 };
        Ok(PyArray1::from_slice(py, &p.forces)
            .reshape([rows, f])?
            .into_any())
    }
    /// Whether the plan reaches the target within the tolerances and the track.
    #[getter]
    fn converged(&self) -> bool {
        self.inner.plan().converged
    }
    /// The target's sign tuple.
    #[getter]
    fn target(&self) -> Vec<i64> {
        self.inner.plan().target.iter().map(|&s| s as i64).collect()
    }
    /// Control period, s.
    #[getter]
    fn dt(&self) -> f64 {
        self.inner.options().dt
    }
    /// RK4 steps per control period.
    #[getter]
    fn substeps(&self) -> usize {
        self.inner.options().substeps
    }
    /// Force limit, N.
    #[getter]
    fn max_force(&self) -> f64 {
        self.inner.options().max_force
    }
    /// Track limit, m.
    #[getter]
    fn track_limit(&self) -> f64 {
        self.inner.options().track_limit
    }
    /// Cost, iterations, time and feasibility, as a dict.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = &self.inner.plan().report;
        let d = PyDict::new(py);
        d.set_item("cost", r.cost)?;
        d.set_item("iterations", r.iterations)?;
        d.set_item("seconds", r.seconds)?;
        d.set_item("guesses_tried", r.guesses_tried)?;
        d.set_item("best_guess", r.best_guess)?;
        d.set_item("status", r.status.describe())?;
        d.set_item("e_q", r.e_q)?;
        d.set_item("e_w", r.e_w)?;
        d.set_item("peak_force", r.peak_force)?;
        d.set_item("rms_force", r.rms_force)?;
        d.set_item("max_cart", r.max_cart)?;
        d.set_item("max_spin", r.max_spin)?;
        d.set_item("reaches_target", r.reaches_target)?;
        d.set_item("within_track", r.within_track)?;
        d.set_item("time_to_reach", r.time_to_reach)?;
        d.set_item("reason", &r.reason)?;
        Ok(d)
    }

    /// TVLQR along the plan, then the LQR at its target.
    fn tracker(&self) -> PyResult<TrajectoryTracker> {
        Ok(TrajectoryTracker {
            inner: self.inner.tracker()?,
        })
    }

    /// Receding-horizon iLQR along the plan: `horizon` steps ahead (`hold_horizon` after
    /// the plan's end), at most `iterations` iLQR iterations and `budget` seconds per
    /// control step (`inf`: no wall-time limit, the iterations alone bound the work).
    #[pyo3(signature = (horizon=40, hold_horizon=25, iterations=2, budget=0.002))]
    fn mpc(
        &self,
        horizon: usize,
        hold_horizon: usize,
        iterations: usize,
        budget: f64,
    ) -> PyResult<MpcController> {
        let options = MpcOptions {
            horizon,
            hold_horizon,
            iterations,
            budget,
        };
        Ok(MpcController {
            inner: self.inner.mpc(options)?,
        })
    }

    fn __repr__(&self) -> String {
        let p = self.inner.plan();
        format!(
            "Plan(target={:?}, steps={}, converged={}, cost={:.4})",
            self.target(),
            p.times.len() - 1,
            if p.converged { "True" } else { "False" },
            p.report.cost
        )
    }
}

/// TVLQR along a plan, then the target's LQR (`Plan.tracker()`).
#[pyclass(module = "chaincart_env._core", name = "TrajectoryTracker")]
pub struct TrajectoryTracker {
    inner: AnyTracker,
}

#[pymethods]
impl TrajectoryTracker {
    /// The force (N, saturated) at control step `k` of the plan's clock in `state`.
    fn force<'py>(
        &mut self,
        py: Python<'py>,
        k: usize,
        state: Floats<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = contiguous(&state);
        Ok(PyArray1::from_vec(py, self.inner.force(k, &y)?))
    }
    /// Number of planned steps.
    #[getter]
    fn steps(&self) -> usize {
        self.inner.steps()
    }
}

/// Receding-horizon iLQR along a plan (`Plan.mpc()`).
#[pyclass(module = "chaincart_env._core", name = "MpcController")]
pub struct MpcController {
    inner: AnyMpc,
}

#[pymethods]
impl MpcController {
    /// The force (N, saturated) at control step `k` of the plan's clock in `state`; the
    /// GIL is released while it computes.
    fn force<'py>(
        &mut self,
        py: Python<'py>,
        k: usize,
        state: Floats<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = contiguous(&state).into_owned();
        let inner = &mut self.inner;
        let u = py.detach(|| inner.force(k, &y))?;
        Ok(PyArray1::from_vec(py, u))
    }
    /// Forgets the warm start (call at a new episode).
    fn reset(&mut self) {
        self.inner.reset()
    }
    /// Work of the last `force` call: `{"iterations", "seconds", "horizon"}`.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.inner.stats();
        let d = PyDict::new(py);
        d.set_item("iterations", s.iterations)?;
        d.set_item("seconds", s.seconds)?;
        d.set_item("horizon", s.horizon)?;
        Ok(d)
    }
}
