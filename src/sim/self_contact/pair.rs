//! The self-collide rule for one pair, eight pairs at a time in lanes.
//!
//! For particle i and a particle j within r of it (positions x, substep
//! start x0, rest positions X, inverse masses w):
//!
//! ```text
//! d = x_i − x_j,   n = d / |d|,   d_min = min(r, |X_i − X_j|)
//! s = w_i / (w_i + w_j)                        i's share
//! p = (d_min − |d|) · s                        the push, when |d| < d_min
//! Δ = (x_i − x0_i) − (x_j − x0_j),   t = Δ − n (Δ·n)     the slide
//! f = t · s                  when |t| ≤ μ p    (static: the slide undone)
//!   = t · (s μ p / |t|)      otherwise         (kinetic: μ times the push)
//! i moves by  n p − f
//! ```
//!
//! A pair with |d| ≥ d_min or d = 0 gives nothing. Every lane computes the
//! one-pair form with the same operations in the same order, so a pair gets
//! the same bits whichever lane or batch it is in.
//!
//! **Both ends at once.** Each pair is computed once, for i and for j. With
//! the roles swapped, d, n, Δ and t only change sign, which IEEE arithmetic
//! does exactly (−a − (−b) = b − a, (−a)·b = −(a·b)), and |d|, d_min,
//! Δ·n, |t| are the same numbers; only the share differs,
//! `s_j = w_j / (w_i + w_j)`. So j's move is
//!
//! ```text
//! j moves by  t f_j − n p_j        p_j = (d_min − |d|) · s_j,  f_j as f with s_j, p_j
//! ```
//!
//! with the bits the rule gives when j is the owner.
//!
//! **d_min given.** d_min depends on the rest positions alone, so for the
//! pairs of a kept list it is computed once, at the search ([`d_min`],
//! the same operations, so the same bits), and the batches read one number
//! a pair instead of gathering both ends' rest rows every substep.

use glam::{Vec3A, Vec4};

use super::SelfContactStep;
use crate::sim::fast::kernel::{LANES, Point, Real, dot, each_lane, scale, sub};
use crate::sim::fast::rows::{Rows, prefetch};
#[cfg(target_arch = "x86_64")]
use crate::sim::fast::simd::{self, SimdLevel};
use crate::sim::fast::wide_lanes::Wide;

/// What the phase reads of each slot of the sorted table, one 16-byte row
/// each (one load a row in the AVX2 path).
pub(super) struct Slots<'a> {
    /// x and w: `[x, y, z, w]`.
    pub(super) point: &'a [[f32; 4]],
    /// x0 and a mark: `[x, y, z, 1 or 0]` (1: a slot whose pairs
    /// `masked` drops).
    pub(super) start: &'a [[f32; 4]],
    /// X: `[x, y, z, 0]`.
    pub(super) rest: &'a [[f32; 4]],
}

/// Pairs of slots, `own[k]` with `other[k]`.
pub(super) struct PairSlots<'a> {
    pub(super) own: &'a [u32],
    pub(super) other: &'a [u32],
    /// `Some`: a kept list's pairs (`self_contact/list.rs`), with each
    /// pair's d_min ([`d_min`], computed at the search). They come to the
    /// rule untested, so a pair with an end marked (a mover) or with both
    /// ends pinned gives nothing; the mark comes with the start row that
    /// the rule reads anyway: no load of its own. `None`: d_min from the
    /// rest rows, and no mask.
    pub(super) listed: Option<&'a [f32]>,
}

/// The moves of pair k's two slots, `own[k]` and `other[k]`.
pub(super) struct Moves<'a> {
    pub(super) own: &'a mut [Vec3A],
    pub(super) other: &'a mut [Vec3A],
}

