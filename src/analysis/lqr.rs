//! LQR gains for any equilibrium and the paper's feedback, eq. (u).
//!
//! The gain `K` (`2 x (4 + 4n)`) is `R^-1 B^T X` for the linearisation of Prop. 2 in
//! `z = [x, C^T xi_1..n, xdot, C^T w_1..n]`, so `u = -K z` is eq. (u) with
//! `[K_x, K_q1..K_qn, K_xdot, K_w1..K_wn]` its 2x2 column blocks and `z` read off the
//! nonlinear state as `x`, `C^T (s_i e3 x q_i)`, `xdot`, `C^T w_i`
//! ([`crate::analysis::coordinates::local_coordinates`]).
//!
//! **Default weights** ([`LqrWeights::paper_default`]): the paper uses
//! `Q = diag[8 I2, I_2n, 8 I2, I_2n]` for the hanging equilibrium (Fig. 2) and
//! `Q = diag[I2, 8 I_2n, I2, 8 I_2n]` for `s = (-1,-1,-1,1,1)` (Fig. 3), `R = I2` for both.
//! We use the first for the hanging equilibrium and the second for every other `s`: an
//! equilibrium with an upright link is a saddle, and weighting the links above the cart
//! is what keeps it up.

use crate::analysis::coordinates::{horizontal_cross, LocalLayout};
use crate::analysis::equilibria::check_signs;
use crate::analysis::linearize::{Linearization, StateSpace};
use crate::analysis::riccati::{solve_care, CareSolution};
use crate::error::{check_finite, check_len, InputError, Result};
use crate::geometry::{Geometry, Layout, Spatial};
use crate::params::{ChainParams, Rig};
use nalgebra::{DMatrix, DVector, Matrix2, Vector2};

/// LQR weights in the `z` ordering: `Q` is `(4 + 4n)` square, `R` is 2x2.
#[derive(Debug, Clone, PartialEq)]
pub struct LqrWeights {
    /// State weight, `(4 + 4n)` square, symmetric positive semi-definite.
    pub q: DMatrix<f64>,
    /// Force weight, 2x2, symmetric positive definite.
    pub r: DMatrix<f64>,
}

impl LqrWeights {
    /// `Q = diag[wx I2, wq I_2n, wxd I2, ww I_2n]`, `R = r I2`.
    pub fn diagonal(n: usize, wx: f64, wq: f64, wxd: f64, ww: f64, r: f64) -> Self {
        let loc = LocalLayout::new(n);
        let mut d = DVector::from_element(loc.dim(), wq);
        for k in 0..2 {
            d[loc.x() + k] = wx;
            d[loc.xdot() + k] = wxd;
        }
        for k in loc.w(0)..loc.dim() {
            d[k] = ww;
        }
        Self {
            q: DMatrix::from_diagonal(&d),
            r: DMatrix::identity(2, 2) * r,
        }
    }

    /// The paper's Fig. 2 weights: `Q = diag[8 I2, I_2n, 8 I2, I_2n]`, `R = I2`.
    pub fn paper_hanging(n: usize) -> Self {
        Self::diagonal(n, 8.0, 1.0, 8.0, 1.0, 1.0)
    }

    /// The paper's Fig. 3 weights: `Q = diag[I2, 8 I_2n, I2, 8 I_2n]`, `R = I2`.
    pub fn paper_folded(n: usize) -> Self {
        Self::diagonal(n, 1.0, 8.0, 1.0, 8.0, 1.0)
    }

    /// [`LqrWeights::paper_hanging`] for the hanging equilibrium, [`LqrWeights::paper_folded`]
    /// for every other `s` (see the module docs).
    pub fn paper_default(s: &[f64]) -> Self {
        if s.iter().all(|&v| v == 1.0) {
            Self::paper_hanging(s.len())
        } else {
            Self::paper_folded(s.len())
        }
    }
}

/// The feedback `u = -K z(state)` of eq. (u) about equilibrium `s`.
#[derive(Debug, Clone, PartialEq)]
pub struct LqrController {
    signs: Vec<f64>,
    gain: DMatrix<f64>,
    /// The 2x2 column blocks of `gain` in `z` order (`2n + 2` of them), so that
    /// [`LqrController::force`] works on fixed-size matrices and allocates nothing.
    blocks: Vec<Matrix2<f64>>,
    care: Option<CareSolution>,
}

impl LqrController {
    /// LQR design for `params` at `s` with the given weights.
    pub fn new(params: &ChainParams, s: &[f64], weights: &LqrWeights) -> Result<Self> {
        Self::from_linearization(&Linearization::new(params, s)?, weights)
    }

    /// LQR design for `params` with the real-rig effects `rig` at `s`
    /// ([`Linearization::with_rig`]): `u` is the command of the rig's actuation (a
    /// force, the cart's acceleration or a voltage per axis).
    ///
    /// Coulomb friction is left out of the design ([`Rig::without_coulomb_friction`]):
    /// its slope at rest, `F_c / v_eps`, is the exact first order but holds only below
    /// `v_eps`, and a gain designed for that much cart damping lost the chain it meets
    /// in motion (docs/physics.md).
    pub fn with_rig(
        params: &ChainParams,
        s: &[f64],
        rig: &Rig,
        weights: &LqrWeights,
    ) -> Result<Self> {
        let design = rig.without_coulomb_friction();
        Self::from_linearization(&Linearization::with_rig(params, s, &design)?, weights)
    }

