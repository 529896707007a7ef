//! Small vectors over any [`Real`] scalar, and the scene operations written on them:
//! the geometry of [`crate::geometry`] made generic in the scalar, so that the same
//! dynamics code yields values (`f64`) and derivatives ([`super::dual::Dual`]).

use super::dual::Real;
use crate::geometry::{Geometry, Planar, Spatial};
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// A fixed-size vector of `D` scalars.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V<S, const D: usize>(pub [S; D]);

impl<S: Real, const D: usize> Add for V<S, D> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, o: Self) -> Self {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
        self
    }
}

impl<S: Real, const D: usize> Sub for V<S, D> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, o: Self) -> Self {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a -= b;
        }
        self
    }
}

impl<S: Real, const D: usize> Neg for V<S, D> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self(self.0.map(|a| -a))
    }
}

impl<S: Real, const D: usize> Mul<S> for V<S, D> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, c: S) -> Self {
        Self(self.0.map(|a| a * c))
    }
}

impl<S: Real, const D: usize> AddAssign for V<S, D> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl<S: Real, const D: usize> SubAssign for V<S, D> {
    #[inline(always)]
    fn sub_assign(&mut self, o: Self) {
        *self = *self - o;
    }
}

/// The operations the generic dynamics and chart need from a small vector.
pub trait Vect<S: Real>:
    Copy
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Neg<Output = Self>
    + Mul<S, Output = Self>
    + AddAssign
    + SubAssign
{
    /// Number of components.
    const DIM: usize;
    /// The zero vector.
    fn zero() -> Self;
    /// Euclidean inner product.
    fn dot(self, o: Self) -> S;
    /// Squared norm.
    #[inline(always)]
    fn norm_squared(self) -> S {
        self.dot(self)
    }
    /// Multiplication by a constant.
    fn scale(self, c: f64) -> Self;
    /// Reads the first `DIM` entries of `s`.
    fn load(s: &[S]) -> Self;
    /// Reads the first `DIM` entries of `s` as constants.
    fn constant(s: &[f64]) -> Self;
    /// Writes the vector into the first `DIM` entries of `s`.
    fn store(self, s: &mut [S]);
    /// Writes the values (real parts) into the first `DIM` entries of `s`.
    fn store_re(self, s: &mut [f64]);
}

impl<S: Real, const D: usize> Vect<S> for V<S, D> {
    const DIM: usize = D;
    #[inline(always)]
    fn zero() -> Self {
        Self([S::cst(0.0); D])
    }
    #[inline(always)]
    fn dot(self, o: Self) -> S {
        let mut acc = self.0[0] * o.0[0];
        for k in 1..D {
            acc += self.0[k] * o.0[k];
        }
        acc
    }
    #[inline(always)]
    fn scale(self, c: f64) -> Self {
        Self(self.0.map(|a| a * c))
    }
    #[inline(always)]
    fn load(s: &[S]) -> Self {
        Self(std::array::from_fn(|k| s[k]))
    }
    #[inline(always)]
    fn constant(s: &[f64]) -> Self {
        Self(std::array::from_fn(|k| S::cst(s[k])))
    }
    #[inline(always)]
    fn store(self, s: &mut [S]) {
        s[..D].copy_from_slice(&self.0);
    }
    #[inline(always)]
    fn store_re(self, s: &mut [f64]) {
        for (o, a) in s[..D].iter_mut().zip(self.0) {
            *o = a.re();
        }
    }
}

/// A scene whose operations are also written for any `Real` scalar, with the
/// tangent bases of the planner's chart (see `super::chart`).
pub trait ScalarGeometry: Geometry {
    /// Components of the cart position and force (2 spatial, 1 planar).
    const CART: usize;
    /// Components of a link direction (3 spatial, 2 planar).
    const LINK: usize;
    /// Components of a spin (3 spatial, 1 planar).
    const SPIN: usize;
    /// Chart coordinates per link direction, and per spin (2 spatial, 1 planar).
    const TANGENT: usize;
    /// Cart position, velocity and force.
    type CartS<S: Real>: Vect<S>;
    /// Link direction.
    type LinkS<S: Real>: Vect<S>;
    /// Angular velocity.
    type SpinS<S: Real>: Vect<S>;

