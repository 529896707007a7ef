//! The two scenes the engine runs: the paper's spatial chain (cart in the e1-e2
//! plane, links on S^2) and its planar special case (cart on the e1 axis, links in
//! the e1-e3 plane). Every algorithm is written once, generic over [`Geometry`], so
//! a planar scene runs the same code on smaller vectors and computes nothing the
//! scene does not use.

use nalgebra::{Vector2, Vector3};
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// A small fixed-size vector that can be read from and written to a flat state slice.
pub trait Vector:
    Copy
    + Debug
    + Send
    + Sync
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<f64, Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + 'static
{
    /// Number of components.
    const DIM: usize;
    /// The zero vector.
    fn zero() -> Self;
    /// Euclidean inner product.
    fn dot(self, other: Self) -> f64;
    /// Squared Euclidean norm.
    fn norm_squared(self) -> f64 {
        self.dot(self)
    }
    /// Reads the first `DIM` entries of `s`.
    fn load(s: &[f64]) -> Self;
    /// Writes the vector into the first `DIM` entries of `s`.
    fn store(self, s: &mut [f64]);
}

impl Vector for f64 {
    const DIM: usize = 1;
    #[inline(always)]
    fn zero() -> Self {
        0.0
    }
    #[inline(always)]
    fn dot(self, other: Self) -> f64 {
        self * other
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        s[0]
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        s[0] = self;
    }
}

impl Vector for Vector2<f64> {
    const DIM: usize = 2;
    #[inline(always)]
    fn zero() -> Self {
        Vector2::zeros()
    }
    #[inline(always)]
    fn dot(self, other: Self) -> f64 {
        self.x * other.x + self.y * other.y
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        Vector2::new(s[0], s[1])
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        s[0] = self.x;
        s[1] = self.y;
    }
}

impl Vector for Vector3<f64> {
    const DIM: usize = 3;
    #[inline(always)]
    fn zero() -> Self {
        Vector3::zeros()
    }
    #[inline(always)]
    fn dot(self, other: Self) -> f64 {
        self.x * other.x + self.y * other.y + self.z * other.z
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        Vector3::new(s[0], s[1], s[2])
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        s[0] = self.x;
        s[1] = self.y;
        s[2] = self.z;
    }
}

/// What distinguishes the spatial scene from the planar one.
pub trait Geometry: Copy + Debug + Send + Sync + Default + 'static {
    /// Cart position and force: R^2 (spatial) or R^1 (planar, along e1).
    type Cart: Vector;
    /// Link direction q_i: R^3, or R^2 = (e1, e3) components in the planar scene.
    type Link: Vector;
    /// Angular velocity w_i: R^3, or R^1 = its e2 component in the planar scene.
    type Spin: Vector;
    /// `"spatial"` or `"planar"`.
    const NAME: &'static str;
    /// `w x q`.
    fn velocity(w: Self::Spin, q: Self::Link) -> Self::Link;
    /// `q x a` (the spin whose velocity at q is a, when a is tangent).
    fn spin(q: Self::Link, a: Self::Link) -> Self::Spin;
    /// `C^T v`: the horizontal (cart) part of a link-space vector.
    fn horizontal(v: Self::Link) -> Self::Cart;
    /// `C x`: a cart vector seen in link space.
    fn lift(x: Self::Cart) -> Self::Link;
    /// `e3 . v` (e3 points along gravity).
    fn down(v: Self::Link) -> f64;
    /// `e3`.
    fn down_unit() -> Self::Link;
    /// `exp(theta^) q`: rotate q by the rotation vector theta.
    fn rotate(theta: Self::Spin, q: Self::Link) -> Self::Link;
    /// Inverse of the right-trivialised tangent of exp, to the order RKMK4 needs.
    fn dexpinv(theta: Self::Spin, k: Self::Spin) -> Self::Spin;
    /// `w` minus its component along the unit vector q (identity where spins are always tangent).
    fn tangent(w: Self::Spin, q: Self::Link) -> Self::Spin;
}

/// The paper's scene: links on S^2, cart in the horizontal plane.
#[derive(Clone, Copy, Debug, Default)]
pub struct Spatial;

/// The planar scene: links in the e1-e3 plane, cart on the e1 axis, spins along e2.
#[derive(Clone, Copy, Debug, Default)]
pub struct Planar;

impl Geometry for Spatial {
    type Cart = Vector2<f64>;
    type Link = Vector3<f64>;
    type Spin = Vector3<f64>;
    const NAME: &'static str = "spatial";

