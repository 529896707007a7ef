//! chaincart: the chain pendulum on a cart (Lee, Leok, McClamroch, CDC 2012).
//!
//! Pure Rust physics and batch engine; the Python bindings live in `src/python/`
//! behind the `python` feature.
//!
//! The modules form a ladder: each uses only those below it (ARCHITECTURE.md; the
//! `architecture` test checks it).
//!
//! * [`error`], [`limits`], [`tridiagonal`]: errors, the largest sizes accepted, a solver.
//! * [`params`]: validated physical parameters.
//! * [`geometry`]: the spatial scene and its planar special case.
//! * [`model`]: exact O(n) accelerations; [`dense`]: the paper's O(n^3) form (oracle);
//!   [`invariants`]: energy, momentum, constraint residuals, the paper's errors.
//! * [`integrate`]: rk4, rkmk4, variational, lie_euler, adaptive, and the failure guard.
//! * [`analysis`]: equilibria, linearisation (Prop. 2), controllability (Prop. 3), Riccati,
//!   LQR; [`lanes`]: the rk4 step with one env per SIMD lane; [`render`]: RGB frames;
//!   [`scaling`]: timing against the number of links; [`any`]: a chain in either scene,
//!   chosen at run time.
//! * [`batch`]: the engine every batch steps with, and [`batch::ChainBatch`] (physics only).
//! * [`env`](mod@env): the RL task (target, start, reward, termination, autoreset) on the
//!   engine.

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
pub mod any;
pub mod batch;
pub mod control;
pub mod dense;
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

pub use error::{ChainError, InputError, IntegrationFailure, Result};
pub use geometry::{Geometry, Planar, Spatial};
pub use integrate::{Method, StepOptions, Stepper};
pub use model::{Chain, PlanarChain, SpatialChain};
pub use params::ChainParams;
