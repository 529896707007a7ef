//! Local coordinates about an equilibrium `s` (paper Prop. 2 and eq. (u)).
//!
//! The linearisation lives in `z = [x, C^T xi_1..C^T xi_n, xdot, C^T w_1..C^T w_n]`
//! (length `4 + 4n`), where near the equilibrium `q_i = exp(xi_i^) (s_i e3)` with
//! `xi_i . e3 = 0`. Two maps connect `z` with the full state `[x, xdot, q_i, w_i]`:
//!
//! * [`local_coordinates`] (state -> z) is the controller's map of eq. (u):
//!   `C^T xi_i ~ C^T (s_i e3 x q_i)`, `C^T w_i` as is. For `q_i = exp(xi_i^) s_i e3`
//!   one has `s_i e3 x q_i = (sin|xi_i| / |xi_i|) xi_i` exactly, so this equals
//!   `C^T xi_i` to first order (the error is cubic), which is all a linear controller
//!   needs, and it costs no trigonometry.
//! * [`state_from_local`] (z -> state) is the exponential chart itself, used to build
//!   perturbed states (finite differences, initial conditions); `w_i` gets the third
//!   component that makes it tangent (`w_i . q_i = 0`) with the given `C^T w_i`.
//!
//! The two are inverse to first order, so a Jacobian at the equilibrium computed
//! through them is the Jacobian in the paper's coordinates.
//!
//! Useful identities (e3 = (0,0,1) along gravity): `e3 x q = (-q_2, q_1, 0)`, so
//! `C^T (s e3 x q) = s (-q_2, q_1)`.

use crate::analysis::equilibria::check_signs;
use crate::error::{check_finite, check_len, ChainError, InputError, Result};
use crate::geometry::{Geometry, Layout, Spatial};
use nalgebra::{Vector2, Vector3};

/// Offsets of the parts of `z = [x, C^T xi_1..n, xdot, C^T w_1..n]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LocalLayout {
    /// Number of links.
    pub n: usize,
}

impl LocalLayout {
    /// The layout for `n` links.
    pub const fn new(n: usize) -> Self {
        Self { n }
    }
    /// `4 + 4n`.
    pub const fn dim(&self) -> usize {
        4 + 4 * self.n
    }
    /// Number of second-order coordinates `2n + 2` (the size of `M`, `G`).
    pub const fn dof(&self) -> usize {
        2 + 2 * self.n
    }
    /// Offset of the cart position `x` (2 entries).
    pub const fn x(&self) -> usize {
        0
    }
    /// Offset of link `i`'s tilt `C^T xi_i` (2 entries).
    pub const fn xi(&self, i: usize) -> usize {
        2 + 2 * i
    }
    /// Offset of the cart velocity `xdot` (2 entries).
    pub const fn xdot(&self) -> usize {
        self.dof()
    }
    /// Offset of link `i`'s horizontal spin `C^T w_i` (2 entries).
    pub const fn w(&self, i: usize) -> usize {
        self.dof() + 2 + 2 * i
    }
}

#[inline(always)]
fn store2(z: &mut [f64], at: usize, v: Vector2<f64>) {
    z[at] = v.x;
    z[at + 1] = v.y;
}

#[inline(always)]
fn load2(z: &[f64], at: usize) -> Vector2<f64> {
    Vector2::new(z[at], z[at + 1])
}

/// `C^T (s e3 x v) = s (-v_2, v_1)`.
#[inline(always)]
pub fn horizontal_cross(s: f64, v: Vector3<f64>) -> Vector2<f64> {
    Vector2::new(-s * v.y, s * v.x)
}

fn check_lengths(s: &[f64], state: &[f64], z_name: &'static str, z: &[f64]) -> Result<()> {
    let n = s.len();
    if n == 0 {
        return Err(InputError::NoLinks.into());
    }
    check_signs(s, n)?;
    check_len("state", state, Layout::<Spatial>::new(n).dim())?;
    check_len(z_name, z, LocalLayout::new(n).dim())
}

/// The controller's coordinates of eq. (u): `z = [x, C^T(s_i e3 x q_i), xdot, C^T w_i]`.
/// `n = s.len()`; `state` has length `4 + 6n`, `z` length `4 + 4n`.
pub fn local_coordinates(s: &[f64], state: &[f64], z: &mut [f64]) -> Result<()> {
    check_lengths(s, state, "z", z)?;
    check_finite("state", state)?;
    let (lay, loc) = (Layout::<Spatial>::new(s.len()), LocalLayout::new(s.len()));
    store2(z, loc.x(), lay.load_x(state));
    store2(z, loc.xdot(), lay.load_xdot(state));
    for (i, &si) in s.iter().enumerate() {
        store2(z, loc.xi(i), horizontal_cross(si, lay.load_q(state, i)));
        store2(z, loc.w(i), Spatial::horizontal(lay.load_w(state, i)));
    }
    Ok(())
}

