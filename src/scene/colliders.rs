//! `[[collider]]` tables: the scene file's colliders, checked key by key.
//!
//! Every error names the collider by its index (`collider[2].radius`), the
//! key, and what is allowed.

use std::sync::Arc;

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use super::SceneErrorKind;
use crate::sim::{Collider, Keyframe, MeshShape, Motion, Pose, Shape};

/// Largest accepted collider coordinate or size, metres.
pub const MAX_EXTENT: f32 = 1e6;
/// Smallest collider dimension and mesh scale (1 µm, the shortest bar a
/// cloth may have: nothing smaller can be touched at f32 precision).
pub const MIN_EXTENT: f32 = crate::sim::mesh::MIN_BAR_LENGTH;
/// Largest accepted collider speed, m/s.
pub const MAX_SPEED: f32 = 1e4;
/// Largest accepted collider spin, rad/s.
pub const MAX_SPIN: f32 = 1e4;

/// The `shape` key of a `[[collider]]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShapeName {
    /// A half-space.
    Plane,
    /// A ball.
    Sphere,
    /// A segment with a radius.
    Capsule,
    /// An oriented box.
    Box,
    /// A triangle mesh from an OBJ file.
    Mesh,
}

/// One `[[collider]]` as written. See the README for every key.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ColliderTable {
    /// Which shape.
    pub shape: ShapeName,
    /// Plane: a point on it.
    pub point: Option<[f32; 3]>,
    /// Plane: the normal (any non-zero length).
    pub normal: Option<[f32; 3]>,
    /// Sphere, box: the centre.
    pub center: Option<[f32; 3]>,
    /// Sphere, capsule: metres, > 0.
    pub radius: Option<f32>,
    /// Capsule: one end of its segment.
    pub start: Option<[f32; 3]>,
    /// Capsule: the other end.
    pub end: Option<[f32; 3]>,
    /// Box: half its size along each of its axes, metres, > 0.
    pub half_extents: Option<[f32; 3]>,
    /// Box, mesh: degrees about x, then y, then z.
    pub rotation: Option<[f32; 3]>,
    /// Mesh: the OBJ file, relative to the scene file.
    pub path: Option<String>,
    /// Mesh: multiplies every coordinate (default 1).
    pub scale: Option<f32>,
    /// Mesh: added after scaling, metres (default 0).
    pub offset: Option<[f32; 3]>,
    /// μ for this collider (default `[solver] friction`).
    pub friction: Option<f32>,
    /// m/s, constant.
    pub velocity: Option<[f32; 3]>,
    /// rad/s about the collider's centre.
    pub angular_velocity: Option<[f32; 3]>,
    /// A keyframed path instead of velocities.
    #[serde(default)]
    pub keyframes: Vec<KeyframeTable>,
    /// Repeat the keyframed path.
    #[serde(rename = "loop")]
    pub looped: Option<bool>,
}

/// `[[collider.keyframes]]`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct KeyframeTable {
    /// Seconds, ≥ 0, increasing from key to key.
    pub time: f64,
    /// Where the collider's centre (plane: its point; capsule: the middle of
    /// its segment; mesh: its origin) is then (default: where it starts).
    pub center: Option<[f32; 3]>,
    /// Degrees about x, then y, then z (default: as it starts).
    pub rotation: Option<[f32; 3]>,
}

/// Reads an OBJ file named by a collider's `path` (resolved by the caller).
pub type ObjReader<'a> = dyn Fn(&str) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), SceneErrorKind> + 'a;

/// Builds the colliders of a scene.
pub fn build(tables: &[ColliderTable], read_obj: &ObjReader) -> Result<Vec<Collider>, SceneErrorKind> {
    tables.iter().enumerate().map(|(i, t)| build_one(i, t, read_obj)).collect()
}

fn invalid(i: usize, key: &str, message: impl Into<String>) -> SceneErrorKind {
    SceneErrorKind::Invalid { key: format!("collider[{i}].{key}"), message: message.into() }
}

fn point(i: usize, key: &str, v: [f32; 3]) -> Result<Vec3, SceneErrorKind> {
    let p = Vec3::from_array(v);
    if p.is_finite() && p.abs().max_element() <= MAX_EXTENT {
        Ok(p)
    } else {
        Err(invalid(i, key, format!("{v:?} is not allowed: finite coordinates within ±1e6 m")))
    }
}

