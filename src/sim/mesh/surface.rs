//! The cloth as a surface: vertex normals and texture coordinates, for the
//! renderer and for export.
//!
//! A vertex normal is the area-weighted mean of the normals of the
//! triangles that meet at the vertex:
//!
//! ```text
//! n_i = normalise( Σ_{t ∋ i} (x_b − x_a) × (x_c − x_a) )
//! ```
//!
//! (the cross product's length is twice the triangle's area, so larger
//! triangles weigh more).

use glam::{Vec2, Vec3};

use super::ClothMesh;

/// Area-weighted vertex normals of a triangle mesh, written into `normals`
/// (resized to `positions.len()`); vertices on no triangle, or whose
/// triangles have no area, get +y.
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]], normals: &mut Vec<Vec3>) {
    normals.clear();
    normals.resize(positions.len(), Vec3::ZERO);
    for &[a, b, c] in triangles {
        let (a, b, c) = (a as usize, b as usize, c as usize);
        let n = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        normals[a] += n;
        normals[b] += n;
        normals[c] += n;
    }
    for n in normals.iter_mut() {
        *n = n.normalize_or(Vec3::Y);
    }
}

/// Texture coordinates from the rest shape, one (u, v) in [0, 1]² per
/// particle.
///
/// A grid's particle (column c, row r) of C × R gets (c/(C−1), r/(R−1)): the
/// texture spans the cloth whatever its spacing. Any other mesh is projected
/// onto the plane of its bounding box's two longest sides, both scaled by
/// the longer one, so the texture keeps the cloth's proportions (a flat
/// sheet maps without distortion; a curved garment as its silhouette).
pub fn texture_coordinates(mesh: &ClothMesh) -> Vec<Vec2> {
    if let Some(grid) = mesh.grid() {
        let along = |i: u32, n: u32| if n > 1 { i as f32 / (n - 1) as f32 } else { 0.0 };
        return (0..grid.rows)
            .flat_map(|r| (0..grid.columns).map(move |c| Vec2::new(along(c, grid.columns), along(r, grid.rows))))
            .collect();
    }
    let (min, max) = mesh.bounds();
    let extent = max - min;
    // The two longest axes of the box, in order.
    let mut axes = [0usize, 1, 2];
    axes.sort_by(|&i, &j| extent[j].total_cmp(&extent[i]));
    let (u_axis, v_axis) = (axes[0], axes[1]);
    let scale = if extent[u_axis] > 0.0 { 1.0 / extent[u_axis] } else { 0.0 };
    mesh.positions()
        .iter()
        .map(|p| Vec2::new((p[u_axis] - min[u_axis]) * scale, (p[v_axis] - min[v_axis]) * scale))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::mesh::{Grid, GridPlane, Pins};

    #[test]
    fn a_flat_square_has_one_normal() {
        // Two triangles of the unit square in the xz plane, wound so that
        // (b − a) × (c − a) points along +y: every vertex's normal is +y.
        let p = [Vec3::ZERO, Vec3::Z, Vec3::new(1.0, 0.0, 1.0), Vec3::X];
        let mut n = Vec::new();
        vertex_normals(&p, &[[0, 1, 2], [0, 2, 3]], &mut n);
        for v in &n {
            assert!(v.abs_diff_eq(Vec3::Y, 1e-6), "{v}");
        }
        // A vertex on no triangle gets +y too; the reversed winding −y.
        vertex_normals(&p, &[[0, 2, 1]], &mut n);
        assert!(n[0].abs_diff_eq(-Vec3::Y, 1e-6) && n[3] == Vec3::Y);
    }

    #[test]
    fn grid_coordinates_span_the_unit_square() {
        let mesh =
            Grid { columns: 3, rows: 2, spacing: 0.5, plane: GridPlane::Vertical, pins: Pins::None, ..Grid::default() }
                .build()
                .unwrap();
        let uv = texture_coordinates(&mesh);
        assert_eq!(uv.len(), 6);
        assert_eq!((uv[0], uv[1], uv[2], uv[5]), (Vec2::ZERO, Vec2::new(0.5, 0.0), Vec2::X, Vec2::ONE));
    }

    #[test]
    fn other_meshes_keep_their_proportions() {
        // A 2 m × 1 m triangle pair in the xy plane: u along x over [0, 1],
        // v along y over [0, 0.5] (both scaled by the longer side).
        let p = vec![Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(2.0, 1.0, 0.0), Vec3::Y];
        let mesh = ClothMesh::from_triangles(p, vec![[0, 1, 2], [0, 2, 3]], &[], None).unwrap();
        let uv = texture_coordinates(&mesh);
        assert_eq!(uv, vec![Vec2::ZERO, Vec2::X, Vec2::new(1.0, 0.5), Vec2::new(0.0, 0.5)]);
    }
}