/// The exponential chart: `q_i = exp(xi_i^) (s_i e3)` with `xi_i = (C^T xi_i, 0)`, and
/// `w_i = (C^T w_i, w_3)` with `w_3` chosen so that `w_i . q_i = 0`. Valid while every
/// `|C^T xi_i| < pi/2` (beyond, `q_i` is horizontal or below and `w_3` is undefined).
pub fn state_from_local(s: &[f64], z: &[f64], state: &mut [f64]) -> Result<()> {
    check_lengths(s, state, "z", z)?;
    check_finite("z", z)?;
    let (lay, loc) = (Layout::<Spatial>::new(s.len()), LocalLayout::new(s.len()));
    lay.store_x(state, load2(z, loc.x()));
    lay.store_xdot(state, load2(z, loc.xdot()));
    for (i, &si) in s.iter().enumerate() {
        let xi = load2(z, loc.xi(i));
        if xi.norm() >= std::f64::consts::FRAC_PI_2 {
            return Err(ChainError::Analysis {
                reason: format!(
                    "|C^T xi_{}| = {}: expected < pi/2 for the exponential chart",
                    i + 1,
                    xi.norm()
                ),
            });
        }
        let q = Spatial::rotate(Spatial::lift(xi), Spatial::down_unit() * si);
        let wh = load2(z, loc.w(i));
        // q.z = s cos|xi| is bounded away from 0 here, so the tangent w_3 exists.
        let w3 = -(wh.x * q.x + wh.y * q.y) / q.z;
        lay.store_q(state, i, q);
        lay.store_w(state, i, Vector3::new(wh.x, wh.y, w3));
    }
    Ok(())
}

/// Time derivative of [`local_coordinates`] along the flow, from the state and its
/// derivative `dstate = [xdot, xdd, qdot_i, wdot_i]` (as `Chain::derivative` writes it):
/// `zdot = [xdot, xdd, C^T(s_i e3 x qdot_i), xdot, C^T wdot_i]`. Exact for the
/// controller's coordinates, so Jacobians through it are exact.
pub fn local_rates(s: &[f64], state: &[f64], dstate: &[f64], zdot: &mut [f64]) -> Result<()> {
    check_lengths(s, state, "zdot", zdot)?;
    check_len("dstate", dstate, state.len())?;
    let (lay, loc) = (Layout::<Spatial>::new(s.len()), LocalLayout::new(s.len()));
    store2(zdot, loc.x(), lay.load_x(dstate));
    store2(zdot, loc.xdot(), lay.load_xdot(dstate));
    for (i, &si) in s.iter().enumerate() {
        store2(zdot, loc.xi(i), horizontal_cross(si, lay.load_q(dstate, i)));
        store2(zdot, loc.w(i), Spatial::horizontal(lay.load_w(dstate, i)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chart_and_controller_map_agree_to_first_order() {
        let s = [1.0, -1.0, 1.0];
        let loc = LocalLayout::new(3);
        for scale in [1e-2, 1e-3, 1e-4] {
            let z: Vec<f64> = (0..loc.dim())
                .map(|k| scale * ((k as f64 * 0.7).sin() + 0.3))
                .collect();
            let mut y = vec![0.0; 4 + 18];
            state_from_local(&s, &z, &mut y).unwrap();
            let mut back = vec![0.0; loc.dim()];
            local_coordinates(&s, &y, &mut back).unwrap();
            let err = z
                .iter()
                .zip(&back)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            // sin|xi|/|xi| - 1 ~ |xi|^2/6: the difference is cubic in the perturbation.
            assert!(err < scale.powi(3), "scale {scale}: {err}");
            let lay = Layout::<Spatial>::new(3);
            for i in 0..3 {
                let (q, w) = (lay.load_q(&y, i), lay.load_w(&y, i));
                assert!((q.norm() - 1.0).abs() < 1e-15 && w.dot(&q).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn lengths_are_checked() {
        let mut z = vec![0.0; 8];
        let e = local_coordinates(&[1.0], &[0.0; 9], &mut z).unwrap_err();
        assert!(
            e.to_string().contains("state has length 9, expected 10"),
            "{e}"
        );
        let e = local_coordinates(&[1.0], &[0.0; 10], &mut z[..7]).unwrap_err();
        assert!(e.to_string().contains("z has length 7, expected 8"), "{e}");
        let e = state_from_local(
            &[1.0],
            &[0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            &mut [0.0; 10],
        );
        assert!(e.unwrap_err().to_string().contains("pi/2"));
    }
}
