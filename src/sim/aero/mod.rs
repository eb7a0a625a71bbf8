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
//! **Turbulence** (`noise.rs`): the air's velocity is the mean wind V plus
//! gusts of smooth value noise carried along by the wind.
//!
//! **How it runs.** The solver writes the positions now and a substep ago as
//! 16-byte rows `[x, y, z, 0]` ([`Solver::read_rows`](super::step::Solver::read_rows)),
//! and three loops follow, each in chunks on the thread pool for large
//! cloths: the air's velocity relative to each particle (eight particles at
//! a time, rows transposed into lanes, where they share a cell of the
//! noise: `noise.rs`); the force each corner of a triangle takes, eight
//! triangles at a time in SIMD lanes (`force.rs`: the same bits as one at a
//! time); and each particle's share, gathered from its incident triangles.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::mesh::ClothMesh;
use super::self_contact::PARALLEL_PARTICLES;
use super::units;
use super::wind::Air;
use noise::Field;
pub use noise::air_velocity;

mod force;
mod noise;

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
    /// Positions x, scene order, as `[x, y, z, 0]` rows (the triangles load
    /// a corner in one 16-byte read); filled by the solver
    /// ([`Solver::read_rows`](super::step::Solver::read_rows)) before
    /// [`Self::compute`].
    pub x: Vec<[f32; 4]>,
    /// Positions one substep ago, the same way.
    pub x_prev: Vec<[f32; 4]>,
    /// u_i = v_air(x_i) − v_i per particle, m/s, as `[x, y, z, 0]` rows.
    relative: Vec<[f32; 4]>,
    /// A third of each triangle's force, N, as `[x, y, z, 0]` rows.
    third_force: Vec<[f32; 4]>,
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
            x: vec![[0.0; 4]; n],
            x_prev: vec![[0.0; 4]; n],
            relative: vec![[0.0; 4]; n],
            third_force: vec![[0.0; 4]; triangles.len()],
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
            // v_air(x) − (x − x_prev)/(h/n), as rows. Chunks in scene order,
            // each with its own cell cache (neighbours mostly share a cell of
            // the noise).
            let dt = step.dt;
            type Chunk<'a> = (&'a mut [[f32; 4]], (&'a [[f32; 4]], &'a [[f32; 4]]));
            let field = |(u, (x, x_prev)): Chunk| noise::relative_air(&gusts, dt, x, x_prev, u);
            const CHUNK: usize = 2048;
            if parallel {
                let x = self.x.par_chunks(CHUNK).zip(self.x_prev.par_chunks(CHUNK));
                self.relative.par_chunks_mut(CHUNK).zip(x).for_each(field);
            } else {
                let x = self.x.chunks(CHUNK).zip(self.x_prev.chunks(CHUNK));
                self.relative.chunks_mut(CHUNK).zip(x).for_each(field);
            }
        }
        {
            // A third of each triangle's force, eight triangles at a time
            // (`force`), in chunks of triangles on the pool.
            const TRIANGLES: usize = 4096;
            let (x, relative) = (&self.x, &self.relative);
            type Chunk<'a> = (&'a mut [[f32; 4]], (&'a [[u32; 3]], &'a [f32]));
            let chunk = |(out, (triangles, masses)): Chunk| {
                force::third_forces(&air, step.dt, x, relative, triangles, masses, out);
            };
            let triangles = self.triangles.chunks(TRIANGLES).zip(self.triangle_mass.chunks(TRIANGLES));
            if parallel {
                let triangles = self.triangles.par_chunks(TRIANGLES).zip(self.triangle_mass.par_chunks(TRIANGLES));
                self.third_force.par_chunks_mut(TRIANGLES).zip(triangles).for_each(chunk);
            } else {
                self.third_force.chunks_mut(TRIANGLES).zip(triangles).for_each(chunk);
            }
        }
        {
            let (offsets, incident, forces) = (&self.offsets, &self.incident, &self.third_force);
            let scale = step.displacement_per_newton;
            let gather = |(i, p): (usize, &mut Vec3)| {
                let range = offsets[i] as usize..offsets[i + 1] as usize;
                // Four lanes at once (w is 0), each the sum of one coordinate.
                let sum = incident[range].iter().map(|&k| Vec4::from_array(forces[k as usize])).sum::<Vec4>();
                *p = sum.truncate() * scale;
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

#[cfg(test)]
mod tests {
    use super::force::triangle_force;
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
}