/// What the two slots of each of `pairs` do to each other, into `out`
/// (every slice the same length; the two slots of a pair not both pinned,
/// unless the pairs are listed).
#[allow(unsafe_code)]
pub(super) fn pair_corrections(slots: &Slots, pairs: &PairSlots, out: Moves, step: &SelfContactStep) {
    #[cfg(target_arch = "x86_64")]
    match simd::level() {
        SimdLevel::Avx512 => {
            // SAFETY: the level is AVX-512 only when the CPU reports AVX-512
            // F and VL besides AVX2 and FMA, the features
            // `avx2::pair_corrections_avx512` is compiled for.
            unsafe { avx2::pair_corrections_avx512(slots, pairs, out, step) };
            return;
        }
        SimdLevel::Avx2 => {
            // SAFETY: the level is AVX2 only when the CPU reports AVX2 and
            // FMA, the features `avx2::pair_corrections` is compiled for.
            unsafe { avx2::pair_corrections(slots, pairs, out, step) };
            return;
        }
        SimdLevel::Portable => {}
    }
    // Without AVX2: the `wide` crate's vectors (NEON, SSE).
    corrections_in::<Wide>(slots, pairs, out, step);
}

/// [`pair_corrections`] on lanes of type `T`: one loop for a kept list's
/// pairs, one for the others (the mask's loads and selects kept out of
/// the plain loop's registers).
#[inline(always)]
fn corrections_in<T: Rows>(slots: &Slots, pairs: &PairSlots, out: Moves, step: &SelfContactStep) {
    match pairs.listed {
        None => corrections_of::<T, false>(slots, pairs, out, step),
        Some(_) => corrections_of::<T, true>(slots, pairs, out, step),
    }
}

/// Batches ahead whose far ends [`corrections_of`] prefetches.
const AHEAD: usize = 8;

/// [`corrections_in`], with `LISTED` when `pairs` are a kept list's (their
/// d_min given): whole batches of eight pairs, then the last one padded.
///
/// Each batch first prefetches the rows of the far ends (`other`) of the
/// batch [`AHEAD`] batches on, positions and start rows. The pairs come in
/// slot order of their own ends, so those rows are read in order; the far
/// ends are anywhere in the cloth's other layer, rows the hardware cannot
/// see coming. On host G (Intel Xeon, two threads, the folded 256 × 256
/// sheet), with and without alternated window by window in one process
/// (medians of 20 windows), the step with / without: 8 batches ahead
/// 0.972–0.992 at AVX2 (four runs), 0.983 at AVX-512, 0.966 on one thread;
/// 3 ahead 0.974–0.994, 6 ahead 0.964–0.992, 12 ahead 0.970–0.980. On the
/// draped disc-183, whose phase is mostly its search, 0.981–1.010 (four
/// runs): no change. A prefetch changes no value: the same bits.
#[inline(always)]
fn corrections_of<T: Rows, const LISTED: bool>(slots: &Slots, pairs: &PairSlots, out: Moves, step: &SelfContactStep) {
    let (own, other, given) = (pairs.own, pairs.other, pairs.listed.unwrap_or(&[]));
    debug_assert!(!LISTED || given.len() == own.len(), "one d_min a listed pair");
    let tail = own.len() / LANES * LANES;
    let batches = own[..tail].chunks_exact(LANES).zip(other[..tail].chunks_exact(LANES));
    let outs = out.own[..tail].chunks_exact_mut(LANES).zip(out.other[..tail].chunks_exact_mut(LANES));
    let far = |rows: &[[f32; 4]], s: u32| rows.as_ptr().wrapping_add(s as usize).cast::<u8>();
    for (k, ((own, other), (out_i, out_j))) in batches.zip(outs).enumerate() {
        if let Some(ahead) = pairs.other.get((k + AHEAD) * LANES..(k + AHEAD + 1) * LANES) {
            for &s in ahead {
                prefetch::<true>(far(slots.point, s));
                prefetch::<true>(far(slots.start, s));
            }
        }
        let a: [usize; LANES] = each_lane!(|l| own[l] as usize);
        let b: [usize; LANES] = each_lane!(|l| other[l] as usize);
        // One bounds check a batch (the slice is eight long).
        let d_mins = if LISTED { given[k * LANES..][..LANES].try_into().unwrap_or([0.0; LANES]) } else { [0.0; LANES] };
        let [moved_i, moved_j] = batch::<T, LISTED>(slots, &a, &b, d_mins, step);
        store(moved_i, out_i);
        store(moved_j, out_j);
    }
    if tail < own.len() {
        // Lanes past the end pair slot 0 with itself: d = 0, nothing.
        let a: [usize; LANES] = std::array::from_fn(|l| own.get(tail + l).map_or(0, |&s| s as usize));
        let b: [usize; LANES] = std::array::from_fn(|l| other.get(tail + l).map_or(0, |&s| s as usize));
        let d_mins: [f32; LANES] = std::array::from_fn(|l| given.get(tail + l).copied().unwrap_or(0.0));
        let [moved_i, moved_j] = batch::<T, LISTED>(slots, &a, &b, d_mins, step);
        let (mut i, mut j) = ([Vec3A::ZERO; LANES], [Vec3A::ZERO; LANES]);
        store(moved_i, &mut i);
        store(moved_j, &mut j);
        let left = own.len() - tail;
        out.own[tail..].copy_from_slice(&i[..left]);
        out.other[tail..].copy_from_slice(&j[..left]);
    }
}

