//! Moving envs between the batch's env-major rows (f64) and a component-major lane
//! group, in both directions. Done element by element this costs about a third of
//! a control step, so the AVX-512 kernel moves 8 x 8 blocks through registers
//! instead (loads of whole rows, an in-register transpose, stores of whole lanes).
//! Both movers are pure data movement plus the f64 <-> f32 conversion the lane type
//! asks for (rounding to nearest, as `as f32` does), so they give the same bits.

// Index loops on purpose: they must inline into the dispatched kernels.
#![allow(clippy::needless_range_loop)]

use super::simd::{LaneReal, Lanes};

/// How a lane group is filled from env rows and written back.
pub(crate) trait RowMover {
    /// Lane k of `y[j]` gets component j of env `first + k` for k < `filled`, and of
    /// env `first` for the lanes past the end (their results are discarded).
    fn rows_to_lanes<const L: usize, T: LaneReal>(
        states: &[f64],
        d: usize,
        first: usize,
        filled: usize,
        y: &mut [Lanes<L, T>],
    );

    /// Env `first + k`'s row gets lane k of `y` for every k with `write[k]`.
    fn lanes_to_rows<const L: usize, T: LaneReal>(
        y: &[Lanes<L, T>],
        states: &mut [f64],
        d: usize,
        first: usize,
        write: &[bool; L],
    );
}

/// Element by element: any instruction set, any lane width.
pub(crate) struct ScalarRows;

impl RowMover for ScalarRows {
    #[inline(always)]
    fn rows_to_lanes<const L: usize, T: LaneReal>(
        states: &[f64],
        d: usize,
        first: usize,
        filled: usize,
        y: &mut [Lanes<L, T>],
    ) {
        let y = &mut y[..d];
        for lane in 0..L {
            let env = first + if lane < filled { lane } else { 0 };
            let row = &states[env * d..(env + 1) * d];
            for j in 0..d {
                y[j].0[lane] = T::from_f64(row[j]);
            }
        }
    }

    #[inline(always)]
    fn lanes_to_rows<const L: usize, T: LaneReal>(
        y: &[Lanes<L, T>],
        states: &mut [f64],
        d: usize,
        first: usize,
        write: &[bool; L],
    ) {
        let y = &y[..d];
        for lane in 0..L {
            if write[lane] {
                let env = first + lane;
                let row = &mut states[env * d..(env + 1) * d];
                for j in 0..d {
                    row[j] = y[j].0[lane].to_f64();
                }
            }
        }
    }
}

/// 8 x 8 blocks through AVX-512 registers for f64 x 8 and f32 x 16 lanes (the
/// product's widths), [`ScalarRows`] for any other. Only code compiled for and
/// running on a CPU with AVX-512F may use it (the AVX-512 kernel in `dispatch`).
#[cfg(target_arch = "x86_64")]
pub(crate) struct Avx512Rows;

#[cfg(target_arch = "x86_64")]
impl RowMover for Avx512Rows {
    #[inline(always)]
    fn rows_to_lanes<const L: usize, T: LaneReal>(
        states: &[f64],
        d: usize,
        first: usize,
        filled: usize,
        y: &mut [Lanes<L, T>],
    ) {
        let y = &mut y[..d];
        let rows = |lane: usize| {
            let env = first + if lane < filled { lane } else { 0 };
            &states[env * d..(env + 1) * d]
        };
        if is::<T, f64>() && L == 8 {
            // SAFETY: `T` is f64 and `L` is 8, so the cast is to the same type; the
            // CPU has AVX-512F (this mover's contract).
            unsafe {
                let y = std::slice::from_raw_parts_mut(y.as_mut_ptr().cast(), d);
                avx512::rows_to_f64x8(std::array::from_fn(rows), y)
            }
        } else if is::<T, f32>() && L == 16 {
            // SAFETY: as above, for f32 and 16 lanes.
            unsafe {
                let y = std::slice::from_raw_parts_mut(y.as_mut_ptr().cast(), d);
                avx512::rows_to_f32x16(std::array::from_fn(rows), y)
            }
        } else {
            ScalarRows::rows_to_lanes(states, d, first, filled, y)
        }
    }

