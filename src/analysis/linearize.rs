//! Prop. 2: the linearisation `M xdd + G x = B u` about equilibrium `s`, in closed form.
//!
//! Coordinates `x = [dx; C^T xi_1; ..; C^T xi_n]` (length `2n + 2`), where
//! `q_i = exp(xi_i^) (s_i e3)`, `xi_i . e3 = 0`. Derivation (checked against finite
//! differences of the nonlinear model in the tests):
//!
//! * `dq_i = xi_i x (s_i e3) = -s_i e3^ C (C^T xi_i)`, and `C^T e3^ C = E = [[0, -1], [1, 0]]`
//!   (`e3^ C = [[0, -1], [1, 0], [0, 0]]`), so the horizontal velocity of link i is
//!   `C^T qdot_i = -s_i E (C^T xi_i)'`, while `qdot_i . qdot_j = s_i s_j (C^T xi_i)' . (C^T xi_j)'`
//!   because the columns of `e3^ C` are orthonormal.
//! * Kinetic energy (eq. T) to second order:
//!   `T = 1/2 M00 |dx'|^2 + sum_i dx' . (-s_i M0i E) (C^T xi_i)' + 1/2 sum_ij s_i s_j M_ij (..)' . (..)'`,
//!   hence `M_xx = M00 I2`, `M_xq_i = -s_i M0i E`, `M_qx = M_xq^T`, `M_qq_ij = s_i s_j M_ij I2`.
//!   This is the paper's `-s_i M_0i e3^ C` once its `M_0i = C^T (scalar)` is multiplied out.
//! * Potential (eq. V): `e3 . q_i = s_i cos|xi_i| ~ s_i (1 - |xi_i|^2 / 2)`, so
//!   `V = const + 1/2 sum_i s_i g l_i (sum_{a>=i} m_a) |C^T xi_i|^2`: `G_qq = diag(s_i gc_i I2)`.
//! * The force does virtual work `u . d(dx)`: `B = [I2; 0]`.
//!
//! At first order `(C^T xi_i)' = C^T w_i` (paper eq. dotxii), which gives the first-order
//! form in `z = [x, C^T xi_i, xdot, C^T w_i]`: `A = [[0, I], [-M^-1 G, 0]]`, `B = [0; M^-1 B]`.
//!
//! Structure worth knowing: every block is a 2x2 multiple of `I2` or of the rotation `E`,
//! so the spatial problem is two copies of the planar one and every eigenvalue is double.
//!
//! **A real rig** ([`Linearization::with_rig`], docs/physics.md "Real-rig effects") adds
//! `D xdot` to `M xdd + G x = B u`:
//!
//! * joint damping, Rayleigh `1/2 sum_i c_i |w_i - w_{i-1}|^2` with `w_i = (C^T xi_i)'` at
//!   first order and `w_0 = 0`: the link block `D_qq` is tridiagonal, `(c_i + c_{i+1}) I2`
//!   on the diagonal and `-c_{i+1} I2` beside it, whatever the signs `s`;
//! * cart friction: `D_xx = (b + F_c / v_eps) I2`, the Coulomb law's slope at rest (exact
//!   at first order, but the law is that steep only while `|v| < v_eps`);
//! * voltage actuation: below the current limit the force is `k (V - k v) / R` with
//!   `k = N k_t / r`, so `B = (k / R) [I2; 0]` and `D_xx` gains the back-EMF's `k^2 / R`;
//! * acceleration actuation: the cart rows become `xdd = a`, so the first-order form
//!   solves `[[I2, 0], [M_qx, M_qq]] xdd = [I2; 0] a - G x - D' xdot` (`D'` with the cart
//!   rows zero: cart friction is refused in this mode, and the servo takes the first
//!   joint's reaction).
//!
//! `modes` and `eigenvalues` stay those of the conservative part `(M, G)`.

use crate::analysis::coordinates::LocalLayout;
use crate::analysis::equilibria::check_signs;
use crate::analysis::pencil::{solve_pencil, PencilEigen};
use crate::error::{ChainError, Result};
use crate::params::{Actuation, ChainParams, Rig};
use nalgebra::{Cholesky, Complex, DMatrix, Matrix2};

/// `E = C^T e3^ C`: the horizontal part of `e3 x (.)`, a rotation by +90 degrees.
pub fn e3_hat_horizontal() -> Matrix2<f64> {
    Matrix2::new(0.0, -1.0, 1.0, 0.0)
}

/// Second-order linearisation of Prop. 2 at equilibrium `s`.
#[derive(Debug, Clone, PartialEq)]
pub struct Linearization {
    signs: Vec<f64>,
    mass: DMatrix<f64>,
    stiffness: DMatrix<f64>,
    damping: DMatrix<f64>,
    input: DMatrix<f64>,
    /// The cart's acceleration is the input (a servo axis), not a force.
    cart_prescribed: bool,
}

/// First-order form `zdot = A z + B u` in `z = [x, C^T xi_i, xdot, C^T w_i]`.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    /// `(4 + 4n) x (4 + 4n)`.
    pub a: DMatrix<f64>,
    /// `(4 + 4n) x 2`.
    pub b: DMatrix<f64>,
}

