//! `render_frame`: one RGB frame of a chain state from the software renderer, and
//! the camera settings of its 3-D view (`check_camera`, `CAMERA_DEFAULTS`).

use super::convert::{contiguous, Floats};
use crate::error::InputError;
use crate::render::{check_frame_size, render, Camera, FrameSpec, ViewKind};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A camera from the settings given, the defaults for the others, checked.
fn camera(
    azimuth: Option<f64>,
    elevation: Option<f64>,
    distance: Option<f64>,
    fov: Option<f64>,
    follow: Option<bool>,
) -> crate::error::Result<Camera> {
    let d = Camera::default();
    let camera = Camera {
        azimuth: azimuth.unwrap_or(d.azimuth),
        elevation: elevation.unwrap_or(d.elevation),
        distance: distance.or(d.distance),
        fov: fov.unwrap_or(d.fov),
        follow: follow.or(d.follow),
    };
    camera.validate()?;
    Ok(camera)
}

fn camera_dict<'py>(py: Python<'py>, c: &Camera) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("azimuth", c.azimuth)?;
    d.set_item("elevation", c.elevation)?;
    d.set_item("distance", c.distance)?;
    d.set_item("fov", c.fov)?;
    d.set_item("follow", c.follow)?;
    Ok(d)
}

/// The default camera settings (`_core.CAMERA_DEFAULTS`).
pub fn camera_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    camera_dict(py, &Camera::default())
}

/// Checks camera settings (`None`: the default) and returns all of them; raises
/// naming the first bad one and what it accepts.
#[pyfunction]
#[pyo3(signature = (*, azimuth=None, elevation=None, distance=None, fov=None, follow=None))]
pub fn check_camera(
    py: Python<'_>,
    azimuth: Option<f64>,
    elevation: Option<f64>,
    distance: Option<f64>,
    fov: Option<f64>,
    follow: Option<bool>,
) -> PyResult<Bound<'_, PyDict>> {
    camera_dict(py, &camera(azimuth, elevation, distance, fov, follow)?)
}

/// The view drawn when `render_view` is none: `"3d"` for spatial chains, `"side"`
/// for planar ones.
#[pyfunction]
pub fn default_view(planar: bool) -> &'static str {
    ViewKind::default_for(planar).name()
}

/// The trail's points as `[x, y, z]` rows.
fn trail_points(trail: Option<PyReadonlyArray2<'_, f64>>) -> PyResult<Vec<[f64; 3]>> {
    let Some(trail) = trail else {
        return Ok(Vec::new());
    };
    if trail.shape()[1] != 3 {
        return Err(InputError::LengthMismatch {
            name: "trail rows",
            got: trail.shape()[1],
            expected: 3,
        }
        .into());
    }
    let rows = trail.as_array();
    Ok(rows
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect())
}

/// Renders a spatial state `[x(2), xdot(2), q(3n), w(3n)]` (embed planar states with
/// `ChainCart.to_spatial` first, and pass `planar=True`) into a `(height, width, 3)`
/// uint8 array. `view` is `"3d"` (a lit perspective view seen by the camera
/// `azimuth`, `elevation`, `distance`, `fov`, `follow`; `None` values: the defaults),
/// `"side"`, `"top"`, `"side+top"`, or `None`: `"side"` if `planar`, else `"3d"`. The target equilibrium `target` (signs) is drawn
/// faintly, the force `force` (N) as an arrow scaled by `max_force`, the track to
/// `+-track_limit` (inf: none), and `trail` (an `(k, 3)` array of tip positions,
/// oldest first) as a fading line in the 3-D view.
#[pyfunction]
#[pyo3(signature = (
    link_lengths, state, force, *, target=None, max_force=1.0, track_limit=f64::INFINITY,
    width=480, height=240, view=None, planar=false, azimuth=None, elevation=None,
    distance=None, fov=None, follow=None, trail=None,
))]
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
    view: Option<&str>,
    planar: bool,
    azimuth: Option<f64>,
    elevation: Option<f64>,
    distance: Option<f64>,
    fov: Option<f64>,
    follow: Option<bool>,
    trail: Option<PyReadonlyArray2<'py, f64>>,
) -> PyResult<Bound<'py, PyAny>> {
    let state = contiguous(&state);
    let trail = trail_points(trail)?;
    let spec = FrameSpec {
        lengths: &link_lengths,
        state: &state,
        target: target.as_deref(),
        force,
        max_force,
        track_limit,
        planar,
        view: view.map_or(Ok(ViewKind::default_for(planar)), ViewKind::from_name)?,
        camera: camera(azimuth, elevation, distance, fov, follow)?,
        trail: &trail,
    };
    check_frame_size(width, height)?;
    let mut pixels = vec![0u8; width * height * 3];
    py.detach(|| render(width, height, &spec, &mut pixels))?;
    Ok(PyArray1::from_vec(py, pixels)
        .reshape([height, width, 3])?
        .into_any())
}
