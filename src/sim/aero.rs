//! The aerodynamics phase: drag and lift of moving air on every triangle.
//!
//! With the wind model [`Wind::Air`](super::Wind::Air), the air moves at
//! v_air(x, t) and each triangle t, of area A, unit normal n and velocity
//! v_t (the mean of its corners' Verlet velocities (x − x_prev)/(h/n)),
//! meets the air at the relative velocity u = v_air − v_t. It feels
//!
//! ```text
//! drag   F_d = ½ ρ C_d A (u·n)|u·n| n
//! lift   F_l = ½ ρ C_l A |u|² cos φ · (n − cos φ û),     cos φ = û·n
//! ```
//!
//! Drag is the pressure of the air's normal component: a sheet falling flat
//! at speed v meets ½ ρ C_d A v², and a sheet edge-on to the wind (u·n = 0)
//! feels nothing. Lift is perpendicular to u, in the plane of u and n, of
//! size ½ ρ C_l A |u|² cos φ sin φ: zero face-on (sin φ = 0) and edge-on
//! (cos φ = 0), largest at 45°, and the same whichever way n points. These are
//! the forms of NvCloth's `applyWind`. Each triangle's force goes a third to
//! each corner; a particle of mass m_i then moves (h/n)² F_i / m_i further
//! in the substep, added after integration (so settling carries it into
//! the particle's velocity, exactly as a force in equation 1).
//!
//! **Explicit drag, bounded.** Computed from last substep's velocity, drag
//! on a very light triangle in a strong wind could overshoot: reverse the
//! relative velocity it opposes in one substep and grow. Each triangle's
//! drag is therefore capped at what stops its relative normal motion in one
//! substep, m_t |u·n| / (h/n), and its lift at m_t |u| / (h/n) (m_t: the
//! triangle's share of the particles' masses). Neither cap acts at the
//! terminal speed of a falling sheet or on a flag at any ordinary h.
//!
//! **Turbulence.** The air's velocity is the mean wind V plus gusts:
//!
//! ```text
//! v_air(x, t) = V + g_t |V| N((x − V t)/ℓ + c t/τ)
//! ```
//!
//! N is smooth value noise (a hashed lattice, quintic interpolation, one
//! octave; each component scaled to unit RMS), deterministic (the same
//! scene gives the same run), carried along by the mean wind (Taylor's
//! frozen turbulence: a gust travels down a flag at the wind's speed, so
//! the flag ripples along its length) and changing on the time scale τ on
//! its own (the drift c, a fixed unit vector); ℓ = τ = `gust_scale`.

use glam::Vec3;
use rayon::prelude::*;

use super::mesh::ClothMesh;
use super::self_contact::PARALLEL_PARTICLES;
use super::units;
use super::wind::Air;

/// RMS of one component of the noise before scaling, measured
/// by `noise_has_unit_rms_per_component` over 200 000 samples.
const NOISE_RMS: f32 = 0.401;
/// The pattern's own drift through the noise, per τ (a fixed unit vector,
/// not along any lattice axis).
const DRIFT: Vec3 = Vec3::new(0.267, 0.534, 0.802);

/// What one substep's aerodynamics needs.
#[derive(Clone, Copy, Debug)]
pub struct AeroStep {
    /// The air.
    pub air: Air,
    /// The time at the start of the substep, seconds.
    pub time: f64,
    /// h/n, seconds.
    pub dt: f32,
    /// (h/n)² / m̄: the displacement per newton of a particle of weight 1.
    pub displacement_per_newton: f32,
    /// Use the thread pool on large cloths.
    pub parallel: bool,
}

/// The phase's state: the triangles and their corners' incidence, each
/// triangle's mass, and the buffers one substep works in.
#[derive(Clone, Debug)]
pub struct Aerodynamics {
    triangles: Vec<[u32; 3]>,
    /// Incident triangles of particle i: `incident[offsets[i]..offsets[i + 1]]`.
    offsets: Vec<u32>,
    incident: Vec<u32>,
    /// m_t: Σ over corners of m_i · (A_t / 3) / A_i, kg (σ A_t for a density).
    triangle_mass: Vec<f32>,
    /// Positions x, scene order; filled by the solver before [`Self::compute`].
    pub x: Vec<Vec3>,
    /// Positions one substep ago, scene order; filled with `x`.
    pub x_prev: Vec<Vec3>,
    /// u_i = v_air(x_i) − v_i per particle, m/s.
    relative: Vec<Vec3>,
    /// A third of each triangle's force, N.
    third_force: Vec<Vec3>,
    push: Vec<Vec3>,
}

