//! The paper's dense Euler-Lagrange equations (eq. ELwm), O(n^3).
//!
//! Kept as an independent oracle for the O(n) form in [`crate::model`] and as a
//! selectable reference for comparisons; never used in the step loop.

use crate::geometry::{Layout, Spatial};
use crate::params::ChainParams;
use nalgebra::{DMatrix, DVector, Matrix3, Vector2, Vector3};

fn hat(v: Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The (2+3n)-square matrix and right-hand side of eq. (ELwm) at state `y`.
pub fn elwm_system(
    params: &ChainParams,
    y: &[f64],
    force: Vector2<f64>,
) -> (DMatrix<f64>, DVector<f64>) {
    let n = params.n_links();
    let lay = Layout::<Spatial>::new(n);
    let dim = 2 + 3 * n;
    let mut a = DMatrix::<f64>::zeros(dim, dim);
    let mut b = DVector::<f64>::zeros(dim);
    let q: Vec<Vector3<f64>> = (0..n).map(|i| lay.load_q(y, i)).collect();
    let w: Vec<Vector3<f64>> = (0..n).map(|i| lay.load_w(y, i)).collect();
    let ct = |v: Vector3<f64>| Vector2::new(v.x, v.y); // C^T
    let e3 = Vector3::new(0.0, 0.0, 1.0);

    // Cart rows: M00 xdd - sum_j M0j q_j^ wdot_j = sum_j M0j |w_j|^2 q_j + u.
    let m00 = params.total_mass();
    a[(0, 0)] = m00;
    a[(1, 1)] = m00;
    let mut rhs_x = force;
    for j in 0..n {
        let block = -hat(q[j]) * params.cart_coupling(j);
        a.view_mut((0, 2 + 3 * j), (2, 3))
            .copy_from(&block.fixed_rows::<2>(0));
        rhs_x += ct(q[j]) * (params.cart_coupling(j) * w[j].norm_squared());
    }
    b.rows_mut(0, 2).copy_from(&rhs_x);

    // Link rows: q_i^ M_i0 xdd + M_ii wdot_i - sum_{j!=i} M_ij q_i^ q_j^ wdot_j
    //          = sum_{j!=i} M_ij |w_j|^2 q_i^ q_j + (sum_{a>=i} m_a) g l_i q_i^ e3.
    for i in 0..n {
        let r = 2 + 3 * i;
        let qi_hat = hat(q[i]);
        let mi0 = qi_hat * params.cart_coupling(i);
        a.view_mut((r, 0), (3, 2))
            .copy_from(&mi0.fixed_columns::<2>(0));
        let mut rhs = qi_hat * e3 * params.gravity_coefficient(i);
        for j in 0..n {
            let c = 2 + 3 * j;
            if i == j {
                a.view_mut((r, c), (3, 3))
                    .copy_from(&(Matrix3::identity() * params.inertia(i, i)));
            } else {
                let mij = params.inertia(i, j);
                a.view_mut((r, c), (3, 3))
                    .copy_from(&(-(qi_hat * hat(q[j])) * mij));
                rhs += qi_hat * q[j] * (mij * w[j].norm_squared());
            }
        }
        b.rows_mut(r, 3).copy_from(&rhs);
    }
    (a, b)
}

/// The joint damping's share of the right-hand side of eq. (ELwm): the generalised
/// moment on link i of the Rayleigh function `D = 1/2 sum_i c_i |w_i - w_{i-1}|^2`
/// (`w_0 = 0`), `-dD/dw_i = tau_i - tau_{i+1}` with `tau_i = -c_i (w_i - w_{i-1})`,
/// projected onto the plane normal to `q_i` (a moment along the massless link moves
/// nothing). The cart rows get nothing: the couples are internal. `damping` holds
/// one coefficient per link.
pub fn elwm_damping_moments(params: &ChainParams, y: &[f64], damping: &[f64]) -> DVector<f64> {
    let n = params.n_links();
    let lay = Layout::<Spatial>::new(n);
    let w = |i: usize| lay.load_w(y, i);
    let tau = |i: usize| {
        if i >= n {
            return Vector3::zeros();
        }
        let below = if i > 0 { w(i - 1) } else { Vector3::zeros() };
        (w(i) - below) * (-damping[i])
    };
    let mut b = DVector::<f64>::zeros(2 + 3 * n);
    for i in 0..n {
        let q = lay.load_q(y, i);
        let moment = tau(i) - tau(i + 1);
        let normal = moment - q * moment.dot(&q);
        b.rows_mut(2 + 3 * i, 3).copy_from(&normal);
    }
    b
}

/// State derivative from the dense form, same layout as [`crate::model::Chain::derivative`].
/// Returns `None` if the dense matrix is numerically singular.
pub fn dense_derivative(
    params: &ChainParams,
    y: &[f64],
    force: Vector2<f64>,
    dy: &mut [f64],
) -> Option<()> {
    dense_derivative_damped(params, y, force, &[], dy)
}

/// [`dense_derivative`] with viscous joint damping, one coefficient per link (empty:
/// none), added as [`elwm_damping_moments`].
pub fn dense_derivative_damped(
    params: &ChainParams,
    y: &[f64],
    force: Vector2<f64>,
    damping: &[f64],
    dy: &mut [f64],
) -> Option<()> {
    let n = params.n_links();
    let lay = Layout::<Spatial>::new(n);
    let (a, mut b) = elwm_system(params, y, force);
    if !damping.is_empty() {
        b += elwm_damping_moments(params, y, damping);
    }
    let sol = a.lu().solve(&b)?;
    lay.store_x(dy, lay.load_xdot(y));
    lay.store_xdot(dy, Vector2::new(sol[0], sol[1]));
    for i in 0..n {
        let q = lay.load_q(y, i);
        lay.store_q(dy, i, lay.load_w(y, i).cross(&q));
        lay.store_w(
            dy,
            i,
            Vector3::new(sol[2 + 3 * i], sol[3 + 3 * i], sol[4 + 3 * i]),
        );
    }
    Some(())
}
