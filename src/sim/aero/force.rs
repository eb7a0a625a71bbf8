//! Drag and lift on eight triangles at once (the forms of the module above:
//! F_d = ½ρC_d A (u·n)|u·n| n, F_l = ½ρC_l A |u|² cos φ (n − cos φ û),
//! each capped so that it cannot reverse the relative motion in a substep).
//!
//! The triangles are taken eight at a time into lanes: each lane computes,
//! operation for operation, what one triangle alone would (the branches of
//! the one-triangle form become selects per lane), so the result has the
//! same bits at every SIMD level and for any grouping. The last group is
//! padded with copies of its last triangle, whose results are dropped.
//!
//! The corners' positions and air velocities are read as 16-byte rows
//! `[x, y, z, 0]` ([`Rows`]): with AVX2 ([`Avx`](crate::sim::fast::avx::Avx)),
//! one load a row and a transpose of eight rows in eight shuffles, where the
//! lanes of [`F32x8`](crate::sim::fast::kernel::F32x8) loaded each
//! coordinate of each corner on its own (about 100 instructions a
//! triangle); the thirds of the forces go out the same way, one row a
//! triangle, which the particles sum four lanes at a time. Without AVX2 the
//! lanes are [`Wide`] (NEON or SSE vectors: the array lanes left part of
//! each octet scalar, and the 256 × 256 cloth's air phase cost about a
//! sixth more).

#[cfg(test)]
use glam::Vec3;

use super::super::wind::Air;
use crate::sim::fast::kernel::{LANES, Point, Real, axes, cross, dot, sub};
use crate::sim::fast::rows::Rows;
#[cfg(target_arch = "x86_64")]
use crate::sim::fast::simd::{self, SimdLevel};
use crate::sim::fast::wide_lanes::Wide;

/// A third of each triangle's force (N) into `third_force`, from the
/// positions `x` and the air's velocity `relative` to each particle (scene
/// order, one `[x, y, z, 0]` row a particle): eight triangles at a time, their
/// corners' rows transposed into lanes ([`Rows`]; with AVX2 one load a row).
#[allow(unsafe_code)]
pub(super) fn third_forces(
    air: &Air,
    dt: f32,
    x: &[[f32; 4]],
    relative: &[[f32; 4]],
    triangles: &[[u32; 3]],
    masses: &[f32],
    third_force: &mut [[f32; 4]],
) {
    #[cfg(target_arch = "x86_64")]
    if simd::level() >= SimdLevel::Avx2 {
        // SAFETY: the level is AVX2 or above only when the CPU reports AVX2
        // and FMA, the features `avx2::third_forces` is compiled for.
        unsafe { avx2::third_forces(air, dt, x, relative, triangles, masses, third_force) };
        return;
    }
    // Without AVX2: the `wide` crate's vectors (NEON, SSE), where the
    // array lanes left part of each octet scalar.
    forces_in::<Wide>(air, dt, x, relative, triangles, masses, third_force);
}

/// [`third_forces`] on lanes of type `T`.
#[inline(always)]
fn forces_in<T: Rows>(
    air: &Air,
    dt: f32,
    x: &[[f32; 4]],
    relative: &[[f32; 4]],
    triangles: &[[u32; 3]],
    masses: &[f32],
    third_force: &mut [[f32; 4]],
) {
    // Whole groups of eight, with no lane to fill (the last group's padding
    // in every group's index computation cost 0.15–0.3 ms of a 256 × 256
    // cloth's 11 ms step on one thread).
    let (groups, rest) = triangles.as_chunks::<LANES>();
    let (outs, last_out) = third_force.as_chunks_mut::<LANES>();
    let (group_masses, last_masses) = masses.as_chunks::<LANES>();
    for ((out, group), mass) in outs.iter_mut().zip(groups).zip(group_masses) {
        *out = octet::<T>(air, dt, x, relative, group, mass);
    }
    // The last group: lanes past its end repeat its last triangle, and
    // their results are dropped.
    if let (Some(&last), Some(&last_mass)) = (rest.last(), last_masses.last()) {
        let mut group = [last; LANES];
        group[..rest.len()].copy_from_slice(rest);
        let mut mass = [last_mass; LANES];
        mass[..rest.len()].copy_from_slice(last_masses);
        let rows = octet::<T>(air, dt, x, relative, &group, &mass);
        last_out.copy_from_slice(&rows[..rest.len()]);
    }
}

