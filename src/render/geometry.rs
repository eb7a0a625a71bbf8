//! What the renderer computes on the CPU: per-scene data (material
//! coordinates, wireframe edges, the checker's cell, where the ground goes)
//! and per-frame data (normals, strain per vertex, bar and particle instances).
//!
//! Everything here is plain data in the layouts the shaders read, so it is
//! tested without a GPU.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use crate::sim::{Bar, BarKind, ClothMesh};

/// A surface vertex as `surface.wgsl` reads it from the dynamic buffer.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SurfaceVertex {
    /// World position, metres.
    pub position: [f32; 3],
    /// Unit normal of the front side (area-weighted mean of the triangles').
    pub normal: [f32; 3],
}

/// One bar as `lines.wgsl` reads it: both ends, its strain and its kind.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BarInstance {
    /// First end, metres.
    pub a: [f32; 3],
    /// |len − rest| / rest.
    pub strain: f32,
    /// Second end, metres.
    pub b: [f32; 3],
    /// 0 for structural, 1 for bend.
    pub kind: f32,
}

/// One particle as `points.wgsl` reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PointInstance {
    /// World position, metres.
    pub position: [f32; 3],
    /// Bit 0: fixed; bit 1: grabbed or hovered.
    pub flags: u32,
}

/// [`PointInstance::flags`] bit of a fixed particle.
pub const POINT_FIXED: u32 = 1;
/// [`PointInstance::flags`] bit of the particle under the mouse or held.
pub const POINT_HIGHLIGHT: u32 = 2;

/// Where the ground goes and how its grid is spaced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    /// Height of the ground plane, metres.
    pub height: f32,
    /// Centre of the visible square, (x, z), metres.
    pub centre: Vec2,
    /// Distance between major grid lines, metres (a power of ten).
    pub major_spacing: f32,
    /// Half the side of the visible square, metres; the grid fades out
    /// towards its edge.
    pub radius: f32,
}

/// The per-scene data derived from a mesh, computed once when a scene loads.
#[derive(Clone, Debug)]
pub struct MeshLayout {
    /// Rest position of every particle in the cloth's own plane, metres.
    pub material: Vec<[f32; 2]>,
    /// Every triangle edge once, for the wireframe.
    pub edges: Vec<[u32; 2]>,
    /// Side of a checker square, metres: a whole number of bar lengths,
    /// about sixteen squares across the cloth.
    pub checker_cell: f32,
    /// Where the ground goes.
    pub ground: Ground,
    /// Radius around the cloth within which everything drawn lies (for the
    /// camera's depth range).
    pub world_radius: f32,
}

impl MeshLayout {
    /// Derives the layout of `mesh`.
    pub fn new(mesh: &ClothMesh) -> Self {
        let (min, max) = mesh.bounds();
        let extent = (max - min).max_element().max(1e-3);
        let ground = place_ground(mesh, extent);
        let cloth_radius = 0.5 * (max - min).length();
        let centre = 0.5 * (min + max);
        let ground_centre = Vec3::new(ground.centre.x, ground.height, ground.centre.y);
        let world_radius = (cloth_radius + centre.distance(ground_centre)).max(ground.radius * 1.5);
        Self {
            material: material_coordinates(mesh.positions(), min, max),
            edges: triangle_edges(mesh.triangles()),
            checker_cell: checker_cell(mesh.bars(), extent),
            ground,
            world_radius,
        }
    }
}

/// Projects rest positions onto the two axes along which the mesh's bounds
/// are widest: the cloth's own plane for a flat cloth.
pub fn material_coordinates(positions: &[Vec3], min: Vec3, max: Vec3) -> Vec<[f32; 2]> {
    let size = max - min;
    // The axis of least extent is dropped; x, y, z in order otherwise.
    let drop = if size.x <= size.y && size.x <= size.z {
        0
    } else if size.y <= size.z {
        1
    } else {
        2
    };
    let (u, v) = match drop {
        0 => (2, 1),
        1 => (0, 2),
        _ => (0, 1),
    };
    positions.iter().map(|p| [p[u] - min[u], p[v] - min[v]]).collect()
}

/// Every edge of `triangles` once, as `[low, high]` index pairs, sorted.
pub fn triangle_edges(triangles: &[[u32; 3]]) -> Vec<[u32; 2]> {
    let mut edges: Vec<[u32; 2]> = triangles
        .iter()
        .flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]])
        .map(|[a, b]| if a < b { [a, b] } else { [b, a] })
        .collect();
    edges.sort_unstable();
    edges.dedup();
    edges
}