fn set_block(m: &mut DMatrix<f64>, row: usize, col: usize, block: &Matrix2<f64>) {
    m.view_mut((row, col), (2, 2)).copy_from(block);
}

impl Linearization {
    /// `M`, `G`, `B` of Prop. 2 for `params` at `s` (checked: length n, entries +-1).
    pub fn new(params: &ChainParams, s: &[f64]) -> Result<Self> {
        let n = params.n_links();
        check_signs(s, n)?;
        let loc = LocalLayout::new(n);
        let dof = loc.dof();
        let eye = Matrix2::identity();
        let e = e3_hat_horizontal();
        let mut mass = DMatrix::zeros(dof, dof);
        let mut stiffness = DMatrix::zeros(dof, dof);
        set_block(&mut mass, 0, 0, &(eye * params.total_mass()));
        for i in 0..n {
            let xq = e * (-s[i] * params.cart_coupling(i));
            set_block(&mut mass, 0, loc.xi(i), &xq);
            set_block(&mut mass, loc.xi(i), 0, &xq.transpose());
            for j in 0..n {
                let mij = s[i] * s[j] * params.inertia(i, j);
                set_block(&mut mass, loc.xi(i), loc.xi(j), &(eye * mij));
            }
            let gi = s[i] * params.gravity_coefficient(i);
            set_block(&mut stiffness, loc.xi(i), loc.xi(i), &(eye * gi));
        }
        let mut input = DMatrix::zeros(dof, 2);
        set_block(&mut input, 0, 0, &eye);
        Ok(Self {
            signs: s.to_vec(),
            mass,
            stiffness,
            damping: DMatrix::zeros(dof, dof),
            input,
            cart_prescribed: false,
        })
    }

    /// The linearisation at `s` of `params` with the real-rig effects `rig` (checked for
    /// this chain), its input `u` the command of the rig's actuation (see the module docs).
    pub fn with_rig(params: &ChainParams, s: &[f64], rig: &Rig) -> Result<Self> {
        let n = params.n_links();
        rig.validate(n)?;
        let mut lin = Self::new(params, s)?;
        let loc = LocalLayout::new(n);
        let eye = Matrix2::identity();
        for i in 0..n {
            let outer = if i + 1 < n { rig.damping(i + 1) } else { 0.0 };
            set_block(
                &mut lin.damping,
                loc.xi(i),
                loc.xi(i),
                &(eye * (rig.damping(i) + outer)),
            );
            if i + 1 < n {
                set_block(&mut lin.damping, loc.xi(i), loc.xi(i + 1), &(-eye * outer));
                set_block(&mut lin.damping, loc.xi(i + 1), loc.xi(i), &(-eye * outer));
            }
        }
        let mut cart_damping = rig.cart_viscous_friction;
        if rig.cart_coulomb_friction != 0.0 {
            cart_damping += rig.cart_coulomb_friction / rig.coulomb_velocity;
        }
        match &rig.actuation {
            Actuation::Force => {}
            Actuation::Acceleration => lin.cart_prescribed = true,
            Actuation::Voltage(motor) => {
                let k = motor.force_per_amp();
                lin.input *= k / motor.resistance;
                cart_damping += k * k / motor.resistance;
            }
        }
        set_block(&mut lin.damping, 0, 0, &(eye * cart_damping));
        Ok(lin)
    }

