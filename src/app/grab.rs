//! Picking a particle under the cursor, and holding one with the mouse.

use glam::{Vec2, Vec3};

use crate::render::OrbitCamera;
use crate::sim::{SimError, Simulation};

/// How far from the cursor a particle may be and still be picked when the
/// ray misses every triangle (or there are none), in pixels.
pub const PICK_RADIUS_PIXELS: f32 = 14.0;

/// What the camera sees: for turning cursor positions into rays.
#[derive(Clone, Copy, Debug)]
pub struct ViewGeometry {
    /// The camera.
    pub camera: OrbitCamera,
    /// Size of the 3-D viewport, pixels.
    pub size: Vec2,
    /// The depth range's radius (see [`OrbitCamera::projection`]).
    pub world_radius: f32,
}

/// The particle under `cursor` (pixels from the viewport's top-left).
///
/// The particle drawn nearest the cursor on screen among those the eye can
/// see there: the corners of the nearest triangle the cursor's ray hits,
/// and every particle within [`PICK_RADIUS_PIXELS`] of the cursor that is
/// not behind that triangle (a particle's marker, a pin's ball, may reach
/// past the triangles around it). So a click on a particle picks that
/// particle, never a neighbour whose triangle lies under the cursor, and a
/// particle behind the cloth is never picked through it. With no triangle
/// hit (a bar-only mesh, or the cursor just off the cloth's edge) every
/// particle within the radius competes; on a tie the nearer to the eye.
pub fn pick(positions: &[Vec3], triangles: &[[u32; 3]], view: &ViewGeometry, cursor: Vec2) -> Option<usize> {
    let ray = view.camera.ray(cursor, view.size, view.world_radius);
    let mut nearest: Option<(f32, [u32; 3])> = None;
    for &tri in triangles {
        let [a, b, c] = tri.map(|i| positions[i as usize]);
        if let Some(t) = ray.hit_triangle(a, b, c)
            && nearest.is_none_or(|(best, _)| t < best)
        {
            nearest = Some((t, tri));
        }
    }
    // Depth along the ray; a particle within 2 % of the camera's distance
    // behind the surface hit is on it (its own triangle, seen edge-on).
    let depth = |p: Vec3| (p - ray.origin).dot(ray.direction);
    let limit = nearest.map_or(f32::INFINITY, |(t, _)| t + 0.02 * view.camera.distance);
    let corners = nearest.map_or([u32::MAX; 3], |(_, tri)| tri);
    (0..positions.len())
        .filter_map(|i| {
            let (pixel, _) = view.camera.project(positions[i], view.size, view.world_radius)?;
            let d = pixel.distance(cursor);
            let corner = corners.contains(&(i as u32));
            let visible = depth(positions[i]) <= limit;
            (corner || (d <= PICK_RADIUS_PIXELS && visible)).then_some((i, d, depth(positions[i])))
        })
        .min_by(|x, y| (x.1, x.2).partial_cmp(&(y.1, y.2)).unwrap_or(std::cmp::Ordering::Equal))
        .map(|(i, _, _)| i)
}

/// The grip of the mouse on a free particle: the largest acceleration a
/// grab gives it, m/s² (a hand taking cloth from rest to 10 m/s in 0.05 s).
pub const GRAB_MAX_ACCELERATION: f32 = 200.0;

/// A particle held by the mouse.
///
/// A free particle is held softly ([`Simulation::hold`]): it stays free
/// with the weight of a hand, and each substep pulls it toward the cursor
/// by at most [`GRAB_MAX_ACCELERATION`], so the cloth follows as far as its
/// bars let it and a fast drag does not stretch them to wherever the cursor
/// is (with inextensible edges, it does not stretch them at all). On
/// release it keeps its velocity. A pin is moved where the mouse puts it,
/// and stays a pin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grab {
    /// The particle held.
    pub particle: usize,
    was_fixed: bool,
    /// A point of the plane the particle moves in, and its normal: the
    /// plane facing the camera through where the particle was grabbed.
    plane_point: Vec3,
    plane_normal: Vec3,
    /// From the cursor's point on the plane to the particle, so it does not
    /// jump to the cursor when grabbed off-centre.
    offset: Vec3,
    /// Where the particle is being held.
    pub target: Vec3,
}

impl Grab {
    /// Takes hold of `particle` under `cursor`, fixing it.
    pub fn start(sim: &mut Simulation, particle: usize, view: &ViewGeometry, cursor: Vec2) -> Result<Self, SimError> {
        let position = *sim
            .positions()
            .get(particle)
            .ok_or(SimError::NoSuchParticle { index: particle, count: sim.positions().len() })?;
        let was_fixed = sim.fixed()[particle];
        let plane_normal = view.camera.backward();
        let ray = view.camera.ray(cursor, view.size, view.world_radius);
        let on_plane = ray.hit_plane(position, plane_normal).unwrap_or(position);
        if !was_fixed {
            sim.hold(particle, position, GRAB_MAX_ACCELERATION)?;
        }
        Ok(Self {
            particle,
            was_fixed,
            plane_point: position,
            plane_normal,
            offset: position - on_plane,
            target: position,
        })
    }

    /// Follows the cursor: the new target is where the cursor's ray meets
    /// the grab plane (unchanged if it runs parallel to it).
    pub fn drag_to(&mut self, view: &ViewGeometry, cursor: Vec2) {
        let ray = view.camera.ray(cursor, view.size, view.world_radius);
        if let Some(p) = ray.hit_plane(self.plane_point, self.plane_normal) {
            self.target = p + self.offset;
        }
    }