/// The checker's square: the median structural bar length times a whole
/// number, so that about sixteen squares span the cloth's largest extent
/// and their borders follow the mesh lines of a grid.
pub fn checker_cell(bars: &[Bar], extent: f32) -> f32 {
    let mut lengths: Vec<f32> = bars.iter().filter(|b| b.kind == BarKind::Structural).map(|b| b.rest_length).collect();
    if lengths.is_empty() {
        return extent / 16.0;
    }
    let mid = lengths.len() / 2;
    let (_, &mut median, _) = lengths.select_nth_unstable_by(mid, f32::total_cmp);
    // Adjacency lists may join diagonal neighbours too; the shortest common
    // length is the edge. Take the smaller of the median and the 10th
    // percentile.
    let tenth = lengths.len() / 10;
    let (_, &mut low, _) = lengths.select_nth_unstable_by(tenth, f32::total_cmp);
    let edge = median.min(low).max(1e-6);
    let per_cell = (extent / (16.0 * edge)).round().max(1.0);
    per_cell * edge
}

/// Puts the ground just below the lowest point the cloth can reach: no
/// particle can hang further below its pins than its distance to the
/// nearest of them (plus a little stretch), and none starts below its rest
/// position. A cloth without pins gets a ground half its size below it.
pub fn place_ground(mesh: &ClothMesh, extent: f32) -> Ground {
    let positions = mesh.positions();
    let (min, max) = mesh.bounds();
    let pins: Vec<Vec3> = positions.iter().zip(mesh.fixed()).filter(|&(_, &f)| f).map(|(&p, _)| p).collect();
    // Sample at most a few hundred pins and particles: the bound is a
    // guide for a floor, not a measurement.
    let pin_step = (pins.len() / 256).max(1);
    let particle_step = (positions.len() / 4096).max(1);
    let mut lowest = min.y;
    if pins.is_empty() {
        lowest -= 0.5 * extent;
    } else {
        for p in positions.iter().step_by(particle_step) {
            // The highest point this particle is held at by any pin.
            let held =
                pins.iter().step_by(pin_step).map(|q| q.y - 1.05 * p.distance(*q)).fold(f32::NEG_INFINITY, f32::max);
            lowest = lowest.min(held);
        }
    }
    let height = lowest - 0.04 * extent;
    let centre = 0.5 * (min + max);
    let major_spacing = 10f32.powf((extent / 2.0).log10().floor());
    Ground { height, centre: Vec2::new(centre.x, centre.z), major_spacing, radius: 3.0 * extent.max(1e-3) }
}

pub use crate::sim::mesh::surface::vertex_normals;

/// Positions and normals interleaved for the surface's dynamic buffer.
pub fn surface_vertices(positions: &[Vec3], normals: &[Vec3], out: &mut Vec<SurfaceVertex>) {
    out.clear();
    out.extend(
        positions.iter().zip(normals).map(|(p, n)| SurfaceVertex { position: p.to_array(), normal: n.to_array() }),
    );
}

/// The strain of one bar at `positions`.
pub fn bar_strain(positions: &[Vec3], bar: &Bar) -> f32 {
    let len = positions[bar.a as usize].distance(positions[bar.b as usize]);
    (len - bar.rest_length).abs() / bar.rest_length
}

/// The strain a vertex shows on the surface: the largest over the bars
/// that meet it and are edges (`is_edge`: [`crate::sim::ClothMesh::is_edge`],
/// a grid's horizontal and vertical bars, the threads' stretch). Bend bars
/// shorten when the cloth folds and a grid's diagonals when it shears,
/// neither of which is stretch.
pub fn vertex_strain(positions: &[Vec3], bars: &[Bar], is_edge: impl Fn(&Bar) -> bool, out: &mut Vec<f32>) {
    out.clear();
    out.resize(positions.len(), 0.0);
    for bar in bars.iter().filter(|b| is_edge(b)) {
        let e = bar_strain(positions, bar);
        let (a, b) = (bar.a as usize, bar.b as usize);
        out[a] = out[a].max(e);
        out[b] = out[b].max(e);
    }
}

/// The bars of the kinds asked for, with their current strain (a grid's
/// shear bars, its diagonals, are drawn with the structural ones).
pub fn bar_instances(positions: &[Vec3], bars: &[Bar], structural: bool, bend: bool, out: &mut Vec<BarInstance>) {
    out.clear();
    let wanted = |b: &&Bar| match b.kind {
        BarKind::Structural | BarKind::Shear => structural,
        BarKind::Bend => bend,
    };
    out.extend(bars.iter().filter(wanted).map(|bar| BarInstance {
        a: positions[bar.a as usize].to_array(),
        strain: bar_strain(positions, bar),
        b: positions[bar.b as usize].to_array(),
        kind: if bar.kind == BarKind::Bend { 1.0 } else { 0.0 },
    }));
}