    #[inline(always)]
    fn velocity(w: Vector3<f64>, q: Vector3<f64>) -> Vector3<f64> {
        w.cross(&q)
    }
    #[inline(always)]
    fn spin(q: Vector3<f64>, a: Vector3<f64>) -> Vector3<f64> {
        q.cross(&a)
    }
    #[inline(always)]
    fn horizontal(v: Vector3<f64>) -> Vector2<f64> {
        Vector2::new(v.x, v.y)
    }
    #[inline(always)]
    fn lift(x: Vector2<f64>) -> Vector3<f64> {
        Vector3::new(x.x, x.y, 0.0)
    }
    #[inline(always)]
    fn down(v: Vector3<f64>) -> f64 {
        v.z
    }
    #[inline(always)]
    fn down_unit() -> Vector3<f64> {
        Vector3::new(0.0, 0.0, 1.0)
    }
    #[inline(always)]
    fn rotate(theta: Vector3<f64>, q: Vector3<f64>) -> Vector3<f64> {
        // Rodrigues: q cos t + (k x q) sin t + k (k.q)(1 - cos t), written with
        // sin(t)/t and (1-cos t)/t^2 so that small angles need no division.
        let t2 = theta.norm_squared();
        let (a, b) = if t2 < 1e-8 {
            (
                1.0 - t2 / 6.0 * (1.0 - t2 / 20.0),
                0.5 - t2 / 24.0 * (1.0 - t2 / 30.0),
            )
        } else {
            let t = t2.sqrt();
            let (s, c) = t.sin_cos();
            (s / t, (1.0 - c) / t2)
        };
        let txq = theta.cross(&q);
        q + txq * a + theta.cross(&txq) * b
    }
    #[inline(always)]
    fn dexpinv(theta: Vector3<f64>, k: Vector3<f64>) -> Vector3<f64> {
        let txk = theta.cross(&k);
        k - txk * 0.5 + theta.cross(&txk) * (1.0 / 12.0)
    }
    #[inline(always)]
    fn tangent(w: Vector3<f64>, q: Vector3<f64>) -> Vector3<f64> {
        w - q * w.dot(q)
    }
}

impl Geometry for Planar {
    type Cart = f64;
    type Link = Vector2<f64>;
    type Spin = f64;
    const NAME: &'static str = "planar";

    // Link vectors are (e1, e3) components; a spin w is w e2, so
    // w e2 x (a, 0, b) = w (b, 0, -a) and (a,0,b) x (c,0,d) = (b c - a d) e2.
    #[inline(always)]
    fn velocity(w: f64, q: Vector2<f64>) -> Vector2<f64> {
        Vector2::new(w * q.y, -w * q.x)
    }
    #[inline(always)]
    fn spin(q: Vector2<f64>, a: Vector2<f64>) -> f64 {
        q.y * a.x - q.x * a.y
    }
    #[inline(always)]
    fn horizontal(v: Vector2<f64>) -> f64 {
        v.x
    }
    #[inline(always)]
    fn lift(x: f64) -> Vector2<f64> {
        Vector2::new(x, 0.0)
    }
    #[inline(always)]
    fn down(v: Vector2<f64>) -> f64 {
        v.y
    }
    #[inline(always)]
    fn down_unit() -> Vector2<f64> {
        Vector2::new(0.0, 1.0)
    }
    #[inline(always)]
    fn rotate(theta: f64, q: Vector2<f64>) -> Vector2<f64> {
        let (s, c) = theta.sin_cos();
        Vector2::new(c * q.x + s * q.y, c * q.y - s * q.x)
    }
    #[inline(always)]
    fn dexpinv(_theta: f64, k: f64) -> f64 {
        k // SO(2) is abelian
    }
    #[inline(always)]
    fn tangent(w: f64, _q: Vector2<f64>) -> f64 {
        w
    }
}

/// Offsets of the parts of a flat state `[x, xdot, q_1..q_n, w_1..w_n]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout<G: Geometry> {
    /// Number of links.
    pub n: usize,
    _g: std::marker::PhantomData<G>,
}