/// The moves of slots `a[l]` and `b[l]`'s pairs ([`rule`]); with
/// `LISTED`, d_min is `d_mins[l]`, and nothing where an end's start row is
/// marked or both ends are pinned (else d_min from the rest rows).
#[inline(always)]
fn batch<T: Rows, const LISTED: bool>(
    slots: &Slots,
    a: &[usize; LANES],
    b: &[usize; LANES],
    d_mins: [f32; LANES],
    step: &SelfContactStep,
) -> [Point<T>; 2] {
    let point = |rows: &[[f32; 4]], s: &[usize; LANES]| -> Point<T> {
        let [x, y, z, _] = T::gather(rows, s);
        [x, y, z]
    };
    let [xi0, xi1, xi2, wi] = T::gather(slots.point, a);
    let [xj0, xj1, xj2, wj] = T::gather(slots.point, b);
    let [x0i0, x0i1, x0i2, mark_i] = T::gather(slots.start, a);
    let [x0j0, x0j1, x0j2, mark_j] = T::gather(slots.start, b);
    let keep = match LISTED {
        true => T::from_values(d_mins),
        false => d_min(point(slots.rest, a), point(slots.rest, b), T::splat(step.thickness)),
    };
    let [moved_i, moved_j] =
        rule([xi0, xi1, xi2], [xj0, xj1, xj2], [x0i0, x0i1, x0i2], [x0j0, x0j1, x0j2], keep, wi, wj, step);
    if !LISTED {
        return [moved_i, moved_j];
    }
    // Marks are 0 or 1: their sum is 0 only when neither end is marked.
    let (zero, half) = (T::splat(0.0), T::splat(0.5));
    let acts = T::if_greater(wi + wj, zero, T::if_greater(mark_i + mark_j, half, zero, T::splat(1.0)), zero);
    // Written out: a closure mapped over the points was left a call per
    // select.
    [
        [
            T::if_greater(acts, half, moved_i[0], zero),
            T::if_greater(acts, half, moved_i[1], zero),
            T::if_greater(acts, half, moved_i[2], zero),
        ],
        [
            T::if_greater(acts, half, moved_j[0], zero),
            T::if_greater(acts, half, moved_j[1], zero),
            T::if_greater(acts, half, moved_j[2], zero),
        ],
    ]
}

/// Lane l of `moved` into `out[l]`, for the lanes `out` has, a row at a
/// time (the rows' fourth lane is 0).
#[inline(always)]
fn store<T: Rows>(moved: Point<T>, out: &mut [Vec3A]) {
    let [x, y, z] = moved;
    let rows = T::to_rows([x, y, z, T::splat(0.0)]);
    for (out, row) in out.iter_mut().zip(rows) {
        *out = Vec3A::from_vec4(Vec4::from_array(row));
    }
}

/// d_min = min(r, |X_i − X_j|) of pairs with rest positions `rest_i`
/// and `rest_j`: in lanes, or one pair at a time as `f32` (the same
/// operations, so the same bits).
#[inline(always)]
pub(super) fn d_min<T: Real>(rest_i: Point<T>, rest_j: Point<T>, r: T) -> T {
    let rest = sub(rest_i, rest_j);
    let rest = dot(rest, rest).sqrt();
    // min(rest, r), as f32::min for numbers.
    T::if_greater(rest, r, r, rest)
}

