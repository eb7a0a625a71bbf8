//! The collide phase: particles pushed out of colliders, with Coulomb friction.
//!
//! For each substep every collider is placed at the substep's start (pose
//! P₀) and end (P₁). A particle that went from x₀ to x over the substep is
//! handled in the collider's frame, where the path is `ℓ₀ = P₀⁻¹ x₀ → ℓ = P₁⁻¹ x`
//! and the collider stands still, so its motion (sliding, turning,
//! keyframed) is removed before anything else is done. With r the thickness:
//!
//! ```text
//! 1. no tunnelling   if ℓ₀ is outside and the segment ℓ₀ → ℓ enters the shape at
//!                    e with normal n, keep ℓ on the free side of the plane
//!                    through e + r n:            ℓ ← ℓ + n · max(0, r − (ℓ − e)·n)
//! 2. no penetration  with φ(ℓ), n at ℓ:           ℓ ← ℓ + n · max(0, r − φ(ℓ))
//! 3. friction        D = total push (depth) of 1 and 2, Δ = ℓ − ℓ₀ the motion
//!                    relative to the surface, Δ_t = Δ − (Δ·n) n its tangential part:
//!                    |Δ_t| ≤ μ D  →  ℓ ← ℓ − Δ_t                  (static: sticks)
//!                    otherwise    →  ℓ ← ℓ − Δ_t · μ D / |Δ_t|     (kinetic: slides)
//! x ← P₁ ℓ
//! ```
//!
//! Position-based Coulomb friction (Macklin et al. 2014): D is the normal
//! displacement the contact removed this substep, i.e. the normal impulse
//! times h/m, so removing at most μD of the tangential displacement is
//! Coulomb's bound. Under gravity on a slope of angle θ, with δ = 0, D =
//! g cos θ (h/n)² and the tangential push is g sin θ (h/n)²: a resting
//! particle sticks when tan θ ≤ μ and otherwise slides with acceleration
//! g (sin θ − μ cos θ).
//!
//! Projecting to exactly r from the surface, and friction removing the
//! tangential creep, let resting contact come to rest: nothing is left to
//! jitter. Planes need no step 1 (a half-space cannot be jumped). Meshes
//! get step 1 through a ray cast in parry3d's BVH: a particle whose path
//! crosses a triangle is stopped on the side it came from, for open and
//! closed meshes alike.
//!
//! **Broad phase.** Each collider's box over the substep (both poses,
//! grown by r) is kept; a particle, or a solver's tile of particles, whose
//! box of start and end positions misses it skips that collider. A plane
//! is skipped when the whole box is farther than r on its free side. The
//! grid solver tests eight particles at once (`ContactStep::may_touch_lanes`),
//! and for a sphere that stands still also clears the particles in its box
//! whose path stays clear of the ball itself (a draped cloth hangs around
//! the ball inside its box).

use glam::Vec3;

use super::collider::{Collider, Pose, Shape};
use super::fast::kernel::{F32x8, LANES, Point, Real};
use super::mesh::bounds;

/// Where one collider is during one substep.
#[derive(Clone, Debug)]
pub struct PlacedCollider<'a> {
    /// The shape, in its own frame.
    pub shape: &'a Shape,
    /// Pose at the substep's start.
    pub start: Pose,
    /// Pose at the substep's end.
    pub end: Pose,
    /// μ for this collider.
    pub friction: f32,
    /// The world box it sweeps in the substep, grown by the thickness
    /// (`None` for a plane).
    bounds: Option<(Vec3, Vec3)>,
    /// A plane's world normal and a point on it, at the start and the end.
    plane: Option<[(Vec3, Vec3); 2]>,
    /// A sphere that stands still over the substep: its world centre and
    /// radius.
    ball: Option<(Vec3, f32)>,
}

/// Everything the collide phase of one substep needs.
#[derive(Clone, Debug)]
pub struct ContactStep<'a> {
    /// r: metres kept between a particle and every collider surface.
    pub thickness: f32,
    /// The colliders, placed.
    pub colliders: Vec<PlacedCollider<'a>>,
}

/// The world box of a local box under a pose.
fn world_box(local: (Vec3, Vec3), pose: &Pose) -> (Vec3, Vec3) {
    let (lo, hi) = local;
    let corners: Vec<Vec3> = (0..8)
        .map(|k| Vec3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][(k >> 1) & 1], [lo.z, hi.z][(k >> 2) & 1]))
        .collect();
    bounds(&corners.iter().map(|&c| pose.apply(c)).collect::<Vec<_>>())
}