fn required<T: Copy>(i: usize, key: &str, v: Option<T>, what: &str) -> Result<T, SceneErrorKind> {
    v.ok_or_else(|| invalid(i, key, format!("is missing: this shape needs {key} ({what})")))
}

fn length(i: usize, key: &str, v: f32) -> Result<f32, SceneErrorKind> {
    if v.is_finite() && (MIN_EXTENT..=MAX_EXTENT).contains(&v) {
        Ok(v)
    } else {
        Err(invalid(i, key, format!("{v:e} is not allowed: metres, 1e-6 <= {key} <= 1e6")))
    }
}

fn bounded(i: usize, key: &str, v: Option<[f32; 3]>, max: f32, unit: &str) -> Result<Vec3, SceneErrorKind> {
    let Some(v) = v else { return Ok(Vec3::ZERO) };
    let p = Vec3::from_array(v);
    if p.is_finite() && p.abs().max_element() <= max {
        Ok(p)
    } else {
        Err(invalid(i, key, format!("{v:?} is not allowed: finite components within ±{max:e} {unit}")))
    }
}

fn rotation(i: usize, v: Option<[f32; 3]>) -> Result<Vec3, SceneErrorKind> {
    bounded(i, "rotation", v, 1e6, "degrees")
}

fn build_one(i: usize, t: &ColliderTable, read_obj: &ObjReader) -> Result<Collider, SceneErrorKind> {
    // Keys that belong to other shapes are errors, not silently ignored.
    let given = [
        ("point", t.point.is_some()),
        ("normal", t.normal.is_some()),
        ("center", t.center.is_some()),
        ("radius", t.radius.is_some()),
        ("start", t.start.is_some()),
        ("end", t.end.is_some()),
        ("half_extents", t.half_extents.is_some()),
        ("rotation", t.rotation.is_some()),
        ("path", t.path.is_some()),
        ("scale", t.scale.is_some()),
        ("offset", t.offset.is_some()),
    ];
    let allowed: &[&str] = match t.shape {
        ShapeName::Plane => &["point", "normal"],
        ShapeName::Sphere => &["center", "radius"],
        ShapeName::Capsule => &["start", "end", "radius"],
        ShapeName::Box => &["center", "half_extents", "rotation"],
        ShapeName::Mesh => &["path", "scale", "offset", "rotation"],
    };
    if let Some((key, _)) = given.iter().find(|(k, g)| *g && !allowed.contains(k)) {
        return Err(invalid(
            i,
            key,
            format!("does not apply to shape = \"{}\", which takes {}", shape_word(t.shape), allowed.join(", ")),
        ));
    }
    let (shape, pose) = match t.shape {
        ShapeName::Plane => {
            let at = point(i, "point", t.point.unwrap_or([0.0; 3]))?;
            let n = point(i, "normal", t.normal.unwrap_or([0.0, 1.0, 0.0]))?;
            let Some(normal) = n.try_normalize() else {
                return Err(invalid(i, "normal", "[0, 0, 0] is not allowed: a vector of non-zero length"));
            };
            (Shape::Plane { normal }, Pose { translation: at, rotation: Quat::IDENTITY })
        }
        ShapeName::Sphere => {
            let c = point(i, "center", required(i, "center", t.center, "[x, y, z] in metres")?)?;
            let radius = length(i, "radius", required(i, "radius", t.radius, "metres")?)?;
            (Shape::Sphere { radius }, Pose { translation: c, rotation: Quat::IDENTITY })
        }
        ShapeName::Capsule => {
            let a = point(i, "start", required(i, "start", t.start, "[x, y, z] in metres")?)?;
            let b = point(i, "end", required(i, "end", t.end, "[x, y, z] in metres")?)?;
            let radius = length(i, "radius", required(i, "radius", t.radius, "metres")?)?;
            let shape = Shape::Capsule { half_axis: (b - a) * 0.5, radius };
            (shape, Pose { translation: (a + b) * 0.5, rotation: Quat::IDENTITY })
        }
        ShapeName::Box => {
            let c = point(i, "center", required(i, "center", t.center, "[x, y, z] in metres")?)?;
            let e = required(i, "half_extents", t.half_extents, "[x, y, z] in metres")?;
            let e = Vec3::new(
                length(i, "half_extents", e[0])?,
                length(i, "half_extents", e[1])?,
                length(i, "half_extents", e[2])?,
            );
            (Shape::Box { half_extents: e }, Pose::from_degrees(c, rotation(i, t.rotation)?))
        }
        ShapeName::Mesh => {
            let path = t.path.as_deref().ok_or_else(|| invalid(i, "path", "is missing: a mesh needs path"))?;
            let scale = t.scale.unwrap_or(1.0);
            if !(scale.is_finite() && (MIN_EXTENT..=MAX_EXTENT).contains(&scale)) {
                return Err(invalid(i, "scale", format!("{scale:e} is not allowed: 1e-6 <= scale <= 1e6")));
            }
            let offset = point(i, "offset", t.offset.unwrap_or([0.0; 3]))?;
            let (vertices, triangles) = read_obj(path).map_err(|e| match e {
                SceneErrorKind::Obj { path, message } => invalid(i, "path", format!("{path}: {message}")),
                other => other,
            })?;
            let vertices: Vec<Vec3> = vertices.into_iter().map(|v| v * scale).collect();
            if let Some(v) = vertices.iter().find(|v| !(v.is_finite() && v.abs().max_element() <= MAX_EXTENT)) {
                return Err(invalid(i, "path", format!("{path}: vertex {v} is beyond ±1e6 m after scaling")));
            }
            let mesh = MeshShape::new(vertices, triangles).map_err(|e| invalid(i, "path", format!("{path}: {e}")))?;
            (Shape::Mesh(Arc::new(mesh)), Pose::from_degrees(offset, rotation(i, t.rotation)?))
        }
    };
    if let Some(mu) = t.friction {
        crate::sim::params::check_friction("friction", mu)
            .map_err(|e| invalid(i, "friction", format!("{} is not allowed: {}", e.value, e.allowed)))?;
    }
    let moving = t.velocity.is_some() || t.angular_velocity.is_some();
    if moving && !t.keyframes.is_empty() {
        return Err(invalid(i, "keyframes", "a collider moves by velocity/angular_velocity or by keyframes, not both"));
    }
    if t.looped.is_some() && t.keyframes.is_empty() {
        return Err(invalid(i, "loop", "applies to a keyframed path; give [[collider.keyframes]]"));
    }
    let motion = if moving {
        Motion::Moving {
            velocity: bounded(i, "velocity", t.velocity, MAX_SPEED, "m/s")?,
            angular_velocity: bounded(i, "angular_velocity", t.angular_velocity, MAX_SPIN, "rad/s")?,
        }
    } else if !t.keyframes.is_empty() {
        let mut keys = Vec::with_capacity(t.keyframes.len());
        for (k, key) in t.keyframes.iter().enumerate() {
            let name = format!("keyframes[{k}]");
            if !(key.time.is_finite() && key.time >= 0.0) {
                return Err(invalid(i, &format!("{name}.time"), format!("{} is not allowed: seconds >= 0", key.time)));
            }
            if keys.last().is_some_and(|p: &Keyframe| key.time <= p.time) {
                return Err(invalid(i, &format!("{name}.time"), "must be later than the key before it"));
            }
            let translation = match key.center {
                Some(c) => point(i, &format!("{name}.center"), c)?,
                None => pose.translation,
            };
            let pose = match key.rotation {
                Some(r) => {
                    Pose::from_degrees(translation, bounded(i, &format!("{name}.rotation"), Some(r), 1e6, "degrees")?)
                }
                None => Pose { translation, rotation: pose.rotation },
            };
            keys.push(Keyframe { time: key.time, pose });
        }
        Motion::Keyframes { keys, looped: t.looped.unwrap_or(false) }
    } else {
        Motion::Fixed
    };
    Ok(Collider { shape, pose, motion, friction: t.friction })
}

fn shape_word(s: ShapeName) -> &'static str {
    match s {
        ShapeName::Plane => "plane",
        ShapeName::Sphere => "sphere",
        ShapeName::Capsule => "capsule",
        ShapeName::Box => "box",
        ShapeName::Mesh => "mesh",
    }
}
