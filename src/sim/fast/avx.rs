//! [`Avx`]: the lane kernels' number type in one AVX register, for the
//! AVX2 paths written with `std::arch` (the coloured layout's octets, the
//! self-collide phase's pairs), where the compiler split [`F32x8`] code
//! into 4-wide halves or scalar code.
//!
//! [`F32x8`]: super::kernel::F32x8

#![allow(unsafe_code)]

use std::arch::x86_64::{
    __m128, __m256, _CMP_EQ_OQ, _CMP_GT_OQ, _mm256_add_ps, _mm256_and_ps, _mm256_andnot_ps, _mm256_blendv_ps,
    _mm256_castps256_ps128, _mm256_cmp_ps, _mm256_cvtss_f32, _mm256_div_ps, _mm256_extractf128_ps, _mm256_floor_ps,
    _mm256_max_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_set_m128, _mm256_set1_ps, _mm256_shuffle_ps,
    _mm256_sqrt_ps, _mm256_sub_ps, _mm256_unpackhi_ps, _mm256_unpacklo_ps,
};
use std::ops::{Add, Div, Mul, Neg, Sub};

use super::kernel::{LANES, Real};
use super::rows::Rows;

/// Eight `f32` lanes in one AVX register, for the shared kernels.
///
/// **Contract** (crate-internal): an `Avx` is made only inside functions
/// compiled with `#[target_feature(enable = "avx2,fma")]` and called only
/// after [`super::simd::level`] said AVX2 or above (the CPU reports AVX2 and
/// FMA). So wherever an `Avx` exists, AVX is available, which is what each
/// `unsafe` below relies on. Every operation is the IEEE operation of the
/// `f32` path, lane by lane (a fused multiply-add only where the kernel asks
/// for one, [`Real::mul_add`]), so both give the same bits.
#[derive(Clone, Copy)]
pub(crate) struct Avx(pub(crate) __m256);

impl Avx {
    /// The first eight values of a column.
    #[inline(always)]
    pub(crate) fn load(column: &[f32]) -> Self {
        let mut lanes = [0.0f32; LANES];
        lanes.copy_from_slice(&column[..LANES]);
        Avx::from(lanes)
    }

    #[inline(always)]
    pub(crate) fn from(lanes: [f32; LANES]) -> Self {
        Avx(bytemuck::cast(lanes))
    }

    #[inline(always)]
    pub(crate) fn lanes(self) -> [f32; LANES] {
        bytemuck::cast(self.0)
    }
}

/// Rows `index[0..8]` of `rows` (x y z w each, one 16-byte load a row)
/// transposed into lanes: [x, y, z, w]. Same contract as [`Avx`].
#[inline(always)]
pub(crate) fn gather_rows(rows: &[[f32; 4]], index: &[usize; LANES]) -> [Avx; 4] {
    let p = |l: usize| -> __m128 { bytemuck::cast(rows[index[l]]) };
    transpose_rows([p(0), p(1), p(2), p(3), p(4), p(5), p(6), p(7)])
}

/// Eight rows (x y z w each, row l in `rows[l]`) transposed into lanes:
/// [x, y, z, w]. Same contract as [`Avx`].
#[inline(always)]
pub(crate) fn transpose_rows(p: [__m128; LANES]) -> [Avx; 4] {
    // SAFETY: by the type's contract, called only where AVX2 is enabled.
    unsafe {
        transpose_pairs([
            _mm256_set_m128(p[4], p[0]),
            _mm256_set_m128(p[5], p[1]),
            _mm256_set_m128(p[6], p[2]),
            _mm256_set_m128(p[7], p[3]),
        ])
    }
}

/// Eight rows in four registers, register l holding row l in its low half
/// and row l + 4 in its high half (the layout of [`untranspose_rows`]),
/// transposed into lanes: [x, y, z, w]. Same contract as [`Avx`].
#[inline(always)]
pub(crate) fn transpose_pairs([r0, r1, r2, r3]: [__m256; 4]) -> [Avx; 4] {
    // SAFETY: by the type's contract, called only where AVX2 is enabled.
    unsafe {
        // Per half: t0 = x0 x1 y0 y1, t1 = z0 z1 w0 w1, t2 = x2 x3 y2 y3, t3 = z2 z3 w2 w3.
        let (t0, t1) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpackhi_ps(r0, r1));
        let (t2, t3) = (_mm256_unpacklo_ps(r2, r3), _mm256_unpackhi_ps(r2, r3));
        // 0x44 takes elements 0, 1 of each source, 0xEE elements 2, 3.
        [
            Avx(_mm256_shuffle_ps::<0x44>(t0, t2)),
            Avx(_mm256_shuffle_ps::<0xEE>(t0, t2)),
            Avx(_mm256_shuffle_ps::<0x44>(t1, t3)),
            Avx(_mm256_shuffle_ps::<0xEE>(t1, t3)),
        ]
    }
}

