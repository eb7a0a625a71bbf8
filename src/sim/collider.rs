//! Colliders: rigid shapes the cloth cannot enter, placed and moved in time.
//!
//! Every shape is described in its own frame and placed by a [`Pose`]
//! (rotation, then translation) that may change with time ([`Motion`]). The
//! queries are made in the shape's frame:
//!
//! ```text
//! plane     φ(p) = p·n                           (the side n points to is free)
//! sphere    φ(p) = |p| − R
//! capsule   φ(p) = |p − q(p)| − R,  q the nearest point of the segment [−a, a]
//! box       φ(p) = |max(|p| − e, 0)| + min(max_k(|p_k| − e_k), 0)
//! mesh      φ(p) = ±|p − q(p)|,  q the nearest point on the triangles (parry3d's
//!           BVH); negative inside a closed mesh, never negative for an open one
//! ```
//!
//! with the outward normal at the nearest surface point, and the first entry
//! of a segment into the shape (closed-form for the analytic shapes, a ray
//! cast through the BVH for meshes), which [`super::contact`] uses to stop
//! tunnelling.

use std::sync::Arc;

use glam::{EulerRot, Quat, Vec3};

/// A rigid placement: a rotation, then a translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Orientation of the shape's frame.
    pub rotation: Quat,
    /// Where the shape's origin is, metres.
    pub translation: Vec3,
}

impl Default for Pose {
    fn default() -> Self {
        Self { rotation: Quat::IDENTITY, translation: Vec3::ZERO }
    }
}

impl Pose {
    /// A pose from a translation and rotations in degrees about x, then y,
    /// then z (the scene file's `rotation`).
    pub fn from_degrees(translation: Vec3, degrees: Vec3) -> Self {
        let r = degrees * (std::f32::consts::PI / 180.0);
        // Extrinsic x, then y, then z: q = qz · qy · qx.
        Self { rotation: Quat::from_euler(EulerRot::ZYX, r.z, r.y, r.x), translation }
    }
    /// A point of the shape's frame in the world.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }
    /// A world point in the shape's frame.
    pub fn inverse_apply(&self, p: Vec3) -> Vec3 {
        self.rotation.inverse() * (p - self.translation)
    }
    /// The pose a fraction `t` of the way from `self` to `other`.
    pub fn lerp(&self, other: &Pose, t: f32) -> Pose {
        Pose {
            rotation: self.rotation.slerp(other.rotation, t),
            translation: self.translation.lerp(other.translation, t),
        }
    }
}

/// A triangle mesh collider: parry3d's `TriMesh` (with its BVH) in the
/// collider's frame.
#[derive(Clone)]
pub struct MeshShape {
    mesh: parry3d::shape::TriMesh,
    closed: bool,
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl std::fmt::Debug for MeshShape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "MeshShape({} vertices, {} triangles, closed: {})",
            self.vertices.len(),
            self.triangles.len(),
            self.closed
        )
    }
}

fn to_parry(v: Vec3) -> parry3d::math::Vector {
    parry3d::math::Vector::new(v.x, v.y, v.z)
}
fn from_parry(v: parry3d::math::Vector) -> Vec3 {
    Vec3::new(v.x, v.y, v.z)
}

impl MeshShape {
    /// A mesh collider from vertices and triangles. A closed, consistently
    /// oriented mesh has an inside; any other is open and two-sided.
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self, String> {
        use parry3d::shape::{TriMesh, TriMeshFlags};
        if triangles.is_empty() {
            return Err("it has no triangles".into());
        }
        let points: Vec<_> = vertices.iter().map(|&v| to_parry(v)).collect();
        // Oriented (pseudo-normals for inside tests) only when every edge is
        // shared by exactly two triangles, in opposite directions.
        let closed = is_closed(&triangles);
        let flags = if closed { TriMeshFlags::ORIENTED } else { TriMeshFlags::empty() };
        let mesh = TriMesh::with_flags(points.clone(), triangles.clone(), flags)
            .or_else(|_| TriMesh::new(points, triangles.clone()))
            .map_err(|e| format!("cannot build its triangle tree: {e}"))?;
        let closed = closed && mesh.pseudo_normals_if_oriented().is_some();
        Ok(Self { mesh, closed, vertices, triangles })
    }
    /// Whether the mesh has an inside.
    pub fn closed(&self) -> bool {
        self.closed
    }
    /// The vertices, in the collider's frame (for drawing).
    pub fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }
    /// The triangles (for drawing).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }
}

