//! The seed's rectangular mesh (its Figures 1 and 2) and its pins.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::{BarKind, ClothMesh, GridShape, MAX_COORDINATE, MAX_PARTICLES, MeshError, MeshParts};

/// In which plane a [`Grid`] lies.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GridPlane {
    /// Hanging in the x–y plane: columns along +x, rows going down −y, row 0
    /// at the top (the seed's figures).
    #[default]
    Vertical,
    /// Lying in the x–z plane: columns along +x, rows along +z.
    Horizontal,
}

/// Which particles of a [`Grid`] are fixed.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Pins {
    /// None: the cloth falls freely.
    None,
    /// Every particle of row 0 (the seed's Figure 1).
    #[default]
    TopRow,
    /// The two ends of row 0.
    TopCorners,
    /// Every particle of column 0 (a flag on its pole).
    LeftColumn,
    /// An explicit list of `[column, row]` cells.
    Cells(Vec<[u32; 2]>),
}

/// The seed's rectangular mesh (Figures 1 and 2).
///
/// Bars are created particle by particle in row-major order; for particle
/// `(c, r)`: right `(c+1, r)`, down `(c, r+1)`, down-right `(c+1, r+1)`,
/// down-left `(c−1, r+1)` (structural), then two to the right `(c+2, r)` and
/// two down `(c, r+2)` (bend). A `C × R` grid thus has
/// `(C−1)R + C(R−1) + 2(C−1)(R−1)` structural and `(C−2)R + C(R−2)` bend bars.
///
/// ```
/// use drape::sim::{Grid, Pins};
/// let mesh = Grid { columns: 20, rows: 30, spacing: 0.5, pins: Pins::TopRow, ..Grid::default() }
///     .build()
///     .unwrap();
/// assert_eq!(mesh.particle_count(), 600);
/// assert_eq!(mesh.bars().len(), 570 + 580 + 1102 + 540 + 560);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Particles per row, ≥ 1. Default 20 (the seed's).
    pub columns: u32,
    /// Rows, ≥ 1. Default 30 (the seed's).
    pub rows: u32,
    /// Distance between neighbouring particles, metres, > 0. Default 0.5.
    pub spacing: f32,
    /// Vertical (the seed's hanging cloth) or horizontal. Default vertical.
    pub plane: GridPlane,
    /// Position of particle (0, 0). Default: centred on x = 0 (and z = 0 for
    /// a horizontal grid), with a vertical grid's bottom row at y = 0.
    pub origin: Option<Vec3>,
    /// Fixed particles. Default the top row.
    pub pins: Pins,
    /// Whether to add the diagonal bars. Default true.
    pub shear: bool,
    /// Whether to add the two-away bend bars. Default true.
    pub bend: bool,
}

impl Default for Grid {
    fn default() -> Self {
        Self {
            columns: 20,
            rows: 30,
            spacing: 0.5,
            plane: GridPlane::Vertical,
            origin: None,
            pins: Pins::TopRow,
            shear: true,
            bend: true,
        }
    }
}