impl Rows for Avx {
    #[inline(always)]
    fn gather(rows: &[[f32; 4]], s: &[usize; LANES]) -> [Self; 4] {
        gather_rows(rows, s)
    }
    #[inline(always)]
    fn to_rows(lanes: [Self; 4]) -> [[f32; 4]; LANES] {
        let rows = untranspose_rows(lanes);
        let mut out = [[0.0; 4]; LANES];
        for (l, row) in rows.into_iter().enumerate() {
            // SAFETY: by the type's contract, called only where AVX2 is enabled.
            let (low, high) = unsafe { (_mm256_castps256_ps128(row), _mm256_extractf128_ps::<1>(row)) };
            out[l] = bytemuck::cast(low);
            out[l + 4] = bytemuck::cast(high);
        }
        out
    }
    #[inline(always)]
    fn from_values(values: [f32; LANES]) -> Self {
        Avx::from(values)
    }
    #[inline(always)]
    fn to_values(self) -> [f32; LANES] {
        self.lanes()
    }
    /// `vcmpps` equal-ordered (false for NaN, −0 = 0), then `vmovmskps`.
    #[inline(always)]
    fn equal_bits(self, other: Self) -> u32 {
        // SAFETY: by the type's contract, called only where AVX2 is enabled.
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, other.0)) as u32 }
    }
    #[inline(always)]
    fn first(self) -> f32 {
        // SAFETY: by the type's contract, called only where AVX2 is enabled.
        unsafe { _mm256_cvtss_f32(self.0) }
    }
}

/// The inverse of [`gather_rows`]'s transpose: four lanes [x, y, z, w] as four
/// registers, register l holding row l in its low half and row l + 4 in its
/// high half. Same contract as [`Avx`].
#[inline(always)]
pub(crate) fn untranspose_rows([x, y, z, w]: [Avx; 4]) -> [__m256; 4] {
    // SAFETY: by the type's contract, called only where AVX2 is enabled.
    unsafe {
        // Per half: t0 = x0 y0 x1 y1, t1 = x2 y2 x3 y3, t2 = z0 w0 z1 w1, t3 = z2 w2 z3 w3.
        let (t0, t1) = (_mm256_unpacklo_ps(x.0, y.0), _mm256_unpackhi_ps(x.0, y.0));
        let (t2, t3) = (_mm256_unpacklo_ps(z.0, w.0), _mm256_unpackhi_ps(z.0, w.0));
        [
            _mm256_shuffle_ps::<0x44>(t0, t2),
            _mm256_shuffle_ps::<0xEE>(t0, t2),
            _mm256_shuffle_ps::<0x44>(t1, t3),
            _mm256_shuffle_ps::<0xEE>(t1, t3),
        ]
    }
}

macro_rules! avx_op {
    ($trait:ident, $method:ident, $intrinsic:ident) => {
        impl $trait for Avx {
            type Output = Avx;
            #[inline(always)]
            fn $method(self, rhs: Avx) -> Avx {
                // SAFETY: an `Avx` exists only where AVX is available.
                Avx(unsafe { $intrinsic(self.0, rhs.0) })
            }
        }
    };
}
avx_op!(Add, add, _mm256_add_ps);
avx_op!(Sub, sub, _mm256_sub_ps);
avx_op!(Mul, mul, _mm256_mul_ps);
avx_op!(Div, div, _mm256_div_ps);

impl Neg for Avx {
    type Output = Avx;
    /// Flips the sign bit, as `-` on an `f32`.
    #[inline(always)]
    fn neg(self) -> Avx {
        // SAFETY: an `Avx` exists only where AVX is available.
        Avx(unsafe { std::arch::x86_64::_mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
    }
}

impl Real for Avx {
    #[inline(always)]
    fn splat(v: f32) -> Self {
        // SAFETY: by the type's contract, called only where AVX2 is enabled.
        Avx(unsafe { _mm256_set1_ps(v) })
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        // SAFETY: an `Avx` exists only where AVX is available.
        Avx(unsafe { _mm256_sqrt_ps(self.0) })
    }
    /// `maxps(a, b)` is `a > b ? a : b`, NaN and signed zeros included.
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        // SAFETY: an `Avx` exists only where AVX is available.
        Avx(unsafe { _mm256_max_ps(self.0, other.0) })
    }
    /// Clears the sign bit, as `f32::abs`.
    #[inline(always)]
    fn abs(self) -> Self {
        // SAFETY: an `Avx` exists only where AVX is available.
        Avx(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
    }
    #[inline(always)]
    fn if_moving(w: Self, then: Self, otherwise: Self) -> Self {
        Self::if_greater(w, Avx::splat(0.0), then, otherwise)
    }
    /// `a > b` ordered: false for NaN, as in the `f32` path.
    #[inline(always)]
    fn if_greater(a: Self, b: Self, then: Self, otherwise: Self) -> Self {
        // SAFETY: an `Avx` exists only where AVX is available.
        Avx(unsafe { _mm256_blendv_ps(otherwise.0, then.0, _mm256_cmp_ps::<_CMP_GT_OQ>(a.0, b.0)) })
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        // SAFETY: an `Avx` exists only where AVX2 and FMA are available.
        Avx(unsafe { std::arch::x86_64::_mm256_fmadd_ps(self.0, b.0, c.0) })
    }
    /// The magnitude bits of `self` and the sign bit of `sign`, as
    /// `f32::copysign`.
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        // SAFETY: an `Avx` exists only where AVX is available.
        Avx(unsafe {
            let bit = _mm256_set1_ps(-0.0);
            _mm256_or_ps(_mm256_andnot_ps(bit, self.0), _mm256_and_ps(bit, sign.0))
        })
    }
    /// `vroundps` toward −∞: `f32::floor`, −0, infinities and NaN included.
    #[inline(always)]
    fn floor(self) -> Self {
        // SAFETY: an `Avx` exists only where AVX is available.
        Avx(unsafe { _mm256_floor_ps(self.0) })
    }
}