impl Aerodynamics {
    /// The phase for `mesh` with these particle masses (kg). A mesh without
    /// triangles feels no air (it is refused before: [`units::check_surface`]).
    pub fn new(mesh: &ClothMesh, masses: &[f32]) -> Self {
        let triangles = mesh.triangles().to_vec();
        let n = mesh.particle_count();
        let mut counts = vec![0u32; n + 1];
        for t in &triangles {
            for &i in t {
                counts[i as usize + 1] += 1;
            }
        }
        for i in 0..n {
            counts[i + 1] += counts[i];
        }
        let offsets = counts;
        let mut fill = offsets.clone();
        let mut incident = vec![0u32; triangles.len() * 3];
        for (k, t) in triangles.iter().enumerate() {
            for &i in t {
                incident[fill[i as usize] as usize] = k as u32;
                fill[i as usize] += 1;
            }
        }
        let areas = units::vertex_areas(mesh.positions(), &triangles);
        let triangle_mass = triangles
            .iter()
            .map(|&t| {
                let third = units::triangle_area(mesh.positions(), t) / 3.0;
                t.iter().map(|&i| masses[i as usize] * third / areas[i as usize].max(f32::MIN_POSITIVE)).sum()
            })
            .collect();
        Self {
            offsets,
            incident,
            triangle_mass,
            x: vec![Vec3::ZERO; n],
            x_prev: vec![Vec3::ZERO; n],
            relative: vec![Vec3::ZERO; n],
            third_force: vec![Vec3::ZERO; triangles.len()],
            push: vec![Vec3::ZERO; n],
            triangles,
        }
    }

    /// The displacement (h/n)² F_i / m̄ of every particle (scene order) from
    /// the air, computed on [`Self::x`] and [`Self::x_prev`]; a particle of
    /// weight w moves w times it.
    pub fn compute(&mut self, step: &AeroStep) -> &[Vec3] {
        let parallel = step.parallel && self.x.len() >= PARALLEL_PARTICLES && rayon::current_num_threads() > 1;
        let air = step.air;
        let gusts = Field::new(&air, step.time as f32);
        {
            // Per particle, the air's velocity relative to it,
            // v_air(x) − (x − x_prev)/(h/n), so the triangles read one
            // vector per corner. Chunks in scene order, each with its own
            // cell cache (neighbours mostly share a cell of the noise).
            let dt = step.dt;
            let field = |((u, x), x_prev): ((&mut [Vec3], &[Vec3]), &[Vec3])| {
                let mut cell = Cell::default();
                for ((u, x), x_prev) in u.iter_mut().zip(x).zip(x_prev) {
                    *u = gusts.at(*x, &mut cell) - (*x - *x_prev) / dt;
                }
            };
            const CHUNK: usize = 2048;
            if parallel {
                let x = self.x.par_chunks(CHUNK).zip(self.x_prev.par_chunks(CHUNK));
                self.relative.par_chunks_mut(CHUNK).zip(x).map(|(u, (x, p))| ((u, x), p)).for_each(field);
            } else {
                let x = self.x.chunks(CHUNK).zip(self.x_prev.chunks(CHUNK));
                self.relative.chunks_mut(CHUNK).zip(x).map(|(u, (x, p))| ((u, x), p)).for_each(field);
            }
        }
        {
            let (x, relative) = (&self.x, &self.relative);
            let per_triangle = |(f, (t, &m)): (&mut Vec3, (&[u32; 3], &f32))| {
                *f = triangle_force(&air, step.dt, m, t.map(|i| i as usize), x, relative) / 3.0;
            };
            let triangles = self.triangles.iter().zip(self.triangle_mass.iter());
            if parallel {
                let triangles = self.triangles.par_iter().zip(self.triangle_mass.par_iter());
                self.third_force.par_iter_mut().zip(triangles).for_each(per_triangle);
            } else {
                self.third_force.iter_mut().zip(triangles).for_each(per_triangle);
            }
        }
        {
            let (offsets, incident, forces) = (&self.offsets, &self.incident, &self.third_force);
            let scale = step.displacement_per_newton;
            let gather = |(i, p): (usize, &mut Vec3)| {
                let range = offsets[i] as usize..offsets[i + 1] as usize;
                *p = incident[range].iter().map(|&k| forces[k as usize]).sum::<Vec3>() * scale;
            };
            if parallel {
                self.push.par_iter_mut().enumerate().for_each(gather);
            } else {
                self.push.iter_mut().enumerate().for_each(gather);
            }
        }
        &self.push
    }
}