/// The force each corner of eight triangles takes, as rows.
#[inline(always)]
fn octet<T: Rows>(
    air: &Air,
    dt: f32,
    x: &[[f32; 4]],
    relative: &[[f32; 4]],
    group: &[[u32; 3]; LANES],
    mass: &[f32; LANES],
) -> [[f32; 4]; LANES] {
    let corner = |rows: &[[f32; 4]], k: usize| -> Point<T> {
        let index: [usize; LANES] = std::array::from_fn(|l| group[l][k] as usize);
        let [x, y, z, _] = T::gather(rows, &index);
        [x, y, z]
    };
    let corners = [corner(x, 0), corner(x, 1), corner(x, 2)];
    let air_at = [corner(relative, 0), corner(relative, 1), corner(relative, 2)];
    let [fx, fy, fz] = corner_force(air, dt, T::from_values(*mass), corners, air_at);
    T::to_rows([fx, fy, fz, T::splat(0.0)])
}

/// [`third_forces`] in AVX registers.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Air, forces_in};
    use crate::sim::fast::avx::Avx;

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn third_forces(
        air: &Air,
        dt: f32,
        x: &[[f32; 4]],
        relative: &[[f32; 4]],
        triangles: &[[u32; 3]],
        masses: &[f32],
        third_force: &mut [[f32; 4]],
    ) {
        forces_in::<Avx>(air, dt, x, relative, triangles, masses, third_force);
    }
}

/// The force each corner takes, a third of the drag plus lift, on eight
/// triangles of mass `mass` (kg) with corners `x` (m) where the air moves
/// at `relative` (m/s) to the corners; zero for a triangle without area.
/// Per lane, the operations of one triangle in the same order; a NaN
/// anywhere gives a NaN or zero force as it would alone.
///
/// The factors of 3 (u is the mean of three corners, each corner takes a
/// third) are folded into constants computed once a call: with s = 3u the
/// sum of the corners' velocities, u·n = s·n/3 and |u| = |s|/3, so
///
/// ```text
/// F_d/3 = sign(s·n) min(ρC_d A (s·n)²/54, m |s·n|/(9 dt))
/// F_l/3 = ρC_l A/54 · (|s| (s·n) n − (s·n)²/|s| s),  capped at m |s|/(9 dt)
/// ```
///
/// (no division on the chain from the corners to the force but the
/// normal's, the lift's direction and its cap).
#[inline(always)]
fn corner_force<T: Real>(air: &Air, dt: f32, mass: T, x: [Point<T>; 3], relative: [Point<T>; 3]) -> Point<T> {
    let [a, b, c] = x;
    let normal2 = cross(sub(b, a), sub(c, a));
    let twice_area = dot(normal2, normal2).sqrt();
    let n = axes(|i| normal2[i] / twice_area);
    let [ra, rb, rc] = relative;
    let s = [ra[0] + rb[0] + rc[0], ra[1] + rb[1] + rc[1], ra[2] + rb[2] + rc[2]];
    let sn = dot(s, n);
    // ½ρ A/27 = ρ (2A)/108: the pressure's factor, per (s·n)², a third.
    let q = T::splat(air.density / 108.0) * twice_area;
    let per_speed = mass * T::splat(1.0 / (9.0 * dt));
    let drag_cap = per_speed * sn.abs();
    let pressure = q * T::splat(air.drag) * sn * sn;
    // sign(s·n) · min(pressure, cap): both are ≥ 0, so the sign is copied.
    let drag_size = T::if_greater(pressure, drag_cap, drag_cap, pressure).copysign(sn);
    let drag = axes(|i| n[i] * drag_size);
    // A triangle without area feels nothing.
    let zero = T::splat(0.0);
    let area_or_zero = |f: Point<T>| axes(|i| T::if_greater(twice_area, zero, f[i], zero));
    if air.lift == 0.0 {
        return area_or_zero(drag);
    }
    // ½ρC_l A |u|² cos φ (n − cos φ û) = ½ρC_l A (|u| u·n n − (u·n)² u/|u|):
    // perpendicular to u, of size ½ρC_l A |u|² |cos φ| sin φ.
    let speed2 = dot(s, s);
    let speed = speed2.sqrt();
    let (along_n, along_s, size) = (speed * sn, sn * sn / speed, q * T::splat(air.lift));
    let lift = [
        (n[0] * along_n - s[0] * along_s) * size,
        (n[1] * along_n - s[1] * along_s) * size,
        (n[2] * along_n - s[2] * along_s) * size,
    ];
    let cap = per_speed * speed;
    let size2 = dot(lift, lift);
    let shrink = cap / size2.sqrt();
    let capped = axes(|i| T::if_greater(size2, cap * cap, lift[i] * shrink, lift[i]));
    // Still air relative to the triangle (|u| = 0): no lift.
    let total = [drag[0] + capped[0], drag[1] + capped[1], drag[2] + capped[2]];
    let still = |k: usize| T::if_greater(speed2, zero, total[k], drag[k]);
    area_or_zero([still(0), still(1), still(2)])
}

