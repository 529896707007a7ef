//! `ChainCart`: the physics model from Python (float64 NumPy in and out).

use super::convert::{contiguous, error, per_link, signs, type_error, vector, Floats};
use crate::analysis::{Linearization, LqrController, LqrWeights};
use crate::any_chain::AnyChain;
use crate::env::PaperFigure;
use crate::error::InputError;
use crate::integrate::{Method, StepOptions};
use crate::params::{
    ChainParams, PAPER_CART_MASS, PAPER_LINK_LENGTH, PAPER_LINK_MASS, STANDARD_GRAVITY,
};
use nalgebra::DMatrix;
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

#[pyclass(frozen, subclass, module = "chaincart_env._core", name = "ChainCart")]
pub struct ChainCart {
    pub(crate) chain: AnyChain,
}

fn options(integrator: &str, substeps: usize) -> PyResult<StepOptions> {
    Ok(StepOptions::new(Method::from_name(integrator)?, substeps)?)
}

fn array<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_vec(py, v)
}

/// A matrix as a 2-D float64 array (row-major copy).
pub(crate) fn matrix_to_numpy<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyAny> {
    let rows: Vec<f64> = (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect();
    PyArray1::from_vec(py, rows)
        .reshape([m.nrows(), m.ncols()])
        .expect("size matches")
        .into_any()
}

/// The LQR weights `Q`, `R` given from Python, each left out the paper's default for `s`.
#[allow(non_snake_case)]
pub(crate) fn lqr_weights<'py>(
    s: &[f64],
    Q: Option<&Bound<'py, PyAny>>,
    R: Option<&Bound<'py, PyAny>>,
) -> PyResult<LqrWeights> {
    let matrix = |name: &str, obj: &Bound<'py, PyAny>| -> PyResult<DMatrix<f64>> {
        let a: Floats<'py> = obj
            .extract()
            .map_err(|_| type_error(format!("{name} = {obj}: expected a 2-D matrix of numbers")))?;
        match a.shape() {
            [r, c] => Ok(DMatrix::from_row_slice(*r, *c, &contiguous(&a))),
            shape => Err(error(format!(
                "{name} has shape {}, expected a 2-D matrix",
                super::convert::shape_text(shape)
            ))),
        }
    };
    let mut weights = LqrWeights::paper_default(s);
    if let Some(q) = Q {
        weights.q = matrix("Q", q)?;
    }
    if let Some(r) = R {
        weights.r = matrix("R", r)?;
    }
    Ok(weights)
}

/// A first-order form `(A, B)` as a tuple of NumPy matrices.
pub(crate) fn state_space_tuple<'py>(
    py: Python<'py>,
    lin: &Linearization,
) -> PyResult<Bound<'py, PyTuple>> {
    let ss = lin.state_space()?;
    PyTuple::new(py, [matrix_to_numpy(py, &ss.a), matrix_to_numpy(py, &ss.b)])
}

impl ChainCart {
    /// A validated sign tuple (or equilibrium name) for this chain.
    fn signs(&self, s: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        let n = self.chain.n_links();
        let s = signs(s, n)?;
        crate::analysis::check_signs(&s, n)?;
        Ok(s)
    }

    pub fn from_params(
        n_links: i64,
        cart_mass: f64,
        link_masses: &Bound<'_, PyAny>,
        link_lengths: &Bound<'_, PyAny>,
        gravity: f64,
        planar: bool,
    ) -> PyResult<Self> {
        if n_links < 0 {
            return Err(InputError::InvalidParameter {
                name: "n_links",
                value: n_links as f64,
                expected: "an integer >= 1",
            }
            .into());
        }
        let n = n_links as usize;
        crate::limits::check_links(n)?; // before the per-link vectors are allocated
        let masses = per_link("link_masses", link_masses, n)?;
        let lengths = per_link("link_lengths", link_lengths, n)?;
        let params = ChainParams::new(cart_mass, &masses, &lengths, gravity)?;
        Ok(Self {
            chain: AnyChain::new(params, planar),
        })
    }
}