/// v_air(x, t), m/s (module docs).
pub fn air_velocity(air: &Air, x: Vec3, time: f32) -> Vec3 {
    Field::new(air, time).at(x, &mut Cell::default())
}

/// v_air(·, t) at one time: what does not depend on x computed once per
/// substep, not per particle (the same operations in the same order, so
/// the same bits).
#[derive(Clone, Copy, Debug)]
struct Field {
    /// V, m/s.
    mean: Vec3,
    /// V t, metres.
    shift: Vec3,
    /// ℓ, metres.
    scale: f32,
    /// c t/τ: the pattern's own drift.
    drift: Vec3,
    /// g_t |V| / RMS of the noise, m/s.
    amplitude: f32,
    /// No gusts (or no wind): the air is V everywhere.
    steady: bool,
}

impl Field {
    fn new(air: &Air, time: f32) -> Self {
        let speed = air.velocity.length();
        let scale = air.gust_scale;
        Self {
            mean: air.velocity,
            shift: air.velocity * time,
            scale,
            drift: DRIFT * (time / scale),
            amplitude: air.gusts * speed / NOISE_RMS,
            steady: air.gusts == 0.0 || speed == 0.0,
        }
    }

    /// v_air(x, t), reusing the lattice values of the cell last visited.
    #[inline]
    fn at(&self, x: Vec3, cell: &mut Cell) -> Vec3 {
        if self.steady {
            return self.mean;
        }
        let q = (x - self.shift) / self.scale + self.drift;
        self.mean + value_noise(q, cell) * self.amplitude
    }
}

/// ⌊v⌋, exactly as `f32::floor` (which the x86-64 baseline build calls
/// out of line): through the integer conversion while |v| < 2²³, above
/// which every f32 is an integer already.
#[inline]
fn floor(v: f32) -> f32 {
    if v.abs() < 8_388_608.0 {
        let t = v as i32 as f32;
        if t > v { t - 1.0 } else { t }
    } else {
        v
    }
}

/// Drag plus lift on the triangle with corners `t` (module docs), capped so
/// that it cannot reverse the relative motion in one substep.
fn triangle_force(air: &Air, dt: f32, mass: f32, t: [usize; 3], x: &[Vec3], relative: &[Vec3]) -> Vec3 {
    let [a, b, c] = t;
    let normal2 = (x[b] - x[a]).cross(x[c] - x[a]);
    let twice_area = normal2.length();
    if twice_area.is_nan() || twice_area <= 0.0 {
        return Vec3::ZERO;
    }
    let n = normal2 / twice_area;
    let area = 0.5 * twice_area;
    let u = (relative[a] + relative[b] + relative[c]) / 3.0;
    let un = u.dot(n);
    let q = 0.5 * air.density * area;
    let drag_cap = mass * un.abs() / dt;
    let drag = n * (un.signum() * (q * air.drag * un * un).min(drag_cap));
    let speed2 = u.length_squared();
    if air.lift == 0.0 || speed2 == 0.0 {
        return drag;
    }
    // ½ρC_l A |u|² cos φ (n − cos φ û) = ½ρC_l A (|u| u·n n − (u·n)² u/|u|):
    // perpendicular to u, of size ½ρC_l A |u|² |cos φ| sin φ.
    let speed = speed2.sqrt();
    let lift = (n * (speed * un) - u * (un * un / speed)) * (q * air.lift);
    let cap = mass * speed / dt;
    let size2 = lift.length_squared();
    if size2 > cap * cap { drag + lift * (cap / size2.sqrt()) } else { drag + lift }
}

