//! [`Wide`]: eight `f32` lanes as the `wide` crate's `f32x8`, for the
//! portable level (a CPU without AVX2, or `DRAPE_SIMD=portable`): two
//! NEON registers on AArch64, two SSE registers on x86-64's baseline, one
//! AVX register where the build enables AVX.
//!
//! [`F32x8`](super::kernel::F32x8) is an array of eight `f32` that the
//! compiler vectorises where the lanes come from memory as lanes (the
//! grid's tiles). The coloured path's octets gather their lanes from rows,
//! and there the compiler kept about half of the projection scalar (host
//! F, x86-64 baseline: 16 scalar square roots and 20 scalar divisions
//! beside 8 and 4 vector ones in the pass; the AArch64 build alike), so the
//! octets were no faster than one bar at a time. `wide` writes each
//! operation as the target's vector instruction.
//!
//! Every operation is the IEEE operation of the `f32` path lane by lane,
//! so the lanes give the bits of one bar at a time: add, subtract,
//! multiply, divide and square root are exact-rounded vector instructions;
//! negation, `abs` and `copysign` act on the sign bit; the comparisons are
//! ordered `>` (false with a NaN, as `f32`'s) and the selects take whole
//! lanes. A multiply-add is fused exactly where the portable level fuses
//! ([`PORTABLE_FUSED`]): `wide` fuses where the target has FMA or is
//! AArch64, the same condition; elsewhere each lane calls `f32::mul_add`
//! (which the kernels ask for only with `FUSED`, never at that level).

use wide::{f32x4, f32x8};

use super::kernel::{LANES, Real};
use super::rows::Rows;
use super::simd::PORTABLE_FUSED;

/// Eight lanes in the target's vector registers (module docs).
pub(crate) type Wide = f32x8;

impl Real for f32x8 {
    #[inline(always)]
    fn splat(v: f32) -> Self {
        f32x8::splat(v)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32x8::sqrt(self)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        self.simd_gt(other).bitselect(self, other)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32x8::abs(self)
    }
    #[inline(always)]
    fn if_moving(w: Self, then: Self, otherwise: Self) -> Self {
        w.simd_gt(f32x8::splat(0.0)).bitselect(then, otherwise)
    }
    #[inline(always)]
    fn if_greater(a: Self, b: Self, then: Self, otherwise: Self) -> Self {
        a.simd_gt(b).bitselect(then, otherwise)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        f32x8::copysign(self, sign)
    }
    /// Lane by lane ([`Real::floor`] of `f32`: the same bits; no kernel
    /// that runs on these lanes floors in its loop).
    #[inline(always)]
    fn floor(self) -> Self {
        f32x8::from(self.to_array().map(Real::floor))
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        if PORTABLE_FUSED {
            f32x8::mul_add(self, b, c)
        } else {
            let (a, b, c) = (self.to_array(), b.to_array(), c.to_array());
            f32x8::from(std::array::from_fn::<f32, LANES, _>(|l| a[l].mul_add(b[l], c[l])))
        }
    }
}

/// Two halves: lanes 0–3 and 4–7.
#[inline(always)]
fn halves(v: f32x8) -> [f32x4; 2] {
    bytemuck::cast(v)
}

#[inline(always)]
fn joined(halves: [f32x4; 2]) -> f32x8 {
    bytemuck::cast(halves)
}

impl Rows for f32x8 {
    /// Each row one 16-byte load, four rows transposed at a time.
    #[inline(always)]
    fn gather(rows: &[[f32; 4]], s: &[usize; LANES]) -> [Self; 4] {
        let row = |l: usize| f32x4::from(rows[s[l]]);
        let low = f32x4::transpose([row(0), row(1), row(2), row(3)]);
        let high = f32x4::transpose([row(4), row(5), row(6), row(7)]);
        [joined([low[0], high[0]]), joined([low[1], high[1]]), joined([low[2], high[2]]), joined([low[3], high[3]])]
    }
    #[inline(always)]
    fn to_rows([x, y, z, w]: [Self; 4]) -> [[f32; 4]; LANES] {
        let [x, y, z, w] = [halves(x), halves(y), halves(z), halves(w)];
        let low = f32x4::transpose([x[0], y[0], z[0], w[0]]);
        let high = f32x4::transpose([x[1], y[1], z[1], w[1]]);
        [low[0], low[1], low[2], low[3], high[0], high[1], high[2], high[3]].map(f32x4::to_array)
    }
    #[inline(always)]
    fn from_values(values: [f32; LANES]) -> Self {
        f32x8::from(values)
    }
    #[inline(always)]
    fn to_values(self) -> [f32; LANES] {
        self.to_array()
    }
    #[inline(always)]
    fn equal_bits(self, other: Self) -> u32 {
        self.simd_eq(other).to_bitmask()
    }
    #[inline(always)]
    fn first(self) -> f32 {
        self.as_array()[0]
    }
}
