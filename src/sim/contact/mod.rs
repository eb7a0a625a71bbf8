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
//! is skipped when the whole box is farther than r on its free side.
//!
//! **A sphere or plane that stands still** is handled in world axes about
//! its centre or its point c, ℓ = x − c, with the plane's world normal:
//! neither changes when turned about its normal or centre, so the frame's
//! rotation is left out (for an unrotated collider these are the numbers of
//! P⁻¹ and P).
//!
//! **Eight at a time** (`contact/lanes.rs`, for the grid solver's lanes):
//! the broad phase lane by lane, which for a still sphere also clears the
//! particles in its box whose path stays clear of the ball (a draped cloth
//! hangs around the ball inside its box); then steps 1 to 3 against a
//! still sphere (the ray cast where a path may have entered it) and steps
//! 2 and 3 against a still plane in lanes, with the one-particle code's
//! bits. Everything else goes one particle at a time.

use glam::Vec3;

use super::collider::{Collider, Pose, Proximity, Shape};
use super::mesh::bounds;

mod lanes;

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
    pub(super) bounds: Option<(Vec3, Vec3)>,
    /// A plane's world normal and a point on it, at the start and the end.
    pub(super) plane: Option<[(Vec3, Vec3); 2]>,
    /// A sphere or plane that stands still over the substep, handled in
    /// world axes about a point of its own.
    pub(super) still: Option<Still>,
}

/// A collider that stands still over a substep, in world axes.
#[derive(Clone, Copy, Debug)]
pub(super) enum Still {
    /// A sphere: its world centre and radius.
    Ball { centre: Vec3, radius: f32 },
    /// A plane: its world normal and a point on it.
    Plane { normal: Vec3, point: Vec3 },
}

impl Still {
    /// The point the collider's frame is centred on.
    pub(super) fn origin(&self) -> Vec3 {
        match *self {
            Still::Ball { centre, .. } => centre,
            Still::Plane { point, .. } => point,
        }
    }
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
                let still = match (&c.shape, plane) {
                    _ if start != end => None,
                    (&Shape::Sphere { radius }, _) => Some(Still::Ball { centre: start.translation, radius }),
                    (Shape::Plane { .. }, Some([(normal, point), _])) => Some(Still::Plane { normal, point }),
                    _ => None,
                };
                let friction = c.friction.unwrap_or(friction);
                PlacedCollider { shape: &c.shape, start, end, friction, bounds, plane, still }
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

    pub(super) fn resolve_one(&self, k: usize, x0: Vec3, x: Vec3) -> Vec3 {
        let c = &self.colliders[k];
        let r = self.thickness;
        // A still ball or plane: world axes about its own point (module
        // docs), which the lanes follow (`lanes.rs`).
        let (l0, mut l) = match c.still {
            Some(still) => (x0 - still.origin(), x - still.origin()),
            None => (c.start.inverse_apply(x0), c.end.inverse_apply(x)),
        };
        let proximity = |l: Vec3| match c.still {
            Some(Still::Plane { normal, .. }) => Some(Proximity { distance: l.dot(normal), normal }),
            _ => c.shape.proximity(l),
        };
        let mut depth = 0.0f32;
        let mut normal = None;
        let mut near = proximity(l);
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
                near = proximity(l);
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
        match c.still {
            Some(still) => l + still.origin(),
            None => c.end.apply(l),
        }
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
