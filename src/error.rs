//! The core's errors in three layers, each carrying the offending data so that
//! messages can name the value and what was expected:
//!
//! * [`InputError`]: an argument is not admissible (the caller's mistake);
//! * [`ChainError::Integration`]: the model's integration failed, at a time, for an
//!   [`IntegrationFailure`];
//! * [`ChainError::Analysis`]: a linear-algebra analysis has no (stable) solution.
//!
//! The Python layer maps the three to `InvalidInputError` (a `ValueError`),
//! `IntegrationError` (a `RuntimeError`) and `AnalysisError` without rewording them.

use std::fmt;

/// An inadmissible argument.
#[derive(Debug, Clone, PartialEq)]
pub enum InputError {
    /// A scalar parameter outside its admissible set (e.g. a mass <= 0 or NaN).
    InvalidParameter {
        /// Name of the argument or quantity.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// One entry of a per-link parameter vector is inadmissible.
    InvalidLinkParameter {
        /// Name of the argument or quantity.
        name: &'static str,
        /// Index of the link.
        link: usize,
        /// The value given.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// A `[low, high]` range that is empty, not finite, or admits inadmissible values.
    InvalidRange {
        /// Name of the argument or quantity.
        name: &'static str,
        /// Lower end of the range.
        low: f64,
        /// Upper end of the range.
        high: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// Two things that must have the same length do not.
    LengthMismatch {
        /// Name of the argument or quantity.
        name: &'static str,
        /// The length given.
        got: usize,
        /// What was expected.
        expected: usize,
    },
    /// The number of links must be at least one.
    NoLinks,
    /// A size (links, envs, steps, ...) beyond what can be allocated.
    TooLarge {
        /// Name of the argument or quantity.
        name: &'static str,
        /// The value given.
        value: usize,
        /// The largest admissible value.
        limit: usize,
    },
    /// A name (integrator, equilibrium, ...) that is not known.
    UnknownName {
        /// What kind of name (integrator, target, ...).
        kind: &'static str,
        /// Name of the argument or quantity.
        name: String,
        /// The names accepted.
        expected: &'static [&'static str],
    },
    /// A configuration key's value of another form than the key takes (e.g. a name
    /// where a number goes).
    WrongForm {
        /// The key.
        name: &'static str,
        /// The value given, as the core read it.
        got: String,
        /// What was expected.
        expected: &'static str,
    },
    /// An input vector contains NaN or infinity.
    NonFinite {
        /// Name of the argument or quantity.
        name: &'static str,
        /// Position of the entry.
        index: usize,
        /// The value given.
        value: f64,
    },
    /// One env's entry of a batch's input (e.g. the action array of a vector env)
    /// is NaN or infinity.
    NonFiniteInEnv {
        /// Name of the argument or quantity.
        name: &'static str,
        /// The env whose entry it is.
        env: usize,
        /// Position within that env's entries.
        component: usize,
        /// The value given.
        value: f64,
    },
    /// A choice that other settings rule out (e.g. f32 physics with an integrator that
    /// has no f32 kernel).
    Incompatible {
        /// Name of the argument.
        name: &'static str,
        /// The value given.
        value: &'static str,
        /// What was expected, naming the setting that rules it out.
        expected: String,
    },
    /// An equilibrium sign tuple with an entry other than +1 or -1.
    InvalidSign {
        /// Position in the tuple.
        index: usize,
        /// The entry given.
        value: f64,
    },
}

/// Why an integration failed.
#[derive(Debug, Clone, PartialEq)]
pub enum IntegrationFailure {
    /// A guarded control period failed: `status` says how (non-finite state,
    /// constraint drift, under-resolved motion, solver failure).
    Step {
        /// Index of the failing control period.
        step: usize,
        /// How the step failed.
        status: &'static str,
        /// The integrator or solver.
        method: &'static str,
        /// The control period (s).
        dt: f64,
    },
    /// The adaptive integrator needed more than `limit` steps in one period.
    TooManySteps {
        /// Most steps allowed in one control period.
        limit: usize,
    },
    /// The adaptive integrator's step size fell below what floating point resolves.
    StepSizeUnderflow,
    /// An implicit solve did not converge.
    NoConvergence {
        /// The integrator or solver.
        method: &'static str,
        /// Iterations done.
        iterations: usize,
        /// The residual reached.
        residual: f64,
        /// The residual asked for.
        tolerance: f64,
    },
}

/// Every error of the core.
#[derive(Debug, Clone, PartialEq)]
pub enum ChainError {
    /// An inadmissible argument.
    Input(InputError),
    /// The integration failed in the step that began at `time` (s from the start
    /// of the call; within a control period for the integrators' own errors).
    Integration {
        /// Time (s) at which the failing step began.
        time: f64,
        /// What failed.
        failure: IntegrationFailure,
    },
    /// Linear-algebra failure in the analysis code (singular matrix, no stabilising solution...).
    Analysis {
        /// What failed.
        reason: String,
    },
}

impl From<InputError> for ChainError {
    fn from(e: InputError) -> Self {
        ChainError::Input(e)
    }
}

impl ChainError {
    /// An integration failure at `time` seconds.
    pub fn integration(time: f64, failure: IntegrationFailure) -> Self {
        ChainError::Integration { time, failure }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use InputError::*;
        match self {
            InvalidParameter {
                name,
                value,
                expected,
            } => {
                write!(f, "invalid {name} = {value}: expected {expected}")
            }
            InvalidLinkParameter {
                name,
                link,
                value,
                expected,
            } => {
                write!(f, "invalid {name}[{link}] = {value}: expected {expected}")
            }
            InvalidRange {
                name,
                low,
                high,
                expected,
            } => {
                write!(
                    f,
                    "invalid {name} range [{low}, {high}]: expected {expected}"
                )
            }
            LengthMismatch {
                name,
                got,
                expected,
            } => {
                write!(f, "{name} has length {got}, expected {expected}")
            }
            NoLinks => write!(f, "n_links = 0: expected at least one link"),
            TooLarge { name, value, limit } => {
                write!(f, "{name} = {value} is too large: expected at most {limit}")
            }
            UnknownName {
                kind,
                name,
                expected,
            } => {
                write!(f, "unknown {kind} {name:?}")?;
                if let Some(closest) = closest_name(name, expected) {
                    write!(f, " (did you mean {closest:?}?)")?;
                }
                write!(f, ": expected one of {}", quoted(expected))
            }
            WrongForm {
                name,
                got,
                expected,
            } => write!(f, "{name} = {got}: expected {expected}"),
            NonFinite { name, index, value } => {
                write!(f, "{name}[{index}] = {value}: expected a finite number")
            }
            NonFiniteInEnv {
                name,
                env,
                component,
                value,
            } => write!(
                f,
                "{name}[{env}, {component}] = {value}: expected a finite number \
                 (env {env}, component {component})"
            ),
            Incompatible {
                name,
                value,
                expected,
            } => write!(f, "{name} = {value:?}: expected {expected}"),
            InvalidSign { index, value } => {
                write!(
                    f,
                    "s[{index}] = {value}: expected +1 (hanging link) or -1 (upright link)"
                )
            }
        }
    }
}

impl fmt::Display for IntegrationFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use IntegrationFailure::*;
        match self {
            Step { step, status, method, dt } => {
                write!(f, "{status} at step {step} ({method} integrator, dt = {dt})")
            }
            TooManySteps { limit } => write!(
                f,
                "adaptive integrator took more than {limit} steps in one control period"
            ),
            StepSizeUnderflow => write!(f, "adaptive step size underflow"),
            NoConvergence { method, iterations, residual, tolerance } => write!(
                f,
                "{method} did not converge in {iterations} iterations: residual {residual:e} > tolerance {tolerance:e}"
            ),
        }
    }
}