    fn from_linearization(lin: &Linearization, weights: &LqrWeights) -> Result<Self> {
        let s = lin.signs();
        let StateSpace { a, b } = lin.state_space()?;
        let care = solve_care(&a, &b, &weights.q, &weights.r)?;
        let mut controller = Self::from_gain(s, care.gain.clone())?;
        controller.care = Some(care);
        Ok(controller)
    }

    /// LQR design with [`LqrWeights::paper_default`].
    pub fn paper(params: &ChainParams, s: &[f64]) -> Result<Self> {
        check_signs(s, params.n_links())?;
        Self::new(params, s, &LqrWeights::paper_default(s))
    }

    /// A controller with a given gain (`2 x (4 + 4n)`, `z` ordering), e.g. one computed
    /// elsewhere.
    pub fn from_gain(s: &[f64], gain: DMatrix<f64>) -> Result<Self> {
        if s.is_empty() {
            return Err(InputError::NoLinks.into());
        }
        check_signs(s, s.len())?;
        let loc = LocalLayout::new(s.len());
        crate::analysis::checks::check_shape("gain", &gain, 2, loc.dim())?;
        crate::analysis::checks::check_finite_matrix("gain", &gain)?;
        let blocks = (0..loc.dim() / 2)
            .map(|b| gain.fixed_view::<2, 2>(0, 2 * b).into_owned())
            .collect();
        Ok(Self {
            signs: s.to_vec(),
            gain,
            blocks,
            care: None,
        })
    }

    /// The equilibrium's sign tuple.
    pub fn signs(&self) -> &[f64] {
        &self.signs
    }
    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.signs.len()
    }
    /// `K`, `2 x (4 + 4n)`, in the `z` ordering.
    pub fn gain(&self) -> &DMatrix<f64> {
        &self.gain
    }
    /// The Riccati solution behind the gain (`None` for [`LqrController::from_gain`]).
    pub fn riccati(&self) -> Option<&CareSolution> {
        self.care.as_ref()
    }

    /// `u = -K_x x - K_xd xdot - sum_i [K_qi C^T(s_i e3 x q_i) + K_wi C^T w_i]`.
    /// Allocation-free. Panics if `state.len() != 4 + 6n` (use
    /// [`LqrController::try_force`] for unchecked input).
    pub fn force(&self, state: &[f64]) -> Vector2<f64> {
        let n = self.signs.len();
        let lay = Layout::<Spatial>::new(n);
        assert_eq!(state.len(), lay.dim(), "state length");
        let k = &self.blocks;
        let mut u = k[0] * lay.load_x(state) + k[n + 1] * lay.load_xdot(state);
        for (i, &si) in self.signs.iter().enumerate() {
            u += k[1 + i] * horizontal_cross(si, lay.load_q(state, i));
            u += k[n + 2 + i] * Spatial::horizontal(lay.load_w(state, i));
        }
        -u
    }

    /// [`LqrController::force`] after checking the state's length and finiteness.
    pub fn try_force(&self, state: &[f64]) -> Result<Vector2<f64>> {
        check_len("state", state, Layout::<Spatial>::new(self.n_links()).dim())?;
        check_finite("state", state)?;
        Ok(self.force(state))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_follow_the_paper() {
        let w = LqrWeights::paper_hanging(2);
        let d: Vec<f64> = w.q.diagonal().iter().copied().collect();
        assert_eq!(
            d,
            vec![8.0, 8.0, 1.0, 1.0, 1.0, 1.0, 8.0, 8.0, 1.0, 1.0, 1.0, 1.0]
        );
        let w = LqrWeights::paper_default(&[-1.0, 1.0]);
        let d: Vec<f64> = w.q.diagonal().iter().copied().collect();
        assert_eq!(
            d,
            vec![1.0, 1.0, 8.0, 8.0, 8.0, 8.0, 1.0, 1.0, 8.0, 8.0, 8.0, 8.0]
        );
        assert_eq!(w.r, DMatrix::identity(2, 2));
    }

    #[test]
    fn force_is_minus_gain_times_z() {
        let s = [1.0, -1.0];
        let gain = DMatrix::from_fn(2, 12, |i, j| (i as f64 + 1.0) * (j as f64 - 5.5));
        let c = LqrController::from_gain(&s, gain.clone()).unwrap();
        let mut y = vec![0.0; 16];
        for (k, v) in y.iter_mut().enumerate() {
            *v = (k as f64 * 1.3).sin();
        }
        let mut z = vec![0.0; 12];
        crate::analysis::coordinates::local_coordinates(&s, &y, &mut z).unwrap();
        let expected = -(&gain * DVector::from_vec(z));
        let u = c.force(&y);
        assert!((u.x - expected[0]).abs() < 1e-12 && (u.y - expected[1]).abs() < 1e-12);
        assert!(c.try_force(&y[..15]).is_err());
        assert!(LqrController::from_gain(&s, DMatrix::zeros(2, 11)).is_err());
    }
}
