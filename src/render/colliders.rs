//! Colliders as triangles for drawing: each shape tessellated in its own
//! frame and placed at its pose, with flat or smooth normals.

use glam::Vec3;

use super::geometry::SurfaceVertex;
use crate::sim::{Collider, Pose, Shape};

/// Segments around a sphere or capsule.
const AROUND: u32 = 32;
/// Rings from pole to pole of a sphere.
const RINGS: u32 = 16;

/// Whether a collider is a horizontal plane facing up: drawn as the ground.
pub fn ground_height(collider: &Collider, pose: &Pose) -> Option<f32> {
    match collider.shape {
        Shape::Plane { normal } if (pose.rotation * normal).y > 0.999 => Some(pose.translation.y),
        _ => None,
    }
}

/// Appends the triangles of `collider` at `pose` to `vertices` and
/// `indices`. Planes other than the ground are drawn as a square of side
/// `2 × plane_radius` around their point.
pub fn tessellate(
    collider: &Collider,
    pose: &Pose,
    plane_radius: f32,
    vertices: &mut Vec<SurfaceVertex>,
    indices: &mut Vec<u32>,
) {
    let base = vertices.len() as u32;
    let mut local: Vec<(Vec3, Vec3)> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    match &collider.shape {
        Shape::Plane { normal } => {
            let (u, v) = normal.any_orthonormal_pair();
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                local.push(((u * a + v * b) * plane_radius, *normal));
            }
            tris.extend([[0, 1, 2], [0, 2, 3]]);
        }
        Shape::Sphere { radius } => sphere(Vec3::ZERO, *radius, None, &mut local, &mut tris),
        Shape::Capsule { half_axis, radius } => {
            let axis = half_axis.normalize_or(Vec3::Y);
            sphere(*half_axis, *radius, Some(axis), &mut local, &mut tris);
            sphere(-*half_axis, *radius, Some(-axis), &mut local, &mut tris);
            // The cylinder between the two half spheres.
            let (u, v) = axis.any_orthonormal_pair();
            let start = local.len() as u32;
            for k in 0..=AROUND {
                let a = k as f32 / AROUND as f32 * std::f32::consts::TAU;
                let n = u * a.cos() + v * a.sin();
                local.push((*half_axis + n * *radius, n));
                local.push((-*half_axis + n * *radius, n));
            }
            for k in 0..AROUND {
                let i = start + 2 * k;
                tris.extend([[i, i + 1, i + 2], [i + 1, i + 3, i + 2]]);
            }
        }
        Shape::Box { half_extents } => {
            for axis in 0..3 {
                for sign in [-1.0f32, 1.0] {
                    let mut n = Vec3::ZERO;
                    n[axis] = sign;
                    let (u, v) = (Vec3::from_array(unit((axis + 1) % 3)), Vec3::from_array(unit((axis + 2) % 3)));
                    let start = local.len() as u32;
                    for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                        local.push(((n + u * a + v * b) * *half_extents, n));
                    }
                    tris.extend([[start, start + 1, start + 2], [start, start + 2, start + 3]]);
                }
            }
        }
        Shape::Mesh(mesh) => {
            // Flat shading: three vertices per triangle.
            let v = mesh.vertices();
            for t in mesh.triangles() {
                let (a, b, c) = (v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]);
                let n = (b - a).cross(c - a).normalize_or(Vec3::Y);
                let start = local.len() as u32;
                local.extend([(a, n), (b, n), (c, n)]);
                tris.push([start, start + 1, start + 2]);
            }
        }
    }
    vertices.extend(
        local.iter().map(|&(p, n)| SurfaceVertex {
            position: pose.apply(p).to_array(),
            normal: (pose.rotation * n).to_array(),
        }),
    );
    indices.extend(tris.iter().flat_map(|t| t.map(|i| i + base)));
}

fn unit(axis: usize) -> [f32; 3] {
    let mut e = [0.0; 3];
    e[axis] = 1.0;
    e
}

/// A UV sphere about `centre`, or with `half = Some(axis)` the half of it
/// on the `axis` side (a capsule's cap).
fn sphere(centre: Vec3, radius: f32, half: Option<Vec3>, local: &mut Vec<(Vec3, Vec3)>, tris: &mut Vec<[u32; 3]>) {
    let pole = half.unwrap_or(Vec3::Y);
    let (u, v) = pole.any_orthonormal_pair();
    let rings = if half.is_some() { RINGS / 2 } else { RINGS };
    let start = local.len() as u32;
    for r in 0..=rings {
        let polar = r as f32 / RINGS as f32 * std::f32::consts::PI;
        for k in 0..=AROUND {
            let a = k as f32 / AROUND as f32 * std::f32::consts::TAU;
            let n = pole * polar.cos() + (u * a.cos() + v * a.sin()) * polar.sin();
            local.push((centre + n * radius, n));
        }
    }
    let row = AROUND + 1;
    for r in 0..rings {
        for k in 0..AROUND {
            let i = start + r * row + k;
            tris.extend([[i, i + row, i + 1], [i + 1, i + row, i + row + 1]]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tessellated_points_lie_on_the_surface() {
        // Every vertex of each shape is on its surface (φ = 0 to rounding),
        // placed at the pose.
        let pose = Pose { translation: Vec3::new(1.0, 2.0, 3.0), ..Pose::default() };
        for shape in [
            Shape::Sphere { radius: 0.5 },
            Shape::Capsule { half_axis: Vec3::new(0.3, 0.1, 0.0), radius: 0.2 },
            Shape::Box { half_extents: Vec3::new(0.4, 0.1, 0.2) },
        ] {
            let c = Collider::fixed(shape, pose);
            let (mut v, mut i) = (Vec::new(), Vec::new());
            tessellate(&c, &pose, 1.0, &mut v, &mut i);
            assert!(!i.is_empty() && i.len() % 3 == 0 && i.iter().all(|&k| (k as usize) < v.len()));
            for p in &v {
                let d = c.shape.proximity(pose.inverse_apply(Vec3::from_array(p.position))).unwrap().distance;
                assert!(d.abs() < 1e-5, "{:?}: vertex {:?} is {d} m off", c.shape, p.position);
            }
        }
    }
}
