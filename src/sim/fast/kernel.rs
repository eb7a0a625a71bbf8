//! The arithmetic of one bar projection and one integration, written once and
//! instantiated for a single `f32` (seams, the coloured path) and for eight
//! lanes [`F32x8`] (the lane layout), so every path computes bit-identical
//! values for the same inputs.
//!
//! Every particle carries its inverse mass `w` relative to the scene's m
//! (1 free, 0 fixed; lane padding has 0 too). A projection moves the ends
//! of a bar by
//!
//! ```text
//! c = ω (C + μ) / (ℓ (w_a + w_b + β)),   x_a ← x_a + w_a c d,   x_b ← x_b − w_b c d
//! ```
//!
//! with d = x_b − x_a, ℓ = |d|, C = ℓ − L (μ = βλ and β only for compliant
//! bars). A bar whose ends both weigh 0 has its denominator replaced by 1,
//! so it moves nothing without a branch, and the lane loops compile to
//! straight SIMD code.
//!
//! The general form ([`relax_pair`]) computes that factor as
//!
//! ```text
//! c = (ℓ² − (L − μ) ℓ) · ω / (ℓ² (w_a + w_b + β)),   ℓ² = d·d,  ℓ = √ℓ²
//! ```
//!
//! (the same c: multiply C + μ = ℓ − (L − μ) and its denominator by ℓ), so
//! that the division waits on ℓ² only and runs beside the square root
//! instead of after it: the projection's chain of dependent operations is a
//! division shorter (tablecloth step 277–286 → 260–269 µs on host D, AVX-512
//! and AVX2 alike). ℓ² there is the rounded d·d, not the square of the
//! rounded ℓ; the two differ by under an ulp of ℓ², which moves the bar's
//! aim by under an ulp of ℓ. The equal-mass form ([`relax_pair_shared`],
//! the grid's) is arranged the same way, its share (½ or 1 for the seed's
//! masses) multiplying 1/ℓ²; for rigid bars at ω = 1 it gives the general
//! form's bits (scaling by a power of two is exact).
//!
//! **Fused multiply-adds.** With `FUSED`, the six moves x ± c d, the sums
//! of d·d and ℓ² − (L − μ) ℓ are each one multiply-add rounded once
//! ([`mul_add`]); without, they are the multiply and the add rounded
//! twice, the bits of the code before (negation is exact and IEEE addition
//! commutes, so `mul_add::<_, false>(a, b, c)` is `c + a·b` exactly). The
//! lane layout and the coloured one fuse wherever their level has FMA
//! (AVX2, AVX-512, and a portable build whose target has it,
//! [`super::simd::PORTABLE_FUSED`]): nine fewer instructions an 8-bar
//! operation and a shorter chain. The seed's step went 69.7–72.5 →
//! 61.9–63.6 µs on host D; the coloured path's octets 14–17 % shorter
//! (tablecloth and disc-183, both builds in one process, alternated).

use std::ops::{Add, Div, Mul, Neg, Sub};

pub(crate) use super::f32x8::{F32x8, each_lane, per_lane};

/// Lengths below this are treated as this when dividing: a bar of zero length
/// then gets a finite factor times a zero direction, so no NaN appears.
const TINY_LENGTH: f32 = 1e-20;

/// Squared lengths (times the weight W, in the general form) below this
/// (m²) are treated as this when dividing, as [`TINY_LENGTH`] (a length of
/// 10⁻¹⁸ m; its square is still a normal `f32`, where 10⁻⁴⁰ would not be).
const TINY_SQUARE: f32 = 1e-36;

/// Lanes of [`F32x8`].
pub(crate) const LANES: usize = 8;

