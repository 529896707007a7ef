//! Energy shaping for one link from Python (`EnergyController`), apart from the
//! planner's bindings: it is built on a `ChainCart`, which itself plans through them.

use super::convert::{contiguous, Floats};
use super::model::ChainCart;
use crate::control::AnyEnergy;
use crate::control::EnergyOptions;
use numpy::PyArray1;
use pyo3::prelude::*;

/// Energy shaping for one link (Astrom & Furuta), then the LQR catch.
#[pyclass(module = "chaincart_env._core", name = "EnergyController")]
pub struct EnergyController {
    inner: AnyEnergy,
}

#[pymethods]
impl EnergyController {
    /// For `model` (a one-link `ChainCart`) with the force limit `max_force` (N); `gain`
    /// ((m/s^2)/J), `centring` (N/m), `damping` (N s/m), and the catch region
    /// `catch_angle` (rad from upright), `catch_rate` (rad/s).
    #[new]
    #[pyo3(signature = (model, max_force, gain=None, centring=None, damping=None, catch_angle=None, catch_rate=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &ChainCart,
        max_force: f64,
        gain: Option<f64>,
        centring: Option<f64>,
        damping: Option<f64>,
        catch_angle: Option<f64>,
        catch_rate: Option<f64>,
    ) -> PyResult<Self> {
        let d = EnergyOptions::default();
        let options = EnergyOptions {
            gain: gain.unwrap_or(d.gain),
            centring: centring.unwrap_or(d.centring),
            damping: damping.unwrap_or(d.damping),
            catch_angle: catch_angle.unwrap_or(d.catch_angle),
            catch_rate: catch_rate.unwrap_or(d.catch_rate),
        };
        Ok(Self {
            inner: AnyEnergy::new(&model.chain, max_force, options)?,
        })
    }
    /// The force (N, saturated) in `state`.
    fn force<'py>(
        &mut self,
        py: Python<'py>,
        state: Floats<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = contiguous(&state);
        Ok(PyArray1::from_vec(py, self.inner.force(&y)?))
    }
    /// Whether the LQR is in charge in `state`.
    fn catching(&self, state: Floats<'_>) -> PyResult<bool> {
        Ok(self.inner.catching(&contiguous(&state))?)
    }
}