/// The lattice values at the eight corners of the noise cell last
/// visited: gusts are far larger than the particle spacing, so neighbouring
/// particles mostly share a cell and its hashes are computed once.
#[derive(Clone, Copy, Debug, Default)]
struct Cell {
    key: Option<[i32; 3]>,
    corners: [Vec3; 8],
}

/// Value noise, each component in ±1: hashed lattice values in [−1, 1]³,
/// quintic interpolation (C² across cells, so the air's velocity and its
/// gradient are smooth). One octave: a second at half the size costs as
/// much again, and the flag's own flutter gives the finer detail.
fn value_noise(q: Vec3, cell: &mut Cell) -> Vec3 {
    let floor = Vec3::new(floor(q.x), floor(q.y), floor(q.z));
    let f = q - floor;
    let fade = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    let key = [floor.x as i32, floor.y as i32, floor.z as i32];
    if cell.key != Some(key) {
        let [ix, iy, iz] = key;
        for (k, corner) in cell.corners.iter_mut().enumerate() {
            let k = k as i32;
            *corner = lattice(ix + (k & 1), iy + ((k >> 1) & 1), iz + (k >> 2));
        }
        cell.key = Some(key);
    }
    let c = &cell.corners;
    let lerp = |a: Vec3, b: Vec3, t: f32| a + (b - a) * t;
    let x00 = lerp(c[0], c[1], fade.x);
    let x10 = lerp(c[2], c[3], fade.x);
    let x01 = lerp(c[4], c[5], fade.x);
    let x11 = lerp(c[6], c[7], fade.x);
    lerp(lerp(x00, x10, fade.y), lerp(x01, x11, fade.y), fade.z)
}