    /// `w x q`.
    fn velocity_s<S: Real>(w: Self::SpinS<S>, q: Self::LinkS<S>) -> Self::LinkS<S>;
    /// `q x a`.
    fn spin_s<S: Real>(q: Self::LinkS<S>, a: Self::LinkS<S>) -> Self::SpinS<S>;
    /// `C^T v`.
    fn horizontal_s<S: Real>(v: Self::LinkS<S>) -> Self::CartS<S>;
    /// `C x`.
    fn lift_s<S: Real>(x: Self::CartS<S>) -> Self::LinkS<S>;
    /// `e3 . v`.
    fn down_s<S: Real>(v: Self::LinkS<S>) -> S;
    /// `e3`.
    fn down_unit_s<S: Real>() -> Self::LinkS<S>;
    /// `exp(theta^) v`.
    fn rotate_s<S: Real>(theta: Self::SpinS<S>, v: Self::LinkS<S>) -> Self::LinkS<S>;
    /// `exp(theta^) w` for a spin (the identity in the plane, where spins are
    /// normal to the plane of rotation).
    fn transport<S: Real>(theta: Self::SpinS<S>, w: Self::SpinS<S>) -> Self::SpinS<S>;
    /// The rotation vector `theta`, normal to both unit vectors, with
    /// `exp(theta^) base = q` (the logarithm on the sphere; undefined at `q = -base`).
    fn log<S: Real>(base: Self::LinkS<S>, q: Self::LinkS<S>) -> Self::SpinS<S>;
    /// `w` minus its component along the unit vector `q`.
    fn tangent_s<S: Real>(w: Self::SpinS<S>, q: Self::LinkS<S>) -> Self::SpinS<S>;
    /// An orthonormal basis of the spins tangent to the unit vector `q` (its first
    /// [`ScalarGeometry::TANGENT`] entries; `SPIN` components each): the spatial one is
    /// `C = [e1, e2]` carried from the nearer pole `+-e3` to `q` by the shortest
    /// rotation, so that at an equilibrium the chart is the paper's local coordinates.
    fn tangent_basis(q: &[f64]) -> [[f64; 3]; 2];
}

impl ScalarGeometry for Spatial {
    const CART: usize = 2;
    const LINK: usize = 3;
    const SPIN: usize = 3;
    const TANGENT: usize = 2;
    type CartS<S: Real> = V<S, 2>;
    type LinkS<S: Real> = V<S, 3>;
    type SpinS<S: Real> = V<S, 3>;