impl fmt::Display for ChainError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ChainError::Input(e) => e.fmt(f),
            ChainError::Integration { time, failure } => {
                write!(f, "numerical failure at t = {time} s: {failure}")
            }
            ChainError::Analysis { reason } => write!(f, "{reason}"),
        }
    }
}

impl std::error::Error for InputError {}
impl std::error::Error for ChainError {}

/// The core's result type.
pub type Result<T> = std::result::Result<T, ChainError>;

/// Rejects NaN/inf in an input vector, naming the first bad entry.
pub fn check_finite(name: &'static str, values: &[f64]) -> Result<()> {
    // Whole blocks without an early exit vectorise; a batch's states or forces are
    // checked on every call, and a bad value is looked for only once one is known.
    let finite = |block: &[f64]| block.iter().fold(true, |ok, v| ok & v.is_finite());
    if values.chunks(256).all(finite) {
        return Ok(());
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(InputError::NonFinite {
            name,
            index,
            value: values[index],
        }
        .into()),
        None => Ok(()),
    }
}

/// Rejects a value that is not a finite number > 0, naming it.
pub fn check_positive(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(InputError::InvalidParameter {
            name,
            value,
            expected: "a finite number > 0",
        }
        .into())
    }
}

/// Rejects a slice whose length is not the expected one.
pub fn check_len(name: &'static str, values: &[f64], expected: usize) -> Result<()> {
    if values.len() == expected {
        Ok(())
    } else {
        Err(InputError::LengthMismatch {
            name,
            got: values.len(),
            expected,
        }
        .into())
    }
}