    /// The equilibrium's sign tuple.
    pub fn signs(&self) -> &[f64] {
        &self.signs
    }
    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.signs.len()
    }
    /// `M`, `(2n + 2)` square, symmetric positive definite.
    pub fn mass_matrix(&self) -> &DMatrix<f64> {
        &self.mass
    }
    /// `G`, `(2n + 2)` square, zero in the cart rows and columns.
    pub fn stiffness_matrix(&self) -> &DMatrix<f64> {
        &self.stiffness
    }
    /// `D`, `(2n + 2)` square, symmetric positive semi-definite: the rig's damping and
    /// friction (zero for the ideal model).
    pub fn damping_matrix(&self) -> &DMatrix<f64> {
        &self.damping
    }
    /// `B = [I2; 0]` (times `k / R` in voltage actuation), `(2n + 2) x 2`.
    pub fn input_matrix(&self) -> &DMatrix<f64> {
        &self.input
    }
    /// The input is the cart's acceleration (acceleration actuation), not a force.
    pub fn cart_prescribed(&self) -> bool {
        self.cart_prescribed
    }
    /// `M_qq` (`2n` square), the chain's inertia with the cart held.
    pub fn m_qq(&self) -> DMatrix<f64> {
        let k = 2 * self.n_links();
        self.mass.view((2, 2), (k, k)).into_owned()
    }
    /// `G_qq` (`2n` square).
    pub fn g_qq(&self) -> DMatrix<f64> {
        let k = 2 * self.n_links();
        self.stiffness.view((2, 2), (k, k)).into_owned()
    }
    /// `D_qq` (`2n` square), the joints' damping (zero for the ideal model).
    pub fn d_qq(&self) -> DMatrix<f64> {
        let k = 2 * self.n_links();
        self.damping.view((2, 2), (k, k)).into_owned()
    }
    /// `M_qx = M_xq^T` (`2n x 2`): how the chain's modes push the cart (Prop. 3's input).
    pub fn m_qx(&self) -> DMatrix<f64> {
        let k = 2 * self.n_links();
        self.mass.view((2, 0), (k, 2)).into_owned()
    }

    /// The first-order form `A`, `B` (see the module docs).
    pub fn state_space(&self) -> Result<StateSpace> {
        let dof = self.mass.nrows();
        let chol = Cholesky::new(self.mass.clone()).ok_or_else(|| ChainError::Analysis {
            reason: "linearised mass matrix M is not positive definite".into(),
        })?;
        let (minv_g, minv_d, minv_b) = if self.cart_prescribed {
            // The cart rows say `xdd = a`; the link rows keep `M_qx xdd` (module docs).
            let mut rows = self.mass.clone();
            rows.view_mut((0, 0), (2, dof)).fill(0.0);
            rows.view_mut((0, 0), (2, 2))
                .copy_from(&DMatrix::identity(2, 2));
            let mut damping = self.damping.clone();
            damping.view_mut((0, 0), (2, dof)).fill(0.0);
            let lu = rows.lu();
            let solve = |m: &DMatrix<f64>| {
                lu.solve(m).ok_or_else(|| ChainError::Analysis {
                    reason: "the chain's inertia M_qq with the cart prescribed is singular".into(),
                })
            };
            (
                solve(&self.stiffness)?,
                solve(&damping)?,
                solve(&self.input)?,
            )
        } else {
            (
                chol.solve(&self.stiffness),
                chol.solve(&self.damping),
                chol.solve(&self.input),
            )
        };
        let mut a = DMatrix::zeros(2 * dof, 2 * dof);
        a.view_mut((0, dof), (dof, dof))
            .copy_from(&DMatrix::identity(dof, dof));
        a.view_mut((dof, 0), (dof, dof)).copy_from(&(-minv_g));
        if self.damping.iter().any(|&v| v != 0.0) {
            a.view_mut((dof, dof), (dof, dof)).copy_from(&(-minv_d));
        }
        let mut b = DMatrix::zeros(2 * dof, 2);
        b.view_mut((dof, 0), (dof, 2)).copy_from(&minv_b);
        Ok(StateSpace { a, b })
    }

    /// `G v = mu M v` with `lambda^2 = -mu`: `mu > 0` an oscillation at `sqrt(mu)` rad/s,
    /// `mu < 0` a saddle with rates `+-sqrt(-mu)`, `mu = 0` the cart's rigid motion.
    pub fn modes(&self) -> Result<PencilEigen> {
        solve_pencil(&self.stiffness, &self.mass)
    }

    /// The `4 + 4n` eigenvalues of `A`, from [`Linearization::modes`]: for each `mu`,
    /// `+-sqrt(-mu)` (real for `mu < 0`, imaginary for `mu > 0`). This keeps the exact
    /// structure (the cart's zeros form Jordan blocks, which a general eigen-solver on `A`
    /// would split into `+-1e-8`-sized spurious pairs). `mu` below `1e-12 max|mu|` counts as 0.
    pub fn eigenvalues(&self) -> Result<Vec<Complex<f64>>> {
        let modes = self.modes()?;
        let zero = 1e-12 * modes.values.amax();
        let mut out = Vec::with_capacity(2 * modes.values.len());
        for &mu in modes.values.iter() {
            let lambda = if mu.abs() <= zero {
                Complex::new(0.0, 0.0)
            } else if mu < 0.0 {
                Complex::new((-mu).sqrt(), 0.0)
            } else {
                Complex::new(0.0, mu.sqrt())
            };
            out.push(lambda);
            out.push(-lambda);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn e3_hat_c_is_the_horizontal_rotation() {
        let c = nalgebra::Matrix3x2::new(1.0, 0.0, 0.0, 1.0, 0.0, 0.0);
        let e3 = nalgebra::Vector3::new(0.0, 0.0, 1.0);
        assert_eq!(c.transpose() * e3.cross_matrix() * c, e3_hat_horizontal());
    }

    #[test]
    fn single_pendulum_has_the_textbook_frequency() {
        // Pendulum on a free cart: lambda^2 = -g (m + m1) / (m l).
        let p = ChainParams::new(2.0, &[0.5], &[0.3], 9.81).unwrap();
        let hang = Linearization::new(&p, &[1.0]).unwrap();
        let mu = hang.modes().unwrap().values;
        let expected = 9.81 * 2.5 / (2.0 * 0.3);
        assert!((mu[3] - expected).abs() < 1e-12 * expected, "{mu}");
        let up = Linearization::new(&p, &[-1.0]).unwrap();
        let mu = up.modes().unwrap().values;
        assert!((mu[0] + expected).abs() < 1e-12 * expected, "{mu}");
    }
}
