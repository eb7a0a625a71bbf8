//! The coloured layout's collide phase: a chunk of particles at a time,
//! eight of them in lanes, as the grid's tiles do.
//!
//! For each chunk ([`super::CHUNK`] particles of the layout's order): the
//! box of its moving particles' start positions x0 = x_pred − d and
//! positions x, and the colliders that may touch it
//! ([`ContactStep::near`]). Then eight particles at a time are gathered
//! from their 16-byte rows into lanes; the lane filter
//! ([`ContactStep::may_touch_lanes`]) clears the lanes no collider can
//! move (most of them: a draped cloth's particles are mostly clear of the
//! shapes' surfaces), and only the others are resolved
//! ([`ContactStep::resolve_lanes`]) and written back. Each lane gets the
//! bits [`ContactStep::resolve`] gives its particle against every collider
//! (a lane pushed out of its chunk's box is resolved again against all of
//! them), so the phase gives the same bits on any thread count and at
//! every SIMD level (the lanes' operations are those of one particle).
//!
//! One particle at a time against every collider, on one thread, the
//! phase took 5.1 ms of a step of disc-183 draped over a ball onto the
//! ground; in chunks in lanes it takes 4.0 ms on one thread and 2.3 ms on
//! two (host D, both in one process, wall clock on a busy host).
//!
//! **The box and the lanes with AVX2.** Written as loops over each
//! particle's coordinates, the chunk's box kept its six bounds on the stack
//! (a store and a reload each, every particle: 45 instructions a particle)
//! and the octets' lanes were stored one value at a time and read back
//! whole, which the store buffer cannot forward; the two were about 45 %
//! of the phase (`perf annotate`). With AVX2 an octet is now taken in
//! registers: its rows transposed, q − d taken on the stored rows and split
//! into x, y and z by blends and permutes, the box kept in lanes. On host
//! G (Intel Xeon, 2 threads) disc-183 draped with contact stepped 2.3–3.5 %
//! quicker (AVX2 10.37 → 10.14 and 10.50 → 10.13 ms, AVX-512 9.59 → 9.30
//! ms; medians of 16 alternated windows a side), about a quarter of the
//! phase; the same bits (every particle's, 30 steps, both levels).

use glam::Vec3;

use super::Particle;
use crate::sim::contact::ContactStep;
use crate::sim::fast::kernel::{F32x8, LANES, Point, lane};
use crate::sim::fast::simd::dispatch;
#[cfg(target_arch = "x86_64")]
use crate::sim::fast::simd::{self, SimdLevel};

dispatch! {
    /// The collide phase on one chunk: `particles` with their
    /// displacements `d` and predicted positions `q` (its lanes compiled
    /// for the SIMD level).
    pub(super) fn collide_chunk(particles: &mut [Particle], d: &[[f32; 3]], q: &[[f32; 3]], contact: &ContactStep)
        = collide_chunk_body, best = ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"]
}

#[inline(always)]
fn collide_chunk_body(particles: &mut [Particle], d: &[[f32; 3]], q: &[[f32; 3]], contact: &ContactStep) {
    // Decided once a chunk: the box and the octets in AVX2 registers.
    #[cfg(target_arch = "x86_64")]
    let registers = simd::level() >= SimdLevel::Avx2;
    #[cfg(not(target_arch = "x86_64"))]
    let registers = false;
    let Some((lo, hi)) = moving_box(particles, d, q, registers) else {
        return;
    };
    let near = contact.near(lo, hi);
    if near.is_empty() {
        return;
    }
    for ((rows, d), q) in particles.chunks_mut(LANES).zip(d.chunks(LANES)).zip(q.chunks(LANES)) {
        let (mut x, x0, moving) = octet(rows, d, q, registers);
        let lanes = contact.collide_lanes(&near, (lo, hi), || moving, &x0, &mut x);
        for (l, row) in rows.iter_mut().enumerate().filter(|(l, _)| lanes & (1 << l) != 0) {
            row.position = lane(&x, l).to_array();
        }
    }
}

/// The box of the moving particles' start positions x0 = q − d and
/// positions x, or None when none moves: with `registers` (the level is
/// AVX2 or above) eight particles at a time in lanes
/// ([`avx2::moving_box`]), else one at a time.
#[inline(always)]
#[allow(unsafe_code)]
#[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
fn moving_box(particles: &[Particle], d: &[[f32; 3]], q: &[[f32; 3]], registers: bool) -> Option<(Vec3, Vec3)> {
    #[cfg(target_arch = "x86_64")]
    if registers {
        // SAFETY: the level is AVX2 or above only when the CPU reports AVX2
        // and FMA, the features the function is compiled for.
        return unsafe { avx2::moving_box(particles, d, q) };
    }
    moving_box_scalar(particles, d, q)
}

