//! The grid a mesh implies.
//!
//! A mesh built by [`crate::sim::Grid`] knows its columns and rows. A
//! triangle mesh that is a sheet of C × R vertices (a modelling tool's
//! subdivided plane exported to OBJ, a generated sheet) has the same
//! structure without saying so. Numbered row by row, every bar joins
//! particle `i = r·C + c` to one a few columns and rows away, and C is
//! found from the bars alone. Numbered any other way (a mesh optimised for
//! a vertex cache, a shuffled sheet), its triangles still give the grid:
//! each cell's longest edge is its diagonal, the others the grid's lines,
//! and rows follow from one corner. Either way the lane layout can run the
//! sheet as it runs a grid. [`BarTable`] then holds every bar by its cell
//! and offset, for [`super::GridLayout::new`] to check that each of its
//! operations' eight lanes finds a bar of one kind in every lane, or none
//! in any, and to give each lane its rest length.

use super::Offset;
use crate::sim::mesh::{ClothMesh, GridShape};

/// A grid found in a mesh that does not say it is one.
pub(super) struct ImpliedGrid {
    pub(super) shape: GridShape,
    /// The grid index `r·C + c` of each scene particle, when the mesh is not
    /// numbered row by row.
    pub(super) number: Option<Vec<u32>>,
}

/// The grid `mesh` is, numbered row by row ([`row_by_row`]) or in any
/// order ([`from_triangles`]), or `None`.
pub(super) fn implied_grid(mesh: &ClothMesh) -> Option<ImpliedGrid> {
    if let Some(shape) = row_by_row(mesh) {
        return Some(ImpliedGrid { shape, number: None });
    }
    let (shape, number) = from_triangles(mesh)?;
    let fits_all = fits(mesh, shape.columns as usize, |i| number[i as usize] as usize);
    fits_all.then_some(ImpliedGrid { shape, number: Some(number) })
}

/// C and R such that every bar of `mesh` is one of the lane layout's
/// offsets between `(i mod C, i div C)` and `(j mod C, j div C)`, or `None`.
///
/// The candidates for C are the neighbours of particle 0 (a corner: its
/// vertical bar reaches particle C), and the numbers next to them; each is
/// checked against every bar, so the cost is a few passes over the bars.
fn row_by_row(mesh: &ClothMesh) -> Option<GridShape> {
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
        .find(|&columns| fits(mesh, columns, |i| i as usize))
        .map(|columns| GridShape { columns: columns as u32, rows: (n / columns) as u32 })
}

/// Marks an empty place in [`from_triangles`]' lists.
const NONE: u32 = u32::MAX;

