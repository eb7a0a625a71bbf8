//! The grid a mesh's vertex order implies.
//!
//! A mesh built by [`crate::sim::Grid`] knows its columns and rows. A
//! triangle mesh that is a sheet of C × R vertices numbered row by row (a
//! modelling tool's subdivided plane, exported to OBJ; a generated sheet)
//! has the same structure without saying so: every bar joins particle
//! `i = r·C + c` to one a few columns and rows away. This finds such a C
//! from the bars alone, so that the lane layout can run the sheet as it
//! runs a grid. [`BarTable`] then holds every bar by its cell and offset,
//! for [`super::GridLayout::new`] to check that each of its operations'
//! eight lanes finds a bar of one kind and rest length in every lane, or
//! none in any.

use super::{Offset, Orientation};
use crate::sim::mesh::{ClothMesh, GridShape};

/// C and R such that every bar of `mesh` is one of the lane layout's
/// offsets between `(i mod C, i div C)` and `(j mod C, j div C)`, or `None`.
///
/// The candidates for C are the neighbours of particle 0 (a corner: its
/// vertical bar reaches particle C), and the numbers next to them; each is
/// checked against every bar, so the cost is a few passes over the bars.
pub(super) fn implied_shape(mesh: &ClothMesh) -> Option<GridShape> {
    let n = mesh.positions().len();
    let bars = mesh.bars();
    let mut candidates: Vec<usize> = bars
        .iter()
        .filter_map(|b| match (b.a, b.b) {
            (0, j) | (j, 0) => Some(j as usize),
            _ => None,
        })
        .flat_map(|j| [j.saturating_sub(1), j, j + 1])
        .filter(|&c| c >= 2 && n.is_multiple_of(c) && n / c >= 2)
        .collect();
    candidates.sort_unstable();
    candidates.dedup();
    candidates
        .into_iter()
        .find(|&columns| fits(bars.iter().map(|b| (b.a as usize, b.b as usize)), columns))
        .map(|columns| GridShape { columns: columns as u32, rows: (n / columns) as u32 })
}

/// Whether every pair is one of the offsets on a grid of `columns`.
fn fits(mut pairs: impl Iterator<Item = (usize, usize)>, columns: usize) -> bool {
    let cell = |i: usize| ((i % columns) as isize, (i / columns) as isize);
    pairs.all(|(a, b)| {
        let ((ca, ra), (cb, rb)) = (cell(a), cell(b));
        Offset::from_delta(cb - ca, rb - ra).is_some()
    })
}

/// Every bar of a grid mesh by the cell of its first end and its offset
/// (in the layout's orientation), and each class's one rest length when
/// all its bars share it.
pub(super) struct BarTable {
    columns: usize,
    /// Rest length of the bar at `(cell · CLASSES + class)`; NaN: no bar.
    rest: Vec<f32>,
    /// Its [`crate::sim::BarKind::index`].
    kind: Vec<u8>,
    /// The mean rest length of each class whose bars are all within 10⁻⁵
    /// of one another (a grid's, up to rounding), which every bar of that
    /// class is projected with.
    class_rest: [Option<f32>; CLASSES],
}

const CLASSES: usize = Offset::ALL.len();

impl BarTable {
    /// `None` when a bar is none of the offsets, or two bars share a cell
    /// and an offset.
    pub(super) fn new(mesh: &ClothMesh, orientation: &Orientation) -> Option<Self> {
        let (columns, rows) = orientation.size();
        let mut table = BarTable {
            columns,
            rest: vec![f32::NAN; columns * rows * CLASSES],
            kind: vec![0; columns * rows * CLASSES],
            class_rest: [None; CLASSES],
        };
        // Per class: sum, least, most, count.
        let mut stats = [(0.0f64, f32::INFINITY, 0.0f32, 0usize); CLASSES];
        for bar in mesh.bars() {
            let (ca, ra) = orientation.cell(bar.a as usize);
            let (cb, rb) = orientation.cell(bar.b as usize);
            let offset = Offset::from_delta(cb as isize - ca as isize, rb as isize - ra as isize)?;
            // The first end: the upper one, or the left one on a row.
            let (c, r) = if (rb, cb) < (ra, ca) { (cb, rb) } else { (ca, ra) };
            let class = Offset::ALL.iter().position(|&o| o == offset)?;
            let at = (r * columns + c) * CLASSES + class;
            if !table.rest[at].is_nan() {
                return None;
            }
            let l = bar.rest_length;
            table.rest[at] = l;
            table.kind[at] = bar.kind.index() as u8;
            let s = &mut stats[class];
            *s = (s.0 + f64::from(l), s.1.min(l), s.2.max(l), s.3 + 1);
        }
        for (class_rest, (sum, lo, hi, count)) in table.class_rest.iter_mut().zip(stats) {
            if count > 0 && hi - lo <= 1e-5 * hi {
                *class_rest = Some((sum / count as f64) as f32);
            }
        }
        Some(table)
    }

    /// Columns of the grid (in the layout's orientation).
    pub(super) fn columns(&self) -> usize {
        self.columns
    }

    /// The kind and rest length of the bar of `offset` from cell `(c, r)`.
    pub(super) fn get(&self, c: usize, r: usize, offset: Offset) -> Option<(u8, f32)> {
        let class = Offset::ALL.iter().position(|&o| o == offset)?;
        let at = (r * self.columns + c) * CLASSES + class;
        let rest = self.rest[at];
        (!rest.is_nan()).then(|| (self.kind[at], self.class_rest[class].unwrap_or(rest)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::fast::grid::tests::{ALTERNATE, DOWN, UP, triangle_sheet};
    use crate::sim::mesh::{Grid, Pins};

    #[test]
    fn a_sheet_numbered_row_by_row_is_found_and_others_are_not() {
        for (flip, diagonals) in [(DOWN, "down"), (UP, "up"), (ALTERNATE, "alternating")] {
            // 40 × 25 and its transpose: C is found from either side.
            for (c, r) in [(40, 25), (25, 40), (17, 3)] {
                let shape = implied_shape(&triangle_sheet(c, r, flip));
                assert_eq!(shape, Some(GridShape { columns: c, rows: r }), "{c} × {r}, diagonals {diagonals}");
            }
        }
        // A grid that says its shape is found from its bars too (the same C).
        let grid = Grid { columns: 20, rows: 30, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
        assert_eq!(implied_shape(&grid), grid.grid());
        // The same sheet with two particles swapped: a bar now jumps across
        // the sheet, and no C makes it a grid.
        let sheet = triangle_sheet(40, 25, DOWN);
        let swap = |i: u32| match i {
            41 => 530,
            530 => 41,
            i => i,
        };
        let mut positions = sheet.positions().to_vec();
        positions.swap(41, 530);
        let triangles = sheet.triangles().iter().map(|t| t.map(swap)).collect();
        let swapped = ClothMesh::from_triangles(positions, triangles, &[0, 39], None).unwrap();
        assert_eq!(implied_shape(&swapped), None);
    }
}