impl<'a> ContactStep<'a> {
    /// The colliders placed for the substep from `t0` to `t1` (seconds).
    pub fn new(colliders: &'a [Collider], thickness: f32, friction: f32, t0: f64, t1: f64) -> Self {
        Self::with_poses(colliders.iter().map(|c| (c, c.pose_at(t0), c.pose_at(t1))), thickness, friction)
    }

    /// The colliders placed at given poses (start, end).
    pub fn with_poses(placed: impl Iterator<Item = (&'a Collider, Pose, Pose)>, thickness: f32, friction: f32) -> Self {
        let colliders = placed
            .map(|(c, start, end)| {
                let bounds = c.shape.local_bounds().map(|local| {
                    let (a0, a1) = world_box(local, &start);
                    let (b0, b1) = world_box(local, &end);
                    (a0.min(b0) - Vec3::splat(thickness), a1.max(b1) + Vec3::splat(thickness))
                });
                let plane = match c.shape {
                    Shape::Plane { normal } => {
                        Some([start, end].map(|pose| (pose.rotation * normal, pose.translation)))
                    }
                    _ => None,
                };
                let ball = match c.shape {
                    Shape::Sphere { radius } if start == end => Some((start.translation, radius)),
                    _ => None,
                };
                let friction = c.friction.unwrap_or(friction);
                PlacedCollider { shape: &c.shape, start, end, friction, bounds, plane, ball }
            })
            .collect();
        Self { thickness, colliders }
    }

    /// Whether collider `k` may touch anything in the box `lo..hi`.
    #[inline]
    pub fn may_touch(&self, k: usize, lo: Vec3, hi: Vec3) -> bool {
        let c = &self.colliders[k];
        match (c.bounds, c.plane) {
            (Some((b0, b1)), _) => lo.cmple(b1).all() && hi.cmpge(b0).all(),
            (None, Some(plane)) => plane.iter().any(|&(n, point)| {
                // The box corner deepest on the plane's closed side.
                let corner = Vec3::select(n.cmpge(Vec3::ZERO), lo, hi);
                (corner - point).dot(n) < self.thickness
            }),
            (None, None) => true,
        }
    }

    /// Which of eight particles, moving from `x0` to `x` (lanes), collider
    /// `k` may move, as a bit mask (bit l: lane l). Conservative: a clear
    /// bit is a particle that [`Self::resolve`] leaves exactly where it is.
    ///
    /// [`Self::may_touch`] on each lane's box of `x0` and `x` (the test
    /// `resolve` makes); and for a sphere that stands still, the particles
    /// in its box but clear of it: farther than r from the surface and
    /// farther from it than the path is long (so neither the ray cast nor
    /// the push can act), each by a margin of 10⁻⁴ of the distance to the
    /// centre, far above the rounding of the collider frame's rotation (a
    /// few ulps) that `resolve` works in.
    #[inline(always)]
    pub(crate) fn may_touch_lanes(&self, k: usize, x0: &Point<F32x8>, x: &Point<F32x8>) -> u8 {
        let lane = |p: &Point<F32x8>, l: usize| Vec3::new(p[0].0[l], p[1].0[l], p[2].0[l]);
        let boxed = (0..LANES).fold(0u8, |m, l| {
            let (a, b) = (lane(x0, l), lane(x, l));
            m | (u8::from(self.may_touch(k, a.min(b), a.max(b))) << l)
        });
        match self.colliders[k].ball {
            Some((centre, radius)) if boxed != 0 => boxed & !self.clear_of_ball(centre, radius, x0, x),
            _ => boxed,
        }
    }

    /// The lanes whose path `x0 → x` stays clear of a still sphere (see
    /// [`Self::may_touch_lanes`]), as a bit mask.
    #[inline(always)]
    fn clear_of_ball(&self, centre: Vec3, radius: f32, x0: &Point<F32x8>, x: &Point<F32x8>) -> u8 {
        let centre = centre.to_array();
        let offset: Point<F32x8> = std::array::from_fn(|i| x[i] - F32x8::splat(centre[i]));
        let path: Point<F32x8> = std::array::from_fn(|i| x[i] - x0[i]);
        let length = |v: &Point<F32x8>| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let (distance, path) = (length(&offset), length(&path));
        (0..LANES).fold(0u8, |m, l| {
            let (d, p) = (distance.0[l], path.0[l]);
            let margin = 1e-4 * d;
            let gap = d - radius;
            let clear = gap - self.thickness > margin && gap - p > margin;
            m | (u8::from(clear) << l)
        })
    }

    /// Every collider's index (for a caller with no box to test).
    pub fn all(&self) -> Vec<usize> {
        (0..self.colliders.len()).collect()
    }

    /// The colliders that may touch anything in `lo..hi`.
    pub fn near(&self, lo: Vec3, hi: Vec3) -> Vec<usize> {
        (0..self.colliders.len()).filter(|&k| self.may_touch(k, lo, hi)).collect()
    }

    /// Contact and friction for one particle that moved from `x0` to `x`
    /// this substep, against the colliders listed in `near`. Returns where
    /// it ends.
    #[inline]
    pub fn resolve(&self, near: &[usize], x0: Vec3, x: Vec3) -> Vec3 {
        let mut x = x;
        for &k in near {
            if self.may_touch(k, x0.min(x), x0.max(x)) {
                x = self.resolve_one(k, x0, x);
            }
        }
        x
    }

    fn resolve_one(&self, k: usize, x0: Vec3, x: Vec3) -> Vec3 {
        let c = &self.colliders[k];
        let r = self.thickness;
        let l0 = c.start.inverse_apply(x0);
        let mut l = c.end.inverse_apply(x);
        let mut depth = 0.0f32;
        let mut normal = None;
        let mut near = c.shape.proximity(l);
        // 1. The path entered the shape: stop it on the entry's side. φ is
        // 1-Lipschitz, so a path whose end is farther from the shape than
        // the path is long never touched it, and the ray cast is skipped
        // (resting and slow particles, the common case) with the same result.
        if near.is_none_or(|p| p.distance <= l.distance(l0))
            && let Some(entry) = c.shape.entry(l0, l)
        {
            let push = r - (l - entry.point).dot(entry.normal);
            if push > 0.0 {
                l += entry.normal * push;
                depth += push;
                normal = Some(entry.normal);
                near = c.shape.proximity(l);
            }
        }
        // 2. Within the thickness of the surface: out along the normal.
        if let Some(p) = near {
            let push = r - p.distance;
            if push > 0.0 {
                l += p.normal * push;
                depth += push;
                normal = Some(p.normal);
            }
        }
        let Some(n) = normal else {
            return x;
        };
        // 3. Coulomb friction on the motion relative to the surface.
        let motion = l - l0;
        let tangential = motion - n * motion.dot(n);
        let slide = tangential.length();
        let bound = c.friction * depth;
        if slide <= bound {
            l -= tangential;
        } else if slide > 0.0 {
            l -= tangential * (bound / slide);
        }
        c.end.apply(l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::collider::Collider;

    fn ground() -> Vec<Collider> {
        vec![Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose::default())]
    }

    #[test]
    fn a_particle_below_the_ground_is_put_at_the_thickness() {
        let colliders = ground();
        let step = ContactStep::new(&colliders, 0.01, 0.0, 0.0, 0.01);
        let x = step.resolve(&[0], Vec3::new(0.0, 0.005, 0.0), Vec3::new(0.3, -0.2, 0.0));
        // Frictionless: keeps its sideways motion, y = thickness (to the
        // rounding of 0.2 + 0.01 in f32).
        assert!((x - Vec3::new(0.3, 0.01, 0.0)).length() < 1e-7, "{x}");
    }

    #[test]
    fn friction_sticks_below_mu_times_depth_and_slides_above() {
        let colliders = ground();
        let step = ContactStep::new(&colliders, 0.0, 0.5, 0.0, 0.01);
        // Pushed 0.1 up; 0.04 sideways ≤ 0.5 · 0.1: sticks where it was.
        let x = step.resolve(&[0], Vec3::ZERO, Vec3::new(0.04, -0.1, 0.0));
        assert!(x.length() < 1e-7, "{x}");
        // 0.2 sideways > 0.05: slides 0.2 − 0.05 = 0.15.
        let x = step.resolve(&[0], Vec3::ZERO, Vec3::new(0.2, -0.1, 0.0));
        assert!((x - Vec3::new(0.15, 0.0, 0.0)).length() < 1e-6, "{x}");
    }

    #[test]
    fn a_moving_collider_carries_what_sticks_to_it() {
        // A box top at y = 0 moving +x by 0.01 in the substep; a particle
        // resting on it (start 0, pushed down by 0.001) keeps its place on
        // the box, so it moves with it.
        let mut box_collider = Collider::fixed(Shape::Box { half_extents: Vec3::new(1.0, 0.5, 1.0) }, Pose::default());
        box_collider.pose.translation = Vec3::new(0.0, -0.5, 0.0);
        box_collider.motion =
            crate::sim::collider::Motion::Moving { velocity: Vec3::new(1.0, 0.0, 0.0), angular_velocity: Vec3::ZERO };
        let colliders = [box_collider];
        let step = ContactStep::new(&colliders, 0.0, 0.5, 0.0, 0.01);
        let x = step.resolve(&[0], Vec3::ZERO, Vec3::new(0.0, -0.001, 0.0));
        // Relative motion 0.01 > μD = 0.0005: slides, but is dragged 0.0005 along.
        assert!((x.x - 0.0005).abs() < 1e-6 && x.y.abs() < 1e-6, "{x}");
    }

    #[test]
    fn the_lanes_filter_clears_only_particles_resolve_leaves_alone() {
        // A still sphere (r 0.5 at (0, 0.6, 0)), a tilted ground, and a
        // sphere moving over the substep; 4000 particles on short and long
        // paths around them, eight at a time. A clear lane must come out of
        // `resolve` bit for bit where it went in; the box part of the filter
        // must agree with `may_touch` exactly; and the sphere test must clear
        // many particles inside the sphere's box (or it proves nothing).
        let tilted = Pose { rotation: glam::Quat::from_rotation_z(0.2), translation: Vec3::new(0.0, -0.1, 0.0) };
        let mut moving = Collider::fixed(Shape::Sphere { radius: 0.3 }, Pose::default());
        moving.pose.translation = Vec3::new(0.9, 0.2, 0.0);
        moving.motion =
            crate::sim::collider::Motion::Moving { velocity: Vec3::new(0.0, 1.0, 0.0), angular_velocity: Vec3::ZERO };
        let colliders = vec![
            Collider::fixed(
                Shape::Sphere { radius: 0.5 },
                Pose { translation: Vec3::new(0.0, 0.6, 0.0), ..Pose::default() },
            ),
            Collider::fixed(Shape::Plane { normal: Vec3::Y }, tilted),
            moving,
        ];
        let step = ContactStep::new(&colliders, 0.01, 0.3, 0.0, 0.01);
        let all = step.all();
        let mut state = 7u32;
        let mut random = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let (mut cleared_in_box, mut moved) = (0, 0);
        for group in 0..500 {
            let reach = if group % 2 == 0 { 0.02 } else { 0.4 };
            let pairs: [(Vec3, Vec3); LANES] = std::array::from_fn(|_| {
                let x = Vec3::new(random() * 2.4, 0.6 + random() * 2.4, random() * 2.4);
                (x + Vec3::new(random(), random(), random()) * reach, x)
            });
            let lanes = |pick: fn(&(Vec3, Vec3)) -> Vec3| -> Point<F32x8> {
                std::array::from_fn(|i| F32x8(std::array::from_fn(|l| pick(&pairs[l])[i])))
            };
            let (x0, x) = (lanes(|p| p.0), lanes(|p| p.1));
            let masks: Vec<u8> = (0..colliders.len()).map(|k| step.may_touch_lanes(k, &x0, &x)).collect();
            for (l, &(a, b)) in pairs.iter().enumerate() {
                let out = step.resolve(&all, a, b);
                moved += usize::from(out != b);
                if masks.iter().all(|m| m & (1 << l) == 0) {
                    assert_eq!(out.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits), "{a} -> {b}");
                }
                for k in [1, 2] {
                    assert_eq!(masks[k] & (1 << l) != 0, step.may_touch(k, a.min(b), a.max(b)), "collider {k}");
                }
                let boxed = step.may_touch(0, a.min(b), a.max(b));
                cleared_in_box += usize::from(boxed && masks[0] & (1 << l) == 0);
                assert!(boxed || masks[0] & (1 << l) == 0);
            }
        }
        assert!(cleared_in_box > 50, "{cleared_in_box} cleared inside the still sphere's box");
        assert!(moved > 200, "{moved} particles moved by contact");
    }

    #[test]
    fn the_broad_phase_skips_far_colliders_and_planes_seen_from_above() {
        let colliders = vec![
            Collider::fixed(
                Shape::Sphere { radius: 0.5 },
                Pose { translation: Vec3::new(5.0, 0.0, 0.0), ..Pose::default() },
            ),
            Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose::default()),
        ];
        let step = ContactStep::new(&colliders, 0.01, 0.3, 0.0, 0.01);
        assert!(step.near(Vec3::new(-1.0, 1.0, -1.0), Vec3::new(1.0, 2.0, 1.0)).is_empty());
        assert_eq!(step.near(Vec3::new(4.0, -0.005, 0.0), Vec3::new(4.6, 1.0, 0.1)), vec![0, 1]);
    }
}