/// A triangulated sheet's grid from its triangles, in any numbering: the
/// shape and each particle's grid index, or `None` when the triangles are
/// not two to a cell of one C × R grid.
///
/// Each triangle's longest edge (in the mesh's rest shape) is a cell's
/// diagonal; its other two are grid lines, so every particle has at most
/// four line neighbours. Row 0 runs from the corner of least index (two
/// line neighbours) along the rim (lines in one triangle only) to the next
/// corner. Each particle of a later row is the one line neighbour of the
/// particle above it that is neither beside that one nor above it. Every
/// particle must be placed exactly once; the caller then checks every bar.
fn from_triangles(mesh: &ClothMesh) -> Option<(GridShape, Vec<u32>)> {
    let (n, x) = (mesh.positions().len(), mesh.positions());
    let triangles = mesh.triangles();
    if triangles.is_empty() {
        return None;
    }
    // Grid lines, each with the number of triangles it borders.
    let mut lines: Vec<(u32, u32)> = Vec::with_capacity(2 * triangles.len());
    for t in triangles {
        let edges = [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
        let length = |(a, b): (u32, u32)| x[a as usize].distance_squared(x[b as usize]);
        let longest = (0..3).max_by(|&i, &j| length(edges[i]).total_cmp(&length(edges[j])))?;
        for (k, &(a, b)) in edges.iter().enumerate() {
            if k != longest {
                lines.push((a.min(b), a.max(b)));
            }
        }
    }
    lines.sort_unstable();
    let mut neighbours = vec![[NONE; 4]; n];
    let mut rim = vec![[false; 4]; n];
    let mut start = 0;
    while start < lines.len() {
        let end = start + lines[start..].iter().take_while(|&&l| l == lines[start]).count();
        let (a, b) = lines[start];
        for (from, to) in [(a, b), (b, a)] {
            let slot = neighbours[from as usize].iter().position(|&j| j == NONE)?;
            neighbours[from as usize][slot] = to;
            rim[from as usize][slot] = end - start == 1;
        }
        start = end;
    }
    let degree = |i: u32| neighbours[i as usize].iter().filter(|&&j| j != NONE).count();
    let corner = (0..n as u32).find(|&i| degree(i) == 2)?;
    // Row 0: along the rim from the corner to the next corner.
    let mut rows: Vec<Vec<u32>> = vec![vec![corner]];
    let mut previous = NONE;
    loop {
        let row = &rows[0];
        let here = *row.last()?;
        if row.len() > 1 && degree(here) == 2 {
            break;
        }
        let next = (0..4).find(|&s| {
            let j = neighbours[here as usize][s];
            j != NONE && j != previous && rim[here as usize][s]
        })?;
        previous = here;
        rows[0].push(neighbours[here as usize][next]);
        if rows[0].len() > n {
            return None;
        }
    }
    let columns = rows[0].len();
    let mut placed = vec![false; n];
    for &i in &rows[0] {
        placed[i as usize] = true;
    }
    loop {
        let r = rows.len();
        let (above, beside) = (if r >= 2 { Some(&rows[r - 2]) } else { None }, &rows[r - 1]);
        let below: Vec<Option<u32>> = (0..columns)
            .map(|c| {
                let i = beside[c];
                let known = |j: u32| {
                    (c > 0 && beside[c - 1] == j) || beside.get(c + 1) == Some(&j) || above.is_some_and(|a| a[c] == j)
                };
                let mut down = neighbours[i as usize].iter().copied().filter(|&j| j != NONE && !known(j));
                let first = down.next();
                if down.next().is_some() { Some(NONE) } else { first }
            })
            .collect();
        if below.iter().all(Option::is_none) {
            break;
        }
        let row: Vec<u32> = below.into_iter().collect::<Option<Vec<u32>>>()?;
        for &i in &row {
            if i == NONE || std::mem::replace(&mut placed[i as usize], true) {
                return None;
            }
        }
        rows.push(row);
    }
    if rows.len() < 2 || rows.len() * columns != n {
        return None;
    }
    let mut number = vec![0u32; n];
    for (r, row) in rows.iter().enumerate() {
        for (c, &i) in row.iter().enumerate() {
            number[i as usize] = (r * columns) as u32 + c as u32;
        }
    }
    Some((GridShape { columns: columns as u32, rows: rows.len() as u32 }, number))
}

/// Whether every bar of `mesh` joins two cells one of the offsets apart on
/// a grid of `columns`, particle i being at grid index `number(i)`.
fn fits(mesh: &ClothMesh, columns: usize, number: impl Fn(u32) -> usize) -> bool {
    let cell = |i: u32| ((number(i) % columns) as isize, (number(i) / columns) as isize);
    mesh.bars().iter().all(|b| {
        let ((ca, ra), (cb, rb)) = (cell(b.a), cell(b.b));
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
    /// `cell(i)`: scene particle i's (column, row) in the layout's
    /// orientation, of `size` (columns, rows). `None` when a bar is none of
    /// the offsets, or two bars share a cell and an offset.
    pub(super) fn new(mesh: &ClothMesh, cell: impl Fn(usize) -> (usize, usize), size: (usize, usize)) -> Option<Self> {
        let (columns, rows) = size;
        let mut table = BarTable {
            columns,
            rest: vec![f32::NAN; columns * rows * CLASSES],
            kind: vec![0; columns * rows * CLASSES],
            class_rest: [None; CLASSES],
        };
        // Per class: sum, least, most, count.
        let mut stats = [(0.0f64, f32::INFINITY, 0.0f32, 0usize); CLASSES];
        for bar in mesh.bars() {
            let (ca, ra) = cell(bar.a as usize);
            let (cb, rb) = cell(bar.b as usize);
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
        self.get_class(c, r, Self::class(offset)?)
    }

    /// `offset`'s index into the table's classes (`None` for an offset
    /// no bar can have).
    pub(super) fn class(offset: Offset) -> Option<usize> {
        Offset::ALL.iter().position(|&o| o == offset)
    }

    /// [`Self::get`] with the offset's class looked up once by the caller.
    pub(super) fn get_class(&self, c: usize, r: usize, class: usize) -> Option<(u8, f32)> {
        let at = (r * self.columns + c) * CLASSES + class;
        let rest = self.rest[at];
        (!rest.is_nan()).then(|| (self.kind[at], self.class_rest[class].unwrap_or(rest)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::fast::grid::tests::{ALTERNATE, DOWN, UP, renumbered, triangle_sheet};
    use crate::sim::mesh::{Grid, Pins};

    #[test]
    fn a_sheet_is_found_in_any_numbering_and_other_meshes_are_not() {
        for (flip, diagonals) in [(DOWN, "down"), (UP, "up"), (ALTERNATE, "alternating")] {
            // 40 × 25 and its transpose: C is found from either side.
            for (c, r) in [(40, 25), (25, 40), (17, 3)] {
                let sheet = triangle_sheet(c, r, flip);
                let found = implied_grid(&sheet).expect("a grid");
                assert_eq!(found.shape, GridShape { columns: c, rows: r }, "{c} × {r}, diagonals {diagonals}");
                assert!(found.number.is_none(), "numbered row by row already");
                // Renumbered, the triangles give the same grid, up to which
                // corner it starts from: every bar still joins cells of
                // one of the offsets (checked inside), and the particles
                // pinned in one row of the sheet are in one row or column.
                let moved = renumbered(&sheet);
                let found = implied_grid(&moved).expect("a grid");
                let number = found.number.expect("a numbering");
                let shape = found.shape;
                assert!(
                    [(c, r), (r, c)].contains(&(shape.columns, shape.rows)),
                    "{c} × {r}, diagonals {diagonals}: found {shape:?}"
                );
                let pinned: Vec<(u32, u32)> = (0..moved.fixed().len())
                    .filter(|&i| moved.fixed()[i])
                    .map(|i| (number[i] % shape.columns, number[i] / shape.columns))
                    .collect();
                let one_row = pinned.iter().all(|p| p.1 == pinned[0].1);
                let one_column = pinned.iter().all(|p| p.0 == pinned[0].0);
                assert!(one_row || one_column, "{c} × {r}, diagonals {diagonals}: pins at {pinned:?}");
            }
        }
        // A grid that says its shape is found from its bars too (the same C).
        let grid = Grid { columns: 20, rows: 30, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
        assert_eq!(implied_grid(&grid).map(|g| g.shape), grid.grid());
        // The sheet with two particles swapped (positions and triangles): no
        // longer numbered row by row, but its triangles still give the grid.
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
        assert!(implied_grid(&swapped).is_some_and(|g| g.number.is_some()));
        // One cell split into four triangles around a particle at its centre:
        // no grid, in any numbering.
        let mut positions = sheet.positions().to_vec();
        let (a, b, c, d) = (410, 411, 450, 451);
        positions.push((positions[a as usize] + positions[d as usize]) * 0.5);
        let centre = positions.len() as u32 - 1;
        let mut triangles: Vec<[u32; 3]> =
            sheet.triangles().iter().copied().filter(|t| !(t.contains(&a) && t.contains(&d))).collect();
        triangles.extend([[centre, a, c], [centre, c, d], [centre, d, b], [centre, b, a]]);
        let fan = ClothMesh::from_triangles(positions, triangles, &[0, 39], None).unwrap();
        assert!(implied_grid(&fan).is_none());
    }
}
