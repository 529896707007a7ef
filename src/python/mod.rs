//! The Python extension `chaincart_env._core`: the only place that knows about
//! Python. Each function converts its arguments, calls the core and converts the
//! result; errors of the core become the exceptions of `chaincart_env.errors` (bad input:
//! `InvalidInputError`, a `ValueError`; failed integration: `IntegrationError`, a
//! `RuntimeError`; failed analysis: `AnalysisError`) with the core's message, and
//! nothing here panics on user input.

mod config;
mod control;
mod convert;
mod energy;
mod env;
mod model;
mod reality;
mod render;

use pyo3::prelude::*;
use pyo3::types::PyTuple;

// Defined in Python (multiple inheritance: InvalidInputError is a ChainCartError and a
// ValueError), imported on first use.
pyo3::import_exception!(chaincart_env.errors, ChainCartError);
pyo3::import_exception!(chaincart_env.errors, InvalidInputError);
pyo3::import_exception!(chaincart_env.errors, InvalidTypeError);
pyo3::import_exception!(chaincart_env.errors, IntegrationError);
pyo3::import_exception!(chaincart_env.errors, AnalysisError);

/// The core's number of worker threads (rayon's global pool; set `RAYON_NUM_THREADS`
/// before the first parallel step to change it).
#[pyfunction]
fn num_threads() -> usize {
    rayon::current_num_threads()
}

/// Seconds per call of `form` (`"fast"`, `"dense"`, `"fast_rk4_step"`) for a
/// uniform spatial chain of `n_links`, timed in Rust on one core (best of 3 runs of
/// at least `min_time` s each); the GIL is released while timing.
#[pyfunction]
#[pyo3(signature = (form, n_links, min_time=0.1))]
fn time_scaling(py: Python<'_>, form: &str, n_links: usize, min_time: f64) -> PyResult<f64> {
    let form = crate::scaling::Form::from_name(form)?;
    Ok(py.detach(|| crate::scaling::time_form(form, n_links, min_time))?)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    // `get_type` below panics if the exceptions' module cannot be imported; importing it
    // here first turns any such failure into the ImportError that caused it.
    py.import("chaincart_env.errors")?;
    m.add("ChainCartError", py.get_type::<ChainCartError>())?;
    m.add("InvalidInputError", py.get_type::<InvalidInputError>())?;
    m.add("InvalidTypeError", py.get_type::<InvalidTypeError>())?;
    m.add("IntegrationError", py.get_type::<IntegrationError>())?;
    m.add("AnalysisError", py.get_type::<AnalysisError>())?;
    m.add_class::<model::ChainCart>()?;
    m.add_class::<env::PyEnvBatch>()?;
    m.add_class::<config::ResolvedConfig>()?;
    m.add_class::<control::Plan>()?;
    m.add_class::<control::TrajectoryTracker>()?;
    m.add_class::<control::MpcController>()?;
    m.add_class::<energy::EnergyController>()?;
    m.add_function(wrap_pyfunction!(num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(time_scaling, m)?)?;
    m.add("MAX_LINKS", crate::limits::MAX_LINKS)?;
    m.add("MAX_STATE_VALUES", crate::limits::MAX_STATE_VALUES)?;
    m.add("MIN_FRAME_SIZE", crate::render::MIN_FRAME_SIZE)?;
    m.add("MAX_FRAME_SIZE", crate::render::MAX_FRAME_SIZE)?;
    m.add_function(wrap_pyfunction!(render::render_frame, m)?)?;
    m.add_function(wrap_pyfunction!(render::check_camera, m)?)?;
    m.add_function(wrap_pyfunction!(render::default_view, m)?)?;
    m.add("CAMERA_DEFAULTS", render::camera_defaults(py)?)?;
    m.add(
        "RENDER_VIEWS",
        PyTuple::new(py, crate::render::ViewKind::NAMES)?,
    )?;
    m.add_function(wrap_pyfunction!(model::target_signs, m)?)?;
    m.add_function(wrap_pyfunction!(model::paper_initial_condition, m)?)?;
    m.add(
        "INTEGRATORS",
        PyTuple::new(py, crate::integrate::Method::NAMES)?,
    )?;
    m.add("DIAGNOSTICS", PyTuple::new(py, crate::env::DIAGNOSTICS)?)?;
    m.add("EVENT_ENDED", crate::env::event::ENDED)?;
    m.add("EVENT_SUCCESS", crate::env::event::SUCCESS)?;
    m.add("EVENT_OUT_OF_TRACK", crate::env::event::OUT_OF_TRACK)?;
    m.add("EVENT_FELL", crate::env::event::FELL)?;
    m.add(
        "EVENT_NUMERICAL_FAILURE",
        crate::env::event::NUMERICAL_FAILURE,
    )?;
    m.add("EVENT_RESET", crate::env::event::RESET)?;
    m.add("RNG_BYTES", crate::env::RNG_BYTES)?;
    m.add("CONFIG_KEYS", config::keys_table(py)?)?;
    m.add("REALITY_KEYS", config::reality_keys_table(py)?)?;
    m.add("SCENES", config::scenes_table(py)?)?;
    m.add("SCENE_SUMMARIES", config::scene_summaries(py)?)?;
    m.add("DEFAULT_SCENE", crate::env::DEFAULT_SCENE)?;
    m.add("TARGET_NAMES", PyTuple::new(py, crate::env::TARGET_NAMES)?)?;
    m.add("START_NAMES", PyTuple::new(py, crate::env::START_NAMES)?)?;
    m.add(
        "REWARD_WEIGHTS",
        config::named_defaults(py, "reward_weights")?,
    )?;
    m.add_function(wrap_pyfunction!(config::resolve_config, m)?)?;
    m.add_function(wrap_pyfunction!(control::check_plan_weights, m)?)?;
    Ok(())
}