/// Rejects a size above `limit` (sizes that cannot be allocated), naming it.
pub fn check_size(name: &'static str, value: usize, limit: usize) -> Result<()> {
    if value <= limit {
        Ok(())
    } else {
        Err(InputError::TooLarge { name, value, limit }.into())
    }
}

/// The accepted name closest to a mistyped `name` (a missing or extra letter, two
/// letters swapped, `-` for `_`, ...), if one is close enough to be meant.
pub fn closest_name(name: &str, accepted: &[&'static str]) -> Option<&'static str> {
    // Similarity 1 - (edits / longer length): "n_link" -> "n_links" is 0.86; below
    // 0.6 the name was more likely something else altogether.
    const LEAST_SIMILARITY: f64 = 0.6;
    let folded = name.to_lowercase().replace('-', "_");
    accepted
        .iter()
        .map(|&candidate| {
            let similarity = strsim::normalized_damerau_levenshtein(
                &folded,
                &candidate.to_lowercase().replace('-', "_"),
            );
            (candidate, similarity)
        })
        .filter(|&(_, similarity)| similarity >= LEAST_SIMILARITY)
        .fold(None, |best: Option<(&'static str, f64)>, item| match best {
            Some(b) if b.1 >= item.1 => Some(b),
            _ => Some(item),
        })
        .map(|(candidate, _)| candidate)
}

/// `"a", "b", "c"`: names as error messages list them.
pub fn quoted(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("{n:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_errors_convert_and_keep_their_message() {
        let e: ChainError = InputError::TooLarge {
            name: "n_links",
            value: 7,
            limit: 5,
        }
        .into();
        assert!(matches!(
            e,
            ChainError::Input(InputError::TooLarge { value: 7, .. })
        ));
        assert_eq!(
            e.to_string(),
            "n_links = 7 is too large: expected at most 5"
        );
        assert_eq!(check_size("n", 5, 5), Ok(()));
        assert!(check_size("n", 6, 5).is_err());
    }

    #[test]
    fn a_mistyped_name_suggests_the_closest_accepted_one() {
        const KEYS: &[&str] = &["n_links", "link_lengths", "link_masses", "dt", "max_force"];
        assert_eq!(closest_name("n_link", KEYS), Some("n_links"));
        assert_eq!(closest_name("link_length", KEYS), Some("link_lengths"));
        assert_eq!(closest_name("link-masses", KEYS), Some("link_masses"));
        assert_eq!(closest_name("max_froce", KEYS), Some("max_force"));
        assert_eq!(closest_name("bogus", KEYS), None);
        assert_eq!(closest_name("", KEYS), None);
        let e = InputError::UnknownName {
            kind: "config key",
            name: "n_link".into(),
            expected: KEYS,
        };
        assert_eq!(
            e.to_string(),
            "unknown config key \"n_link\" (did you mean \"n_links\"?): expected one of \
             \"n_links\", \"link_lengths\", \"link_masses\", \"dt\", \"max_force\""
        );
        let far = InputError::UnknownName {
            kind: "config key",
            name: "bogus".into(),
            expected: KEYS,
        };
        assert!(!far.to_string().contains("did you mean"), "{far}");
    }

    #[test]
    fn the_first_non_finite_value_is_named_wherever_it_lies() {
        let mut values = vec![0.5; 1000];
        assert_eq!(check_finite("v", &values), Ok(()));
        assert_eq!(check_finite("v", &[]), Ok(()));
        for (index, bad) in [
            (0, f64::NAN),
            (255, f64::INFINITY),
            (256, f64::NAN),
            (999, -f64::INFINITY),
        ] {
            values[index] = bad;
            values[(index + 300) % 1000] = f64::NAN; // a later one, or an earlier one
            let e = check_finite("v", &values).unwrap_err();
            let first = index.min((index + 300) % 1000);
            assert!(
                matches!(e, ChainError::Input(InputError::NonFinite { index: i, .. }) if i == first),
                "{e}"
            );
            values.fill(0.5);
        }
    }

    #[test]
    fn integration_errors_carry_time_and_failure() {
        let e = ChainError::integration(
            0.25,
            IntegrationFailure::Step {
                step: 5,
                status: "non-finite state",
                method: "rk4",
                dt: 0.05,
            },
        );
        let ChainError::Integration { time, failure } = &e else {
            panic!("not an integration error: {e:?}")
        };
        assert_eq!(*time, 0.25);
        assert_eq!(
            failure.to_string(),
            "non-finite state at step 5 (rk4 integrator, dt = 0.05)"
        );
        assert_eq!(
            e.to_string(),
            "numerical failure at t = 0.25 s: non-finite state at step 5 (rk4 integrator, dt = 0.05)"
        );
    }
}
