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

use glam::Vec3;

use super::Particle;
use crate::sim::contact::ContactStep;
use crate::sim::fast::kernel::{F32x8, LANES, lane};
use crate::sim::fast::simd::dispatch;

dispatch! {
    /// The collide phase on one chunk: `particles` with their
    /// displacements `d` and predicted positions `q` (its lanes compiled
    /// for the SIMD level).
    pub(super) fn collide_chunk(particles: &mut [Particle], d: &[[f32; 3]], q: &[[f32; 3]], contact: &ContactStep)
        = collide_chunk_body, best = ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"]
}

#[inline(always)]
fn collide_chunk_body(particles: &mut [Particle], d: &[[f32; 3]], q: &[[f32; 3]], contact: &ContactStep) {
    // Plain loops over arrays: built with `std::array::from_fn` and `Vec3`,
    // the lanes went through the stack element by element.
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
    if lo[0] > hi[0] {
        return;
    }
    let (lo, hi) = (Vec3::from_array(lo), Vec3::from_array(hi));
    let near = contact.near(lo, hi);
    if near.is_empty() {
        return;
    }
    for ((rows, d), q) in particles.chunks_mut(LANES).zip(d.chunks(LANES)).zip(q.chunks(LANES)) {
        // Lanes past the chunk's end hold a particle of weight 0 at the
        // origin: never moved, never written.
        let (mut x, mut x0) = ([F32x8([0.0; LANES]); 3], [F32x8([0.0; LANES]); 3]);
        let mut moving = 0u8;
        for (l, ((p, d), q)) in rows.iter().zip(d).zip(q).enumerate() {
            for i in 0..3 {
                x[i].0[l] = p.position[i];
                x0[i].0[l] = q[i] - d[i];
            }
            moving |= u8::from(p.weight > 0.0) << l;
        }
        let lanes = contact.collide_lanes(&near, (lo, hi), || moving, &x0, &mut x);
        for (l, row) in rows.iter_mut().enumerate().filter(|(l, _)| lanes & (1 << l) != 0) {
            row.position = lane(&x, l).to_array();
        }
    }
}
