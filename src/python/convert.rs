//! Argument conversion shared by the classes: errors, array-likes, sign tuples.

use super::{AnalysisError, IntegrationError, InvalidInputError, InvalidTypeError};
use crate::error::{ChainError, InputError};
use numpy::{AllowTypeChange, PyArrayDyn, PyArrayLikeDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyString;
use std::borrow::Cow;

impl From<ChainError> for PyErr {
    fn from(e: ChainError) -> PyErr {
        let message = e.to_string();
        match e {
            ChainError::Input(_) => InvalidInputError::new_err(message),
            ChainError::Integration { time, failure } => {
                IntegrationError::new_err((message, time, failure.to_string()))
            }
            ChainError::Analysis { .. } => AnalysisError::new_err(message),
        }
    }
}

impl From<InputError> for PyErr {
    fn from(e: InputError) -> PyErr {
        InvalidInputError::new_err(e.to_string())
    }
}

/// An `InvalidInputError` (a `ValueError`) with `message`.
pub fn error(message: String) -> PyErr {
    InvalidInputError::new_err(message)
}

/// An `InvalidTypeError` (a `TypeError` and an `InvalidInputError`) with `message`.
pub fn type_error(message: String) -> PyErr {
    InvalidTypeError::new_err(message)
}

/// `(3, 2)`-style shape text.
pub fn shape_text(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

pub fn check_shape(name: &str, shape: &[usize], expected: &[usize]) -> PyResult<()> {
    if shape == expected {
        Ok(())
    } else {
        Err(error(format!(
            "{name} has shape {}, expected {}",
            shape_text(shape),
            shape_text(expected)
        )))
    }
}

/// Any array-like of numbers as float64 (converted by NumPy if needed).
pub type Floats<'py> = PyArrayLikeDyn<'py, f64, AllowTypeChange>;

/// The contents of a float64 array, borrowed when contiguous.
pub fn contiguous<'a>(a: &'a Floats<'_>) -> Cow<'a, [f64]> {
    match a.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
    }
}

/// A float64 vector of exactly `len` entries.
pub fn vector<'a>(name: &str, a: &'a Floats<'_>, len: usize) -> PyResult<Cow<'a, [f64]>> {
    check_shape(name, a.shape(), &[len])?;
    Ok(contiguous(a))
}

/// Actions as they come: float32 or float64 arrays without conversion, anything else
/// converted to float64 by NumPy.
pub enum Actions<'py> {
    F32(numpy::PyReadonlyArrayDyn<'py, f32>),
    F64(numpy::PyReadonlyArrayDyn<'py, f64>),
    Other(Floats<'py>),
}

impl<'py> Actions<'py> {
    pub fn extract(obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        if let Ok(a) = obj.cast::<PyArrayDyn<f32>>() {
            return Ok(Self::F32(
                a.try_readonly().map_err(|e| error(e.to_string()))?,
            ));
        }
        if let Ok(a) = obj.cast::<PyArrayDyn<f64>>() {
            return Ok(Self::F64(
                a.try_readonly().map_err(|e| error(e.to_string()))?,
            ));
        }
        obj.extract::<Floats<'py>>()
            .map(Self::Other)
            .map_err(|_| type_error("actions must be an array of numbers".to_string()))
    }

    pub fn shape(&self) -> &[usize] {
        match self {
            Self::F32(a) => a.shape(),
            Self::F64(a) => a.shape(),
            Self::Other(a) => a.shape(),
        }
    }
}

/// A slice view of actions, converting only non-contiguous arrays.
pub enum ActionSlice<'a> {
    F32(Cow<'a, [f32]>),
    F64(Cow<'a, [f64]>),
}

impl<'py> Actions<'py> {
    pub fn slice(&self) -> ActionSlice<'_> {
        match self {
            Self::F32(a) => ActionSlice::F32(match a.as_slice() {
                Ok(s) => Cow::Borrowed(s),
                Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
            }),
            Self::F64(a) => ActionSlice::F64(match a.as_slice() {
                Ok(s) => Cow::Borrowed(s),
                Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
            }),
            Self::Other(a) => ActionSlice::F64(contiguous(a)),
        }
    }
}

/// An equilibrium given by name (see [`crate::env::target_signs`]) or as a sequence
/// of +1/-1.
pub fn signs(obj: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<f64>> {
    if let Ok(name) = obj.cast::<PyString>() {
        return Ok(crate::env::target_signs(name.to_str()?, n)?);
    }
    obj.extract::<Vec<f64>>().map_err(|_| {
        type_error(format!(
            "equilibrium {obj}: expected a name ({}) or a sequence of {n} signs +1/-1",
            crate::error::quoted(&crate::env::TARGET_NAMES)
        ))
    })
}

/// A scalar broadcast to `n` links, or one value per link.
pub fn per_link(name: &'static str, obj: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<f64>> {
    if let Ok(v) = obj.extract::<f64>() {
        return Ok(vec![v; n]);
    }
    let v: Vec<f64> = obj.extract().map_err(|_| {
        type_error(format!(
            "{name} = {obj}: expected a number or a sequence of {n} numbers"
        ))
    })?;
    if v.len() != n {
        return Err(InputError::LengthMismatch {
            name,
            got: v.len(),
            expected: n,
        }
        .into());
    }
    Ok(v)
}