/// The rule of the module docs for eight pairs in lanes: i's position,
/// j's, their substep-start positions, d_min ([`d_min`]) and weights; i's
/// move and j's.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn rule<T: Real>(
    xi: Point<T>,
    xj: Point<T>,
    x0i: Point<T>,
    x0j: Point<T>,
    keep: T,
    wi: T,
    wj: T,
    step: &SelfContactStep,
) -> [Point<T>; 2] {
    let zero = T::splat(0.0);
    let d = sub(xi, xj);
    let dist2 = dot(d, d);
    let dist = dist2.sqrt();
    let (share_i, share_j) = (wi / (wi + wj), wj / (wi + wj));
    let n = [d[0] / dist, d[1] / dist, d[2] / dist];
    let (push_i, push_j) = ((keep - dist) * share_i, (keep - dist) * share_j);
    let relative = sub(sub(xi, x0i), sub(xj, x0j));
    let tangential = sub(relative, scale(n, dot(relative, n)));
    let slide = dot(tangential, tangential).sqrt();
    let moved_i = sub(scale(n, push_i), scale(tangential, friction(share_i, push_i, slide, step)));
    let moved_j = sub(scale(tangential, friction(share_j, push_j, slide, step)), scale(n, push_j));
    // Nothing unless 0 < |d| < d_min (and |d| < r, which d_min ≤ r implies).
    let touching = |v: T| T::if_greater(dist2, zero, T::if_greater(keep, dist, v, zero), zero);
    [
        [touching(moved_i[0]), touching(moved_i[1]), touching(moved_i[2])],
        [touching(moved_j[0]), touching(moved_j[1]), touching(moved_j[2])],
    ]
}

/// The factor of the slide t one end removes, with its share and push:
/// static (the slide undone, by the share) or kinetic (μ times the push).
#[inline(always)]
fn friction<T: Real>(share: T, push: T, slide: T, step: &SelfContactStep) -> T {
    let bound = T::splat(step.friction) * push;
    let kinetic = share * bound / slide;
    T::if_greater(slide, bound, kinetic, share)
}