/// The operations the kernels need, for `f32` and for eight lanes of it.
pub(crate) trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    fn splat(v: f32) -> Self;
    fn sqrt(self) -> Self;
    /// `if self > other { self } else { other }` (same rule for both types).
    fn max(self, other: Self) -> Self;
    fn abs(self) -> Self;
    /// `if w > 0 { then } else { otherwise }`, lane by lane: does a particle
    /// of inverse mass w move.
    fn if_moving(w: Self, then: Self, otherwise: Self) -> Self;
    /// `if a > b { then } else { otherwise }`, lane by lane.
    fn if_greater(a: Self, b: Self, then: Self, otherwise: Self) -> Self;
    /// `self` with the sign of `sign`, lane by lane (`f32::copysign`).
    fn copysign(self, sign: Self) -> Self;
    /// ⌊self⌋, lane by lane, with the bits of `f32::floor`.
    fn floor(self) -> Self;
    /// self · b + c rounded once (`f32::mul_add`), lane by lane: one
    /// instruction where the code is compiled for FMA, a call out of line
    /// elsewhere (so only [`mul_add`] with `FUSED` calls it).
    fn mul_add(self, b: Self, c: Self) -> Self;
}

/// a · b + c, rounded once with `FUSED`, else as `c + a · b` (module docs).
#[inline(always)]
pub(crate) fn mul_add<T: Real, const FUSED: bool>(a: T, b: T, c: T) -> T {
    if FUSED { a.mul_add(b, c) } else { c + a * b }
}

/// c − a · b, rounded once with `FUSED` (as (−a) · b + c: negation is
/// exact, so the fused sum is that of the exact c − a·b, signed zeros
/// included), else as `c − a · b`.
#[inline(always)]
pub(crate) fn mul_sub_from<T: Real, const FUSED: bool>(a: T, b: T, c: T) -> T {
    if FUSED { (-a).mul_add(b, c) } else { c - a * b }
}

