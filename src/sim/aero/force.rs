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
use super::PointLanes;
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

/// A third of the force of each triangle of `aligned` octets (N), on
/// points in lanes ([`PointLanes`], the places of a solver's lanes): corner
/// k of lane l of octet j is lane l of element `aligned[j][k]`, so each
/// corner is one element of `x` and `relative` (`points`: positions, the
/// air's velocity and the element they start at), loaded as it is, and each
/// octet's thirds go out as lanes too (no transpose either way). `masses`
/// holds eight a octet. The same bits as [`third_forces`] for the same
/// corners.
#[allow(unsafe_code)]
pub(super) fn aligned_forces(
    air: &Air,
    dt: f32,
    points: (&[PointLanes], &[PointLanes], usize),
    aligned: &[[u32; 3]],
    masses: &[f32],
    third_force: &mut [PointLanes],
) {
    #[cfg(target_arch = "x86_64")]
    if simd::level() >= SimdLevel::Avx2 {
        // SAFETY: the level is AVX2 or above only when the CPU reports AVX2
        // and FMA, the features `avx2::aligned_forces` is compiled for.
        unsafe { avx2::aligned_forces(air, dt, points, aligned, masses, third_force) };
        return;
    }
    aligned_in::<Wide>(air, dt, points, aligned, masses, third_force);
}

/// [`aligned_forces`] on lanes of type `T`.
#[inline(always)]
fn aligned_in<T: Rows>(
    air: &Air,
    dt: f32,
    (x, relative, first): (&[PointLanes], &[PointLanes], usize),
    aligned: &[[u32; 3]],
    masses: &[f32],
    third_force: &mut [PointLanes],
) {
    let (group_masses, _) = masses.as_chunks::<LANES>();
    for ((out, elements), mass) in third_force.iter_mut().zip(aligned).zip(group_masses) {
        let corner = |points: &[PointLanes], k: usize| -> Point<T> {
            let [x, y, z] = &points[elements[k] as usize - first];
            [T::from_values(*x), T::from_values(*y), T::from_values(*z)]
        };
        let corners = [corner(x, 0), corner(x, 1), corner(x, 2)];
        let air_at = [corner(relative, 0), corner(relative, 1), corner(relative, 2)];
        let [fx, fy, fz] = corner_force(air, dt, T::from_values(*mass), corners, air_at);
        *out = [fx.to_values(), fy.to_values(), fz.to_values()];
    }
}

/// [`third_forces`] for triangles whose corners are places of a solver's
/// lanes (element p/8, lane p mod 8), eight at a time, each corner read
/// place by place: the triangles no aligned octet takes.
#[allow(unsafe_code)]
pub(super) fn gathered_forces(
    air: &Air,
    dt: f32,
    x: &[PointLanes],
    relative: &[PointLanes],
    triangles: &[[u32; 3]],
    masses: &[f32],
    third_force: &mut [[f32; 4]],
) {
    #[cfg(target_arch = "x86_64")]
    if simd::level() >= SimdLevel::Avx2 {
        // SAFETY: the level is AVX2 or above only when the CPU reports AVX2
        // and FMA, the features `avx2::gathered_forces` is compiled for.
        unsafe { avx2::gathered_forces(air, dt, x, relative, triangles, masses, third_force) };
        return;
    }
    gathered_in::<Wide>(air, dt, x, relative, triangles, masses, third_force);
}

/// [`gathered_forces`] on lanes of type `T`.
#[inline(always)]
fn gathered_in<T: Rows>(
    air: &Air,
    dt: f32,
    x: &[PointLanes],
    relative: &[PointLanes],
    triangles: &[[u32; 3]],
    masses: &[f32],
    third_force: &mut [[f32; 4]],
) {
    // The last group padded with copies of its last triangle, dropped.
    let gathered =
        |group: &[[u32; 3]; LANES], mass: &[f32; LANES]| gathered_octet::<T>(air, dt, x, relative, group, mass);
    let (groups, rest) = triangles.as_chunks::<LANES>();
    let (outs, last_out) = third_force.as_chunks_mut::<LANES>();
    let (group_masses, last_masses) = masses.as_chunks::<LANES>();
    for ((out, group), mass) in outs.iter_mut().zip(groups).zip(group_masses) {
        *out = gathered(group, mass);
    }
    if let (Some(&last), Some(&last_mass)) = (rest.last(), last_masses.last()) {
        let mut group = [last; LANES];
        group[..rest.len()].copy_from_slice(rest);
        let mut mass = [last_mass; LANES];
        mass[..rest.len()].copy_from_slice(last_masses);
        last_out.copy_from_slice(&gathered(&group, &mass)[..rest.len()]);
    }
}

