//! [`F32x8`]: eight `f32` lanes as a plain array, the portable number type
//! of the lane kernels ([`super::kernel`]). Every operation is a loop over
//! the lanes that the compiler turns into one vector instruction where the
//! lanes come from memory as lanes (the grid's tiles); each is the IEEE
//! operation of the `f32` path lane by lane, so the lanes give the bits of
//! one value at a time.

use std::ops::{Add, Div, Mul, Neg, Sub};

use super::kernel::{LANES, Real};

/// `[e(0), …, e(7)]` for an expression `e` of the lane `l`, written out
/// lane by lane: `std::array::from_fn` in a large kernel is not always
/// inlined, and a call per lane undoes the vectorisation.
macro_rules! each_lane {
    (|$l:ident| $e:expr) => {
        [
            { let $l = 0usize; $e },
            { let $l = 1usize; $e },
            { let $l = 2usize; $e },
            { let $l = 3usize; $e },
            { let $l = 4usize; $e },
            { let $l = 5usize; $e },
            { let $l = 6usize; $e },
            { let $l = 7usize; $e },
        ]
    };
}
pub(crate) use each_lane;

/// `F32x8([e(0), …, e(7)])`: [`each_lane!`] into lanes.
macro_rules! per_lane {
    (|$l:ident| $e:expr) => {
        $crate::sim::fast::f32x8::F32x8($crate::sim::fast::f32x8::each_lane!(|$l| $e))
    };
}
pub(crate) use per_lane;

/// Eight `f32` lanes; every operation is a loop over the lanes that the
/// compiler turns into one vector instruction.
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(32))]
pub(crate) struct F32x8(pub(crate) [f32; LANES]);

macro_rules! lanewise {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F32x8 {
            type Output = F32x8;
            #[inline(always)]
            fn $method(self, rhs: F32x8) -> F32x8 {
                F32x8(std::array::from_fn(|l| self.0[l] $op rhs.0[l]))
            }
        }
    };
}
lanewise!(Add, add, +);
lanewise!(Sub, sub, -);
lanewise!(Mul, mul, *);
lanewise!(Div, div, /);

impl Neg for F32x8 {
    type Output = F32x8;
    #[inline(always)]
    fn neg(self) -> F32x8 {
        F32x8(self.0.map(|v| -v))
    }
}

impl Real for F32x8 {
    #[inline(always)]
    fn splat(v: f32) -> Self {
        F32x8([v; LANES])
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        F32x8(self.0.map(f32::sqrt))
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        F32x8(std::array::from_fn(|l| Real::max(self.0[l], other.0[l])))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F32x8(self.0.map(f32::abs))
    }
    #[inline(always)]
    fn if_moving(w: Self, then: Self, otherwise: Self) -> Self {
        F32x8(std::array::from_fn(|l| Real::if_moving(w.0[l], then.0[l], otherwise.0[l])))
    }
    #[inline(always)]
    fn if_greater(a: Self, b: Self, then: Self, otherwise: Self) -> Self {
        F32x8(std::array::from_fn(|l| Real::if_greater(a.0[l], b.0[l], then.0[l], otherwise.0[l])))
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        F32x8(std::array::from_fn(|l| self.0[l].copysign(sign.0[l])))
    }
    #[inline(always)]
    fn floor(self) -> Self {
        F32x8(self.0.map(Real::floor))
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        F32x8(std::array::from_fn(|l| f32::mul_add(self.0[l], b.0[l], c.0[l])))
    }
}

impl F32x8 {
    /// Lane l takes lane l + 1 (lane 7 takes lane 0).
    #[inline(always)]
    pub(crate) fn rotate_down(self) -> Self {
        F32x8(std::array::from_fn(|l| self.0[(l + 1) % LANES]))
    }
    /// Lane l takes lane l − 1 (lane 0 takes lane 7): undoes `rotate_down`.
    #[inline(always)]
    pub(crate) fn rotate_up(self) -> Self {
        F32x8(std::array::from_fn(|l| self.0[(l + LANES - 1) % LANES]))
    }
    /// The largest lane.
    #[inline(always)]
    pub(crate) fn max_lane(self) -> f32 {
        self.0.into_iter().fold(f32::NEG_INFINITY, Real::max)
    }
    /// The least lane, by the rule `if a < b { a } else { b }` (`Vec3::min`'s).
    #[inline(always)]
    pub(crate) fn min_lane(self) -> f32 {
        self.0.into_iter().fold(f32::INFINITY, |a, b| if a < b { a } else { b })
    }
}