/// Three values in [−1, 1] from a lattice point (a 32-bit integer hash,
/// the finaliser of MurmurHash3, ten bits per value).
fn lattice(x: i32, y: i32, z: i32) -> Vec3 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ (z as u32).wrapping_mul(0xcb1a_b31f);
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^= h >> 16;
    let unit = |bits: u32| (bits & 1023) as f32 / 511.5 - 1.0;
    Vec3::new(unit(h), unit(h >> 10), unit(h >> 20))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn air() -> Air {
        Air { velocity: Vec3::new(8.0, 0.0, 0.0), gusts: 0.0, lift: 0.0, ..Air::default() }
    }

    /// One triangle's force with its corners at rest.
    fn force_on(air: &Air, corners: [Vec3; 3]) -> Vec3 {
        let x = corners.to_vec();
        let v_air: Vec<Vec3> = x.iter().map(|&p| air_velocity(air, p, 0.0)).collect();
        triangle_force(air, 0.01, 1.0, [0, 1, 2], &x, &v_air)
    }

    #[test]
    fn drag_face_on_is_half_rho_cd_a_u_squared_and_edge_on_is_zero() {
        // Face-on to 8 m/s along x: a right triangle of legs 1 in the y–z
        // plane, A = 0.5 m²: ½ · 1.2 · 1.0 · 0.5 · 64 = 19.2 N along +x.
        let a = air();
        let f = force_on(&a, [Vec3::ZERO, Vec3::Y, Vec3::Z]);
        assert!((f - Vec3::new(19.2, 0.0, 0.0)).length() < 1e-4, "{f}");
        // Edge-on (the triangle in the x–y plane): no force at all.
        let f = force_on(&a, [Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(f, Vec3::ZERO);
        // The normal's direction does not matter.
        let f = force_on(&a, [Vec3::ZERO, Vec3::Z, Vec3::Y]);
        assert!((f - Vec3::new(19.2, 0.0, 0.0)).length() < 1e-4, "{f}");
    }

    #[test]
    fn lift_is_perpendicular_to_the_wind_and_largest_at_45_degrees() {
        let a = Air { lift: 0.5, drag: 0.0, ..air() };
        // A plate tilted by φ from face-on: normal (cos φ, sin φ, 0).
        let plate = |phi: f32| {
            let n = Vec3::new(phi.cos(), phi.sin(), 0.0);
            let e = n.cross(Vec3::Z);
            force_on(&a, [Vec3::ZERO, e, Vec3::Z])
        };
        let face_on = plate(0.0);
        assert!(face_on.length() < 1e-4, "{face_on}");
        let at45 = plate(std::f32::consts::FRAC_PI_4);
        // ½ ρ C_l A |u|² cos sin = 0.5 · 1.2 · 0.5 · 0.5 · 64 · 0.5 = 4.8 N,
        // perpendicular to the wind (along ±y).
        assert!(at45.x.abs() < 1e-4 && (at45.y.abs() - 4.8).abs() < 1e-3, "{at45}");
        let at20 = plate(20f32.to_radians());
        assert!(at20.length() < at45.length(), "{at20} vs {at45}");
    }

    #[test]
    fn drag_cannot_reverse_the_relative_motion_in_one_substep() {
        // A 1 g triangle of 0.5 m² in 8 m/s: uncapped drag (19.2 N) would add
        // 19.2 · 0.01 / 0.001 = 192 m/s; capped, it adds exactly 8 m/s.
        let a = air();
        let x = vec![Vec3::ZERO, Vec3::Y, Vec3::Z];
        let v_air = vec![a.velocity; 3];
        let f = triangle_force(&a, 0.01, 0.001, [0, 1, 2], &x, &v_air);
        assert!((f.x * 0.01 / 0.001 - 8.0).abs() < 1e-3, "{f}");
    }

    #[test]
    fn the_floor_is_f32s_floor() {
        for v in
            [0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 2.999_999_8, -2.999_999_8, 8_388_607.5, -8_388_607.5, 1e9, -1e9, 3e38]
        {
            assert_eq!(floor(v), v.floor(), "{v}");
        }
        assert!(floor(f32::NAN).is_nan());
        assert_eq!(floor(f32::INFINITY), f32::INFINITY);
        assert_eq!(floor(f32::NEG_INFINITY), f32::NEG_INFINITY);
    }

    #[test]
    fn noise_has_unit_rms_per_component_and_is_smooth_and_deterministic() {
        let mut sum = Vec3::ZERO;
        let count = 200_000;
        for k in 0..count {
            let q = Vec3::new(k as f32 * 0.173, (k % 997) as f32 * 0.311, (k % 313) as f32 * 0.129);
            let v = value_noise(q, &mut Cell::default()) / NOISE_RMS;
            sum += v * v;
        }
        let rms = (sum / count as f32).map(f32::sqrt);
        assert!((rms - Vec3::ONE).abs().max_element() < 0.08, "{rms}");
        // Smooth: a step of 1e-3 cells changes it by far less than its size.
        let q = Vec3::new(3.3, -1.7, 8.2);
        let noise = |q: Vec3| value_noise(q, &mut Cell::default());
        assert!((noise(q) - noise(q + Vec3::splat(1e-3))).length() < 0.02);
        assert_eq!(noise(q), noise(q));
        // The cell cache gives the same values as a fresh evaluation.
        let mut cell = Cell::default();
        for k in 0..100 {
            let p = q + Vec3::new(k as f32 * 0.031, 0.0, k as f32 * 0.017);
            assert_eq!(value_noise(p, &mut cell), noise(p));
        }
    }

    #[test]
    fn gusts_vary_the_air_along_the_wind_and_average_to_the_mean() {
        let a = Air { gusts: 0.3, gust_scale: 1.5, ..air() };
        // 2000 points 1.5 m apart on a plane: about 2000 independent gusts.
        let samples: Vec<Vec3> = (0..2000)
            .map(|k| air_velocity(&a, Vec3::new((k % 50) as f32 * 1.5, 0.3, (k / 50) as f32 * 1.5), 0.0))
            .collect();
        let mean = samples.iter().sum::<Vec3>() / samples.len() as f32;
        let spread = (samples.iter().map(|v| (*v - mean).length_squared()).sum::<f32>() / 2000.0).sqrt();
        // 3 components of RMS 0.3 · 8 = 2.4 m/s: about 4.2 m/s together; the
        // mean of ~2000 gusts is within 4.2/√2000 ≈ 0.1 m/s of V, say 0.4.
        assert!((mean - a.velocity).length() < 0.4, "{mean}");
        assert!((2.5..6.0).contains(&spread), "{spread}");
        // Steady air is the mean everywhere.
        assert_eq!(air_velocity(&air(), Vec3::new(1.0, 2.0, 3.0), 4.0), air().velocity);
    }
}