/// Every directed edge appears once and its reverse once.
fn is_closed(triangles: &[[u32; 3]]) -> bool {
    let mut edges = std::collections::HashSet::with_capacity(triangles.len() * 3);
    for t in triangles {
        for k in 0..3 {
            if !edges.insert((t[k], t[(k + 1) % 3])) {
                return false;
            }
        }
    }
    edges.iter().all(|&(a, b)| edges.contains(&(b, a)))
}

/// A collider's shape, in its own frame.
#[derive(Clone, Debug)]
pub enum Shape {
    /// The half-space `p·normal ≥ 0` is free; `normal` has unit length.
    Plane {
        /// Unit normal, pointing to the free side.
        normal: Vec3,
    },
    /// A ball of this radius (metres) about the origin.
    Sphere {
        /// Metres, > 0.
        radius: f32,
    },
    /// The segment from `−half_axis` to `half_axis`, thickened by `radius`.
    Capsule {
        /// Half the segment, metres.
        half_axis: Vec3,
        /// Metres, > 0.
        radius: f32,
    },
    /// The box `|p_k| ≤ half_extents_k`.
    Box {
        /// Metres, each > 0.
        half_extents: Vec3,
    },
    /// A triangle mesh.
    Mesh(Arc<MeshShape>),
}

/// The nearest surface point's signed distance and outward normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Proximity {
    /// φ: metres outside the surface (negative inside).
    pub distance: f32,
    /// Unit outward normal at the nearest surface point.
    pub normal: Vec3,
}

/// Where a segment first enters a shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    /// The entry point.
    pub point: Vec3,
    /// The outward normal there (facing the segment's start).
    pub normal: Vec3,
}

impl Shape {
    /// φ and the outward normal at `p` (shape frame). `None` only where the
    /// normal is undefined (a point exactly on an open mesh).
    pub fn proximity(&self, p: Vec3) -> Option<Proximity> {
        match self {
            Shape::Plane { normal } => Some(Proximity { distance: p.dot(*normal), normal: *normal }),
            Shape::Sphere { radius } => {
                let len = p.length();
                let normal = if len > 0.0 { p / len } else { Vec3::Y };
                Some(Proximity { distance: len - radius, normal })
            }
            Shape::Capsule { half_axis, radius } => {
                let q = nearest_on_segment(p, -*half_axis, *half_axis);
                let d = p - q;
                let len = d.length();
                let normal = if len > 0.0 { d / len } else { half_axis.any_orthonormal_vector() };
                Some(Proximity { distance: len - radius, normal })
            }
            Shape::Box { half_extents } => Some(box_proximity(p, *half_extents)),
            Shape::Mesh(mesh) => {
                use parry3d::query::PointQuery;
                let proj = mesh.mesh.project_local_point(to_parry(p), false);
                let q = from_parry(proj.point);
                let d = p - q;
                let len = d.length();
                if len == 0.0 {
                    return None;
                }
                let inside = mesh.closed && proj.is_inside;
                Some(if inside {
                    Proximity { distance: -len, normal: -d / len }
                } else {
                    Proximity { distance: len, normal: d / len }
                })
            }
        }
    }

    /// The first point where the segment `from → to` (shape frame) enters the
    /// shape, if `from` is outside and the segment reaches it. Planes never
    /// need it (a half-space cannot be jumped over) and return `None`.
    pub fn entry(&self, from: Vec3, to: Vec3) -> Option<Entry> {
        let dir = to - from;
        let length = dir.length();
        if length == 0.0 {
            return None;
        }
        let unit = dir / length;
        let (t, normal) = match self {
            Shape::Plane { .. } => return None,
            Shape::Sphere { radius } => {
                let t = ray_sphere(from, unit, Vec3::ZERO, *radius)?;
                (t, (from + unit * t).normalize_or(Vec3::Y))
            }
            Shape::Capsule { half_axis, radius } => {
                let t = ray_capsule(from, unit, -*half_axis, *half_axis, *radius)?;
                let p = from + unit * t;
                (t, (p - nearest_on_segment(p, -*half_axis, *half_axis)).normalize_or(Vec3::Y))
            }
            Shape::Box { half_extents } => ray_box(from, unit, *half_extents)?,
            Shape::Mesh(mesh) => {
                use parry3d::query::{Ray, RayCast};
                let ray = Ray::new(to_parry(from), to_parry(unit));
                let hit = mesh.mesh.cast_local_ray_and_get_normal(&ray, length, false)?;
                let n = from_parry(hit.normal).normalize_or(Vec3::Y);
                // Two-sided: the normal faces where the segment came from.
                (hit.time_of_impact, if n.dot(unit) > 0.0 { -n } else { n })
            }
        };
        (t <= length).then_some(Entry { point: from + unit * t, normal })
    }

