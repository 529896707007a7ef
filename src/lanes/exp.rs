//! `exp` written once, branch-free, for the scalar code and the lanes alike: a lane
//! applies the very same function, so a reward computed in a lane has the bits of the
//! single env's, and LLVM turns a loop of it into packed instructions (libm's `exp` is
//! one call per number). Within 2 ulp of the correctly rounded result (tested against
//! the standard library's); its bits do not depend on the CPU, unlike a platform libm's.

/// `ln 2` split so that `k * LN2_HI` is exact for the `|k| < 2^11` used here (the low
/// 32 bits of its significand are zero) and `LN2_HI + LN2_LO` is `ln 2` to 2^-80.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
/// `1.5 * 2^52`: adding it rounds a number of magnitude below `2^51` to an integer
/// (to nearest, ties to even) and leaves that integer in the low bits.
const ROUNDER: f64 = 6_755_399_441_055_744.0;
/// `1/j!` for `j = 0..=13`: the Taylor series of `exp` on `|r| <= ln2 / 2` to well
/// below an f64 rounding error (the first term left out is under 5e-18).
const INV_FACTORIALS: [f64; 14] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
];

/// `e^x`: 0 below about -745.2, infinite above about 709.8, NaN for NaN.
#[inline(always)]
pub fn exp(x: f64) -> f64 {
    // Past these bounds the result is 0 or infinite anyway; inside them k stays small.
    let clamped = x.clamp(-746.0, 710.0);
    // x = k ln2 + r with |r| <= ln2 / 2.
    let shifted = clamped * std::f64::consts::LOG2_E + ROUNDER;
    let k_float = shifted - ROUNDER;
    let k = shifted.to_bits().wrapping_sub(ROUNDER.to_bits()) as i64;
    let r = (clamped - k_float * LN2_HI) - k_float * LN2_LO;
    let p = 1.0 + (r + r * r * series_tail(r));
    // 2^k as two normal powers of two, so that results near both ends of the range
    // (k from -1077 to 1025) need no special case; the products are exact unless the
    // result is subnormal or overflows.
    let k_low = k >> 1;
    let k_high = k - k_low;
    let result = p * power_of_two(k_low) * power_of_two(k_high);
    if x.is_nan() {
        x
    } else {
        result
    }
}

/// `sum_{j=2}^{13} r^(j-2) / j!`, so that `e^r = 1 + r + r^2 * tail`, evaluated in
/// Estrin's scheme (pairs, then quads through `r^2`, then `r^4` and `r^8`): 7
/// dependent operations where Horner's rule takes 22. The single env waits for this
/// latency on every step; the lanes pay the three extra products in throughput only.
/// The leading `1 + r` stays outside, added last, so that the tail's roundings
/// (relative to a term below 0.07) barely reach the result.
#[inline(always)]
fn series_tail(r: f64) -> f64 {
    let c = &INV_FACTORIALS;
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let pair = |j: usize| c[j] + c[j + 1] * r;
    let quad_a = pair(2) + pair(4) * r2;
    let quad_b = pair(6) + pair(8) * r2;
    let quad_c = pair(10) + pair(12) * r2;
    (quad_a + quad_b * r4) + quad_c * r8
}

/// `2^k` for `-1022 <= k <= 1023`.
#[inline(always)]
fn power_of_two(k: i64) -> f64 {
    f64::from_bits(((k + 1023) as u64) << 52)
}

#[cfg(test)]
mod tests {
    use super::exp;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Distance in units in the last place between two positive finite numbers.
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn exp_is_within_two_ulp_of_the_standard_library_over_its_range() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut worst = 0;
        for _ in 0..200_000 {
            let x: f64 = rng.random_range(-745.0..709.7);
            let d = ulps(exp(x), x.exp());
            worst = worst.max(d);
            assert!(d <= 2, "exp({x:e}) = {:e}, std {:e}", exp(x), x.exp());
        }
        // Near zero, where rewards live.
        for _ in 0..200_000 {
            let x: f64 = rng.random_range(-20.0..1.0);
            assert!(ulps(exp(x), x.exp()) <= 2, "exp({x:e})");
        }
        assert!(worst <= 2);
    }

    #[test]
    fn exp_handles_the_ends_of_its_range() {
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(-0.0), 1.0);
        assert_eq!(exp(f64::NEG_INFINITY), 0.0);
        assert_eq!(exp(-746.0), 0.0);
        assert_eq!(exp(-1e300), 0.0);
        assert_eq!(exp(f64::INFINITY), f64::INFINITY);
        assert_eq!(exp(709.8), f64::INFINITY);
        assert!(exp(709.78).is_finite());
        assert!(exp(f64::NAN).is_nan());
        // Subnormal results: within a few ulp of the standard library's (their ulp is
        // coarse relative to the value, so compare absolutely).
        for x in [-708.5, -720.0, -740.0, -744.4] {
            let (ours, std) = (exp(x), x.exp());
            assert!((ours - std).abs() <= 4.0 * f64::from_bits(1), "exp({x})");
            assert!(ours > 0.0, "exp({x}) = 0");
        }
    }
}