    /// Pulls the particle toward the target (a pin: puts it there); call
    /// once per frame before stepping.
    pub fn hold(&self, sim: &mut Simulation) -> Result<(), SimError> {
        if self.was_fixed {
            sim.move_particle(self.particle, self.target)
        } else {
            sim.hold(self.particle, self.target, GRAB_MAX_ACCELERATION)
        }
    }

    /// Lets go: a free particle keeps its velocity, a pin stays.
    pub fn release(self, sim: &mut Simulation) -> Result<(), SimError> {
        if !self.was_fixed {
            sim.release(self.particle);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, GridPlane, Pins, SolverParams};

    /// A 5 × 5 vertical grid, 1 m spacing, top row pinned, seen head-on.
    fn setup() -> (Simulation, ViewGeometry) {
        let mesh = Grid {
            columns: 5,
            rows: 5,
            spacing: 1.0,
            plane: GridPlane::Vertical,
            pins: Pins::TopRow,
            ..Grid::default()
        }
        .build()
        .unwrap();
        let sim =
            Simulation::new(mesh, SolverParams { wind: crate::sim::Wind::None, ..SolverParams::default() }).unwrap();
        let mut camera = OrbitCamera::default();
        camera.fit(sim.mesh().bounds(), 1.0);
        (sim, ViewGeometry { camera, size: Vec2::new(400.0, 400.0), world_radius: 20.0 })
    }

    fn screen(view: &ViewGeometry, p: Vec3) -> Vec2 {
        view.camera.project(p, view.size, view.world_radius).unwrap().0
    }

    #[test]
    fn picks_the_particle_under_the_cursor_and_nothing_off_the_cloth() {
        let (sim, view) = setup();
        for i in [0, 7, 12, 24] {
            let at = screen(&view, sim.positions()[i]) + Vec2::new(3.0, -2.0);
            assert_eq!(pick(sim.positions(), sim.mesh().triangles(), &view, at), Some(i));
        }
        assert_eq!(pick(sim.positions(), sim.mesh().triangles(), &view, Vec2::new(2.0, 2.0)), None);
    }

    #[test]
    fn a_particle_drawn_in_front_of_another_triangle_is_the_one_picked() {
        // A particle on no triangle, 1 m in front of the sheet, half way
        // between particles 12 and 13 on screen: a click on it used to take
        // the nearest corner of the sheet's triangle behind it. One 3 m
        // behind the sheet is hidden by it and never picked.
        let (sim, view) = setup();
        let mut positions = sim.positions().to_vec();
        let between = 0.5 * (positions[12] + positions[13]);
        let toward_eye = -view.camera.ray(screen(&view, between), view.size, view.world_radius).direction;
        positions.push(between + toward_eye);
        positions.push(between - 3.0 * toward_eye);
        let at = screen(&view, positions[25]);
        assert_eq!(pick(&positions, sim.mesh().triangles(), &view, at), Some(25));
        let behind = screen(&view, positions[26]) + Vec2::new(1.0, 0.0);
        assert_ne!(pick(&positions, sim.mesh().triangles(), &view, behind), Some(26));
    }

    #[test]
    fn picks_without_triangles_by_screen_distance() {
        let (sim, view) = setup();
        let at = screen(&view, sim.positions()[12]) + Vec2::new(5.0, 5.0);
        assert_eq!(pick(sim.positions(), &[], &view, at), Some(12));
        let far = screen(&view, sim.positions()[12]) + Vec2::new(PICK_RADIUS_PIXELS * 3.0, 0.0);
        assert!(pick(sim.positions(), &[], &view, far).is_none_or(|i| i != 12));
    }

    #[test]
    fn a_grabbed_particle_follows_the_cursor_in_the_view_plane_and_is_released_free() {
        let (mut sim, view) = setup();
        let particle = 22; // bottom row, free
        let start = sim.positions()[particle];
        let cursor = screen(&view, start);
        let mut grab = Grab::start(&mut sim, particle, &view, cursor).unwrap();
        assert!(!sim.fixed()[particle], "a free particle is held softly, not fixed");
        assert_eq!(sim.holds().len(), 1);
        grab.drag_to(&view, cursor + Vec2::new(40.0, 0.0));
        let reach = grab.target.x - start.x;
        assert!(reach > 0.2, "the cursor moved the target {reach} m");
        for _ in 0..10 {
            grab.hold(&mut sim).unwrap();
            sim.step().unwrap();
        }
        // Pulled most of the way in the view plane (z stays): the bars hold
        // it back a little, as the hand's weight is 50 particles'.
        let moved = sim.positions()[particle];
        assert!(moved.x - start.x > 0.5 * reach && (moved.z - start.z).abs() < 1e-3, "{start} → {moved}");
        // Its neighbour was pulled along.
        assert!(sim.positions()[particle - 1].x > sim.mesh().positions()[particle - 1].x);
        grab.release(&mut sim).unwrap();
        assert!(!sim.fixed()[particle] && sim.holds().is_empty());
        assert_eq!(sim.inverse_masses()[particle], 1.0, "its own weight back");
    }

    #[test]
    fn a_grabbed_pin_stays_a_pin() {
        let (mut sim, view) = setup();
        let cursor = screen(&view, sim.positions()[2]);
        let grab = Grab::start(&mut sim, 2, &view, cursor).unwrap();
        grab.release(&mut sim).unwrap();
        assert!(sim.fixed()[2]);
    }
}