impl Real for f32 {
    #[inline(always)]
    fn splat(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        if self > other { self } else { other }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn if_moving(w: Self, then: Self, otherwise: Self) -> Self {
        if w > 0.0 { then } else { otherwise }
    }
    #[inline(always)]
    fn if_greater(a: Self, b: Self, then: Self, otherwise: Self) -> Self {
        if a > b { then } else { otherwise }
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        f32::copysign(self, sign)
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        f32::mul_add(self, b, c)
    }
    /// Through the integer conversion while |v| < 2²³, above which every
    /// `f32` is an integer already: `f32::floor` is a call out of line in the
    /// x86-64 baseline build, this is a few instructions. The sign is kept
    /// (⌊−0⌋ = −0, as `f32::floor`).
    #[inline(always)]
    fn floor(self) -> Self {
        if self.abs() < 8_388_608.0 {
            let t = self as i32 as f32;
            if t > self { t - 1.0 } else { t.copysign(self) }
        } else {
            self
        }
    }
}

/// A point: x, y, z.
pub(crate) type Point<T> = [T; 3];

/// `[f(0), f(1), f(2)]`: a point built axis by axis. `std::array::from_fn`
/// in its place was left out of line for larger closures, where it lacks
/// the caller's CPU features (each axis a call, its lanes through the
/// stack: 21 such calls in the grid's collide phase, measured slower).
#[inline(always)]
pub(crate) fn axes<T: Real>(f: impl Fn(usize) -> T) -> Point<T> {
    [f(0), f(1), f(2)]
}

/// u − v.
#[inline(always)]
pub(crate) fn sub<T: Real>(u: Point<T>, v: Point<T>) -> Point<T> {
    [u[0] - v[0], u[1] - v[1], u[2] - v[2]]
}

/// u · s.
#[inline(always)]
pub(crate) fn scale<T: Real>(u: Point<T>, s: T) -> Point<T> {
    [u[0] * s, u[1] * s, u[2] * s]
}

/// (u_x v_x + u_y v_y) + u_z v_z, in glam's order (so lanes give glam's bits).
#[inline(always)]
pub(crate) fn dot<T: Real>(u: Point<T>, v: Point<T>) -> T {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

/// u × v, in glam's order.
#[inline(always)]
pub(crate) fn cross<T: Real>(u: Point<T>, v: Point<T>) -> Point<T> {
    [u[1] * v[2] - v[1] * u[2], u[2] * v[0] - v[2] * u[0], u[0] * v[1] - v[0] * u[1]]
}

/// Lane l of eight points.
#[inline(always)]
pub(crate) fn lane(p: &Point<F32x8>, l: usize) -> glam::Vec3 {
    glam::Vec3::new(p[0].0[l], p[1].0[l], p[2].0[l])
}

/// Projects one bar (the seed's Figure 3): moves `a` and `b` along the bar so
/// their distance returns towards `rest`, each in proportion to its inverse
/// mass, ω times the way. Returns `|len − rest|`, the violation before the
/// projection.
///
/// With `XPBD`, the bar is compliant: `mu` (β·λ of [`crate::sim::relax`], in
/// metres) accumulates over the passes of a substep and the correction aims
/// at `C + mu` instead of C, so the bar settles at C = −mu where its spring
/// holds the load.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn relax_pair<T: Real, const XPBD: bool, const FUSED: bool>(
    a: &mut Point<T>,
    wa: T,
    b: &mut Point<T>,
    wb: T,
    rest: T,
    mu: &mut T,
    beta: T,
    omega: T,
) -> T {
    let (d, square) = bar_square::<T, FUSED>(a, b);
    correct_pair::<T, XPBD, FUSED>(a, wa, b, wb, d, square, rest, mu, beta, omega)
}

/// The first half of [`relax_pair`]: the bar's vector d = x_b − x_a and its
/// squared length ℓ² = d·d (m²).
#[inline(always)]
pub(crate) fn bar_square<T: Real, const FUSED: bool>(a: &Point<T>, b: &Point<T>) -> (Point<T>, T) {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    (d, length_squared::<T, FUSED>(&d))
}

/// d·d, as [`bar_square`] takes it (z² + (y² + x²), each sum fused with
/// `FUSED`).
#[inline(always)]
pub(crate) fn length_squared<T: Real, const FUSED: bool>(d: &Point<T>) -> T {
    mul_add::<T, FUSED>(d[2], d[2], mul_add::<T, FUSED>(d[1], d[1], d[0] * d[0]))
}

/// The second half of [`relax_pair`]: the correction, from the bar's
/// vector `d` and squared length `square` of [`bar_square`], in the form
/// whose division does not wait on the square root (module docs).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn correct_pair<T: Real, const XPBD: bool, const FUSED: bool>(
    a: &mut Point<T>,
    wa: T,
    b: &mut Point<T>,
    wb: T,
    d: Point<T>,
    square: T,
    rest: T,
    mu: &mut T,
    beta: T,
    omega: T,
) -> T {
    let (ca, cb, violation) = pair_shares::<T, XPBD, FUSED>(wa, wb, square, rest, mu, beta, omega);
    for k in 0..3 {
        a[k] = mul_add::<T, FUSED>(ca, d[k], a[k]);
        b[k] = mul_sub_from::<T, FUSED>(cb, d[k], b[k]);
    }
    violation
}

/// [`correct_pair`] less its moves: the multiples `(ca, cb)` of d that end
/// a gains and end b loses (x_a += ca d, x_b −= cb d), and |ℓ − L|; `mu`
/// is updated with `XPBD`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn pair_shares<T: Real, const XPBD: bool, const FUSED: bool>(
    wa: T,
    wb: T,
    square: T,
    rest: T,
    mu: &mut T,
    beta: T,
    omega: T,
) -> (T, T, T) {
    // W = w_a + w_b (+ β with compliance). Without it β is 0, and adding
    // +0 would only turn a −0 sum into +0, which the select below treats
    // alike: the same bits, one addition fewer an octet.
    let weight = if XPBD { wa + wb + beta } else { wa + wb };
    // Both ends weigh 0 (fixed, padding): divide by 1 and move nothing.
    let weight = T::if_moving(weight, weight, T::splat(1.0));
    // ω / (ℓ² W): independent of the square root, computed beside it. The
    // floor is on the product: a lane of padding (both weights 0, W = β)
    // may have ℓ² = 0 and a β small enough that floor × β would underflow
    // and the quotient overflow (0 · ∞ is NaN).
    let per_square = omega / (square * weight).max(T::splat(TINY_SQUARE));
    let len = square.sqrt();
    // (C + μ) ℓ = ℓ² − (L − μ) ℓ.
    let aim = if XPBD { rest - *mu } else { rest };
    let scaled = mul_sub_from::<T, FUSED>(aim, len, square);
    let (ca, cb) = ((wa * per_square) * scaled, (wb * per_square) * scaled);
    if XPBD {
        // β Δλ = −β ω (C + βλ) / (w_a + w_b + β) = −β c ℓ.
        *mu = *mu - beta * (scaled * per_square) * len;
    }
    (ca, cb, (len - rest).abs())
}