/// [`moving_box`] one particle at a time.
#[inline(always)]
fn moving_box_scalar(particles: &[Particle], d: &[[f32; 3]], q: &[[f32; 3]]) -> Option<(Vec3, Vec3)> {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for ((p, d), q) in particles.iter().zip(d).zip(q) {
        if p.weight > 0.0 {
            for i in 0..3 {
                let x0 = q[i] - d[i];
                lo[i] = lo[i].min(p.position[i]).min(x0);
                hi[i] = hi[i].max(p.position[i]).max(x0);
            }
        }
    }
    (lo[0] <= hi[0]).then(|| (Vec3::from_array(lo), Vec3::from_array(hi)))
}

/// Eight particles in lanes: positions x, start positions x0 = q − d, and
/// which of them move (bit l: lane l's weight > 0); with `registers` a
/// whole octet in registers ([`avx2::octet`]), else lane by lane.
#[inline(always)]
#[allow(unsafe_code)]
#[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
fn octet(rows: &[Particle], d: &[[f32; 3]], q: &[[f32; 3]], registers: bool) -> (Point<F32x8>, Point<F32x8>, u8) {
    #[cfg(target_arch = "x86_64")]
    if registers && rows.len() == LANES {
        // SAFETY: as in `moving_box`; the octet is whole.
        return unsafe { avx2::octet(rows, d, q) };
    }
    octet_scalar(rows, d, q)
}

/// [`octet`] lane by lane. Lanes past a short octet's end hold a particle
/// of weight 0 at the origin: never moved, never written.
#[inline(always)]
fn octet_scalar(rows: &[Particle], d: &[[f32; 3]], q: &[[f32; 3]]) -> (Point<F32x8>, Point<F32x8>, u8) {
    // Plain loops over arrays (as in `moving_box_scalar`): built with
    // `std::array::from_fn` and `Vec3`, the lanes went through the stack
    // element by element.
    let (mut x, mut x0) = ([F32x8([0.0; LANES]); 3], [F32x8([0.0; LANES]); 3]);
    let mut moving = 0u8;
    for (l, ((p, d), q)) in rows.iter().zip(d).zip(q).enumerate() {
        for i in 0..3 {
            x[i].0[l] = p.position[i];
            x0[i].0[l] = q[i] - d[i];
        }
        moving |= u8::from(p.weight > 0.0) << l;
    }
    (x, x0, moving)
}