/// Particle dots: every particle when `all`, otherwise only the fixed ones;
/// the highlighted particle always, and last so that it draws on top.
pub fn point_instances(
    positions: &[Vec3],
    fixed: &[bool],
    all: bool,
    pins: bool,
    highlight: Option<usize>,
    out: &mut Vec<PointInstance>,
) {
    out.clear();
    for (i, (p, &f)) in positions.iter().zip(fixed).enumerate() {
        if Some(i) == highlight || !(all || (pins && f)) {
            continue;
        }
        out.push(PointInstance { position: p.to_array(), flags: if f { POINT_FIXED } else { 0 } });
    }
    if let Some(i) = highlight.filter(|&i| i < positions.len()) {
        let f = if fixed[i] { POINT_FIXED } else { 0 };
        out.push(PointInstance { position: positions[i].to_array(), flags: f | POINT_HIGHLIGHT });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, GridPlane, Pins};

    fn grid(columns: u32, rows: u32, plane: GridPlane) -> ClothMesh {
        Grid { columns, rows, spacing: 0.5, plane, pins: Pins::TopRow, ..Grid::default() }.build().unwrap()
    }

    #[test]
    fn a_flat_grid_has_up_facing_normals_on_its_front() {
        let mesh = grid(4, 3, GridPlane::Horizontal);
        let mut normals = Vec::new();
        vertex_normals(mesh.positions(), mesh.triangles(), &mut normals);
        assert_eq!(normals.len(), 12);
        // Every normal is ±y and all agree: the triangles are wound consistently.
        let first = normals[0];
        assert!((first.y.abs() - 1.0).abs() < 1e-6, "{first}");
        assert!(normals.iter().all(|n| (*n - first).length() < 1e-6));
    }

    #[test]
    fn material_coordinates_span_the_grid_in_its_plane() {
        let mesh = grid(5, 3, GridPlane::Vertical);
        let (min, max) = mesh.bounds();
        let m = material_coordinates(mesh.positions(), min, max);
        // Vertical grid: x across (0..2 m) and y down (0..1 m); z dropped.
        let us: Vec<f32> = m.iter().map(|c| c[0]).collect();
        let vs: Vec<f32> = m.iter().map(|c| c[1]).collect();
        assert_eq!(us.iter().cloned().fold(0.0, f32::max), 2.0);
        assert_eq!(vs.iter().cloned().fold(0.0, f32::max), 1.0);
    }

    #[test]
    fn each_triangle_edge_appears_once() {
        // Two triangles sharing the edge 1–2: five edges.
        let edges = triangle_edges(&[[0, 1, 2], [2, 1, 3]]);
        assert_eq!(edges, vec![[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]);
    }

    #[test]
    fn checker_cell_is_a_whole_number_of_edges() {
        let mesh = grid(20, 30, GridPlane::Vertical); // the seed: 14.5 m tall, 0.5 m edges
        let cell = checker_cell(mesh.bars(), 14.5);
        assert_eq!(cell, 1.0, "two edges per square");
    }

    #[test]
    fn ground_is_below_anything_a_hanging_cloth_can_reach() {
        let mesh = grid(20, 30, GridPlane::Vertical); // top row at 14.5 m, 14.5 m of cloth below it
        let ground = place_ground(&mesh, 14.5);
        assert!(ground.height < 14.5 - 14.5 * 1.04, "{ground:?}");
        assert!(ground.height > -2.0, "not absurdly far: {ground:?}");
        assert_eq!(ground.major_spacing, 1.0);
    }

    #[test]
    fn strain_per_vertex_is_the_largest_of_its_structural_bars() {
        let positions = [Vec3::ZERO, Vec3::new(1.1, 0.0, 0.0), Vec3::new(1.1, 0.9, 0.0)];
        let bars = [
            Bar { a: 0, b: 1, rest_length: 1.0, kind: BarKind::Structural },
            Bar { a: 1, b: 2, rest_length: 1.0, kind: BarKind::Structural },
            Bar { a: 0, b: 2, rest_length: 0.1, kind: BarKind::Bend },
        ];
        let mut s = Vec::new();
        vertex_strain(&positions, &bars, |b| b.kind == BarKind::Structural, &mut s);
        assert!((s[0] - 0.1).abs() < 1e-6 && (s[1] - 0.1).abs() < 1e-6 && (s[2] - 0.1).abs() < 1e-6, "{s:?}");
        let mut inst = Vec::new();
        bar_instances(&positions, &bars, false, true, &mut inst);
        assert_eq!(inst.len(), 1);
        assert_eq!(inst[0].kind, 1.0);
    }

    #[test]
    fn points_show_pins_and_put_the_highlight_last() {
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let fixed = [true, false, false];
        let mut out = Vec::new();
        point_instances(&positions, &fixed, false, true, Some(1), &mut out);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].flags, POINT_FIXED);
        assert_eq!(out[1].flags, POINT_HIGHLIGHT);
        point_instances(&positions, &fixed, true, true, None, &mut out);
        assert_eq!(out.len(), 3);
    }
}