/// [`pair_corrections`] in AVX registers.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Moves, PairSlots, SelfContactStep, Slots, corrections_in};
    use crate::sim::fast::avx::Avx;

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn pair_corrections(slots: &Slots, pairs: &PairSlots, out: Moves, step: &SelfContactStep) {
        corrections_in::<Avx>(slots, pairs, out, step);
    }

    /// The same 256-bit code where AVX-512 VL gives it 32 vector
    /// registers instead of 16.
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    pub(super) fn pair_corrections_avx512(slots: &Slots, pairs: &PairSlots, out: Moves, step: &SelfContactStep) {
        corrections_in::<Avx>(slots, pairs, out, step);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Moves as `Vec3`s, to compare with the one-pair rule.
    fn plain(moves: Vec<Vec3A>) -> Vec<Vec3> {
        moves.into_iter().map(Vec3::from).collect()
    }

    type Build = fn(&Slots, &PairSlots, Moves, &SelfContactStep);

    /// Every build of the rule this CPU runs, by name: the portable lanes,
    /// and the AVX2 and AVX-512 builds where the CPU has their features
    /// (called directly: the level that `pair_corrections` picks is the
    /// process's, shared with the tests running beside these).
    #[allow(unsafe_code)]
    fn builds() -> Vec<(&'static str, Build)> {
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
        let mut builds: Vec<(&'static str, Build)> =
            vec![("portable", |s, pairs, out, step| corrections_in::<Wide>(s, pairs, out, step))];
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
                // SAFETY: pushed only where the CPU has AVX2 and FMA.
                let avx2: Build = |s, pairs, out, step| unsafe { avx2::pair_corrections(s, pairs, out, step) };
                builds.push(("avx2", avx2));
            }
            if is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vl") {
                // SAFETY: pushed only where the CPU has AVX-512 F and VL
                // (and so AVX2 and FMA).
                let avx512: Build = |s, pairs, out, step| unsafe { avx2::pair_corrections_avx512(s, pairs, out, step) };
                builds.push(("avx512", avx512));
            }
        }
        builds
    }

    /// The module docs' rule for one pair, written plainly.
    #[allow(clippy::too_many_arguments)]
    fn one_pair(
        xi: Vec3,
        xj: Vec3,
        x0i: Vec3,
        x0j: Vec3,
        ri: Vec3,
        rj: Vec3,
        wi: f32,
        wj: f32,
        r: f32,
        mu: f32,
    ) -> Vec3 {
        let d = xi - xj;
        let dist2 = d.length_squared();
        if dist2 >= r * r || dist2 == 0.0 {
            return Vec3::ZERO;
        }
        let keep = ri.distance(rj).min(r);
        let dist = dist2.sqrt();
        if dist >= keep {
            return Vec3::ZERO;
        }
        let share = wi / (wi + wj);
        let n = d / dist;
        let push = (keep - dist) * share;
        let relative = (xi - x0i) - (xj - x0j);
        let tangential = relative - n * relative.dot(n);
        let slide = tangential.length();
        let bound = mu * push;
        let friction = if slide <= bound { tangential * share } else { tangential * (share * bound / slide) };
        n * push - friction
    }

    #[test]
    fn lanes_give_each_pair_the_bits_of_the_one_pair_rule() {
        // Slot 0 against slots 1..=11 (r = 1 cm, μ = 0.4), chosen to reach
        // every branch: pushed with static friction (small slide), with
        // kinetic friction (large slide), coincident (d = 0), farther than
        // r, rest neighbours at 5 mm kept only at 5 mm (one inside, one
        // outside that distance), a pinned partner (w_j = 0, i takes the
        // whole push), and random pairs for the rest.
        let r = 0.01;
        let p = Vec3::new(0.3, 0.2, 0.1);
        let mut x = vec![p];
        let mut x0 = vec![p];
        let mut rest = vec![Vec3::ZERO];
        let mut w = vec![1.0];
        let mut add = |xj: Vec3, x0j: Vec3, rj: Vec3, wj: f32| {
            x.push(xj);
            x0.push(x0j);
            rest.push(rj);
            w.push(wj);
        };
        let far = Vec3::X;
        add(p + Vec3::new(0.0, 0.004, 0.0), p + Vec3::new(0.0001, 0.004, 0.0), far, 1.0); // static
        add(p + Vec3::new(0.0, 0.006, 0.0), p + Vec3::new(0.005, 0.006, 0.0), far, 2.0); // kinetic
        add(p, p, far, 1.0); // d = 0
        add(p + Vec3::new(0.0, 0.02, 0.0), p, far, 1.0); // beyond r
        add(p + Vec3::new(0.003, 0.0, 0.0), p, Vec3::new(0.005, 0.0, 0.0), 1.0); // rest neighbour, inside
        add(p + Vec3::new(0.007, 0.0, 0.0), p, Vec3::new(0.005, 0.0, 0.0), 1.0); // rest neighbour, outside
        add(p + Vec3::new(0.0, 0.0, 0.005), p + Vec3::new(0.001, 0.0, 0.005), far, 0.0); // pinned partner
        let mut seed = 7u32;
        let mut random = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32 - 0.5
        };
        for _ in 0..4 {
            let xj = p + Vec3::new(random(), random(), random()) * 0.015;
            let x0j = xj + Vec3::new(random(), random(), random()) * 0.004;
            add(xj, x0j, Vec3::new(random(), random(), random()) * 0.02, 1.0);
        }
        let row = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
        let point: Vec<[f32; 4]> = x.iter().zip(&w).map(|(&v, &w)| row(v, w)).collect();
        let start: Vec<[f32; 4]> = x0.iter().map(|&v| row(v, 0.0)).collect();
        let rests: Vec<[f32; 4]> = rest.iter().map(|&v| row(v, 0.0)).collect();
        let slots = Slots { point: &point, start: &start, rest: &rests };
        let other: Vec<u32> = (1..x.len() as u32).collect();
        let own = vec![0u32; other.len()];
        let step = SelfContactStep { thickness: r, friction: 0.4, parallel: false };
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        // The pairs as a kept list gives them: d_min computed beforehand,
        // one pair at a time (no end marked, none with both ends pinned).
        let keep = listed_d_min(&rests, &own, &other, r);
        // 11 pairs: a whole batch of eight and a padded one, in every build,
        // with d_min from the rest rows and given.
        let mut results = Vec::new();
        for (build, corrections) in builds() {
            for listed in [None, Some(&keep[..])] {
                let mut moved = vec![Vec3A::NAN; other.len()];
                let mut moved_j = vec![Vec3A::NAN; other.len()];
                let pairs = PairSlots { own: &own, other: &other, listed };
                corrections(&slots, &pairs, Moves { own: &mut moved, other: &mut moved_j }, &step);
                results.push((build, plain(moved), plain(moved_j)));
            }
        }
        // The AVX2 build is among those compared wherever the CPU has it.
        #[cfg(target_arch = "x86_64")]
        assert!(
            !is_x86_feature_detected!("avx2") || results.iter().any(|(build, ..)| *build == "avx2"),
            "the AVX2 build is not compared on a CPU that has AVX2"
        );
        // Each pair's moves by the one-pair rule: i's end, and j's as the
        // rule gives it with j as the owner.
        let expected: Vec<(Vec3, Vec3)> = other
            .iter()
            .map(|&j| {
                let j = j as usize;
                let i_end = one_pair(x[0], x[j], x0[0], x0[j], rest[0], rest[j], w[0], w[j], r, 0.4);
                let j_end = one_pair(x[j], x[0], x0[j], x0[0], rest[j], rest[0], w[j], w[0], r, 0.4);
                (i_end, j_end)
            })
            .collect();
        for (build, moved, moved_j) in &results {
            for (k, (&j, &(i_end, j_end))) in other.iter().zip(&expected).enumerate() {
                assert_eq!(bits(moved[k]), bits(i_end), "{build}: pair {j}");
                assert_eq!(bits(moved_j[k]), bits(j_end), "{build}: pair {j}, j's end");
            }
        }
        let pushed = expected.iter().filter(|(i_end, _)| *i_end != Vec3::ZERO).count();
        let (_, moved, moved_j) = &results[0];
        // Static, kinetic, the rest neighbour inside 5 mm and the pinned
        // partner at least are pushed; d = 0, beyond r and the rest
        // neighbour outside 5 mm are not.
        assert!(pushed >= 4, "{moved:?}");
        assert_eq!([moved[2], moved[3], moved[5]], [Vec3::ZERO; 3]);
        // The pinned partner: i takes the whole push, 1 cm − 5 mm, along +z
        // less the friction's sideways part, and the partner none.
        assert!((moved[6].z + 0.005).abs() < 1e-6, "{:?}", moved[6]);
        assert_eq!(moved_j[6], Vec3::ZERO);
        // The kinetic pair (w_j = 2): j takes two thirds of the push, along
        // +y: 2/3 · (1 cm − 6 mm).
        assert!((moved_j[1].y - 2.0 / 3.0 * 0.004).abs() < 1e-6, "{:?}", moved_j[1]);
    }

    /// d_min of each pair, one pair at a time, as a search computes it for
    /// a kept list.
    fn listed_d_min(rest: &[[f32; 4]], own: &[u32], other: &[u32], r: f32) -> Vec<f32> {
        let point = |s: u32| {
            let row = rest[s as usize];
            [row[0], row[1], row[2]]
        };
        own.iter().zip(other).map(|(&i, &j)| d_min(point(i), point(j), r)).collect()
    }

    #[test]
    fn a_wrong_d_min_given_changes_the_pushes() {
        // The check above could pass were the given d_min never read: with
        // r given for every pair instead, the rest neighbours 3 mm apart
        // (rest 5 mm, so d_min = 5 mm) are pushed to 1 cm instead.
        let r = 0.01;
        let point = vec![[0.0, 0.0, 0.0, 1.0], [0.003, 0.0, 0.0, 1.0]];
        let start = vec![[0.0, 0.0, 0.0, 0.0], [0.003, 0.0, 0.0, 0.0]];
        let rest = vec![[0.0, 0.0, 0.0, 0.0], [0.005, 0.0, 0.0, 0.0]];
        let slots = Slots { point: &point, start: &start, rest: &rest };
        let step = SelfContactStep { thickness: r, friction: 0.0, parallel: false };
        let (own, other) = ([0u32], [1u32]);
        let keep = listed_d_min(&rest, &own, &other, r);
        assert_eq!(keep, [0.005], "d_min = min(r, 5 mm)");
        for (build, corrections) in builds() {
            let run = |keep: &[f32]| {
                let (mut i, mut j) = (vec![Vec3A::NAN; 1], vec![Vec3A::NAN; 1]);
                let pairs = PairSlots { own: &own, other: &other, listed: Some(keep) };
                corrections(&slots, &pairs, Moves { own: &mut i, other: &mut j }, &step);
                i[0].x
            };
            // Each end takes half of 5 mm − 3 mm, or of 1 cm − 3 mm.
            assert!((run(&keep) + 0.001).abs() < 1e-7, "{build}: {}", run(&keep));
            assert!((run(&[r]) + 0.0035).abs() < 1e-7, "{build}: {}", run(&[r]));
        }
    }

    #[test]
    fn marked_ends_and_pinned_pairs_give_nothing_when_asked() {
        // Slot 0 against slots 1..=4, each 4 mm away (r = 1 cm): every pair
        // is pushed. Marking slot 2, and pinning slots 0 and 4 after the
        // first run, leaves pairs 0–1 and 0–3 (slot 0 pinned, its partner
        // free) with the bits they had; 0–2 (marked) and 0–4 (both pinned)
        // give exactly nothing, where 0/0 shares would otherwise give NaN.
        // The four pairs come three times, so the mask acts in a whole
        // batch of eight and in a padded one, in every build.
        let r = 0.01;
        let p = Vec3::new(0.1, 0.2, 0.3);
        let x: Vec<Vec3> = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X].iter().map(|d| p + *d * 0.004).collect();
        let rest: Vec<[f32; 4]> = (0..5).map(|i| [i as f32, 0.0, 0.0, 0.0]).collect();
        let step = SelfContactStep { thickness: r, friction: 0.3, parallel: false };
        let (own, other) = (vec![0u32; 12], [1u32, 2, 3, 4].repeat(3));
        for (build, corrections) in builds() {
            // `skip`: the marks, in the start rows' fourth lane, and the mask on.
            let run = |w: [f32; 5], skip: Option<&[bool]>| {
                let point: Vec<[f32; 4]> = x.iter().zip(w).map(|(v, w)| [v.x, v.y, v.z, w]).collect();
                let mark = |k: usize| skip.map_or(0.0, |marked| f32::from(u8::from(marked[k])));
                let start: Vec<[f32; 4]> = x.iter().enumerate().map(|(k, v)| [v.x, v.y, v.z, mark(k)]).collect();
                let slots = Slots { point: &point, start: &start, rest: &rest };
                let keep = listed_d_min(&rest, &own, &other, r);
                let pairs = PairSlots { own: &own, other: &other, listed: skip.map(|_| &keep[..]) };
                let (mut i, mut j) = (vec![Vec3A::NAN; 12], vec![Vec3A::NAN; 12]);
                corrections(&slots, &pairs, Moves { own: &mut i, other: &mut j }, &step);
                (plain(i), plain(j))
            };
            marked_and_pinned(build, run);
        }
    }

    /// The assertions of `marked_ends_and_pinned_pairs_give_nothing_when_asked`
    /// for one build: `run(w, marks)` gives the twelve pairs' moves.
    fn marked_and_pinned(build: &str, run: impl Fn([f32; 5], Option<&[bool]>) -> (Vec<Vec3>, Vec<Vec3>)) {
        let pinned = [0.0, 1.0, 1.0, 1.0, 0.0];
        let (i, j) = run(pinned, None);
        assert!(i[3].is_nan() && j[3].is_nan(), "{build}: both pinned, unmasked: 0/0 shares");
        let marked = [false, false, true, false, false];
        let (mi, mj) = run(pinned, Some(&marked));
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for k in 0..12 {
            if k % 4 == 0 || k % 4 == 2 {
                assert_eq!((bits(mi[k]), bits(mj[k])), (bits(i[k]), bits(j[k])), "{build}: pair {k}");
                assert!(mj[k].length() > 1e-3, "{build}: pair {k} is pushed: {:?}", mj[k]);
            } else {
                assert_eq!((bits(mi[k]), bits(mj[k])), (bits(Vec3::ZERO), bits(Vec3::ZERO)), "{build}: pair {k}");
            }
        }
        // Unmarked and free, pair 0–2 is pushed: the mark is what stops it.
        let (_, free) = run([1.0; 5], Some(&[false; 5]));
        assert!(free[1].length() > 1e-3 && free[9].length() > 1e-3, "{build}: {:?}", free[1]);
    }
}
