//! The planner's chart on the state manifold: increments of `2 + 2n` (planar) or
//! `4 + 4n` (spatial) numbers about any state, never leaving `|q_i| = 1`,
//! `w_i . q_i = 0`.
//!
//! About a base state `(x, xdot, q_i, w_i)` each link is varied by the paper's own
//! variations, `q_i -> exp(xi_i^) q_i` with `xi_i . q_i = 0`, and its spin by a
//! tangent increment carried along: `w_i -> exp(xi_i^) (w_i + omega_i)`. The
//! coordinates of `xi_i` and `omega_i` are taken in an orthonormal basis `b_1, b_2`
//! of the plane normal to `q_i` ([`ScalarGeometry::tangent_basis`]); in the plane,
//! one angle and one rate. The order is the paper's
//! `z = [x, xi_1..n, xdot, omega_1..n]`.
//!
//! At an equilibrium the basis is `C = [e1, e2]`, so the chart is exactly the local
//! coordinates of [`crate::analysis::coordinates`] to first order, and the Riccati
//! solution there is the cost-to-go in these coordinates. [`retract`] and [`local`]
//! are exact inverses of each other (the sphere's exponential and logarithm), so
//! deviations from a nominal trajectory are measured without linearisation error.

use super::dual::Real;
use super::vector::{ScalarGeometry, Vect};
use crate::geometry::Layout;

/// Offsets of the parts of a chart increment `[x, xi_1..n, xdot, omega_1..n]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChartLayout {
    /// Number of links.
    pub n: usize,
    /// Components of the cart position (1 planar, 2 spatial).
    pub cart: usize,
    /// Coordinates per link tilt and per spin (1 planar, 2 spatial).
    pub tangent: usize,
}

impl ChartLayout {
    /// The layout for `n` links of scene `G`.
    pub const fn of<G: ScalarGeometry>(n: usize) -> Self {
        Self {
            n,
            cart: G::CART,
            tangent: G::TANGENT,
        }
    }
    /// `2 + 2n` planar, `4 + 4n` spatial.
    pub const fn dim(&self) -> usize {
        2 * self.cart + 2 * self.n * self.tangent
    }
    /// Offset of the cart position.
    pub const fn x(&self) -> usize {
        0
    }
    /// Offset of link `i`'s tilt.
    pub const fn tilt(&self, i: usize) -> usize {
        self.cart + i * self.tangent
    }
    /// Offset of the cart velocity.
    pub const fn xdot(&self) -> usize {
        self.cart + self.n * self.tangent
    }
    /// Offset of link `i`'s spin increment.
    pub const fn spin(&self, i: usize) -> usize {
        2 * self.cart + (self.n + i) * self.tangent
    }
}

/// A base state of the chart with its tangent bases.
#[derive(Clone, Debug, PartialEq)]
pub struct ChartPoint {
    /// The state, in the model's layout.
    pub y: Vec<f64>,
    /// Per link, the basis `b_1, b_2` of the plane normal to `q_i` (spin components).
    basis: Vec<[[f64; 3]; 2]>,
}

impl ChartPoint {
    /// The chart about `y` (a state of `n` links of scene `G`).
    pub fn new<G: ScalarGeometry>(n: usize, y: &[f64]) -> Self {
        let mut p = Self {
            y: y.to_vec(),
            basis: vec![[[0.0; 3]; 2]; n],
        };
        p.set::<G>(y);
        p
    }

    /// Moves the base to `y` without allocating.
    pub fn set<G: ScalarGeometry>(&mut self, y: &[f64]) {
        self.y.copy_from_slice(y);
        let lay = Layout::<G>::new(self.basis.len());
        for (i, b) in self.basis.iter_mut().enumerate() {
            *b = G::tangent_basis(&y[lay.q(i)..lay.q(i) + G::LINK]);
        }
    }

    fn spin_of<G: ScalarGeometry, S: Real>(&self, i: usize, coords: &[S]) -> G::SpinS<S> {
        let mut v = G::SpinS::<S>::constant(&self.basis[i][0]) * coords[0];
        for (k, &c) in coords.iter().enumerate().take(G::TANGENT).skip(1) {
            v += G::SpinS::<S>::constant(&self.basis[i][k]) * c;
        }
        v
    }

    fn coords_of<G: ScalarGeometry, S: Real>(&self, i: usize, v: G::SpinS<S>, out: &mut [S]) {
        for (k, o) in out.iter_mut().enumerate().take(G::TANGENT) {
            *o = v.dot(G::SpinS::<S>::constant(&self.basis[i][k]));
        }
    }
}

/// The state at increment `delta` (length [`ChartLayout::dim`]) from `base`.
pub fn retract<G: ScalarGeometry, S: Real>(base: &ChartPoint, delta: &[S], y: &mut [S]) {
    let n = base.basis.len();
    let (lay, chart) = (Layout::<G>::new(n), ChartLayout::of::<G>(n));
    for c in 0..G::CART {
        y[lay.x() + c] = delta[chart.x() + c] + base.y[lay.x() + c];
        y[lay.xdot() + c] = delta[chart.xdot() + c] + base.y[lay.xdot() + c];
    }
    for i in 0..n {
        let xi = base.spin_of::<G, S>(i, &delta[chart.tilt(i)..]);
        let q = G::rotate_s(xi, G::LinkS::<S>::constant(&base.y[lay.q(i)..]));
        let w = G::SpinS::<S>::constant(&base.y[lay.w(i)..])
            + base.spin_of::<G, S>(i, &delta[chart.spin(i)..]);
        q.store(&mut y[lay.q(i)..]);
        G::transport(xi, w).store(&mut y[lay.w(i)..]);
    }
}