/// The force each corner of eight triangles takes, as rows, their corners
/// read place by place (element p/8, lane p mod 8).
#[inline(always)]
fn gathered_octet<T: Rows>(
    air: &Air,
    dt: f32,
    x: &[PointLanes],
    relative: &[PointLanes],
    group: &[[u32; 3]; LANES],
    mass: &[f32; LANES],
) -> [[f32; 4]; LANES] {
    let corner = |points: &[PointLanes], k: usize| -> Point<T> {
        let mut lanes = [[0.0; LANES]; 3];
        for (l, t) in group.iter().enumerate() {
            let p = t[k] as usize;
            let element = &points[p / LANES];
            for c in 0..3 {
                lanes[c][l] = element[c][p % LANES];
            }
        }
        [T::from_values(lanes[0]), T::from_values(lanes[1]), T::from_values(lanes[2])]
    };
    let corners = [corner(x, 0), corner(x, 1), corner(x, 2)];
    let air_at = [corner(relative, 0), corner(relative, 1), corner(relative, 2)];
    let [fx, fy, fz] = corner_force(air, dt, T::from_values(*mass), corners, air_at);
    T::to_rows([fx, fy, fz, T::splat(0.0)])
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
    use super::{Air, PointLanes, aligned_in, forces_in, gathered_in};
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

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn aligned_forces(
        air: &Air,
        dt: f32,
        points: (&[PointLanes], &[PointLanes], usize),
        aligned: &[[u32; 3]],
        masses: &[f32],
        third_force: &mut [PointLanes],
    ) {
        aligned_in::<Avx>(air, dt, points, aligned, masses, third_force);
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn gathered_forces(
        air: &Air,
        dt: f32,
        x: &[PointLanes],
        relative: &[PointLanes],
        triangles: &[[u32; 3]],
        masses: &[f32],
        third_force: &mut [[f32; 4]],
    ) {
        gathered_in::<Avx>(air, dt, x, relative, triangles, masses, third_force);
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

    #[test]
    fn octets_on_lanes_give_the_bits_of_rows() {
        // Five elements of eight places (40 points). Two aligned octets
        // (corner k of lane l is lane l of element `octet[k]`) and eleven
        // triangles gathered place by place (one full group and a padded
        // one), against the same triangles read as rows: the same bits.
        let air = Air { velocity: Vec3::new(6.0, 1.0, -2.0), lift: 0.4, drag: 1.2, ..Air::default() };
        let point = |p: usize| {
            let t = p as f32;
            Vec3::new((t * 0.37).sin(), (t * 0.91).cos() * 0.5, t * 0.05)
        };
        let velocity = |p: usize| air.velocity - point(p) * 2.0;
        let lanes = |f: &dyn Fn(usize) -> Vec3| -> Vec<PointLanes> {
            (0..5).map(|e| [0, 1, 2].map(|k| std::array::from_fn(|l| f(e * LANES + l)[k]))).collect()
        };
        let (x, relative) = (lanes(&point), lanes(&velocity));
        let x_rows = rows(&(0..40).map(point).collect::<Vec<_>>());
        let relative_rows = rows(&(0..40).map(velocity).collect::<Vec<_>>());
        let octets = [[0u32, 2, 1], [3, 4, 2]];
        let octet_masses: Vec<f32> = (0..16).map(|k| 0.02 + k as f32 * 0.001).collect();
        let mut lane_force = vec![[[f32::NAN; LANES]; 3]; 2];
        aligned_forces(&air, 0.01, (&x, &relative, 0), &octets, &octet_masses, &mut lane_force);
        // The same octets from element 1 on (the first element skipped).
        let mut shifted = vec![[[f32::NAN; LANES]; 3]; 1];
        aligned_forces(&air, 0.01, (&x[1..], &relative[1..], 1), &octets[1..], &octet_masses[8..], &mut shifted);
        assert_eq!(shifted[0].map(|c| c.map(f32::to_bits)), lane_force[1].map(|c| c.map(f32::to_bits)));
        let as_rows: Vec<[u32; 3]> =
            octets.iter().flat_map(|o| (0..LANES as u32).map(move |l| o.map(|e| e * LANES as u32 + l))).collect();
        let mut row_force = vec![[f32::NAN; 4]; 16];
        third_forces(&air, 0.01, &x_rows, &relative_rows, &as_rows, &octet_masses, &mut row_force);
        for (k, row) in row_force.iter().enumerate() {
            let lanes = lane_force[k / LANES].map(|c| c[k % LANES].to_bits());
            assert_eq!(lanes, [row[0], row[1], row[2]].map(f32::to_bits), "octet triangle {k}");
        }
        let gathered: Vec<[u32; 3]> = (0..11u32).map(|k| [k * 3 % 40, (k * 7 + 1) % 40, (k * 11 + 5) % 40]).collect();
        let masses: Vec<f32> = (0..11).map(|k| 0.01 + k as f32 * 0.002).collect();
        let mut from_lanes = vec![[f32::NAN; 4]; 11];
        gathered_forces(&air, 0.01, &x, &relative, &gathered, &masses, &mut from_lanes);
        let mut from_rows = vec![[f32::NAN; 4]; 11];
        third_forces(&air, 0.01, &x_rows, &relative_rows, &gathered, &masses, &mut from_rows);
        let bits = |f: &[[f32; 4]]| f.iter().map(|r| r.map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&from_lanes), bits(&from_rows));
        let zero: Vec<usize> = from_rows
            .iter()
            .chain(&row_force)
            .enumerate()
            .filter(|(_, f)| f[..3] == [0.0; 3])
            .map(|(k, _)| k)
            .collect();
        // Only gathered triangle 9, [27, 24, 24], has no area, so no force.
        assert_eq!(zero, [9], "{gathered:?}");
        // The portable lanes give the level's bits.
        let mut portable = vec![[[f32::NAN; LANES]; 3]; 2];
        aligned_in::<Wide>(&air, 0.01, (&x, &relative, 0), &octets, &octet_masses, &mut portable);
        assert_eq!(portable.map_bits(), lane_force.map_bits());
        let mut portable = vec![[f32::NAN; 4]; 11];
        gathered_in::<Wide>(&air, 0.01, &x, &relative, &gathered, &masses, &mut portable);
        assert_eq!(bits(&portable), bits(&from_lanes));
    }

    trait MapBits {
        fn map_bits(&self) -> Vec<u32>;
    }

    impl MapBits for Vec<PointLanes> {
        fn map_bits(&self) -> Vec<u32> {
            self.iter().flatten().flatten().map(|v| v.to_bits()).collect()
        }
    }
}
