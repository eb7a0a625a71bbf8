//! Drag and lift on eight triangles at once (the forms of the module above:
//! F_d = ½ρC_d A (u·n)|u·n| n, F_l = ½ρC_l A |u|² cos φ (n − cos φ û),
//! each capped so that it cannot reverse the relative motion in a substep).
//!
//! The triangles are taken eight at a time into the lanes of [`F32x8`]: each
//! lane computes, operation for operation, what one triangle alone would
//! (the branches of the one-triangle form become selects per lane), so the
//! result has the same bits at every SIMD level and for any grouping. The
//! last group is padded with copies of its last triangle, whose results are
//! dropped.

use glam::Vec3;

use super::super::wind::Air;
use crate::sim::fast::kernel::{F32x8, LANES, Point, Real, cross, dot, per_lane, sub};
use crate::sim::fast::simd::dispatch;

dispatch! {
    /// A third of each triangle's force (N) into `third_force`, from the
    /// positions `x` and the air's velocity `relative` to each particle
    /// (scene order), at the chosen SIMD level.
    pub(super) fn third_forces(
        air: &Air,
        dt: f32,
        x: &[Vec3],
        relative: &[Vec3],
        triangles: &[[u32; 3]],
        masses: &[f32],
        third_force: &mut [Vec3],
    ) = third_forces_body, best = ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"]
}

#[inline(always)]
fn third_forces_body(
    air: &Air,
    dt: f32,
    x: &[Vec3],
    relative: &[Vec3],
    triangles: &[[u32; 3]],
    masses: &[f32],
    third_force: &mut [Vec3],
) {
    let groups = third_force.chunks_mut(LANES).zip(triangles.chunks(LANES)).zip(masses.chunks(LANES));
    for ((out, group), mass) in groups {
        // Lanes past the group's end repeat its last triangle.
        let last = group.len() - 1;
        let lane_mass = per_lane!(|l| mass[l.min(last)]);
        let index: [[usize; 3]; LANES] = std::array::from_fn(|l| group[l.min(last)].map(|i| i as usize));
        let corners = [corner(x, &index, 0), corner(x, &index, 1), corner(x, &index, 2)];
        let air_at = [corner(relative, &index, 0), corner(relative, &index, 1), corner(relative, &index, 2)];
        let [fx, fy, fz] = force(air, dt, lane_mass, corners, air_at);
        let three = F32x8::splat(3.0);
        let (fx, fy, fz) = (fx / three, fy / three, fz / three);
        for (l, f) in out.iter_mut().enumerate() {
            *f = Vec3::new(fx.0[l], fy.0[l], fz.0[l]);
        }
    }
}

/// Drag plus lift on eight triangles of mass `mass` (kg) with corners `x`
/// (m) where the air moves at `relative` (m/s) to the corners; zero for a
/// triangle without area. Per lane, the operations of one triangle in the
/// same order; a NaN anywhere gives a NaN or zero force as it would alone.
#[inline(always)]
fn force(air: &Air, dt: f32, mass: F32x8, x: [Point<F32x8>; 3], relative: [Point<F32x8>; 3]) -> Point<F32x8> {
    let [a, b, c] = x;
    let normal2 = cross(sub(b, a), sub(c, a));
    let twice_area = dot(normal2, normal2).sqrt();
    let n = each(normal2, |v| v / twice_area);
    let area = F32x8::splat(0.5) * twice_area;
    let [ra, rb, rc] = relative;
    let three = F32x8::splat(3.0);
    let u = [(ra[0] + rb[0] + rc[0]) / three, (ra[1] + rb[1] + rc[1]) / three, (ra[2] + rb[2] + rc[2]) / three];
    let un = dot(u, n);
    let q = F32x8::splat(0.5 * air.density) * area;
    let dt = F32x8::splat(dt);
    let drag_cap = mass * un.abs() / dt;
    let pressure = q * F32x8::splat(air.drag) * un * un;
    // sign(u·n) · min(pressure, cap): both are ≥ 0, so the sign is copied.
    let drag_size = F32x8::if_greater(pressure, drag_cap, drag_cap, pressure).copysign(un);
    let drag = each(n, |v| v * drag_size);
    // A triangle without area feels nothing.
    let zero = F32x8::splat(0.0);
    let area_or_zero = |f: Point<F32x8>| each(f, |v| F32x8::if_greater(twice_area, zero, v, zero));
    if air.lift == 0.0 {
        return area_or_zero(drag);
    }
    // ½ρC_l A |u|² cos φ (n − cos φ û) = ½ρC_l A (|u| u·n n − (u·n)² u/|u|):
    // perpendicular to u, of size ½ρC_l A |u|² |cos φ| sin φ.
    let speed2 = dot(u, u);
    let speed = speed2.sqrt();
    let (along_n, along_u, size) = (speed * un, un * un / speed, q * F32x8::splat(air.lift));
    let lift = [
        (n[0] * along_n - u[0] * along_u) * size,
        (n[1] * along_n - u[1] * along_u) * size,
        (n[2] * along_n - u[2] * along_u) * size,
    ];
    let cap = mass * speed / dt;
    let size2 = dot(lift, lift);
    let shrink = cap / size2.sqrt();
    let capped = each(lift, |v| F32x8::if_greater(size2, cap * cap, v * shrink, v));
    // Still air relative to the triangle (|u| = 0): no lift.
    let total = [drag[0] + capped[0], drag[1] + capped[1], drag[2] + capped[2]];
    let still = |k: usize| F32x8::if_greater(speed2, zero, total[k], drag[k]);
    area_or_zero([still(0), still(1), still(2)])
}

