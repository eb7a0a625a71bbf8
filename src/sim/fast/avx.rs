//! [`Avx`]: the lane kernels' number type in one AVX register, for the
//! AVX2 paths written with `std::arch` (the coloured layout's octets, the
//! self-collide phase's pairs), where the compiler split [`F32x8`] code
//! into 4-wide halves or scalar code.
//!
//! [`F32x8`]: super::kernel::F32x8

#![allow(unsafe_code)]

use std::arch::x86_64::{
    __m256, _CMP_GT_OQ, _mm256_add_ps, _mm256_andnot_ps, _mm256_blendv_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_max_ps,
    _mm256_mul_ps, _mm256_set1_ps, _mm256_sqrt_ps, _mm256_sub_ps,
};
use std::ops::{Add, Div, Mul, Sub};

use super::kernel::{LANES, Real};

/// Eight `f32` lanes in one AVX register, for the shared kernels.
///
/// **Contract** (crate-internal): an `Avx` is made only inside functions
/// compiled with `#[target_feature(enable = "avx2,fma")]` and called only
/// after [`super::simd::level`] said AVX2 or above (the CPU reports AVX2 and
/// FMA). So wherever an `Avx` exists, AVX is available, which is what each
/// `unsafe` below relies on. Every operation is the IEEE operation of the
/// `f32` path, lane by lane (no fused multiply-add), so both give the same
/// bits.
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
}
