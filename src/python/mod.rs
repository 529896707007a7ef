//! The Python extension `chaincart_env._core`: the only place that knows about
//! Python. Each function converts its arguments, calls the core and converts the
//! result; errors of the core become `ChainCartError` (a `ValueError`) with the core's
//! message, and nothing here panics on user input.

mod convert;
mod env;
mod model;
mod reality;
mod render;

use pyo3::prelude::*;
use pyo3::types::PyTuple;

pyo3::create_exception!(
    chaincart_env._core,
    ChainCartError,
    pyo3::exceptions::PyValueError,
    "Invalid input for chaincart (a ValueError); the message names the value and what was expected."
);

/// The core's number of worker threads (rayon's global pool; set `RAYON_NUM_THREADS`
/// before the first parallel step to change it).
#[pyfunction]
fn num_threads() -> usize {
    rayon::current_num_threads()
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ChainCartError", py.get_type::<ChainCartError>())?;
    m.add_class::<model::ChainCart>()?;
    m.add_class::<env::EnvBatch>()?;
    m.add_function(wrap_pyfunction!(num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_frame, m)?)?;
    m.add_function(wrap_pyfunction!(model::target_signs, m)?)?;
    m.add_function(wrap_pyfunction!(model::paper_initial_condition, m)?)?;
    m.add(
        "INTEGRATORS",
        PyTuple::new(py, crate::integrate::Method::ALL.map(|m| m.name()))?,
    )?;
    m.add("DIAGNOSTICS", PyTuple::new(py, crate::env::DIAGNOSTICS)?)?;
    m.add("EVENT_ENDED", crate::env::event::ENDED)?;
    m.add("EVENT_SUCCESS", crate::env::event::SUCCESS)?;
    m.add("EVENT_OUT_OF_TRACK", crate::env::event::OUT_OF_TRACK)?;
    m.add(
        "EVENT_NUMERICAL_FAILURE",
        crate::env::event::NUMERICAL_FAILURE,
    )?;
    m.add("EVENT_RESET", crate::env::event::RESET)?;
    m.add("RNG_BYTES", crate::env::batch::RNG_BYTES)?;
    m.add("REALITY_KEYS", reality::keys_table(py)?)?;
    Ok(())
}