    /// The shape's bounding box in its own frame; `None` for a plane.
    pub fn local_bounds(&self) -> Option<(Vec3, Vec3)> {
        match self {
            Shape::Plane { .. } => None,
            Shape::Sphere { radius } => Some((Vec3::splat(-radius), Vec3::splat(*radius))),
            Shape::Capsule { half_axis, radius } => {
                let e = half_axis.abs() + Vec3::splat(*radius);
                Some((-e, e))
            }
            Shape::Box { half_extents } => Some((-*half_extents, *half_extents)),
            Shape::Mesh(mesh) => Some(super::mesh::bounds(&mesh.vertices)),
        }
    }
}

fn nearest_on_segment(p: Vec3, a: Vec3, b: Vec3) -> Vec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 == 0.0 {
        return a;
    }
    a + ab * ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
}

fn box_proximity(p: Vec3, e: Vec3) -> Proximity {
    let q = p.abs() - e;
    let outside = q.max(Vec3::ZERO);
    if outside.max_element() > 0.0 {
        let nearest = p.clamp(-e, e);
        let d = p - nearest;
        let len = d.length();
        return Proximity { distance: len, normal: d / len };
    }
    // Inside: the nearest face is the one of the largest q.
    let axis = if q.x >= q.y && q.x >= q.z {
        0
    } else if q.y >= q.z {
        1
    } else {
        2
    };
    let mut normal = Vec3::ZERO;
    normal[axis] = if p[axis] >= 0.0 { 1.0 } else { -1.0 };
    Proximity { distance: q[axis], normal }
}

/// Distance along the unit ray to a sphere, if the origin is outside and the
/// ray meets it ahead.
fn ray_sphere(origin: Vec3, unit: Vec3, centre: Vec3, radius: f32) -> Option<f32> {
    let oc = origin - centre;
    let c = oc.length_squared() - radius * radius;
    if c <= 0.0 {
        return None;
    }
    let b = oc.dot(unit);
    let h = b * b - c;
    if b >= 0.0 || h < 0.0 {
        return None;
    }
    Some(-b - h.sqrt())
}

/// Distance along the unit ray to a capsule (segment a–b, radius r), if the
/// origin is outside and the ray meets it ahead: the side of the cylinder,
/// else the nearer end cap.
fn ray_capsule(origin: Vec3, unit: Vec3, a: Vec3, b: Vec3, r: f32) -> Option<f32> {
    if (origin - nearest_on_segment(origin, a, b)).length_squared() <= r * r {
        return None;
    }
    let ba = b - a;
    let oa = origin - a;
    let (baba, bard, baoa) = (ba.dot(ba), ba.dot(unit), ba.dot(oa));
    let (rdoa, oaoa) = (unit.dot(oa), oa.dot(oa));
    let qa = baba - bard * bard;
    let qb = baba * rdoa - baoa * bard;
    let qc = baba * oaoa - baoa * baoa - r * r * baba;
    let h = qb * qb - qa * qc;
    let mut best: Option<f32> = None;
    if qa > 1e-12 && h >= 0.0 {
        let t = (-qb - h.sqrt()) / qa;
        let y = baoa + t * bard;
        if t >= 0.0 && y > 0.0 && y < baba {
            best = Some(t);
        }
    }
    for cap in [a, b] {
        if let Some(t) = ray_sphere(origin, unit, cap, r) {
            best = Some(best.map_or(t, |s| s.min(t)));
        }
    }
    best
}

/// Slab test against the box |p_k| ≤ e_k: distance along the unit ray and the
/// entry face's normal, if the origin is outside and the ray meets it ahead.
fn ray_box(origin: Vec3, unit: Vec3, e: Vec3) -> Option<(f32, Vec3)> {
    let (mut enter, mut exit, mut axis) = (f32::NEG_INFINITY, f32::INFINITY, 0usize);
    for k in 0..3 {
        if unit[k] == 0.0 {
            if origin[k].abs() > e[k] {
                return None;
            }
            continue;
        }
        let t1 = (-e[k] - origin[k]) / unit[k];
        let t2 = (e[k] - origin[k]) / unit[k];
        let (near, far) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
        if near > enter {
            enter = near;
            axis = k;
        }
        exit = exit.min(far);
    }
    if enter > exit || enter < 0.0 {
        return None;
    }
    let mut normal = Vec3::ZERO;
    normal[axis] = if unit[axis] > 0.0 { -1.0 } else { 1.0 };
    Some((enter, normal))
}