impl Grid {
    /// Builds the mesh; errors on a zero dimension, a spacing that is not a
    /// positive finite number, a pinned cell outside the grid, or a grid too
    /// large for memory (checked before anything is allocated).
    pub fn build(&self) -> Result<ClothMesh, MeshError> {
        let (cols, rows) = (self.columns, self.rows);
        if cols == 0 || rows == 0 {
            return Err(MeshError::BadGrid {
                what: format!("is {cols} × {rows}: columns and rows must each be at least 1"),
            });
        }
        let count = u128::from(cols) * u128::from(rows);
        if count > MAX_PARTICLES as u128 {
            return Err(MeshError::TooManyParticles { count });
        }
        if !(self.spacing.is_finite() && self.spacing >= super::MIN_BAR_LENGTH) {
            return Err(MeshError::BadGrid {
                what: format!(
                    "spacing is {:e} m: it must be at least 1e-6 m (1 µm), for f32 to resolve the bars' stretch",
                    self.spacing
                ),
            });
        }
        let extent = self.spacing * (cols.max(rows) - 1) as f32;
        if extent > MAX_COORDINATE {
            return Err(MeshError::BadGrid { what: format!("is {extent} m across: at most 1e6 m is allowed") });
        }
        let shape = GridShape { columns: cols, rows };
        let s = self.spacing;
        let width = s * (cols - 1) as f32;
        let height = s * (rows - 1) as f32;
        let (origin, right, down) = match self.plane {
            GridPlane::Vertical => (self.origin.unwrap_or(Vec3::new(-0.5 * width, height, 0.0)), Vec3::X, Vec3::NEG_Y),
            GridPlane::Horizontal => {
                (self.origin.unwrap_or(Vec3::new(-0.5 * width, 0.0, -0.5 * height)), Vec3::X, Vec3::Z)
            }
        };
        let mut positions = Vec::with_capacity(count as usize);
        for r in 0..rows {
            for c in 0..cols {
                positions.push(origin + right * (c as f32 * s) + down * (r as f32 * s));
            }
        }
        let mut fixed = vec![false; count as usize];
        let mut pin = |c: u32, r: u32| fixed[shape.index(c, r) as usize] = true;
        match &self.pins {
            Pins::None => {}
            Pins::TopRow => (0..cols).for_each(|c| pin(c, 0)),
            Pins::TopCorners => {
                pin(0, 0);
                pin(cols - 1, 0);
            }
            Pins::LeftColumn => (0..rows).for_each(|r| pin(0, r)),
            Pins::Cells(cells) => {
                for &[c, r] in cells {
                    if c >= cols || r >= rows {
                        return Err(MeshError::BadGrid {
                            what: format!(
                                "pin [{c}, {r}] is outside the grid: columns are 0 to {}, rows 0 to {}",
                                cols - 1,
                                rows - 1
                            ),
                        });
                    }
                    pin(c, r);
                }
            }
        }
        let mut bars = Vec::new();
        let idx = |c: u32, r: u32| shape.index(c, r);
        for r in 0..rows {
            for c in 0..cols {
                let i = idx(c, r);
                if c + 1 < cols {
                    bars.push((i, idx(c + 1, r), BarKind::Structural));
                }
                if r + 1 < rows {
                    bars.push((i, idx(c, r + 1), BarKind::Structural));
                    if self.shear && c + 1 < cols {
                        bars.push((i, idx(c + 1, r + 1), BarKind::Shear));
                    }
                    if self.shear && c >= 1 {
                        bars.push((i, idx(c - 1, r + 1), BarKind::Shear));
                    }
                }
                if self.bend && c + 2 < cols {
                    bars.push((i, idx(c + 2, r), BarKind::Bend));
                }
                if self.bend && r + 2 < rows {
                    bars.push((i, idx(c, r + 2), BarKind::Bend));
                }
            }
        }
        let mut triangles = Vec::with_capacity(2 * (cols as usize - 1) * (rows as usize).saturating_sub(1));
        for r in 0..rows.saturating_sub(1) {
            for c in 0..cols.saturating_sub(1) {
                let (i, right, below, diag) = (idx(c, r), idx(c + 1, r), idx(c, r + 1), idx(c + 1, r + 1));
                // Counter-clockwise seen from +z (vertical) or +y (horizontal).
                triangles.push([i, below, right]);
                triangles.push([right, below, diag]);
            }
        }
        // Rest lengths from the exact grid geometry, not from positions that
        // were rounded to f32 (which would scatter them by ~1e-7 relative).
        let rest_lengths = bars
            .iter()
            .map(|&(a, b, _)| {
                let (dc, dr) = (i64::from(a % cols) - i64::from(b % cols), i64::from(a / cols) - i64::from(b / cols));
                (f64::from(s) * ((dc * dc + dr * dr) as f64).sqrt()) as f32
            })
            .collect();
        ClothMesh::new(MeshParts {
            positions,
            velocities: Vec::new(),
            fixed,
            bars,
            rest_lengths,
            triangles,
            grid: Some(shape),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bar_count(c: u32, r: u32) -> usize {
        let (c, r) = (c as usize, r as usize);
        (c - 1) * r + c * (r - 1) + 2 * (c - 1) * (r - 1) + c.saturating_sub(2) * r + c * r.saturating_sub(2)
    }

    #[test]
    fn grid_bar_counts_follow_the_formula() {
        for (c, r) in [(2, 2), (3, 5), (20, 30), (7, 1), (1, 7)] {
            let mesh = Grid { columns: c, rows: r, ..Grid::default() }.build().unwrap();
            let c1 = c.max(1) as usize;
            let expected = if c == 1 || r == 1 {
                // A single row or column: a chain with bend bars.
                let n = (c * r) as usize;
                (n - 1) + n.saturating_sub(2)
            } else {
                bar_count(c, r)
            };
            assert_eq!(mesh.bars().len(), expected, "{c}×{r} (c1 {c1})");
            assert_eq!(mesh.triangles().len(), 2 * (c as usize - 1) * (r as usize - 1));
        }
    }

    #[test]
    fn grid_rest_lengths_are_spacing_diagonal_and_double() {
        let s = 0.25;
        let mesh = Grid { columns: 4, rows: 4, spacing: s, ..Grid::default() }.build().unwrap();
        for bar in mesh.bars() {
            let l = bar.rest_length;
            let ok = match bar.kind {
                BarKind::Structural => (l - s).abs() < 1e-6,
                BarKind::Shear => (l - s * 2f32.sqrt()).abs() < 1e-6,
                BarKind::Bend => (l - 2.0 * s).abs() < 1e-6,
            };
            assert!(ok, "{bar:?}");
        }
    }

    #[test]
    fn pins_select_the_documented_cells() {
        let count = |pins| {
            let m = Grid { columns: 5, rows: 4, pins, ..Grid::default() }.build().unwrap();
            m.fixed().iter().filter(|&&f| f).count()
        };
        assert_eq!(count(Pins::None), 0);
        assert_eq!(count(Pins::TopRow), 5);
        assert_eq!(count(Pins::TopCorners), 2);
        assert_eq!(count(Pins::LeftColumn), 4);
        assert_eq!(count(Pins::Cells(vec![[4, 3], [0, 0]])), 2);
        let err = Grid { columns: 5, rows: 4, pins: Pins::Cells(vec![[5, 0]]), ..Grid::default() }.build();
        assert!(matches!(err, Err(MeshError::BadGrid { .. })), "{err:?}");
    }

    #[test]
    fn vertical_grid_hangs_from_row_zero() {
        let mesh = Grid { columns: 3, rows: 3, spacing: 1.0, ..Grid::default() }.build().unwrap();
        let p = mesh.positions();
        assert_eq!(p[0], Vec3::new(-1.0, 2.0, 0.0));
        assert_eq!(p[8], Vec3::new(1.0, 0.0, 0.0));
    }

    #[test]
    fn oversized_grid_is_rejected_before_allocation() {
        let err = Grid { columns: u32::MAX, rows: u32::MAX, ..Grid::default() }.build();
        assert!(matches!(err, Err(MeshError::TooManyParticles { .. })), "{err:?}");
    }
}
