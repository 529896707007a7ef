//! `render_frame`: one RGB frame of a chain state from the software renderer.

use super::convert::{contiguous, Floats};
use crate::render::{check_frame_size, render, FrameSpec};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;

/// Renders a spatial state `[x(2), xdot(2), q(3n), w(3n)]` (embed planar states with
/// `ChainCart.to_spatial` first) into a `(height, width, 3)` uint8 array: a side view
/// (e1 right, gravity down) and, with `top_view`, a top view; the target equilibrium
/// `target` (signs) drawn faintly, the force `force` (N) as an arrow scaled by
/// `max_force`, the track to `+-track_limit` (inf: the view follows the cart).
#[pyfunction]
#[pyo3(signature = (link_lengths, state, force, *, target=None, max_force=1.0, track_limit=f64::INFINITY, width=480, height=240, top_view=true))]
#[allow(clippy::too_many_arguments)]
pub fn render_frame<'py>(
    py: Python<'py>,
    link_lengths: Vec<f64>,
    state: Floats<'py>,
    force: [f64; 2],
    target: Option<Vec<f64>>,
    max_force: f64,
    track_limit: f64,
    width: usize,
    height: usize,
    top_view: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let state = contiguous(&state);
    let spec = FrameSpec {
        lengths: &link_lengths,
        state: &state,
        target: target.as_deref(),
        force,
        max_force,
        track_limit,
        top_view,
    };
    check_frame_size(width, height)?;
    let mut pixels = vec![0u8; width * height * 3];
    py.detach(|| render(width, height, &spec, &mut pixels))?;
    Ok(PyArray1::from_vec(py, pixels)
        .reshape([height, width, 3])?
        .into_any())
}