#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx2 {
    use std::arch::x86_64::{
        __m256, _CMP_GT_OQ, _mm256_blend_ps, _mm256_blendv_ps, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_max_ps,
        _mm256_min_ps, _mm256_movemask_ps, _mm256_permutevar8x32_ps, _mm256_set1_ps, _mm256_setr_epi32,
        _mm256_setzero_ps, _mm256_sub_ps,
    };

    use glam::Vec3;

    use super::{LANES, Particle, moving_box_scalar};
    use crate::sim::fast::avx::transpose_rows;
    use crate::sim::fast::kernel::{F32x8, Point};

    /// Positions, weights and start positions of eight particles in lanes:
    /// the rows transposed ([`transpose_rows`]), and q − d taken on the
    /// rows as stored (three 32-byte loads of each, element by element: the
    /// bits of each lane's subtraction) and then split into x, y and z
    /// (six blends and three permutes).
    ///
    /// # Safety
    /// AVX2 is available; each slice holds eight elements.
    #[inline(always)]
    unsafe fn lanes(rows: &[Particle], d: &[[f32; 3]], q: &[[f32; 3]]) -> ([__m256; 3], __m256, [__m256; 3]) {
        assert!(rows.len() == LANES && d.len() == LANES && q.len() == LANES);
        let rows: &[[f32; 4]] = bytemuck::cast_slice(rows);
        let [x, y, z, w] = transpose_rows(std::array::from_fn(|l| bytemuck::cast(rows[l])));
        let (d, q): (&[f32], &[f32]) = (bytemuck::cast_slice(d), bytemuck::cast_slice(q));
        // SAFETY: 24 floats each (asserted above); AVX2 is available.
        unsafe {
            let start =
                |k: usize| _mm256_sub_ps(_mm256_loadu_ps(q[8 * k..].as_ptr()), _mm256_loadu_ps(d[8 * k..].as_ptr()));
            // a = x0 y0 z0 x1 y1 z1 x2 y2, b = z2 x3 y3 z3 x4 y4 z4 x5,
            // c = y5 z5 x6 y6 z6 x7 y7 z7.
            let (a, b, c) = (start(0), start(1), start(2));
            // x: a at 0, 3, 6; b at 1, 4, 7; c at 2, 5 → x0 x3 x6 x1 x4 x7 x2 x5.
            let xs = _mm256_blend_ps::<0b0010_0100>(_mm256_blend_ps::<0b1001_0010>(a, b), c);
            // y: c at 0, 3, 6; a at 1, 4, 7; b at 2, 5 → y5 y0 y3 y6 y1 y4 y7 y2.
            let ys = _mm256_blend_ps::<0b0010_0100>(_mm256_blend_ps::<0b1001_0010>(c, a), b);
            // z: b at 0, 3, 6; c at 1, 4, 7; a at 2, 5 → z2 z5 z0 z3 z6 z1 z4 z7.
            let zs = _mm256_blend_ps::<0b0010_0100>(_mm256_blend_ps::<0b1001_0010>(b, c), a);
            let x0 = _mm256_permutevar8x32_ps(xs, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
            let y0 = _mm256_permutevar8x32_ps(ys, _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6));
            let z0 = _mm256_permutevar8x32_ps(zs, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
            ([x.0, y.0, z.0], w.0, [x0, y0, z0])
        }
    }

    /// [`super::moving_box`] in lanes: each lane keeps the least and the
    /// greatest of its moving particles' coordinates (`vminps` with the
    /// coordinate first passes a NaN over, as `f32::min` does), the lanes'
    /// extremes then folded with the last few particles one at a time.
    /// Minima and maxima are exact, so the box is the one particle at a
    /// time gives.
    ///
    /// # Safety
    /// AVX2 is available.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn moving_box(particles: &[Particle], d: &[[f32; 3]], q: &[[f32; 3]]) -> Option<(Vec3, Vec3)> {
        let whole = particles.len().min(d.len()).min(q.len()) / LANES * LANES;
        let (mut lo, mut hi) = ([_mm256_set1_ps(f32::INFINITY); 3], [_mm256_set1_ps(f32::NEG_INFINITY); 3]);
        for k in (0..whole).step_by(LANES) {
            let r = k..k + LANES;
            // SAFETY: AVX2 is available (the caller's promise); eight each.
            let (x, w, x0) = unsafe { lanes(&particles[r.clone()], &d[r.clone()], &q[r]) };
            let moving = _mm256_cmp_ps::<_CMP_GT_OQ>(w, _mm256_setzero_ps());
            for i in 0..3 {
                let least = _mm256_min_ps(x0[i], _mm256_min_ps(x[i], lo[i]));
                let greatest = _mm256_max_ps(x0[i], _mm256_max_ps(x[i], hi[i]));
                lo[i] = _mm256_blendv_ps(lo[i], least, moving);
                hi[i] = _mm256_blendv_ps(hi[i], greatest, moving);
            }
        }
        let rest = moving_box_scalar(&particles[whole..], &d[whole..], &q[whole..]);
        let (mut l, mut h) =
            rest.map_or(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(l, h)| (l.to_array(), h.to_array()));
        for i in 0..3 {
            let (lanes_lo, lanes_hi): ([f32; LANES], [f32; LANES]) = (bytemuck::cast(lo[i]), bytemuck::cast(hi[i]));
            l[i] = lanes_lo.into_iter().fold(l[i], f32::min);
            h[i] = lanes_hi.into_iter().fold(h[i], f32::max);
        }
        (l[0] <= h[0]).then(|| (Vec3::from_array(l), Vec3::from_array(h)))
    }

    /// [`super::octet`] in registers.
    ///
    /// # Safety
    /// AVX2 is available; each slice holds eight elements.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn octet(rows: &[Particle], d: &[[f32; 3]], q: &[[f32; 3]]) -> (Point<F32x8>, Point<F32x8>, u8) {
        // SAFETY: the caller's promise.
        let (x, w, x0) = unsafe { lanes(rows, d, q) };
        let moving = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(w, _mm256_setzero_ps())) as u8;
        let lanes = |v: [__m256; 3]| v.map(|v| F32x8(bytemuck::cast(v)));
        (lanes(x), lanes(x0), moving)
    }
}