#[pymethods]
impl ChainCart {
    #[new]
    // Unset parameters are the paper's example system (as its figures' scenes).
    #[pyo3(signature = (
        n_links, cart_mass=None, link_masses=None, link_lengths=None, gravity=None, planar=false
    ))]
    fn new(
        py: Python<'_>,
        n_links: i64,
        cart_mass: Option<f64>,
        link_masses: Option<&Bound<'_, PyAny>>,
        link_lengths: Option<&Bound<'_, PyAny>>,
        gravity: Option<f64>,
        planar: bool,
    ) -> PyResult<Self> {
        let mass = PAPER_LINK_MASS.into_pyobject(py)?.into_any();
        let length = PAPER_LINK_LENGTH.into_pyobject(py)?.into_any();
        Self::from_params(
            n_links,
            cart_mass.unwrap_or(PAPER_CART_MASS),
            link_masses.unwrap_or(&mass),
            link_lengths.unwrap_or(&length),
            gravity.unwrap_or(STANDARD_GRAVITY),
            planar,
        )
    }

    #[getter]
    fn n_links(&self) -> usize {
        self.chain.n_links()
    }
    #[getter]
    fn planar(&self) -> bool {
        self.chain.is_planar()
    }
    #[getter]
    fn state_dim(&self) -> usize {
        self.chain.state_dim()
    }
    #[getter]
    fn force_dim(&self) -> usize {
        self.chain.force_dim()
    }
    #[getter]
    fn cart_mass(&self) -> f64 {
        self.chain.params().cart_mass()
    }
    #[getter]
    fn link_masses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(py, self.chain.params().masses())
    }
    #[getter]
    fn link_lengths<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(py, self.chain.params().lengths())
    }
    #[getter]
    fn gravity(&self) -> f64 {
        self.chain.params().gravity()
    }
    /// `name -> (start, stop)` of each block of a state (`x`, `xdot`, `q`, `w`).
    #[getter]
    fn state_layout<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, start, stop) in self.chain.state_blocks() {
            d.set_item(name, (start, stop))?;
        }
        Ok(d)
    }
    /// The constructor's arguments as a dict.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("n_links", self.n_links())?;
        d.set_item("cart_mass", self.cart_mass())?;
        d.set_item("link_masses", self.link_masses(py)?)?;
        d.set_item("link_lengths", self.link_lengths(py)?)?;
        d.set_item("gravity", self.gravity())?;
        d.set_item("planar", self.planar())?;
        Ok(d)
    }

    fn derivative<'py>(
        &self,
        py: Python<'py>,
        state: Floats<'py>,
        force: Floats<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = vector("state", &state, self.chain.state_dim())?;
        let u = vector("force", &force, self.chain.force_dim())?;
        Ok(array(py, self.chain.derivative(&y, &u)?))
    }

    #[pyo3(signature = (state, force, dt, integrator="rk4", substeps=1))]
    fn step<'py>(
        &self,
        py: Python<'py>,
        state: Floats<'py>,
        force: Floats<'py>,
        dt: f64,
        integrator: &str,
        substeps: usize,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let opts = options(integrator, substeps)?;
        let y = vector("state", &state, self.chain.state_dim())?;
        let u = vector("force", &force, self.chain.force_dim())?;
        Ok(array(py, self.chain.step(&y, &u, dt, &opts)?))
    }

    #[pyo3(signature = (state, forces, dt, integrator="rk4", substeps=1))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        state: Floats<'py>,
        forces: Floats<'py>,
        dt: f64,
        integrator: &str,
        substeps: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = options(integrator, substeps)?;
        let (d, f) = (self.chain.state_dim(), self.chain.force_dim());
        let y = vector("state", &state, d)?;
        let steps = match forces.shape() {
            [steps, ff] if *ff == f => *steps,
            shape => {
                return Err(error(format!(
                    "forces has shape {}, expected (steps, {f})",
                    super::convert::shape_text(shape)
                )))
            }
        };
        let u = contiguous(&forces);
        let chain = &self.chain;
        let (y, u) = (&*y, &*u);
        let traj = py.detach(|| chain.simulate(y, u, steps, dt, &opts))?;
        Ok(array(py, traj).reshape([steps + 1, d])?.into_any())
    }

    /// Total energy (kinetic + potential).
    fn energy(&self, state: Floats<'_>) -> PyResult<f64> {
        let y = vector("state", &state, self.chain.state_dim())?;
        Ok(self.chain.energy(&y)?.total())
    }
    fn kinetic_energy(&self, state: Floats<'_>) -> PyResult<f64> {
        let y = vector("state", &state, self.chain.state_dim())?;
        Ok(self.chain.energy(&y)?.kinetic)
    }
    fn potential_energy(&self, state: Floats<'_>) -> PyResult<f64> {
        let y = vector("state", &state, self.chain.state_dim())?;
        Ok(self.chain.energy(&y)?.potential)
    }
    fn horizontal_momentum<'py>(
        &self,
        py: Python<'py>,
        state: Floats<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = vector("state", &state, self.chain.state_dim())?;
        Ok(array(py, self.chain.horizontal_momentum(&y)?))
    }
    /// `(max | |q_i| - 1 |, max |w_i . q_i|)`.
    fn residuals(&self, state: Floats<'_>) -> PyResult<(f64, f64)> {
        let y = vector("state", &state, self.chain.state_dim())?;
        let r = self.chain.residuals(&y)?;
        Ok((r.unit_length, r.tangency))
    }
    /// The paper's `(e_q, e_w)` with respect to equilibrium `s`.
    fn errors(&self, state: Floats<'_>, s: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
        let y = vector("state", &state, self.chain.state_dim())?;
        let s = signs(s, self.chain.n_links())?;
        Ok(self.chain.errors(&y, &s)?)
    }
    fn equilibrium<'py>(
        &self,
        py: Python<'py>,
        s: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let s = signs(s, self.chain.n_links())?;
        Ok(array(py, self.chain.equilibrium(&s)?))
    }
    fn to_spatial<'py>(
        &self,
        py: Python<'py>,
        state: Floats<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = vector("state", &state, self.chain.state_dim())?;
        Ok(array(py, self.chain.to_spatial(&y)?))
    }
    #[pyo3(name = "from_spatial")]
    fn planar_part<'py>(
        &self,
        py: Python<'py>,
        state: Floats<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = vector("state", &state, 4 + 6 * self.chain.n_links())?;
        Ok(array(py, self.chain.from_spatial(&y)?))
    }

    /// LQR gain `K` (shape `(2, 4 + 4n)`, the paper's ordering
    /// `z = [x, C^T xi_1..n, xdot, C^T w_1..n]`) of the spatial linearisation at
    /// equilibrium `s`, for weights `Q` (`(4+4n)` square) and `R` (2x2); by default the
    /// paper's (`diag[8 I2, I_2n, 8 I2, I_2n]` for hanging, `diag[I2, 8 I_2n, I2, 8 I_2n]`
    /// otherwise, `R = I2`). The same gain serves the planar model through
    /// `to_spatial`.
    #[pyo3(signature = (s, Q=None, R=None))]
    #[allow(non_snake_case)]
    fn lqr_gain<'py>(
        &self,
        py: Python<'py>,
        s: &Bound<'py, PyAny>,
        Q: Option<&Bound<'py, PyAny>>,
        R: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let s = self.signs(s)?;
        let weights = lqr_weights(&s, Q, R)?;
        let params = self.chain.params().clone();
        let controller = py.detach(|| LqrController::new(&params, &s, &weights))?;
        Ok(matrix_to_numpy(py, controller.gain()))
    }

    /// Linearisation at equilibrium `s` (paper Prop. 2). By default the first-order
    /// `(A, B)` in `z = [x, C^T xi_1..n, xdot, C^T w_1..n]` (`A`: (4+4n) square, `B`:
    /// (4+4n) x 2); with `second_order=True` the paper's `(M, G, B)` in
    /// `[x, C^T xi_1..n]` ((2n+2) square, (2n+2) x 2).
    #[pyo3(signature = (s, second_order=false))]
    fn linearize<'py>(
        &self,
        py: Python<'py>,
        s: &Bound<'py, PyAny>,
        second_order: bool,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let lin = Linearization::new(self.chain.params(), &self.signs(s)?)?;
        if second_order {
            let parts = [
                lin.mass_matrix(),
                lin.stiffness_matrix(),
                lin.input_matrix(),
            ];
            PyTuple::new(py, parts.map(|m| matrix_to_numpy(py, m)))
        } else {
            state_space_tuple(py, &lin)
        }
    }

    /// Eigenvalues `lambda` of the linearisation at `s` (roots of
    /// `det(lambda^2 M + G) = 0`, each with its sign pair), as complex numbers.
    fn eigenvalues<'py>(
        &self,
        py: Python<'py>,
        s: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<numpy::Complex64>>> {
        let lin = Linearization::new(self.chain.params(), &self.signs(s)?)?;
        let values: Vec<numpy::Complex64> = lin
            .eigenvalues()?
            .into_iter()
            .map(|z| numpy::Complex64::new(z.re, z.im))
            .collect();
        Ok(PyArray1::from_vec(py, values))
    }

    /// Controllability of the linearisation at `s` (paper Prop. 3) by the PBH
    /// eigenvector test: `(controllable, margin)`, the margin being the smallest
    /// `sigma_min(V^T M_qx) / ||M_qx||` over the eigenspaces `V` of the chain
    /// (0: a mode the cart cannot move; controllable means margin > 1e-8).
    fn controllability(&self, s: &Bound<'_, PyAny>) -> PyResult<(bool, f64)> {
        let c = crate::analysis::controllability(self.chain.params(), &self.signs(s)?)?;
        Ok((c.controllable, c.margin))
    }

    /// A plan from `start` (an equilibrium name, a sign tuple or a full state) to the
    /// equilibrium `target` (a name or a sign tuple) within `max_force` (N per axis) and
    /// `track_limit` (m): control-limited iLQR over `duration` s (default `1 + n_links`)
    /// at the control period `dt` with `substeps` RK4 steps, from up to `guesses`
    /// initial guesses, at most `max_iterations` iterations and `max_time` s (`inf`: no
    /// wall-time limit, the iterations alone bound the work). `weights`
    /// overrides cost weights (`x`, `q`, `v`, `w`, `force`, `track`, `terminal`,
    /// `track_margin`). The GIL is released while it plans.
    #[pyo3(signature = (
        start, target, *, max_force, track_limit=2.4, duration=None, dt=0.02, substeps=2,
        max_iterations=1000, max_time=30.0, guesses=10, weights=None
    ))]
    #[allow(clippy::too_many_arguments)]
    fn plan(
        &self,
        py: Python<'_>,
        start: &Bound<'_, PyAny>,
        target: &Bound<'_, PyAny>,
        max_force: f64,
        track_limit: f64,
        duration: Option<f64>,
        dt: f64,
        substeps: usize,
        max_iterations: usize,
        max_time: f64,
        guesses: usize,
        weights: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<super::control::Plan> {
        let defaults = crate::control::PlanOptions::default();
        let options = crate::control::PlanOptions {
            max_force,
            track_limit,
            duration: duration.unwrap_or(1.0 + self.chain.n_links() as f64),
            dt,
            substeps,
            max_iterations,
            max_time,
            guesses,
            ..defaults
        };
        super::control::plan(
            py,
            &self.chain,
            super::control::PlanArguments {
                start: start.clone(),
                target: target.clone(),
                options,
                weights: weights.cloned(),
            },
        )
    }

    /// All 2^n equilibria as sign tuples, hanging (all +1) first, in binary order
    /// (bit i-1 of the index set means link i is upright). Refused for n > 20.
    fn equilibria(&self) -> PyResult<Vec<Vec<i64>>> {
        let all = crate::analysis::all_signs(self.chain.n_links())?;
        Ok(all
            .into_iter()
            .map(|s| s.into_iter().map(|v| v as i64).collect())
            .collect())
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let me = slf.get();
        let args = (
            me.n_links(),
            me.cart_mass(),
            me.link_masses(py)?,
            me.link_lengths(py)?,
            me.gravity(),
            me.planar(),
        );
        PyTuple::new(
            py,
            [
                slf.get_type().into_any(),
                args.into_pyobject(py)?.into_any(),
            ],
        )
    }

    fn __repr__(slf: &Bound<'_, Self>) -> PyResult<String> {
        let me = slf.get();
        let py = slf.py();
        Ok(format!(
            "{}(n_links={}, cart_mass={}, link_masses={}, link_lengths={}, gravity={}, planar={})",
            slf.get_type().qualname()?,
            me.n_links(),
            me.cart_mass(),
            me.link_masses(py)?.repr()?,
            me.link_lengths(py)?.repr()?,
            me.gravity(),
            if me.planar() { "True" } else { "False" }
        ))
    }
}

/// The sign tuple of a named equilibrium (`hanging`, `inverted`, `folded`,
/// `folded_up`, or a paper figure's `paper-fig1..3`) for `n_links` links.
#[pyfunction]
pub fn target_signs(name: &str, n_links: usize) -> PyResult<Vec<i64>> {
    Ok(crate::env::target_signs(name, n_links)?
        .into_iter()
        .map(|s| s as i64)
        .collect())
}

/// The paper's initial condition for `figure` (`"paper-fig1"`, `"paper-fig2"`,
/// `"paper-fig3"`) as a spatial state of the 5-link chain.
#[pyfunction]
pub fn paper_initial_condition<'py>(
    py: Python<'py>,
    figure: &str,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let fig = PaperFigure::from_name(figure).ok_or_else(|| InputError::UnknownName {
        kind: "paper figure",
        name: figure.to_string(),
        expected: &PaperFigure::NAMES,
    })?;
    Ok(array(py, crate::env::paper_initial_condition(fig)))
}