/// A third of the force on one triangle with corners `t` (the lanes' form
/// for a single triangle).
#[cfg(test)]
pub(super) fn triangle_force(air: &Air, dt: f32, mass: f32, t: [usize; 3], x: &[Vec3], relative: &[Vec3]) -> Vec3 {
    let mut out = [Vec3::ZERO];
    let triangle = [t.map(|i| i as u32)];
    third_forces(air, dt, x, relative, &triangle, &[mass], &mut out);
    out[0] * 3.0
}

/// Corner k of eight triangles (`index[l]`: lane l's corners) as lanes.
#[inline(always)]
fn corner(v: &[Vec3], index: &[[usize; 3]; LANES], k: usize) -> Point<F32x8> {
    let p: [Vec3; LANES] = [
        v[index[0][k]],
        v[index[1][k]],
        v[index[2][k]],
        v[index[3][k]],
        v[index[4][k]],
        v[index[5][k]],
        v[index[6][k]],
        v[index[7][k]],
    ];
    [per_lane!(|l| p[l].x), per_lane!(|l| p[l].y), per_lane!(|l| p[l].z)]
}

/// `f` on each coordinate.
#[inline(always)]
fn each(p: Point<F32x8>, f: impl Fn(F32x8) -> F32x8) -> Point<F32x8> {
    [f(p[0]), f(p[1]), f(p[2])]
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
        let mut together = vec![Vec3::ZERO; 19];
        third_forces(&air, 0.01, &x, &relative, &triangles, &masses, &mut together);
        for (k, (t, m)) in triangles.iter().zip(&masses).enumerate() {
            let mut alone = [Vec3::ZERO];
            third_forces(&air, 0.01, &x, &relative, &[*t], &[*m], &mut alone);
            assert_eq!(together[k].to_array().map(f32::to_bits), alone[0].to_array().map(f32::to_bits), "triangle {k}");
        }
        // The special triangles are what they claim to be: no area, no
        // force; still air (u = 0) no force either; the light one's drag
        // and lift are each capped at m|u|/dt, so together at most twice
        // that, while the same triangle at 1 kg feels far more.
        assert_eq!(together[4], Vec3::ZERO);
        assert_eq!(together[9], Vec3::ZERO);
        let u = (relative[13] + relative[15] + relative[18]) / 3.0;
        let cap = 1e-7 * u.length() / 0.01;
        let light = together[13].length() * 3.0;
        assert!(light <= 2.0 * cap * 1.0001, "{light} vs {cap}");
        let mut heavy = [Vec3::ZERO];
        third_forces(&air, 0.01, &x, &relative, &[triangles[13]], &[1.0], &mut heavy);
        assert!(heavy[0].length() * 3.0 > 10.0 * light, "{} vs {light}", heavy[0].length() * 3.0);
        assert!(together.iter().filter(|f| f.length() > 0.0).count() >= 16);
    }
}
