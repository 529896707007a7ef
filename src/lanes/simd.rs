//! `L` numbers processed together, one per lane, as a plain fixed-size array.
//!
//! Every operation is a loop over the lanes doing exactly the scalar operation, so
//! LLVM turns it into packed instructions of whatever width the enclosing function
//! was compiled for, and lane k's result is bit for bit the scalar result on lane k's
//! inputs. Everything is `#[inline(always)]` so that it is compiled inside the
//! dispatched kernels with their target features.

// Index loops on purpose: iterator adaptors and `copy_from_slice` are not always
// inlined, and whatever is not inlined runs as baseline code outside the
// dispatched kernels.
#![allow(clippy::needless_range_loop)]

use crate::error::{InputError, Result};
use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Number type of the lane physics: f64, or f32 with twice the lanes per register.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Precision {
    /// f64: every env bit-identical to the per-env path.
    #[default]
    F64,
    /// f32 (twice the lanes): faster, within the accuracy documented in `docs/simd.md`.
    F32,
}

impl Precision {
    /// The names of the precisions, as the configuration writes them.
    pub const NAMES: [&'static str; 2] = ["f64", "f32"];

    /// The name of this precision (`"f64"` or `"f32"`).
    pub fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::F32 => "f32",
        }
    }

    /// The precision with this name, or an error listing the names.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "f64" => Ok(Precision::F64),
            "f32" => Ok(Precision::F32),
            _ => Err(InputError::UnknownName {
                kind: "precision",
                name: name.to_string(),
                expected: &Precision::NAMES,
            }
            .into()),
        }
    }
}

/// The number type of a lane: f64, or f32 for twice the lanes per register.
pub trait LaneReal:
    Copy
    + Debug
    + PartialEq
    + PartialOrd
    + Send
    + Sync
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + 'static
{
    /// Zero.
    const ZERO: Self;
    /// One.
    const ONE: Self;
    /// The precision this type stands for.
    const PRECISION: Precision;
    /// Nearest value (the identity for f64).
    fn from_f64(v: f64) -> Self;
    /// Exact.
    fn to_f64(self) -> f64;
    /// The square root.
    fn sqrt(self) -> Self;
    /// The absolute value.
    fn abs(self) -> Self;
    /// Neither NaN nor infinite.
    fn is_finite(self) -> bool;
    /// Not a number.
    fn is_nan(self) -> bool;
}

macro_rules! lane_real {
    ($t:ty, $precision:ident) => {
        impl LaneReal for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const PRECISION: Precision = Precision::$precision;
            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
        }
    };
}
lane_real!(f64, F64);
lane_real!(f32, F32);

/// One number per lane. Aligned to 64 bytes so that eight f64 (or sixteen f32)
/// lanes fill one cache line and one AVX-512 register.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Lanes<const L: usize, T: LaneReal = f64>(pub [T; L]);

impl<const L: usize, T: LaneReal> Lanes<L, T> {
    #[inline(always)]
    /// Every lane holding `v`.
    pub fn splat(v: T) -> Self {
        Self([v; L])
    }
    #[inline(always)]
    /// Every lane zero.
    pub fn zero() -> Self {
        Self::splat(T::ZERO)
    }
    /// `v` rounded to the lane type, in every lane.
    #[inline(always)]
    pub fn splat_f64(v: f64) -> Self {
        Self::splat(T::from_f64(v))
    }
    // Index loops, not iterator adaptors: they must inline completely into the
    // dispatched kernels, or they would run as baseline code.
    #[inline(always)]
    fn map(self, f: impl Fn(T) -> T) -> Self {
        let mut out = self.0;
        for k in 0..L {
            out[k] = f(out[k]);
        }
        Self(out)
    }
    #[inline(always)]
    fn zip(self, other: Self, f: impl Fn(T, T) -> T) -> Self {
        let mut out = self.0;
        for k in 0..L {
            out[k] = f(out[k], other.0[k]);
        }
        Self(out)
    }
    #[inline(always)]
    /// Lane-wise square root.
    pub fn sqrt(self) -> Self {
        self.map(T::sqrt)
    }
    #[inline(always)]
    /// Lane-wise absolute value.
    pub fn abs(self) -> Self {
        self.map(T::abs)
    }
    /// The larger of two numbers per lane, written as compare-and-select so that it
    /// vectorises. Like `f64::max` it returns the other operand when one is NaN;
    /// it may differ from it only in the sign of a zero result.
    #[inline(always)]
    pub fn max(self, other: Self) -> Self {
        self.zip(other, |a, b| if b > a || a.is_nan() { b } else { a })
    }
    /// Lanes whose value is finite (not NaN, not infinite).
    #[inline(always)]
    pub fn finite_mask(self) -> [bool; L] {
        let mut out = [false; L];
        for k in 0..L {
            out[k] = self.0[k].is_finite();
        }
        out
    }
    /// Lanes whose value is greater than `limit` (false for NaN).
    #[inline(always)]
    pub fn greater_mask(self, limit: Self) -> [bool; L] {
        let mut out = [false; L];
        for k in 0..L {
            out[k] = self.0[k] > limit.0[k];
        }
        out
    }
}