/// A third of the force on one triangle with corners `t` (the lanes' form
/// for a single triangle).
#[cfg(test)]
pub(super) fn triangle_force(air: &Air, dt: f32, mass: f32, t: [usize; 3], x: &[Vec3], relative: &[Vec3]) -> Vec3 {
    let mut out = [[0.0; 4]];
    let triangle = [t.map(|i| i as u32)];
    let (x, relative) = (rows(x), rows(relative));
    third_forces(air, dt, &x, &relative, &triangle, &[mass], &mut out);
    Vec3::from_slice(&out[0][..3]) * 3.0
}

/// Points as `[x, y, z, 0]` rows, the form [`third_forces`] reads.
#[cfg(test)]
fn rows(points: &[Vec3]) -> Vec<[f32; 4]> {
    points.iter().map(|p| p.extend(0.0).to_array()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_give_each_triangle_the_bits_it_gets_alone() {
        // 19 triangles: two full groups and three in a padded one. Among
        // them a triangle without area, one in still air (|u| = 0), one
        // whose lift is capped (a light triangle in strong air), and
        // corners shared between triangles.
        let air = Air { velocity: Vec3::new(8.0, 1.0, 0.0), lift: 0.7, drag: 1.1, ..Air::default() };
        let x: Vec<Vec3> = (0..24)
            .map(|i| {
                let t = i as f32;
                Vec3::new((t * 0.37).sin(), (t * 0.91).cos() * 0.5, t * 0.05)
            })
            .collect();
        let mut relative: Vec<Vec3> = x.iter().map(|p| air.velocity - *p * 3.0).collect();
        let mut triangles: Vec<[u32; 3]> = (0..19u32).map(|k| [k, k + 2, k + 5]).collect();
        triangles[4] = [1, 1, 2];
        triangles[9] = [20, 21, 22];
        for i in [20, 21, 22] {
            relative[i] = Vec3::ZERO;
        }
        let mut masses: Vec<f32> = (0..19).map(|k| 0.01 + k as f32 * 0.003).collect();
        masses[13] = 1e-7;
        let (x, relative) = (rows(&x), rows(&relative));
        let mut together = vec![[f32::NAN; 4]; 19];
        third_forces(&air, 0.01, &x, &relative, &triangles, &masses, &mut together);
        let bits = |f: &[f32; 4]| f.map(f32::to_bits);
        for (k, (t, m)) in triangles.iter().zip(&masses).enumerate() {
            let mut alone = [[f32::NAN; 4]];
            third_forces(&air, 0.01, &x, &relative, &[*t], &[*m], &mut alone);
            assert_eq!(bits(&together[k]), bits(&alone[0]), "triangle {k}");
        }
        // The portable lanes give the bits of the level's own (AVX2 loads
        // and transposes where the CPU has it).
        let mut portable = vec![[f32::NAN; 4]; 19];
        forces_in::<Wide>(&air, 0.01, &x, &relative, &triangles, &masses, &mut portable);
        assert_eq!(together.iter().map(bits).collect::<Vec<_>>(), portable.iter().map(bits).collect::<Vec<_>>());
        // The special triangles are what they claim to be: no area, no
        // force; still air (u = 0) no force either; the light one's drag
        // and lift are each capped at m|u|/dt, so together at most twice
        // that, while the same triangle at 1 kg feels far more. (Rows are
        // [x, y, z, 0].)
        let together: Vec<Vec3> = together.iter().map(|f| Vec3::from_slice(&f[..3])).collect();
        assert_eq!(together[4], Vec3::ZERO);
        assert_eq!(together[9], Vec3::ZERO);
        let corner = |i: usize| Vec3::from_slice(&relative[i][..3]);
        let u = (corner(13) + corner(15) + corner(18)) / 3.0;
        let cap = 1e-7 * u.length() / 0.01;
        let light = together[13].length() * 3.0;
        assert!(light <= 2.0 * cap * 1.0001, "{light} vs {cap}");
        let mut heavy = [[0.0; 4]];
        third_forces(&air, 0.01, &x, &relative, &[triangles[13]], &[1.0], &mut heavy);
        let heavy = [Vec3::from_slice(&heavy[0][..3])];
        assert!(heavy[0].length() * 3.0 > 10.0 * light, "{} vs {light}", heavy[0].length() * 3.0);
        assert!(together.iter().filter(|f| f.length() > 0.0).count() >= 16);
    }
}
