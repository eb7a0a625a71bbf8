//! [`ClothMesh::from_adjacency`]: the seed's generic form, a list of the
//! particles each particle is barred to.

use rustc_hash::FxHashSet;

use glam::Vec3;

use super::{BarKind, ClothMesh, MeshError, MeshParts, check_index};

impl ClothMesh {
    /// The seed's generic form: particle positions, the indices of the fixed
    /// ones, and for every particle the list of particles it is barred to.
    ///
    /// A bar may be listed from one end or from both (`adjacency[i]` holds `j`
    /// and `adjacency[j]` holds `i`); it is one bar either way, created when it
    /// is first met scanning particles in order. Listing `j` twice in the same
    /// `adjacency[i]` is a [`MeshError::DuplicateBar`].
    pub fn from_adjacency(
        positions: Vec<Vec3>,
        fixed: &[u64],
        adjacency: &[Vec<u64>],
        velocities: Option<Vec<Vec3>>,
    ) -> Result<Self, MeshError> {
        let n = positions.len();
        if n == 0 {
            return Err(MeshError::Empty);
        }
        if adjacency.len() != n {
            return Err(MeshError::WrongLength { what: "adjacency", got: adjacency.len(), expected: n });
        }
        let mut fixed_flags = vec![false; n];
        for (k, &i) in fixed.iter().enumerate() {
            let i = check_index(|| format!("fixed[{k}]"), i, n)?;
            fixed_flags[i as usize] = true;
        }
        let mut bars = Vec::new();
        let mut seen: FxHashSet<(u32, u32)> = FxHashSet::default();
        let mut in_this_list: FxHashSet<u32> = FxHashSet::default();
        for (i, list) in adjacency.iter().enumerate() {
            in_this_list.clear();
            for &j in list {
                let j = check_index(|| format!("adjacency[{i}]"), j, n)?;
                let i = i as u32;
                if i == j {
                    return Err(MeshError::SelfBar { particle: i });
                }
                if !in_this_list.insert(j) {
                    return Err(MeshError::DuplicateBar { a: i, b: j });
                }
                if seen.insert((i.min(j), i.max(j))) {
                    bars.push((i, j, BarKind::Structural));
                }
            }
        }
        Self::new(MeshParts {
            positions,
            velocities: velocities.unwrap_or_default(),
            fixed: fixed_flags,
            bars,
            rest_lengths: Vec::new(),
            triangles: Vec::new(),
            grid: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adjacency_listed_from_both_ends_is_one_bar() {
        let pos = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let mesh = ClothMesh::from_adjacency(pos, &[0], &[vec![1, 2], vec![0], vec![0]], None).unwrap();
        assert_eq!(mesh.bars().len(), 2);
        assert_eq!((mesh.bars()[0].a, mesh.bars()[0].b), (0, 1));
        assert_eq!(mesh.fixed(), &[true, false, false]);
    }

    #[test]
    fn adjacency_errors() {
        let pos = || vec![Vec3::ZERO, Vec3::X];
        let e = |r: Result<ClothMesh, MeshError>| r.unwrap_err();
        assert!(matches!(
            e(ClothMesh::from_adjacency(pos(), &[], &[vec![5], vec![]], None)),
            MeshError::IndexOutOfRange { index: 5, .. }
        ));
        assert!(matches!(
            e(ClothMesh::from_adjacency(pos(), &[], &[vec![0], vec![]], None)),
            MeshError::SelfBar { particle: 0 }
        ));
        assert!(matches!(
            e(ClothMesh::from_adjacency(pos(), &[], &[vec![1, 1], vec![]], None)),
            MeshError::DuplicateBar { .. }
        ));
        assert!(matches!(
            e(ClothMesh::from_adjacency(pos(), &[7], &[vec![1], vec![]], None)),
            MeshError::IndexOutOfRange { .. }
        ));
        assert!(matches!(e(ClothMesh::from_adjacency(pos(), &[], &[vec![1]], None)), MeshError::WrongLength { .. }));
        assert!(matches!(e(ClothMesh::from_adjacency(vec![], &[], &[], None)), MeshError::Empty));
        let same = vec![Vec3::ONE, Vec3::ONE];
        assert!(matches!(
            e(ClothMesh::from_adjacency(same, &[], &[vec![1], vec![]], None)),
            MeshError::ShortBar { .. }
        ));
        let nan = vec![Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0)];
        assert!(matches!(
            e(ClothMesh::from_adjacency(nan, &[], &[vec![1], vec![]], None)),
            MeshError::BadCoordinate { .. }
        ));
        let v = Some(vec![Vec3::ZERO]);
        assert!(matches!(
            e(ClothMesh::from_adjacency(pos(), &[], &[vec![1], vec![]], v)),
            MeshError::WrongLength { .. }
        ));
    }
}