/// One key of a keyframed path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Seconds of simulated time.
    pub time: f64,
    /// The pose at that time.
    pub pose: Pose,
}

/// How a collider moves.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Motion {
    /// It stays where it was placed.
    #[default]
    Fixed,
    /// Constant velocity (m/s) and angular velocity (rad/s, about its origin).
    Moving {
        /// m/s.
        velocity: Vec3,
        /// rad/s, about the shape's origin.
        angular_velocity: Vec3,
    },
    /// Linear between keys (rotation spherically), held before the first
    /// and after the last unless `looped`, which repeats the path.
    Keyframes {
        /// At least one, in increasing time.
        keys: Vec<Keyframe>,
        /// Repeat the path with period `last.time`.
        looped: bool,
    },
}

/// A rigid collider: a shape, where it starts, how it moves, and its
/// friction coefficient.
#[derive(Clone, Debug)]
pub struct Collider {
    /// The shape in its own frame.
    pub shape: Shape,
    /// Its pose at time 0 (ignored by keyframed motion).
    pub pose: Pose,
    /// How it moves.
    pub motion: Motion,
    /// μ, Coulomb's coefficient; `None` takes the solver's.
    pub friction: Option<f32>,
}

impl Collider {
    /// A collider that does not move.
    pub fn fixed(shape: Shape, pose: Pose) -> Self {
        Self { shape, pose, motion: Motion::Fixed, friction: None }
    }

    /// Its pose at simulated time `t` (seconds).
    pub fn pose_at(&self, t: f64) -> Pose {
        match &self.motion {
            Motion::Fixed => self.pose,
            Motion::Moving { velocity, angular_velocity } => {
                let t32 = t as f32;
                let spin = Quat::from_scaled_axis(*angular_velocity * t32);
                Pose { rotation: spin * self.pose.rotation, translation: self.pose.translation + *velocity * t32 }
            }
            Motion::Keyframes { keys, looped } => keyframe_pose(keys, *looped, t),
        }
    }
}

