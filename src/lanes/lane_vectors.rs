//! Small vectors of lanes and the scene operations on them, mirroring
//! [`crate::geometry`] operation for operation (same terms, same order, the same
//! zero components), so that each lane reproduces the scalar result exactly.

// Index loops on purpose: iterator adaptors and `copy_from_slice` are not always
// inlined, and whatever is not inlined runs as baseline code outside the
// dispatched kernels.
#![allow(clippy::manual_memcpy)]

use super::simd::{LaneReal, Lanes};
use crate::geometry::{Planar, Spatial};
use std::ops::{Add, Mul, Sub};

/// A `D`-vector per lane, stored component by component.
#[derive(Clone, Copy, Debug)]
pub struct LaneVec<const D: usize, const L: usize, T: LaneReal = f64>(pub [Lanes<L, T>; D]);

/// What the kernel needs of a lane vector (implemented by every `LaneVec`).
pub trait LaneVector<const L: usize, T: LaneReal = f64>:
    Copy
    + std::fmt::Debug
    + Send
    + Sync
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Lanes<L, T>, Output = Self>
{
    /// Number of components.
    const DIM: usize;
    /// The zero vector in every lane.
    fn zero() -> Self;
    /// `x_0 y_0 + x_1 y_1 + ...`, summed left to right like the scalar `dot`.
    fn dot(self, other: Self) -> Lanes<L, T>;
    #[inline(always)]
    /// Lane-wise squared norm.
    fn norm_squared(self) -> Lanes<L, T> {
        self.dot(self)
    }
    /// Components `y[at..at + DIM]` of a component-major state.
    fn load(y: &[Lanes<L, T>], at: usize) -> Self;
    /// Components `component(at)..component(at + DIM - 1)`.
    fn load_with(at: usize, component: impl Fn(usize) -> Lanes<L, T>) -> Self;
    /// Writes the vector's components from index `at` of a component-major buffer.
    fn store(self, y: &mut [Lanes<L, T>], at: usize);
}

impl<const D: usize, const L: usize, T: LaneReal> LaneVector<L, T> for LaneVec<D, L, T> {
    const DIM: usize = D;
    #[inline(always)]
    fn zero() -> Self {
        Self([Lanes::zero(); D])
    }
    #[inline(always)]
    fn dot(self, other: Self) -> Lanes<L, T> {
        let mut acc = self.0[0] * other.0[0];
        for d in 1..D {
            acc = acc + self.0[d] * other.0[d];
        }
        acc
    }
    #[inline(always)]
    fn load(y: &[Lanes<L, T>], at: usize) -> Self {
        // One range check for the whole vector, none per component.
        let src = &y[at..at + D];
        let mut out = Self::zero();
        for d in 0..D {
            out.0[d] = src[d];
        }
        out
    }
    #[inline(always)]
    fn load_with(at: usize, component: impl Fn(usize) -> Lanes<L, T>) -> Self {
        // A plain loop: `std::array::from_fn` was left as a call out of the kernel.
        let mut out = Self::zero();
        for d in 0..D {
            out.0[d] = component(at + d);
        }
        out
    }
    #[inline(always)]
    fn store(self, y: &mut [Lanes<L, T>], at: usize) {
        let dst = &mut y[at..at + D];
        for d in 0..D {
            dst[d] = self.0[d];
        }
    }
}

impl<const D: usize, const L: usize, T: LaneReal> Add for LaneVec<D, L, T> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, other: Self) -> Self {
        for d in 0..D {
            self.0[d] = self.0[d] + other.0[d];
        }
        self
    }
}

impl<const D: usize, const L: usize, T: LaneReal> Sub for LaneVec<D, L, T> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, other: Self) -> Self {
        for d in 0..D {
            self.0[d] = self.0[d] - other.0[d];
        }
        self
    }
}

impl<const D: usize, const L: usize, T: LaneReal> Mul<Lanes<L, T>> for LaneVec<D, L, T> {
    type Output = Self;
    #[inline(always)]
    fn mul(mut self, c: Lanes<L, T>) -> Self {
        for d in 0..D {
            self.0[d] = self.0[d] * c;
        }
        self
    }
}