/// The equal-mass form of [`relax_pair`], with the shares precomputed (the
/// lane layout's fast path, whenever every inverse mass is 0 or 1). With
/// c₁ = ω/(1 + β) (partner fixed) and c₂ = ω/(2 + β) (partner free), the
/// share of end a is `sa = own_a · partner_b` and of end b
/// `sb = own_b · partner_a` ([`Weights`]): `own` is 1 for a particle that
/// moves, `partner` is c₁ for a fixed one, c₂ for a free one and 0 for lane
/// padding (so a bar to padding moves nothing). This is the general formula
/// for w ∈ {0, 1} without its per-bar sum and select; for rigid bars and
/// ω = 1 it gives the same bits (`½ · 1/ℓ²` is `1/(2ℓ²)`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn relax_pair_shared<T: Real, const XPBD: bool, const FUSED: bool>(
    a: &mut Point<T>,
    sa: T,
    b: &mut Point<T>,
    sb: T,
    rest: T,
    mu: &mut T,
    beta: T,
) -> T {
    let (d, square) = bar_square::<T, FUSED>(a, b);
    // 1/ℓ², beside the square root (as in [`correct_pair`]).
    let per_square = T::splat(1.0) / square.max(T::splat(TINY_SQUARE));
    let len = square.sqrt();
    let aim = if XPBD { rest - *mu } else { rest };
    // (C + μ) ℓ = ℓ² − (L − μ) ℓ.
    let scaled = mul_sub_from::<T, FUSED>(aim, len, square);
    let (ca, cb) = ((sa * per_square) * scaled, (sb * per_square) * scaled);
    for k in 0..3 {
        a[k] = mul_add::<T, FUSED>(ca, d[k], a[k]);
        b[k] = mul_sub_from::<T, FUSED>(cb, d[k], b[k]);
    }
    if XPBD {
        // β Δλ = −β (C + βλ) ω/(k + β), and the larger share is ω/(k + β).
        *mu = *mu - beta * (len - aim) * sa.max(sb);
    }
    (len - rest).abs()
}

/// A particle's part in [`relax_pair_shared`]: `own` (does it move) and
/// `partner` (how far its partner moves).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Weights<T> {
    pub(crate) own: T,
    pub(crate) partner: T,
}

impl<T: Real> Weights<T> {
    /// The shares of a bar from this particle (end a) to `b`:
    /// `[own_a · partner_b, own_b · partner_a]`, those of
    /// [`relax_pair_shared`].
    #[inline(always)]
    pub(crate) fn shares(self, b: Weights<T>) -> [T; 2] {
        [self.own * b.partner, b.own * self.partner]
    }
}

/// c₁ and c₂ of [`relax_pair_shared`] for one kind of bar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Shares {
    fixed_partner: f32,
    free_partner: f32,
}

impl Shares {
    /// The shares of a bar with β = α m/h² and over-relaxation ω.
    pub(crate) fn new(beta: f32, omega: f32) -> Self {
        Self { fixed_partner: omega / (1.0 + beta), free_partner: omega / (2.0 + beta) }
    }

    /// The part of a particle of inverse mass `w` (0 or 1) that exists
    /// (`present`) or is lane padding.
    pub(crate) fn weights(self, w: f32, present: bool) -> Weights<f32> {
        match (present, w > 0.0) {
            (false, _) => Weights { own: 0.0, partner: 0.0 },
            (true, false) => Weights { own: 0.0, partner: self.fixed_partner },
            (true, true) => Weights { own: 1.0, partner: self.free_partner },
        }
    }
}