    #[inline(always)]
    fn velocity_s<S: Real>(w: V<S, 3>, q: V<S, 3>) -> V<S, 3> {
        cross(w, q)
    }
    #[inline(always)]
    fn spin_s<S: Real>(q: V<S, 3>, a: V<S, 3>) -> V<S, 3> {
        cross(q, a)
    }
    #[inline(always)]
    fn horizontal_s<S: Real>(v: V<S, 3>) -> V<S, 2> {
        V([v.0[0], v.0[1]])
    }
    #[inline(always)]
    fn lift_s<S: Real>(x: V<S, 2>) -> V<S, 3> {
        V([x.0[0], x.0[1], S::cst(0.0)])
    }
    #[inline(always)]
    fn down_s<S: Real>(v: V<S, 3>) -> S {
        v.0[2]
    }
    #[inline(always)]
    fn down_unit_s<S: Real>() -> V<S, 3> {
        V([S::cst(0.0), S::cst(0.0), S::cst(1.0)])
    }
    #[inline(always)]
    fn rotate_s<S: Real>(theta: V<S, 3>, v: V<S, 3>) -> V<S, 3> {
        // Rodrigues with sin(t)/t and (1 - cos t)/t^2, by their series for small t
        // (where they also differentiate cleanly at t = 0).
        let t2 = theta.norm_squared();
        let (a, b) = if t2.re() < 1e-8 {
            (
                S::cst(1.0) - t2 * (1.0 / 6.0) * (S::cst(1.0) - t2 * (1.0 / 20.0)),
                S::cst(0.5) - t2 * (1.0 / 24.0) * (S::cst(1.0) - t2 * (1.0 / 30.0)),
            )
        } else {
            let t = t2.sqrt();
            let (s, c) = t.sin_cos();
            (s / t, (S::cst(1.0) - c) / t2)
        };
        let txv = cross(theta, v);
        v + txv * a + cross(theta, txv) * b
    }
    #[inline(always)]
    fn transport<S: Real>(theta: V<S, 3>, w: V<S, 3>) -> V<S, 3> {
        Self::rotate_s(theta, w)
    }
    #[inline(always)]
    fn log<S: Real>(base: V<S, 3>, q: V<S, 3>) -> V<S, 3> {
        // theta = angle (base x q) / |base x q|. Near base, angle / sin(angle) is taken
        // from its series in sin^2 so that the derivative at q = base exists.
        let c = cross(base, q);
        let s2 = c.norm_squared();
        let d = base.dot(q);
        let factor = if s2.re() < 1e-12 && d.re() > 0.0 {
            S::cst(1.0) + s2 * (1.0 / 6.0) + s2 * s2 * (3.0 / 40.0)
        } else {
            let s = (s2 + 1e-300).sqrt();
            s.atan2(d) / s
        };
        c * factor
    }
    #[inline(always)]
    fn tangent_s<S: Real>(w: V<S, 3>, q: V<S, 3>) -> V<S, 3> {
        w - q * w.dot(q)
    }
    fn tangent_basis(q: &[f64]) -> [[f64; 3]; 2] {
        // R = I + k^ + k^2 / (1 + c), k = p x q, c = p . q >= 0, p = sign(q_3) e3: the
        // shortest rotation taking the pole p to q; the basis is R e1, R e2.
        let sigma = if q[2] >= 0.0 { 1.0 } else { -1.0 };
        let k = [-sigma * q[1], sigma * q[0], 0.0];
        let c = sigma * q[2];
        let f = 1.0 / (1.0 + c);
        let rotate = |e: [f64; 3]| {
            let kxe = cross_f64(k, e);
            let kxkxe = cross_f64(k, kxe);
            std::array::from_fn(|i| e[i] + kxe[i] + f * kxkxe[i])
        };
        [rotate([1.0, 0.0, 0.0]), rotate([0.0, 1.0, 0.0])]
    }
}

impl ScalarGeometry for Planar {
    const CART: usize = 1;
    const LINK: usize = 2;
    const SPIN: usize = 1;
    const TANGENT: usize = 1;
    type CartS<S: Real> = V<S, 1>;
    type LinkS<S: Real> = V<S, 2>;
    type SpinS<S: Real> = V<S, 1>;

    // As in crate::geometry: links are (e1, e3) components, spins are along e2.
    #[inline(always)]
    fn velocity_s<S: Real>(w: V<S, 1>, q: V<S, 2>) -> V<S, 2> {
        V([w.0[0] * q.0[1], -(w.0[0] * q.0[0])])
    }
    #[inline(always)]
    fn spin_s<S: Real>(q: V<S, 2>, a: V<S, 2>) -> V<S, 1> {
        V([q.0[1] * a.0[0] - q.0[0] * a.0[1]])
    }
    #[inline(always)]
    fn horizontal_s<S: Real>(v: V<S, 2>) -> V<S, 1> {
        V([v.0[0]])
    }
    #[inline(always)]
    fn lift_s<S: Real>(x: V<S, 1>) -> V<S, 2> {
        V([x.0[0], S::cst(0.0)])
    }
    #[inline(always)]
    fn down_s<S: Real>(v: V<S, 2>) -> S {
        v.0[1]
    }
    #[inline(always)]
    fn down_unit_s<S: Real>() -> V<S, 2> {
        V([S::cst(0.0), S::cst(1.0)])
    }
    #[inline(always)]
    fn rotate_s<S: Real>(theta: V<S, 1>, v: V<S, 2>) -> V<S, 2> {
        let (s, c) = theta.0[0].sin_cos();
        V([c * v.0[0] + s * v.0[1], c * v.0[1] - s * v.0[0]])
    }
    #[inline(always)]
    fn transport<S: Real>(_theta: V<S, 1>, w: V<S, 1>) -> V<S, 1> {
        w
    }
    #[inline(always)]
    fn log<S: Real>(base: V<S, 2>, q: V<S, 2>) -> V<S, 1> {
        V([Self::spin_s(base, q).0[0].atan2(base.dot(q))])
    }
    #[inline(always)]
    fn tangent_s<S: Real>(w: V<S, 1>, _q: V<S, 2>) -> V<S, 1> {
        w
    }
    fn tangent_basis(_q: &[f64]) -> [[f64; 3]; 2] {
        [[1.0, 0.0, 0.0], [0.0; 3]]
    }
}

