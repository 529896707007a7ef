//! chaincart: the chain pendulum on a cart (Lee, Leok, McClamroch, CDC 2012).
//!
//! Pure Rust physics, controllers, batch engine and RL task; the Python bindings live in
//! `src/python/` behind the `python` feature.
//!
//! The modules form a ladder, each using only those below it: ARCHITECTURE.md at the
//! repository's root draws it, with the invariants and where to start reading; the
//! `architecture` integration test (`tests/it/architecture.rs`) checks it.

#![warn(missing_docs)]

/// Runs `$body` with `$x` bound to the value inside `$value`, an enum `$kind` with
/// the variants `Spatial` and `Planar` (the run-time choice of scene), so that one
/// generic call serves both.
macro_rules! dispatch {
    ($kind:ident, $value:expr, $x:ident => $body:expr) => {
        match $value {
            $kind::Spatial($x) => $body,
            $kind::Planar($x) => $body,
        }
    };
}

pub mod analysis;
pub mod any_chain;
pub mod control;
pub mod dense;
pub mod engine;
pub mod env;
pub mod error;
pub mod geometry;
pub mod integrate;
pub mod invariants;
pub mod lanes;
pub mod limits;
pub mod model;
pub mod params;
pub mod render;
pub mod scaling;
pub mod tridiagonal;

#[cfg(feature = "python")]
mod python;

// The integration tests (tests/it/) are a module of the unit-test binary: one test
// binary compiles the crate's generic code once instead of twice. They reach the crate
// by its name, as users do.
#[cfg(test)]
extern crate self as chaincart;
#[cfg(test)]
#[path = "../tests/it/main.rs"]
mod integration_tests;

pub use error::{ChainError, InputError, IntegrationFailure, Result};
pub use geometry::{Geometry, Planar, Spatial};
pub use integrate::{Method, StepOptions, Stepper};
pub use model::{Chain, PlanarChain, SpatialChain};
pub use params::ChainParams;