/// The scene operations of [`crate::geometry::Geometry`] on lanes.
pub trait LaneGeometry<const L: usize, T: LaneReal = f64>: crate::geometry::Geometry {
    /// The cart vector, across lanes.
    type CartL: LaneVector<L, T>;
    /// A link direction, across lanes.
    type LinkL: LaneVector<L, T>;
    /// An angular velocity, across lanes.
    type SpinL: LaneVector<L, T>;
    /// `w x q`, lane by lane.
    fn lanes_velocity(w: Self::SpinL, q: Self::LinkL) -> Self::LinkL;
    /// `q x a`, lane by lane (the angular velocity of a tangent velocity).
    fn lanes_spin(q: Self::LinkL, a: Self::LinkL) -> Self::SpinL;
    /// The horizontal part of a vector, lane by lane.
    fn lanes_horizontal(v: Self::LinkL) -> Self::CartL;
    /// A cart vector embedded in space, lane by lane.
    fn lanes_lift(x: Self::CartL) -> Self::LinkL;
    /// The component along gravity (e3), lane by lane.
    fn lanes_down(v: Self::LinkL) -> Lanes<L, T>;
    /// `e3` in every lane.
    fn lanes_down_unit() -> Self::LinkL;
    /// `w` with its component along `q` removed, lane by lane.
    fn lanes_tangent(w: Self::SpinL, q: Self::LinkL) -> Self::SpinL;
}

impl<const L: usize, T: LaneReal> LaneGeometry<L, T> for Spatial {
    type CartL = LaneVec<2, L, T>;
    type LinkL = LaneVec<3, L, T>;
    type SpinL = LaneVec<3, L, T>;
    #[inline(always)]
    fn lanes_velocity(w: LaneVec<3, L, T>, q: LaneVec<3, L, T>) -> LaneVec<3, L, T> {
        cross(w, q)
    }
    #[inline(always)]
    fn lanes_spin(q: LaneVec<3, L, T>, a: LaneVec<3, L, T>) -> LaneVec<3, L, T> {
        cross(q, a)
    }
    #[inline(always)]
    fn lanes_horizontal(v: LaneVec<3, L, T>) -> LaneVec<2, L, T> {
        LaneVec([v.0[0], v.0[1]])
    }
    #[inline(always)]
    fn lanes_lift(x: LaneVec<2, L, T>) -> LaneVec<3, L, T> {
        LaneVec([x.0[0], x.0[1], Lanes::zero()])
    }
    #[inline(always)]
    fn lanes_down(v: LaneVec<3, L, T>) -> Lanes<L, T> {
        v.0[2]
    }
    #[inline(always)]
    fn lanes_down_unit() -> LaneVec<3, L, T> {
        LaneVec([Lanes::zero(), Lanes::zero(), Lanes::splat(T::ONE)])
    }
    #[inline(always)]
    fn lanes_tangent(w: LaneVec<3, L, T>, q: LaneVec<3, L, T>) -> LaneVec<3, L, T> {
        w - q * w.dot(q)
    }
}

/// `a x b` in the component order nalgebra uses.
#[inline(always)]
fn cross<const L: usize, T: LaneReal>(
    a: LaneVec<3, L, T>,
    b: LaneVec<3, L, T>,
) -> LaneVec<3, L, T> {
    let [ax, ay, az] = a.0;
    let [bx, by, bz] = b.0;
    LaneVec([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx])
}

impl<const L: usize, T: LaneReal> LaneGeometry<L, T> for Planar {
    type CartL = LaneVec<1, L, T>;
    type LinkL = LaneVec<2, L, T>;
    type SpinL = LaneVec<1, L, T>;
    #[inline(always)]
    fn lanes_velocity(w: LaneVec<1, L, T>, q: LaneVec<2, L, T>) -> LaneVec<2, L, T> {
        let w = w.0[0];
        LaneVec([w * q.0[1], -w * q.0[0]])
    }
    #[inline(always)]
    fn lanes_spin(q: LaneVec<2, L, T>, a: LaneVec<2, L, T>) -> LaneVec<1, L, T> {
        LaneVec([q.0[1] * a.0[0] - q.0[0] * a.0[1]])
    }
    #[inline(always)]
    fn lanes_horizontal(v: LaneVec<2, L, T>) -> LaneVec<1, L, T> {
        LaneVec([v.0[0]])
    }
    #[inline(always)]
    fn lanes_lift(x: LaneVec<1, L, T>) -> LaneVec<2, L, T> {
        LaneVec([x.0[0], Lanes::zero()])
    }
    #[inline(always)]
    fn lanes_down(v: LaneVec<2, L, T>) -> Lanes<L, T> {
        v.0[1]
    }
    #[inline(always)]
    fn lanes_down_unit() -> LaneVec<2, L, T> {
        LaneVec([Lanes::zero(), Lanes::splat(T::ONE)])
    }
    #[inline(always)]
    fn lanes_tangent(w: LaneVec<1, L, T>, _q: LaneVec<2, L, T>) -> LaneVec<1, L, T> {
        w
    }
}