/// The increment from `base` to the state `y`: the inverse of [`retract`].
pub fn local<G: ScalarGeometry, S: Real>(base: &ChartPoint, y: &[S], delta: &mut [S]) {
    let n = base.basis.len();
    let (lay, chart) = (Layout::<G>::new(n), ChartLayout::of::<G>(n));
    for c in 0..G::CART {
        delta[chart.x() + c] = y[lay.x() + c] + (-base.y[lay.x() + c]);
        delta[chart.xdot() + c] = y[lay.xdot() + c] + (-base.y[lay.xdot() + c]);
    }
    for i in 0..n {
        let q = G::LinkS::<S>::load(&y[lay.q(i)..]);
        let xi = G::log(G::LinkS::<S>::constant(&base.y[lay.q(i)..]), q);
        base.coords_of::<G, S>(i, xi, &mut delta[chart.tilt(i)..]);
        let w = G::transport(-xi, G::SpinS::<S>::load(&y[lay.w(i)..]))
            - G::SpinS::<S>::constant(&base.y[lay.w(i)..]);
        base.coords_of::<G, S>(i, w, &mut delta[chart.spin(i)..]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::{local_coordinates, state_from_local};
    use crate::geometry::{Planar, Spatial};
    use crate::model::Chain;
    use crate::params::ChainParams;
    use rand::{Rng, SeedableRng};

    fn random_state<G: ScalarGeometry>(n: usize, rng: &mut impl Rng) -> Vec<f64> {
        let chain = Chain::<G>::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap());
        let mut y: Vec<f64> = (0..chain.state_dim())
            .map(|_| rng.random_range(-1.0..1.0))
            .collect();
        chain.project(&mut y);
        y
    }

    fn round_trip<G: ScalarGeometry>(n: usize) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let chart = ChartLayout::of::<G>(n);
        for _ in 0..20 {
            let base = ChartPoint::new::<G>(n, &random_state::<G>(n, &mut rng));
            let delta: Vec<f64> = (0..chart.dim())
                .map(|_| rng.random_range(-1.0..1.0))
                .collect();
            let mut y = vec![0.0; base.y.len()];
            retract::<G, f64>(&base, &delta, &mut y);
            let lay = Layout::<G>::new(n);
            for i in 0..n {
                let q = G::LinkS::<f64>::load(&y[lay.q(i)..]);
                let w = G::SpinS::<f64>::load(&y[lay.w(i)..]);
                assert!((q.norm_squared() - 1.0).abs() < 1e-14);
                assert!((G::tangent_s(w, q) - w).norm_squared() < 1e-28);
            }
            let mut back = vec![0.0; chart.dim()];
            local::<G, f64>(&base, &y, &mut back);
            for (a, b) in delta.iter().zip(&back) {
                assert!((a - b).abs() < 1e-12, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn local_inverts_retract_and_keeps_the_constraints() {
        for n in [1, 3] {
            round_trip::<Planar>(n);
            round_trip::<Spatial>(n);
        }
    }

    #[test]
    fn at_an_equilibrium_the_chart_is_the_papers_local_coordinates() {
        let s = [1.0, -1.0, -1.0];
        let chain = Chain::<Spatial>::new(ChainParams::uniform(3, 1.0, 0.1, 0.5, 9.81).unwrap());
        let base = ChartPoint::new::<Spatial>(3, &chain.equilibrium(&s).unwrap());
        let z: Vec<f64> = (0..16).map(|k| 0.2 * ((k as f64).sin())).collect();
        let mut y = vec![0.0; 22];
        state_from_local(&s, &z, &mut y).unwrap();
        let mut delta = vec![0.0; 16];
        local::<Spatial, f64>(&base, &y, &mut delta);
        let mut paper = vec![0.0; 16];
        local_coordinates(&s, &y, &mut paper).unwrap();
        // The positions (cart and tilts) are the exponential chart's, exactly.
        for k in 0..8 {
            assert!(
                (delta[k] - z[k]).abs() < 1e-12,
                "{k}: {} vs {}",
                delta[k],
                z[k]
            );
        }
        // Everything agrees with the controller's map to first order.
        for scale in [1e-2, 1e-3] {
            let zs: Vec<f64> = z.iter().map(|v| v * scale).collect();
            state_from_local(&s, &zs, &mut y).unwrap();
            local::<Spatial, f64>(&base, &y, &mut delta);
            local_coordinates(&s, &y, &mut paper).unwrap();
            for (a, b) in delta.iter().zip(&paper) {
                assert!((a - b).abs() < 3.0 * scale * scale, "{scale}: {a} vs {b}");
            }
        }
    }
}
