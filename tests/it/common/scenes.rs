//! The paper's initial conditions, shared by the tests.
#![allow(dead_code)]

use chaincart::geometry::Layout;
use chaincart::Spatial;
use nalgebra::{Vector2, Vector3};

/// Paper eq. (IC1): the perturbed folded start of Fig. 1 (also used for Fig. 2).
pub fn paper_ic1() -> Vec<f64> {
    let lay = Layout::<Spatial>::new(5);
    let mut y = vec![0.0; lay.dim()];
    lay.store_x(&mut y, Vector2::new(0.2, 0.1));
    lay.store_xdot(&mut y, Vector2::new(0.0, -0.1));
    for i in 0..4 {
        // q_i = (-1)^i e3 for i = 1..4 (1-based).
        let sign = if (i + 1) % 2 == 0 { 1.0 } else { -1.0 };
        lay.store_q(&mut y, i, Vector3::new(0.0, 0.0, sign));
    }
    let d = 1f64.to_radians();
    lay.store_q(&mut y, 4, Vector3::new(d.sin(), 0.0, -d.cos()));
    y
}