impl<G: Geometry> Layout<G> {
    /// The layout for `n` links.
    pub const fn new(n: usize) -> Self {
        Self {
            n,
            _g: std::marker::PhantomData,
        }
    }
    /// `2 dim(cart) + n (dim(link) + dim(spin))`: 4 + 6n spatial, 2 + 3n planar.
    #[inline(always)]
    pub const fn dim(&self) -> usize {
        2 * G::Cart::DIM + self.n * (G::Link::DIM + G::Spin::DIM)
    }
    #[inline(always)]
    /// Offset of the cart position.
    pub const fn x(&self) -> usize {
        0
    }
    #[inline(always)]
    /// Offset of the cart velocity.
    pub const fn xdot(&self) -> usize {
        G::Cart::DIM
    }
    #[inline(always)]
    /// Offset of link `i`'s direction `q_i`.
    pub const fn q(&self, i: usize) -> usize {
        2 * G::Cart::DIM + i * G::Link::DIM
    }
    #[inline(always)]
    /// Offset of link `i`'s angular velocity `w_i`.
    pub const fn w(&self, i: usize) -> usize {
        2 * G::Cart::DIM + self.n * G::Link::DIM + i * G::Spin::DIM
    }
    #[inline(always)]
    /// The cart position of state `y`.
    pub fn load_x(&self, y: &[f64]) -> G::Cart {
        G::Cart::load(&y[self.x()..])
    }
    #[inline(always)]
    /// The cart velocity of state `y`.
    pub fn load_xdot(&self, y: &[f64]) -> G::Cart {
        G::Cart::load(&y[self.xdot()..])
    }
    #[inline(always)]
    /// Link `i`'s direction in state `y`.
    pub fn load_q(&self, y: &[f64], i: usize) -> G::Link {
        G::Link::load(&y[self.q(i)..])
    }
    #[inline(always)]
    /// Link `i`'s angular velocity in state `y`.
    pub fn load_w(&self, y: &[f64], i: usize) -> G::Spin {
        G::Spin::load(&y[self.w(i)..])
    }
    #[inline(always)]
    /// Writes the cart position into `y`.
    pub fn store_x(&self, y: &mut [f64], v: G::Cart) {
        v.store(&mut y[self.x()..])
    }
    #[inline(always)]
    /// Writes the cart velocity into `y`.
    pub fn store_xdot(&self, y: &mut [f64], v: G::Cart) {
        v.store(&mut y[self.xdot()..])
    }
    #[inline(always)]
    /// Writes link `i`'s direction into `y`.
    pub fn store_q(&self, y: &mut [f64], i: usize, v: G::Link) {
        v.store(&mut y[self.q(i)..])
    }
    #[inline(always)]
    /// Writes link `i`'s angular velocity into `y`.
    pub fn store_w(&self, y: &mut [f64], i: usize, v: G::Spin) {
        v.store(&mut y[self.w(i)..])
    }
}

/// Spatial state of a planar one: `x -> (x, 0)`, `(a, b) -> (a, 0, b)`, `w -> (0, w, 0)`.
pub fn planar_to_spatial(n: usize, planar: &[f64], spatial: &mut [f64]) {
    let (p, s) = (Layout::<Planar>::new(n), Layout::<Spatial>::new(n));
    s.store_x(spatial, Vector2::new(p.load_x(planar), 0.0));
    s.store_xdot(spatial, Vector2::new(p.load_xdot(planar), 0.0));
    for i in 0..n {
        let q = p.load_q(planar, i);
        s.store_q(spatial, i, Vector3::new(q.x, 0.0, q.y));
        s.store_w(spatial, i, Vector3::new(0.0, p.load_w(planar, i), 0.0));
    }
}

/// Planar part of a spatial state (drops the e2 components of x, xdot, q and the e1, e3 of w).
pub fn spatial_to_planar(n: usize, spatial: &[f64], planar: &mut [f64]) {
    let (p, s) = (Layout::<Planar>::new(n), Layout::<Spatial>::new(n));
    p.store_x(planar, s.load_x(spatial).x);
    p.store_xdot(planar, s.load_xdot(spatial).x);
    for i in 0..n {
        let q = s.load_q(spatial, i);
        p.store_q(planar, i, Vector2::new(q.x, q.z));
        p.store_w(planar, i, s.load_w(spatial, i).y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planar_operations_are_the_spatial_ones_restricted_to_the_plane() {
        let q = Vector2::new(0.6, -0.8);
        let a = Vector2::new(0.3, 1.7);
        let w = 1.3;
        let q3 = Vector3::new(q.x, 0.0, q.y);
        let a3 = Vector3::new(a.x, 0.0, a.y);
        let w3 = Vector3::new(0.0, w, 0.0);
        let v = Spatial::velocity(w3, q3);
        assert!((Planar::velocity(w, q) - Vector2::new(v.x, v.z)).norm() < 1e-15);
        assert!((Planar::spin(q, a) - Spatial::spin(q3, a3).y).abs() < 1e-15);
        let r = Spatial::rotate(w3 * 0.7, q3);
        assert!((Planar::rotate(w * 0.7, q) - Vector2::new(r.x, r.z)).norm() < 1e-15);
    }

    #[test]
    fn rodrigues_matches_small_and_large_angles() {
        let q = Vector3::new(0.0, 0.6, 0.8);
        for scale in [1e-9, 1e-5, 1e-3, 0.5, 3.0] {
            let theta = Vector3::new(0.3, -0.2, 0.9) * scale;
            let r = Spatial::rotate(theta, q);
            assert!((r.norm() - 1.0).abs() < 1e-15);
            let rot = nalgebra::Rotation3::new(theta);
            assert!((r - rot * q).norm() < 1e-15, "scale {scale}");
        }
    }
}