/// Pulls a particle back onto the sphere of radius `reach` around `anchor`
/// if it is outside (a tether; `reach` is +∞ for particles without one).
#[inline(always)]
pub(crate) fn tether<T: Real>(x: &mut Point<T>, anchor: Point<T>, reach: T, w: T) {
    let d = [x[0] - anchor[0], x[1] - anchor[1], x[2] - anchor[2]];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let scale = reach / len.max(T::splat(TINY_LENGTH));
    for k in 0..3 {
        let pulled = anchor[k] + d[k] * scale;
        x[k] = T::if_greater(len, reach, T::if_moving(w, pulled, x[k]), x[k]);
    }
}

/// How far a bar is beyond tolerance: `violation − slack` (slack =
/// tolerance · rest) if the bar can move (one end free, both present), −∞
/// otherwise, so that a maximum over bars ignores bars that cannot move.
#[inline(always)]
pub(crate) fn excess<T: Real>(violation: T, wa: T, wb: T, slack: T) -> T {
    T::if_greater(wa + wb, T::splat(0.0), violation - slack, T::splat(f32::NEG_INFINITY))
}

/// Equation 1 in displacement form for a particle of inverse mass w > 0:
/// `d ← keep·d + w·accel + gravity`, `x ← x + d` (keep = 1 − δ, accel =
/// h²f/m, gravity = h²g, the same for every moving particle).
/// Particles of weight 0 (fixed, padding) keep their bits. Returns the new
/// x, the prediction relaxation starts from.
#[inline(always)]
pub(crate) fn integrate<T: Real>(
    x: &mut Point<T>,
    d: &mut Point<T>,
    w: T,
    keep: T,
    accel: Point<T>,
    gravity: Point<T>,
) -> Point<T> {
    for k in 0..3 {
        let nd = keep * d[k] + w * accel[k] + gravity[k];
        let nx = x[k] + nd;
        d[k] = T::if_moving(w, nd, d[k]);
        x[k] = T::if_moving(w, nx, x[k]);
    }
    *x
}