fn keyframe_pose(keys: &[Keyframe], looped: bool, t: f64) -> Pose {
    let (Some(first), Some(last)) = (keys.first(), keys.last()) else {
        return Pose::default();
    };
    let t = if looped && last.time > 0.0 { t.rem_euclid(last.time) } else { t };
    if t <= first.time {
        return first.pose;
    }
    for pair in keys.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        if t <= b.time {
            let span = b.time - a.time;
            let s = if span > 0.0 { ((t - a.time) / span) as f32 } else { 1.0 };
            return a.pose.lerp(&b.pose, s);
        }
    }
    last.pose
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_distances_of_the_analytic_shapes() {
        // Points chosen so the answers are whole numbers.
        let sphere = Shape::Sphere { radius: 1.0 };
        assert_eq!(sphere.proximity(Vec3::new(0.0, 3.0, 0.0)).unwrap().distance, 2.0);
        assert_eq!(sphere.proximity(Vec3::new(0.5, 0.0, 0.0)).unwrap().normal, Vec3::X);
        let capsule = Shape::Capsule { half_axis: Vec3::X, radius: 0.5 };
        // Beside the middle: 2 from the axis; beyond the end: 3 from (1, 0, 0).
        assert_eq!(capsule.proximity(Vec3::new(0.2, 2.0, 0.0)).unwrap().distance, 1.5);
        assert_eq!(capsule.proximity(Vec3::new(4.0, 0.0, 0.0)).unwrap().distance, 2.5);
        let cube = Shape::Box { half_extents: Vec3::new(1.0, 0.5, 2.0) };
        let inside = cube.proximity(Vec3::new(0.0, 0.3, 0.0)).unwrap();
        assert!((inside.distance + 0.2).abs() < 1e-6 && inside.normal == Vec3::Y, "{inside:?}");
        // Off a corner: (3, 4) beyond the edge x = 1, y = 0.5 → distance 5.
        assert_eq!(cube.proximity(Vec3::new(4.0, 4.5, 0.0)).unwrap().distance, 5.0);
        let plane = Shape::Plane { normal: Vec3::Y };
        assert_eq!(plane.proximity(Vec3::new(7.0, -0.25, 1.0)).unwrap().distance, -0.25);
    }

    #[test]
    fn segments_enter_where_they_first_meet_the_shape() {
        let sphere = Shape::Sphere { radius: 1.0 };
        let e = sphere.entry(Vec3::new(-5.0, 0.0, 0.0), Vec3::new(5.0, 0.0, 0.0)).unwrap();
        assert!((e.point - Vec3::new(-1.0, 0.0, 0.0)).length() < 1e-6 && e.normal == -Vec3::X, "{e:?}");
        assert!(sphere.entry(Vec3::new(-5.0, 0.0, 0.0), Vec3::new(-2.0, 0.0, 0.0)).is_none(), "stops short");
        assert!(sphere.entry(Vec3::new(-5.0, 2.0, 0.0), Vec3::new(5.0, 2.0, 0.0)).is_none(), "passes by");
        let capsule = Shape::Capsule { half_axis: Vec3::X, radius: 0.5 };
        let side = capsule.entry(Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.0, -3.0, 0.0)).unwrap();
        assert!((side.point.y - 0.5).abs() < 1e-6 && side.normal == Vec3::Y, "{side:?}");
        let cap = capsule.entry(Vec3::new(5.0, 0.0, 0.0), Vec3::ZERO).unwrap();
        assert!((cap.point.x - 1.5).abs() < 1e-5, "{cap:?}");
        let slab = Shape::Box { half_extents: Vec3::new(1.0, 0.01, 1.0) };
        let top = slab.entry(Vec3::new(0.2, 1.0, 0.3), Vec3::new(0.2, -1.0, 0.3)).unwrap();
        assert!((top.point.y - 0.01).abs() < 1e-6 && top.normal == Vec3::Y, "{top:?}");
    }

    #[test]
    fn closed_mesh_has_an_inside_and_an_open_one_two_sides() {
        // A tetrahedron, faces wound outwards.
        let v = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let t = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let tet = Shape::Mesh(Arc::new(MeshShape::new(v.clone(), t).unwrap()));
        let inside = tet.proximity(Vec3::splat(0.1)).unwrap();
        assert!(inside.distance < 0.0 && (inside.distance + 0.1).abs() < 1e-5, "{inside:?}");
        assert!(tet.proximity(Vec3::new(0.2, 0.2, -1.0)).unwrap().distance > 0.99);
        let hit = tet.entry(Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.2, 0.2, 1.0)).unwrap();
        assert!(hit.point.z.abs() < 1e-6 && hit.normal == -Vec3::Z, "{hit:?}");
        // One triangle: open, two-sided, distances never negative.
        let open = Shape::Mesh(Arc::new(MeshShape::new(v, vec![[0, 1, 2]]).unwrap()));
        let below = open.proximity(Vec3::new(0.1, 0.1, -0.5)).unwrap();
        assert!((below.distance - 0.5).abs() < 1e-6 && below.normal == -Vec3::Z, "{below:?}");
    }

    #[test]
    fn poses_move_and_keyframes_interpolate() {
        let pose = Pose::from_degrees(Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 90.0, 0.0));
        // 90° about y takes +x to −z.
        assert!((pose.apply(Vec3::X) - Vec3::new(1.0, 0.0, -1.0)).length() < 1e-6);
        assert!((pose.inverse_apply(pose.apply(Vec3::new(0.3, 0.2, 0.1))) - Vec3::new(0.3, 0.2, 0.1)).length() < 1e-6);
        let key = |time, x| Keyframe { time, pose: Pose { translation: Vec3::new(x, 0.0, 0.0), ..Pose::default() } };
        let c = Collider {
            motion: Motion::Keyframes { keys: vec![key(0.0, 0.0), key(2.0, 1.0)], looped: true },
            ..Collider::fixed(Shape::Sphere { radius: 1.0 }, Pose::default())
        };
        assert!((c.pose_at(0.5).translation.x - 0.25).abs() < 1e-6);
        assert!((c.pose_at(2.5).translation.x - 0.25).abs() < 1e-6, "looped");
        let moving = Collider {
            motion: Motion::Moving { velocity: Vec3::new(0.2, 0.0, 0.0), angular_velocity: Vec3::ZERO },
            ..Collider::fixed(Shape::Sphere { radius: 1.0 }, Pose::default())
        };
        assert!((moving.pose_at(5.0).translation.x - 1.0).abs() < 1e-6);
    }
}
