//! [`ClothMesh::from_triangles`]: a triangle mesh (an OBJ file). A
//! structural bar on every edge; a bend bar across every edge shared by
//! exactly two triangles, joining the two vertices opposite it (for
//! triangles (a, b, c) and (b, a, d) the bar c–d), whose rest length is
//! their distance in the given shape.

use rustc_hash::{FxHashMap, FxHashSet};

use glam::Vec3;

use super::{BarKind, ClothMesh, MeshError, MeshParts, check_index};

impl ClothMesh {
    /// A triangle mesh: a structural bar on every edge and a bend bar across
    /// every edge shared by exactly two triangles, between the two vertices
    /// opposite it. Bend bars that would duplicate another bar or have zero
    /// length (a mesh folded flat onto itself) are left out.
    pub fn from_triangles(
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        fixed: &[u64],
        velocities: Option<Vec<Vec3>>,
    ) -> Result<Self, MeshError> {
        let n = positions.len();
        if n == 0 {
            return Err(MeshError::Empty);
        }
        let mut fixed_flags = vec![false; n];
        for (k, &i) in fixed.iter().enumerate() {
            let i = check_index(|| format!("pinned[{k}]"), i, n)?;
            fixed_flags[i as usize] = true;
        }
        for (i, t) in triangles.iter().enumerate() {
            for &v in t {
                check_index(|| format!("triangle {i}"), v.into(), n)?;
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(MeshError::DegenerateTriangle { index: i, vertices: *t });
            }
        }
        // Every edge once, in the order triangles first list it, as an
        // undirected key; per edge, the first two vertices opposite it (in
        // the order triangles list them) and how many there are. One table
        // entry an edge, no list each: a 100 000-vertex mesh has 300 000.
        let key = |a: u32, b: u32| u64::from(a.min(b)) << 32 | u64::from(a.max(b));
        let mut index: FxHashMap<u64, u32> = FxHashMap::default();
        index.reserve(triangles.len() * 3 / 2 + 3);
        let mut edges: Vec<(u32, u32)> = Vec::with_capacity(triangles.len() * 3 / 2 + 3);
        let mut opposite: Vec<([u32; 2], u32)> = Vec::with_capacity(edges.capacity());
        for t in &triangles {
            for k in 0..3 {
                let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let e = *index.entry(key(a, b)).or_insert_with(|| {
                    edges.push((a, b));
                    opposite.push(([0; 2], 0));
                    (edges.len() - 1) as u32
                });
                let (first, count) = &mut opposite[e as usize];
                if let Some(slot) = first.get_mut(*count as usize) {
                    *slot = c;
                }
                *count += 1;
            }
        }
        // A bend bar across every edge of exactly two triangles, unless it
        // joins a vertex to itself or to one at the same place, or repeats
        // an edge or an earlier bend bar.
        let mut bars: Vec<(u32, u32, BarKind)> = edges.iter().map(|&(a, b)| (a, b, BarKind::Structural)).collect();
        let mut bends: FxHashSet<u64> = FxHashSet::default();
        for &([c, d], count) in &opposite {
            if count == 2 && c != d {
                let far_enough = positions[c as usize].distance(positions[d as usize]) > 0.0;
                if far_enough && !index.contains_key(&key(c, d)) && bends.insert(key(c, d)) {
                    bars.push((c, d, BarKind::Bend));
                }
            }
        }
        Self::new(MeshParts {
            positions,
            velocities: velocities.unwrap_or_default(),
            fixed: fixed_flags,
            bars,
            rest_lengths: Vec::new(),
            triangles,
            grid: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangles_give_edge_bars_and_one_bend_bar_per_interior_edge() {
        // Two triangles sharing the edge 1–2: a unit square split on its diagonal.
        let pos = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
        let mesh = ClothMesh::from_triangles(pos, vec![[0, 1, 2], [2, 1, 3]], &[], None).unwrap();
        let structural = mesh.bars().iter().filter(|b| b.kind == BarKind::Structural).count();
        let bend: Vec<_> = mesh.bars().iter().filter(|b| b.kind == BarKind::Bend).collect();
        assert_eq!(structural, 5);
        assert_eq!(bend.len(), 1);
        assert_eq!((bend[0].a.min(bend[0].b), bend[0].a.max(bend[0].b)), (0, 3));
        assert!((bend[0].rest_length - 2f32.sqrt()).abs() < 1e-6);
        let err = ClothMesh::from_triangles(vec![Vec3::ZERO, Vec3::X], vec![[0, 1, 1]], &[], None);
        assert!(matches!(err, Err(MeshError::IndexOutOfRange { .. }) | Err(MeshError::DegenerateTriangle { .. })));
    }

    #[test]
    fn bend_bars_skip_shared_edges_of_three_triangles_repeats_and_edges() {
        let bars = |mesh: &ClothMesh, kind| -> Vec<(u32, u32)> {
            mesh.bars().iter().filter(|b| b.kind == kind).map(|b| (b.a, b.b)).collect()
        };
        let at = |n: usize| (0..n).map(|i| Vec3::new(i as f32, (i * i) as f32 * 0.1, 0.0)).collect::<Vec<_>>();
        // Edge 0–1 in three triangles: no bend bar across it; the other
        // edges are in one triangle each.
        let fan = ClothMesh::from_triangles(at(5), vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]], &[], None).unwrap();
        let edges = vec![(0, 1), (1, 2), (2, 0), (0, 3), (3, 1), (1, 4), (4, 0)];
        assert_eq!((bars(&fan, BarKind::Structural), bars(&fan, BarKind::Bend)), (edges, vec![]));
        // A closed tetrahedron: every edge in two triangles, and every bend
        // bar across one would repeat the opposite edge.
        let tetrahedron = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]];
        let closed = ClothMesh::from_triangles(at(4), tetrahedron.to_vec(), &[], None).unwrap();
        assert_eq!((bars(&closed, BarKind::Structural).len(), bars(&closed, BarKind::Bend)), (6, vec![]));
        // Two edges each with 3 and 4 opposite (0–1 and 1–2), two with 0 and
        // 2 (1–3 and 1–4): one bend bar each, in the order of the edges
        // that first give them, ends as the triangles list them.
        let wings = vec![[0, 1, 3], [1, 0, 4], [1, 2, 3], [2, 1, 4]];
        let mesh = ClothMesh::from_triangles(at(5), wings, &[], None).unwrap();
        let edges = vec![(0, 1), (1, 3), (3, 0), (0, 4), (4, 1), (1, 2), (2, 3), (4, 2)];
        assert_eq!((bars(&mesh, BarKind::Structural), bars(&mesh, BarKind::Bend)), (edges, vec![(3, 4), (0, 2)]));
    }
}