/// After relaxation: the step's displacement is the predicted one plus what
/// relaxation added, `d ← d + (x − x_pred)`. Computed this way d never picks
/// up the rounding of x, so a damped particle comes to rest instead of
/// creeping by an ulp every step.
#[inline(always)]
pub(crate) fn settle<T: Real>(d: &mut Point<T>, x: Point<T>, predicted: Point<T>, w: T) {
    for k in 0..3 {
        d[k] = T::if_moving(w, d[k] + (x[k] - predicted[k]), d[k]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_floor_has_the_bits_of_f32s_floor() {
        let values = [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999_8,
            -2.999_999_8,
            8_388_607.5,
            -8_388_607.5,
            1e9,
            -1e9,
            3e38,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for v in values {
            assert_eq!(Real::floor(v).to_bits(), v.floor().to_bits(), "{v}");
        }
        assert!(Real::floor(f32::NAN).is_nan());
        let lanes = F32x8(std::array::from_fn(|l| values[l + 1]));
        assert_eq!(lanes.floor().0.map(f32::to_bits), lanes.0.map(|v| v.floor().to_bits()));
    }

    /// A rigid projection: [`relax_pair`] without compliance, ω = 1.
    fn relax_rigid<T: Real, const FUSED: bool>(a: &mut Point<T>, wa: T, b: &mut Point<T>, wb: T, rest: T) -> T {
        relax_pair::<T, false, FUSED>(a, wa, b, wb, rest, &mut T::splat(0.0), T::splat(0.0), T::splat(1.0))
    }

    fn relax<const FUSED: bool>(a: [f32; 3], wa: f32, b: [f32; 3], wb: f32, rest: f32) -> ([f32; 3], [f32; 3]) {
        let (mut a, mut b) = (a, b);
        relax_rigid::<f32, FUSED>(&mut a, wa, &mut b, wb, rest);
        (a, b)
    }

    /// Each test below runs the kernel unfused and fused (in this build,
    /// without FMA, `f32::mul_add` is the library's exact software one: the
    /// bits of the FMA instruction).
    #[test]
    fn a_weightless_bar_of_no_length_moves_nothing_even_when_barely_compliant() {
        weightless_bar::<false>();
        weightless_bar::<true>();
    }

    fn weightless_bar<const FUSED: bool>() {
        // Lane padding: both ends weigh 0 and sit at one point (ℓ² = 0), a
        // compliant bar with β = 10⁻⁶ (a silk seed cloth's is of that
        // order): W = β. Flooring ℓ² alone at 10⁻³⁶ would give
        // ω / (10⁻³⁶ · 10⁻⁶) = ∞ and 0 · ∞ = NaN in the move (it did, the
        // seed cloth in silk blew up on its first step); the floor is on
        // ℓ² W, so the quotient is at most 10³⁶ and the move is 0 · 0.
        let (mut a, mut b, mut mu) = ([0.5f32, 0.25, 0.0], [0.5f32, 0.25, 0.0], 0.0f32);
        relax_pair::<f32, true, FUSED>(&mut a, 0.0, &mut b, 0.0, 1.0, &mut mu, 1e-6, 1.0);
        assert_eq!((a, b), ([0.5, 0.25, 0.0], [0.5, 0.25, 0.0]));
        assert!(mu.is_finite(), "μ {mu}");
        // The same in lanes, beside a lane that does move (free ends 2 m
        // apart, rest 1: half each, as in Figure 3).
        let mut la =
            [F32x8(std::array::from_fn(|l| if l == 0 { 0.0 } else { 0.5 })), F32x8::splat(0.0), F32x8::splat(0.0)];
        let mut lb =
            [F32x8(std::array::from_fn(|l| if l == 0 { 2.0 } else { 0.5 })), F32x8::splat(0.0), F32x8::splat(0.0)];
        let w = F32x8(std::array::from_fn(|l| if l == 0 { 1.0 } else { 0.0 }));
        relax_rigid::<F32x8, FUSED>(&mut la, w, &mut lb, w, F32x8::splat(1.0));
        assert_eq!((la[0].0[0], lb[0].0[0]), (0.5, 1.5));
        assert!((1..LANES).all(|l| la[0].0[l] == 0.5 && lb[0].0[l] == 0.5));
    }

    #[test]
    fn shares_follow_figure_3_and_the_inverse_masses() {
        figure_3::<false>();
        figure_3::<true>();
    }

    fn figure_3<const FUSED: bool>() {
        let relax = relax::<FUSED>;
        // Free–free of equal mass: half each. Rest 1, length 2 along x.
        assert_eq!(relax([0.0; 3], 1.0, [2.0, 0.0, 0.0], 1.0, 1.0), ([0.5, 0.0, 0.0], [1.5, 0.0, 0.0]));
        // Free–fixed: the free end takes it all.
        assert_eq!(relax([0.0; 3], 0.0, [2.0, 0.0, 0.0], 1.0, 1.0), ([0.0; 3], [1.0, 0.0, 0.0]));
        assert_eq!(relax([0.0; 3], 1.0, [2.0, 0.0, 0.0], 0.0, 1.0), ([1.0, 0.0, 0.0], [2.0, 0.0, 0.0]));
        // Both weightless (fixed or padding): nothing moves.
        assert_eq!(relax([0.0; 3], 0.0, [2.0, 0.0, 0.0], 0.0, 1.0), ([0.0; 3], [2.0, 0.0, 0.0]));
        // a three times as heavy as b (w 1/3 against 1): a moves 1/4 of the
        // correction of 1 m, b 3/4.
        let (a, b) = relax([0.0; 3], 1.0 / 3.0, [2.0, 0.0, 0.0], 1.0, 1.0);
        assert!((a[0] - 0.25).abs() < 1e-6 && (b[0] - 1.25).abs() < 1e-6, "{a:?} {b:?}");
    }

    #[test]
    fn lanes_compute_what_the_scalar_computes() {
        lanes_and_scalar::<false>();
        lanes_and_scalar::<true>();
    }

    fn lanes_and_scalar<const FUSED: bool>() {
        let mut a = [F32x8(std::array::from_fn(|l| l as f32 * 0.3)), F32x8::splat(0.5), F32x8::splat(-1.0)];
        let mut b = [F32x8(std::array::from_fn(|l| 1.0 + l as f32 * 0.7)), F32x8::splat(0.1), F32x8::splat(2.0)];
        let wa = F32x8([1.0, 1.0, 0.0, 1.0, 0.0, 0.5, 0.0, 2.0]);
        let wb = F32x8([1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.25]);
        let (a0, b0) = (a, b);
        relax_rigid::<F32x8, FUSED>(&mut a, wa, &mut b, wb, F32x8::splat(0.8));
        for l in 0..LANES {
            let (sa, sb) = relax::<FUSED>(
                [a0[0].0[l], a0[1].0[l], a0[2].0[l]],
                wa.0[l],
                [b0[0].0[l], b0[1].0[l], b0[2].0[l]],
                wb.0[l],
                0.8,
            );
            assert_eq!(sa, [a[0].0[l], a[1].0[l], a[2].0[l]], "lane {l}");
            assert_eq!(sb, [b[0].0[l], b[1].0[l], b[2].0[l]], "lane {l}");
        }
    }

    #[test]
    fn compliant_projection_matches_the_reference_formula() {
        compliant_against_reference::<false>();
        compliant_against_reference::<true>();
    }

    fn compliant_against_reference<const FUSED: bool>() {
        // The μ form against crate::sim::relax's λ form, over a few passes
        // with β = 0.7, ω = 1.3, free–free, free–fixed and unequal masses.
        for (wa, wb) in [(1.0f32, 1.0f32), (0.0, 1.0), (0.5, 2.0)] {
            let (beta, omega, rest) = (0.7f32, 1.3f32, 1.0f32);
            let (mut a, mut b, mut mu) = ([0.0f32, 0.0, 0.0], [1.8f32, 0.3, -0.2], 0.0f32);
            let (mut ra, mut rb, mut lambda) = (glam::Vec3::from(a), glam::Vec3::from(b), 0.0f32);
            for _ in 0..5 {
                relax_pair::<f32, true, FUSED>(&mut a, wa, &mut b, wb, rest, &mut mu, beta, omega);
                let (da, db) = crate::sim::relax::project_bar_compliant(ra, rb, rest, wa, wb, beta, &mut lambda, omega);
                (ra, rb) = (ra + da, rb + db);
            }
            assert!((glam::Vec3::from(a) - ra).length() < 1e-6 && (glam::Vec3::from(b) - rb).length() < 1e-6);
            assert!((mu - beta * lambda).abs() < 1e-6, "μ {mu} vs βλ {}", beta * lambda);
        }
    }

    #[test]
    fn the_shared_form_is_the_general_one_for_weights_of_zero_and_one() {
        shared_against_general::<false>();
        shared_against_general::<true>();
    }

    fn shared_against_general<const FUSED: bool>() {
        // Rigid bars at ω = 1: the same bits. Compliant and over-relaxed:
        // the same to rounding.
        for (beta, omega) in [(0.0f32, 1.0f32), (0.7, 1.3)] {
            let shares = Shares::new(beta, omega);
            for (wa, wb) in [(1.0f32, 1.0f32), (0.0, 1.0), (1.0, 0.0), (0.0, 0.0)] {
                let (mut a, mut b, mut mu) = ([0.1f32, 0.2, 0.0], [1.9f32, 0.3, -0.2], 0.0f32);
                let (mut ga, mut gb, mut gmu) = (a, b, 0.0f32);
                for _ in 0..3 {
                    let [sa, sb] = shares.weights(wa, true).shares(shares.weights(wb, true));
                    relax_pair_shared::<f32, true, FUSED>(&mut a, sa, &mut b, sb, 1.0, &mut mu, beta);
                    relax_pair::<f32, true, FUSED>(&mut ga, wa, &mut gb, wb, 1.0, &mut gmu, beta, omega);
                }
                if beta == 0.0 {
                    assert_eq!((a, b), (ga, gb), "w {wa} {wb}");
                }
                for k in 0..3 {
                    assert!((a[k] - ga[k]).abs() < 1e-6 && (b[k] - gb[k]).abs() < 1e-6, "β {beta}, w {wa} {wb}");
                }
                // (A bar between two fixed ends moves nothing; its μ is moot.)
                assert!(wa + wb == 0.0 || (mu - gmu).abs() < 1e-6, "μ {mu} vs {gmu}");
            }
        }
        // Padding: a bar to it moves neither end.
        let shares = Shares::new(0.0, 1.0);
        let (mut a, mut b) = ([0.0f32; 3], [2.0f32, 0.0, 0.0]);
        let [sa, sb] = shares.weights(1.0, true).shares(shares.weights(0.0, false));
        relax_pair_shared::<f32, false, FUSED>(&mut a, sa, &mut b, sb, 1.0, &mut 0.0, 0.0);
        assert_eq!((a, b), ([0.0; 3], [2.0, 0.0, 0.0]));
    }

    #[test]
    fn tether_pulls_back_only_free_particles_that_are_too_far() {
        let anchor = [0.0f32; 3];
        let mut far = [3.0f32, 4.0, 0.0];
        tether(&mut far, anchor, 2.5, 1.0);
        assert!((far[0] - 1.5).abs() < 1e-6 && (far[1] - 2.0).abs() < 1e-6, "{far:?}");
        let mut near = [1.0f32, 1.0, 0.0];
        tether(&mut near, anchor, 2.5, 1.0);
        assert_eq!(near, [1.0, 1.0, 0.0]);
        let mut fixed = [3.0f32, 4.0, 0.0];
        tether(&mut fixed, anchor, 2.5, 0.0);
        assert_eq!(fixed, [3.0, 4.0, 0.0]);
        let mut untied = [3.0f32, 4.0, 0.0];
        tether(&mut untied, anchor, f32::INFINITY, 1.0);
        assert_eq!(untied, [3.0, 4.0, 0.0]);
    }

    #[test]
    fn zero_length_bar_stays_finite() {
        assert_eq!(relax::<false>([1.0; 3], 1.0, [1.0; 3], 1.0, 0.5), ([1.0; 3], [1.0; 3]));
        assert_eq!(relax::<true>([1.0; 3], 1.0, [1.0; 3], 1.0, 0.5), ([1.0; 3], [1.0; 3]));
    }

    #[test]
    fn integration_leaves_fixed_particles_alone_and_scales_the_force_by_weight() {
        let (mut x, mut d) = ([-0.0f32, 1.0, 2.0], [0.0f32; 3]);
        integrate(&mut x, &mut d, 0.0, 0.98, [1.0; 3], [0.5; 3]);
        assert_eq!(((-0.0f32).to_bits(), [1.0, 2.0], [0.0; 3]), (x[0].to_bits(), [x[1], x[2]], d));
        integrate(&mut x, &mut d, 1.0, 0.98, [1.0; 3], [0.0; 3]);
        assert_eq!((x, d), ([1.0, 2.0, 3.0], [1.0; 3]));
        // Twice the inverse mass, twice the push of a force.
        let (mut x, mut d) = ([0.0f32; 3], [0.0f32; 3]);
        integrate(&mut x, &mut d, 2.0, 1.0, [1.0; 3], [0.0; 3]);
        assert_eq!(x, [2.0; 3]);
    }

    #[test]
    fn rotations_are_inverse() {
        let v = F32x8(std::array::from_fn(|l| l as f32));
        assert_eq!(v.rotate_down().0, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 0.0]);
        assert_eq!(v.rotate_down().rotate_up(), v);
    }
}