macro_rules! lane_binary {
    ($trait:ident, $method:ident, $op:tt) => {
        impl<const L: usize, T: LaneReal> $trait for Lanes<L, T> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                self.zip(other, |a, b| a $op b)
            }
        }
    };
}
lane_binary!(Add, add, +);
lane_binary!(Sub, sub, -);
lane_binary!(Mul, mul, *);
lane_binary!(Div, div, /);

impl<const L: usize, T: LaneReal> Neg for Lanes<L, T> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|v| -v)
    }
}

/// Whether `[Lanes<L, T>]` is a dense array of numbers (no alignment padding), true
/// whenever `L` numbers fill a multiple of 64 bytes.
pub const fn is_dense<const L: usize, T: LaneReal>() -> bool {
    std::mem::size_of::<Lanes<L, T>>() == std::mem::size_of::<T>() * L
}

/// A dense buffer of lanes as one flat slice of numbers, so that element-wise loops
/// over whole states run over contiguous memory (and LLVM vectorises them along
/// it rather than gathering across lanes). Callers check [`is_dense`].
#[inline(always)]
pub fn flat_mut<const L: usize, T: LaneReal>(v: &mut [Lanes<L, T>]) -> &mut [T] {
    assert!(is_dense::<L, T>());
    let len = v.len() * L;
    // SAFETY: `Lanes<L, T>` is `repr(C)` around `[T; L]` with no padding (checked).
    unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr().cast::<T>(), len) }
}

/// Shared [`flat_mut`].
#[inline(always)]
pub fn flat<const L: usize, T: LaneReal>(v: &[Lanes<L, T>]) -> &[T] {
    assert!(is_dense::<L, T>());
    // SAFETY: as in `flat_mut`.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<T>(), v.len() * L) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operations_are_the_scalar_ones_per_lane() {
        let a = Lanes([1.5, -0.0, f64::NAN, 3.0]);
        let b = Lanes([0.25, 0.0, 1.0, f64::INFINITY]);
        // Same bits, except that a NaN's sign and payload are not specified.
        let same = |x: f64, y: f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
        for k in 0..4 {
            let (x, y) = (a.0[k], b.0[k]);
            assert!(same((a + b).0[k], x + y), "lane {k}");
            assert!(same((a - b).0[k], x - y), "lane {k}");
            assert!(same((a * b).0[k], x * y), "lane {k}");
            assert!(same((a / b).0[k], x / y), "lane {k}");
            // max(-0, +0) is a zero of either sign (as `f64::max` allows).
            let zeros = x == 0.0 && y == 0.0;
            assert!(zeros || same(a.max(b).0[k], x.max(y)), "lane {k}");
            assert!(zeros || same(b.max(a).0[k], y.max(x)), "lane {k}");
            assert_eq!(a.max(b).0[k] == 0.0, zeros, "lane {k}");
            assert!(same(a.sqrt().0[k], x.sqrt()), "lane {k}");
        }
        assert_eq!(a.finite_mask(), [true, true, false, true]);
        assert_eq!(
            b.greater_mask(Lanes::splat(0.5)),
            [false, false, true, true]
        );
    }
}
