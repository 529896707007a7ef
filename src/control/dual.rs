//! Forward-mode automatic differentiation: the [`Real`] scalars the generic dynamics
//! run on, and the dual number [`Dual`] that carries `N` directional derivatives.
//!
//! A `Dual<N>` is `re + sum_k eps_k e_k` with `e_j e_k = 0`: evaluating a function on
//! it gives the value and, in `eps`, the derivative along `N` seeded directions at
//! once. The step Jacobians need up to `4 + 4n + 2` directions; they are computed in
//! chunks of `N` (a fixed size, no heap allocation), so one monomorphised kernel
//! serves every chain. Only first derivatives are needed (the planner's Hessians are
//! Gauss-Newton), so a minimal type is enough and keeps the hot loop free of
//! dependencies and dynamic sizes.

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A scalar the generic dynamics run on: `f64` (values) or [`Dual`] (derivatives).
pub trait Real:
    Copy
    + Debug
    + Send
    + Sync
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
    + Add<f64, Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign<f64>
    + 'static
{
    /// The constant `v` (no derivative).
    fn cst(v: f64) -> Self;
    /// The value (real part).
    fn re(self) -> f64;
    /// `sqrt(self)`, for a value > 0.
    fn sqrt(self) -> Self;
    /// `(sin self, cos self)`.
    fn sin_cos(self) -> (Self, Self);
    /// `atan2(self, x)`.
    fn atan2(self, x: Self) -> Self;
    /// `1 / self`.
    fn recip(self) -> Self;
    /// `tanh(self)` (the regularised Coulomb law of a rig's cart friction).
    fn tanh(self) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        f64::sin_cos(self)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    #[inline(always)]
    fn recip(self) -> Self {
        1.0 / self
    }
    #[inline(always)]
    fn tanh(self) -> Self {
        f64::tanh(self)
    }
}

/// A value and its derivatives along `N` directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<const N: usize> {
    /// The value.
    pub re: f64,
    /// The derivative along each seeded direction.
    pub eps: [f64; N],
}

impl<const N: usize> Dual<N> {
    /// A value with the given derivatives.
    #[inline(always)]
    pub fn new(re: f64, eps: [f64; N]) -> Self {
        Self { re, eps }
    }
    /// `f(re) + f'(re) eps`: the chain rule for a scalar function with derivative `d`.
    #[inline(always)]
    fn chain(self, value: f64, d: f64) -> Self {
        let mut eps = self.eps;
        for e in &mut eps {
            *e *= d;
        }
        Self { re: value, eps }
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, o: Self) -> Self {
        self.re += o.re;
        for (a, b) in self.eps.iter_mut().zip(o.eps) {
            *a += b;
        }
        self
    }
}

impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, o: Self) -> Self {
        self.re -= o.re;
        for (a, b) in self.eps.iter_mut().zip(o.eps) {
            *a -= b;
        }
        self
    }
}

impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let mut eps = [0.0; N];
        for ((e, a), b) in eps.iter_mut().zip(self.eps).zip(o.eps) {
            *e = a * o.re + self.re * b;
        }
        Self {
            re: self.re * o.re,
            eps,
        }
    }
}

impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    #[inline(always)]
    #[allow(clippy::suspicious_arithmetic_impl)] // a quotient is the product with the reciprocal
    fn div(self, o: Self) -> Self {
        self * o.recip()
    }
}

impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.chain(-self.re, -1.0)
    }
}

impl<const N: usize> Mul<f64> for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, c: f64) -> Self {
        self.chain(self.re * c, c)
    }
}

impl<const N: usize> Add<f64> for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, c: f64) -> Self {
        self.re += c;
        self
    }
}

impl<const N: usize> AddAssign for Dual<N> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl<const N: usize> SubAssign for Dual<N> {
    #[inline(always)]
    fn sub_assign(&mut self, o: Self) {
        *self = *self - o;
    }
}

impl<const N: usize> MulAssign<f64> for Dual<N> {
    #[inline(always)]
    fn mul_assign(&mut self, c: f64) {
        *self = *self * c;
    }
}

impl<const N: usize> Real for Dual<N> {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        Self {
            re: v,
            eps: [0.0; N],
        }
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self.re
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let r = self.re.sqrt();
        self.chain(r, 0.5 / r)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.re.sin_cos();
        (self.chain(s, c), self.chain(c, -s))
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        // d atan2(y, x) = (x dy - y dx) / (x^2 + y^2).
        let r2 = self.re * self.re + x.re * x.re;
        let (cy, cx) = (x.re / r2, -self.re / r2);
        let mut eps = [0.0; N];
        for ((e, dy), dx) in eps.iter_mut().zip(self.eps).zip(x.eps) {
            *e = cy * dy + cx * dx;
        }
        Self {
            re: self.re.atan2(x.re),
            eps,
        }
    }
    #[inline(always)]
    fn recip(self) -> Self {
        let r = 1.0 / self.re;
        self.chain(r, -r * r)
    }
    #[inline(always)]
    fn tanh(self) -> Self {
        let t = self.re.tanh();
        self.chain(t, 1.0 - t * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A function using every operation, generic over the scalar.
    fn f<S: Real>(x: S, y: S) -> S {
        let (s, c) = (x * y).sin_cos();
        (s + c * 2.0).sqrt() * x.atan2(y + 3.0) / (x * x + 1.0) - y.recip() * 0.5 + (x * 0.3).tanh()
    }

    #[test]
    fn derivatives_match_central_differences() {
        let (x, y) = (0.7, -1.3);
        let d = f(Dual::new(x, [1.0, 0.0]), Dual::new(y, [0.0, 1.0]));
        assert_eq!(d.re, f(x, y));
        let h = 1e-6;
        let dx = (f(x + h, y) - f(x - h, y)) / (2.0 * h);
        let dy = (f(x, y + h) - f(x, y - h)) / (2.0 * h);
        assert!((d.eps[0] - dx).abs() < 1e-8, "{} vs {dx}", d.eps[0]);
        assert!((d.eps[1] - dy).abs() < 1e-8, "{} vs {dy}", d.eps[1]);
    }
}