    #[inline(always)]
    fn lanes_to_rows<const L: usize, T: LaneReal>(
        y: &[Lanes<L, T>],
        states: &mut [f64],
        d: usize,
        first: usize,
        write: &[bool; L],
    ) {
        let y = &y[..d];
        // Rows of the lanes not written are never touched: a lane past the end of
        // the batch has no row, and the row of a failed env keeps its last good state.
        let end = first + write.iter().rposition(|&w| w).map_or(0, |k| k + 1);
        let states = &mut states[first * d..end * d];
        if is::<T, f64>() && L == 8 {
            // SAFETY: `T` is f64 and `L` is 8 (same type); the CPU has AVX-512F.
            unsafe {
                let y = std::slice::from_raw_parts(y.as_ptr().cast(), d);
                avx512::f64x8_to_rows(y, states, d, &std::array::from_fn(|k| write[k]))
            }
        } else if is::<T, f32>() && L == 16 {
            // SAFETY: as above, for f32 and 16 lanes.
            unsafe {
                let y = std::slice::from_raw_parts(y.as_ptr().cast(), d);
                avx512::f32x16_to_rows(y, states, d, &std::array::from_fn(|k| write[k]))
            }
        } else {
            ScalarRows::lanes_to_rows(y, states, d, 0, write)
        }
    }
}

