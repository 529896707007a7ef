//! One error type for the whole core. Variants carry the offending data so that
//! messages can name the value and what was expected (the Python layer maps each
//! to a `ValueError` subclass without rewording it).

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub enum ChainError {
    /// A scalar parameter outside its admissible set (e.g. a mass <= 0 or NaN).
    InvalidParameter {
        name: &'static str,
        value: f64,
        expected: &'static str,
    },
    /// One entry of a per-link parameter vector is inadmissible.
    InvalidLinkParameter {
        name: &'static str,
        link: usize,
        value: f64,
        expected: &'static str,
    },
    /// A `[low, high]` range that is empty, not finite, or admits inadmissible values.
    InvalidRange {
        name: &'static str,
        low: f64,
        high: f64,
        expected: &'static str,
    },
    /// Two things that must have the same length do not.
    LengthMismatch {
        name: &'static str,
        got: usize,
        expected: usize,
    },
    /// The number of links must be at least one.
    NoLinks,
    /// A name (integrator, equilibrium, ...) that is not known.
    UnknownName {
        kind: &'static str,
        name: String,
        expected: &'static str,
    },
    /// An input vector contains NaN or infinity.
    NonFinite {
        name: &'static str,
        index: usize,
        value: f64,
    },
    /// An equilibrium sign tuple with an entry other than +1 or -1.
    InvalidSign { index: usize, value: f64 },
    /// The integration produced a non-finite state or broke a constraint.
    NumericalFailure { reason: String },
    /// An implicit solve did not converge.
    NoConvergence {
        method: &'static str,
        iterations: usize,
        residual: f64,
        tolerance: f64,
    },
    /// Linear-algebra failure in the analysis code (singular matrix, no stabilising solution...).
    Analysis { reason: String },
}

impl fmt::Display for ChainError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ChainError::*;
        match self {
            InvalidParameter { name, value, expected } => {
                write!(f, "invalid {name} = {value}: expected {expected}")
            }
            InvalidLinkParameter { name, link, value, expected } => {
                write!(f, "invalid {name}[{link}] = {value}: expected {expected}")
            }
            InvalidRange { name, low, high, expected } => {
                write!(f, "invalid {name} range [{low}, {high}]: expected {expected}")
            }
            LengthMismatch { name, got, expected } => {
                write!(f, "{name} has length {got}, expected {expected}")
            }
            NoLinks => write!(f, "n_links = 0: expected at least one link"),
            UnknownName { kind, name, expected } => {
                write!(f, "unknown {kind} {name:?}: expected one of {expected}")
            }
            NonFinite { name, index, value } => {
                write!(f, "{name}[{index}] = {value}: expected a finite number")
            }
            InvalidSign { index, value } => {
                write!(f, "s[{index}] = {value}: expected +1 (hanging link) or -1 (upright link)")
            }
            NumericalFailure { reason } => write!(f, "numerical failure: {reason}"),
            NoConvergence { method, iterations, residual, tolerance } => write!(
                f,
                "{method} did not converge in {iterations} iterations: residual {residual:e} > tolerance {tolerance:e}"
            ),
            Analysis { reason } => write!(f, "{reason}"),
        }
    }
}

impl std::error::Error for ChainError {}

pub type Result<T> = std::result::Result<T, ChainError>;

/// Rejects NaN/inf in an input vector, naming the first bad entry.
pub fn check_finite(name: &'static str, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(ChainError::NonFinite {
            name,
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

/// Rejects a value that is not a finite number > 0, naming it.
pub fn check_positive(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ChainError::InvalidParameter {
            name,
            value,
            expected: "a finite number > 0",
        })
    }
}

/// Rejects a slice whose length is not the expected one.
pub fn check_len(name: &'static str, values: &[f64], expected: usize) -> Result<()> {
    if values.len() == expected {
        Ok(())
    } else {
        Err(ChainError::LengthMismatch {
            name,
            got: values.len(),
            expected,
        })
    }
}