#[inline(always)]
fn cross<S: Real>(a: V<S, 3>, b: V<S, 3>) -> V<S, 3> {
    let (a, b) = (a.0, b.0);
    V([
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ])
}

fn cross_f64(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    cross(V(a), V(b)).0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Geometry;
    use nalgebra::{Vector2, Vector3};

    #[test]
    fn scalar_operations_are_the_geometry_ones() {
        let (q, a, w) = (
            Vector3::new(0.3, -0.4, 0.866),
            Vector3::new(1.1, 0.2, -0.7),
            Vector3::new(-0.5, 2.0, 0.4),
        );
        let v3 = |v: Vector3<f64>| V([v.x, v.y, v.z]);
        let arr = |v: Vector3<f64>| [v.x, v.y, v.z];
        assert_eq!(
            Spatial::velocity_s(v3(w), v3(q)).0,
            arr(<Spatial as Geometry>::velocity(w, q))
        );
        assert_eq!(
            Spatial::spin_s(v3(q), v3(a)).0,
            arr(<Spatial as Geometry>::spin(q, a))
        );
        let r = <Spatial as ScalarGeometry>::rotate_s(v3(w * 0.3), v3(q)).0;
        let expected = <Spatial as Geometry>::rotate(w * 0.3, q);
        assert!((Vector3::from(r) - expected).norm() < 1e-15);
        let (q2, a2) = (Vector2::new(0.6, -0.8), Vector2::new(0.3, 1.7));
        let v2 = |v: Vector2<f64>| V([v.x, v.y]);
        let v = <Planar as Geometry>::velocity(1.3, q2);
        assert_eq!(Planar::velocity_s(V([1.3]), v2(q2)).0, [v.x, v.y]);
        assert_eq!(
            Planar::spin_s(v2(q2), v2(a2)).0[0],
            <Planar as Geometry>::spin(q2, a2)
        );
        let r = <Planar as ScalarGeometry>::rotate_s(V([0.7]), v2(q2)).0;
        assert_eq!(Vector2::from(r), <Planar as Geometry>::rotate(0.7, q2));
    }

    #[test]
    fn spatial_basis_is_orthonormal_tangent_and_c_at_the_poles() {
        assert_eq!(
            Spatial::tangent_basis(&[0.0, 0.0, 1.0]),
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        );
        assert_eq!(
            Spatial::tangent_basis(&[0.0, 0.0, -1.0]),
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        );
        for q in [[0.6, 0.0, 0.8], [0.36, -0.48, -0.8], [1.0, 0.0, 0.0]] {
            let [b1, b2] = Spatial::tangent_basis(&q);
            let dot = |a: [f64; 3], b: [f64; 3]| V(a).dot(V(b));
            for (x, y, want) in [
                (b1, b1, 1.0),
                (b2, b2, 1.0),
                (b1, b2, 0.0),
                (b1, q, 0.0),
                (b2, q, 0.0),
            ] {
                assert!((dot(x, y) - want).abs() < 1e-15, "{q:?}");
            }
        }
    }
}
