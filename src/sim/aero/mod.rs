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
//! **How it runs**, in one of two forms, each in three passes (chunks or
//! tiles on the thread pool for large cloths): the air's velocity relative
//! to each particle (`noise.rs`), the force each corner of a triangle
//! takes, eight triangles at a time in SIMD lanes (`force.rs`: the same
//! bits as one at a time), and each particle's sum of its triangles'
//! thirds.
//!
//! - *In scene order* (`rows.rs`), for any solver: the solver writes the
//!   positions now and a substep ago as 16-byte rows `[x, y, z, 0]`
//!   ([`Solver::read_rows`]), eight rows are transposed into lanes for each
//!   group of particles or triangle corners, and the sums go back through
//!   [`Solver::push`].
//! - *In the solver's lanes* (`lanes.rs`), where the solver has lanes the
//!   phase can read as they are ([`Lanes`](super::step::Lanes): the grid's tiles): the air's
//!   velocity is computed on each slot of eight lanes where it lies, a
//!   triangle whose three corners are lane l of three slots for every lane
//!   l of an octet is computed on whole slots (no transposes; on a grid
//!   every triangle but those across the edge of a block of columns), and
//!   each slot's sums are added to the lanes as the solver visits them.
//!   On the 256 × 256 cloth in gusty air the phase took 0.8 ms a step on
//!   two threads where scene order took 1.1–1.3 ms (docs/performance.md).

use super::fast::kernel::LANES;
use super::mesh::ClothMesh;
use super::self_contact::PARALLEL_PARTICLES;
use super::step::{LanePlaces, Solver};
use super::units;
use super::wind::Air;
use lanes::LaneForm;
use noise::Field;
pub use noise::air_velocity;
use rows::RowForm;

mod force;
mod lanes;
mod noise;
mod rows;

/// Eight points, one array a coordinate (x, y, z), lane l the l-th point:
/// the form a slot of a solver's lanes holds ([`Lanes::tiles`](super::step::Lanes::tiles)).
pub type PointLanes = [[f32; LANES]; 3];

/// Triangles a task of the thread pool takes.
const TRIANGLES: usize = 4096;

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

/// The phase's state: the triangles, their masses and the buffers one
/// substep works in, in scene order or in a solver's lanes.
#[derive(Clone, Debug)]
pub struct Aerodynamics {
    /// Particles in the cloth.
    particles: usize,
    form: Form,
}

#[derive(Clone, Debug)]
enum Form {
    Rows(RowForm),
    Lanes(LaneForm),
}

impl Aerodynamics {
    /// The phase for `mesh` with these particle masses (kg), reading the
    /// cloth in scene order, or in the solver's lanes when `lanes` says
    /// where each particle is there ([`Lanes::places`](super::step::Lanes::places)). A mesh without
    /// triangles feels no air (it is refused before:
    /// [`units::check_surface`]).
    pub fn new(mesh: &ClothMesh, masses: &[f32], lanes: Option<&LanePlaces>) -> Self {
        let masses = triangle_masses(mesh, masses);
        let form = match lanes {
            Some(lanes) => Form::Lanes(LaneForm::new(mesh.triangles(), masses, lanes)),
            None => Form::Rows(RowForm::new(mesh.particle_count(), mesh.triangles(), masses)),
        };
        Self { particles: mesh.particle_count(), form }
    }

    /// Whether the phase reads the solver's lanes (else rows in scene order).
    pub fn in_lanes(&self) -> bool {
        matches!(self.form, Form::Lanes(_))
    }

    /// The share of triangles computed on whole slots of the lanes (0 in
    /// scene order).
    pub fn aligned_share(&self) -> f64 {
        match &self.form {
            Form::Lanes(lanes) => lanes.aligned_share(),
            Form::Rows(_) => 0.0,
        }
    }

    /// Computes the displacement (h/n)² F_i / m̄ of every particle from the
    /// air on the solver's state; a particle of weight w moves w times it
    /// ([`Self::push`], after integration).
    pub fn compute(&mut self, solver: &dyn Solver, step: &AeroStep) {
        let parallel = step.parallel && self.particles >= PARALLEL_PARTICLES && rayon::current_num_threads() > 1;
        let gusts = Field::new(&step.air, step.time as f32);
        match &mut self.form {
            Form::Rows(rows) => rows.compute(solver, step, &gusts, parallel),
            Form::Lanes(lanes) => lanes.compute(solver.lanes(), step, &gusts, parallel),
        }
    }

    /// Moves every particle of weight w by w (h/n)² F_i / m̄ (from
    /// [`Self::compute`]).
    pub fn push(&self, solver: &mut dyn Solver) {
        match &self.form {
            Form::Rows(rows) => rows.push(solver),
            Form::Lanes(lanes) => {
                if let Some(solver) = solver.lanes_mut() {
                    lanes.push(solver);
                }
            }
        }
    }
}

/// m_t of each triangle: Σ over corners of m_i · (A_t / 3) / A_i, kg (σ A_t
/// for a density), from the particles' masses `masses`, kg.
fn triangle_masses(mesh: &ClothMesh, masses: &[f32]) -> Vec<f32> {
    let areas = units::vertex_areas(mesh.positions(), mesh.triangles());
    mesh.triangles()
        .iter()
        .map(|&t| {
            let third = units::triangle_area(mesh.positions(), t) / 3.0;
            t.iter().map(|&i| masses[i as usize] * third / areas[i as usize].max(f32::MIN_POSITIVE)).sum()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

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