/// Whether `A` is `B` (known at compile time, so the test folds away).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn is<A: 'static, B: 'static>() -> bool {
    std::any::TypeId::of::<A>() == std::any::TypeId::of::<B>()
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::Lanes;
    use std::arch::x86_64::*;

    /// Rows of 8 f64 in, the 8 columns out (row k's element j is column j's lane k).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn transpose(r: [__m512d; 8]) -> [__m512d; 8] {
        // Pairs of rows interleaved: [a0 b0 a2 b2 a4 b4 a6 b6] and [a1 b1 a3 b3 ...].
        let t = [
            _mm512_unpacklo_pd(r[0], r[1]),
            _mm512_unpackhi_pd(r[0], r[1]),
            _mm512_unpacklo_pd(r[2], r[3]),
            _mm512_unpackhi_pd(r[2], r[3]),
            _mm512_unpacklo_pd(r[4], r[5]),
            _mm512_unpackhi_pd(r[4], r[5]),
            _mm512_unpacklo_pd(r[6], r[7]),
            _mm512_unpackhi_pd(r[6], r[7]),
        ];
        // Quads: [a0 b0 c0 d0 a4 b4 c4 d4] from t0, t2 (and so on).
        let even = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0);
        let odd = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
        let u = [
            _mm512_permutex2var_pd(t[0], even, t[2]), // columns 0 and 4 of rows a..d
            _mm512_permutex2var_pd(t[0], odd, t[2]),  // 2 and 6
            _mm512_permutex2var_pd(t[1], even, t[3]), // 1 and 5
            _mm512_permutex2var_pd(t[1], odd, t[3]),  // 3 and 7
            _mm512_permutex2var_pd(t[4], even, t[6]), // the same of rows e..h
            _mm512_permutex2var_pd(t[4], odd, t[6]),
            _mm512_permutex2var_pd(t[5], even, t[7]),
            _mm512_permutex2var_pd(t[5], odd, t[7]),
        ];
        // Halves: the low 256 bits of both quads, or the high ones.
        [
            _mm512_shuffle_f64x2::<0x44>(u[0], u[4]),
            _mm512_shuffle_f64x2::<0x44>(u[2], u[6]),
            _mm512_shuffle_f64x2::<0x44>(u[1], u[5]),
            _mm512_shuffle_f64x2::<0x44>(u[3], u[7]),
            _mm512_shuffle_f64x2::<0xEE>(u[0], u[4]),
            _mm512_shuffle_f64x2::<0xEE>(u[2], u[6]),
            _mm512_shuffle_f64x2::<0xEE>(u[1], u[5]),
            _mm512_shuffle_f64x2::<0xEE>(u[3], u[7]),
        ]
    }

    /// The first `width` (1..=8) bits set.
    #[inline(always)]
    fn mask(width: usize) -> __mmask8 {
        (0xFFu16 >> (8 - width)) as __mmask8
    }

    /// Columns `c0..c0 + width` of eight rows (each at least that long).
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load_block(rows: &[&[f64]; 8], c0: usize, width: usize) -> [__m512d; 8] {
        let m = mask(width);
        // SAFETY: the masked load reads only elements c0..c0 + width, inside each row.
        std::array::from_fn(|k| unsafe { _mm512_maskz_loadu_pd(m, rows[k].as_ptr().add(c0)) })
    }

    /// Row k (from `c0`, `width` elements) of `block` into `rows[k * d..]` where `write[k]`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn store_block(
        block: [__m512d; 8],
        rows: &mut [f64],
        d: usize,
        c0: usize,
        width: usize,
        write: &[bool; 8],
    ) {
        let m = mask(width);
        for k in 0..8 {
            if write[k] {
                let row = &mut rows[k * d..(k + 1) * d];
                // SAFETY: the masked store writes only elements c0..c0 + width of the row.
                unsafe { _mm512_mask_storeu_pd(row.as_mut_ptr().add(c0), m, block[k]) }
            }
        }
    }

    /// `rows` (all of length `y.len()`) into f64 lanes.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn rows_to_f64x8(rows: [&[f64]; 8], y: &mut [Lanes<8, f64>]) {
        let d = y.len();
        for c0 in (0..d).step_by(8) {
            let width = 8.min(d - c0);
            let cols = transpose(unsafe { load_block(&rows, c0, width) });
            for j in 0..width {
                // SAFETY: `Lanes` is 64-byte aligned.
                unsafe { _mm512_store_pd(y[c0 + j].0.as_mut_ptr(), cols[j]) }
            }
        }
    }

    /// f64 lanes into the rows `states[k * d..]` with `write[k]`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn f64x8_to_rows(
        y: &[Lanes<8, f64>],
        states: &mut [f64],
        d: usize,
        write: &[bool; 8],
    ) {
        for c0 in (0..d).step_by(8) {
            let width = 8.min(d - c0);
            // SAFETY: `Lanes` is 64-byte aligned; columns past `width` are not stored.
            let cols = std::array::from_fn(|j| unsafe {
                _mm512_load_pd(y[c0 + j.min(width - 1)].0.as_ptr())
            });
            unsafe { store_block(transpose(cols), states, d, c0, width, write) }
        }
    }

    /// `rows` (all of length `y.len()`) into f32 lanes: envs 0..8 and 8..16 moved as
    /// f64 blocks, then rounded to f32 and packed.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn rows_to_f32x16(rows: [&[f64]; 16], y: &mut [Lanes<16, f32>]) {
        let d = y.len();
        let low: [&[f64]; 8] = std::array::from_fn(|k| rows[k]);
        let high: [&[f64]; 8] = std::array::from_fn(|k| rows[k + 8]);
        for c0 in (0..d).step_by(8) {
            let width = 8.min(d - c0);
            let a = transpose(unsafe { load_block(&low, c0, width) });
            let b = transpose(unsafe { load_block(&high, c0, width) });
            for j in 0..width {
                let (a, b) = (_mm512_cvtpd_ps(a[j]), _mm512_cvtpd_ps(b[j]));
                let packed = _mm512_insertf64x4::<1>(
                    _mm512_castpd256_pd512(_mm256_castps_pd(a)),
                    _mm256_castps_pd(b),
                );
                // SAFETY: `Lanes` is 64-byte aligned.
                unsafe { _mm512_store_ps(y[c0 + j].0.as_mut_ptr(), _mm512_castpd_ps(packed)) }
            }
        }
    }

    /// f32 lanes, widened exactly, into the rows `states[k * d..]` with `write[k]`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn f32x16_to_rows(
        y: &[Lanes<16, f32>],
        states: &mut [f64],
        d: usize,
        write: &[bool; 16],
    ) {
        let low: [bool; 8] = std::array::from_fn(|k| write[k]);
        let high: [bool; 8] = std::array::from_fn(|k| write[k + 8]);
        let high_rows = states.len().saturating_sub(8 * d);
        for c0 in (0..d).step_by(8) {
            let width = 8.min(d - c0);
            let mut a = [_mm512_setzero_pd(); 8];
            let mut b = [_mm512_setzero_pd(); 8];
            for j in 0..width {
                // SAFETY: `Lanes` is 64-byte aligned.
                let v = _mm512_castps_pd(unsafe { _mm512_load_ps(y[c0 + j].0.as_ptr()) });
                a[j] = _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_castpd512_pd256(v)));
                b[j] = _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(v)));
            }
            unsafe { store_block(transpose(a), states, d, c0, width, &low) }
            if high_rows > 0 {
                let rest = &mut states[8 * d..];
                unsafe { store_block(transpose(b), rest, d, c0, width, &high) }
            }
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    /// Rows of `num_envs` envs of `d` components, every value distinct.
    fn rows(num_envs: usize, d: usize) -> Vec<f64> {
        (0..num_envs * d)
            .map(|i| (i as f64 + 0.1) * 1.000_000_1)
            .collect()
    }

    /// Both movers, both directions, for lane type `T` x `L`, every width d in 1..=20
    /// and partial groups: the same lanes, the same rows, the unwritten rows untouched.
    fn movers_agree<const L: usize, T: LaneReal>() {
        for d in 1..=20 {
            for filled in [1, L / 2 + 1, L] {
                let states = rows(filled + 1, d);
                let mut scalar = vec![Lanes::<L, T>::zero(); d];
                let mut wide = vec![Lanes::<L, T>::splat_f64(7.0); d];
                ScalarRows::rows_to_lanes(&states, d, 1, filled, &mut scalar);
                Avx512Rows::rows_to_lanes(&states, d, 1, filled, &mut wide);
                assert_eq!(scalar, wide, "rows to lanes, d = {d}, filled = {filled}");
                for (j, lanes) in scalar.iter().enumerate() {
                    for k in 0..L {
                        let env = 1 + if k < filled { k } else { 0 };
                        assert_eq!(lanes.0[k], T::from_f64(states[env * d + j]));
                    }
                }
                let write: [bool; L] = std::array::from_fn(|k| k < filled && k % 3 != 1);
                let mut by_scalar = vec![-1.0; (filled + 1) * d];
                let mut by_wide = by_scalar.clone();
                ScalarRows::lanes_to_rows(&scalar, &mut by_scalar, d, 1, &write);
                Avx512Rows::lanes_to_rows(&scalar, &mut by_wide, d, 1, &write);
                assert_eq!(
                    by_scalar, by_wide,
                    "lanes to rows, d = {d}, filled = {filled}"
                );
                for env in 0..=filled {
                    let written = env >= 1 && write[env - 1];
                    let row = &by_wide[env * d..(env + 1) * d];
                    let expected: Vec<f64> = if written {
                        states[env * d..(env + 1) * d]
                            .iter()
                            .map(|&v| T::from_f64(v).to_f64())
                            .collect()
                    } else {
                        vec![-1.0; d]
                    };
                    assert_eq!(row, &expected[..], "env {env}, d = {d}");
                }
            }
        }
    }

    #[test]
    fn avx512_mover_matches_the_scalar_one() {
        if !std::arch::is_x86_feature_detected!("avx512f") {
            // Nothing to compare on this CPU: the AVX-512 kernel is never chosen here.
            return;
        }
        movers_agree::<8, f64>();
        movers_agree::<16, f32>();
        movers_agree::<4, f64>();
    }
}
