//! The cloth's topology: particles, bars and (for drawing) triangles.
//!
//! A [`ClothMesh`] is what the seed calls "a list of particles containing their
//! position and a Boolean variable indicating if they are free or fixed" plus
//! "a graph, in the form of adjacency list, representing the bars". It is
//! immutable once built and shared by every solver; each bar's rest length is
//! the distance between its particles as given.
//!
//! Three builders cover the three ways a cloth is described:
//! - [`Grid`] — the seed's rectangular mesh (Figures 1 and 2): a bar to every
//!   immediate neighbour, horizontal, vertical and both diagonals, and a bend
//!   bar to the particles two away horizontally and vertically;
//! - [`ClothMesh::from_adjacency`] — the seed's generic form;
//! - [`ClothMesh::from_triangles`] — a triangle mesh (an OBJ file): a bar on
//!   every edge and a bend bar across every interior edge, joining the two
//!   vertices opposite it.
//!
//! Every builder validates what it is given and reports the first problem as
//! a [`MeshError`]; no input makes it panic.

mod adjacency;
mod error;
mod grid;
pub mod surface;
mod triangles;

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The index of the first bar that joins the same two particles as an
/// earlier one, if any.
///
/// Bars are bucketed by their lower particle with a counting sort (O(bars),
/// keeping input order within a bucket) and each bucket is searched for a
/// repeated upper particle: a handful of bars per particle in a cloth, so
/// this is several times cheaper than hashing every pair (it was 40 % of
/// building a 256 × 256 grid).
fn first_repeated_bar(bars: &[Bar], particles: usize) -> Option<usize> {
    let lo = |bar: &Bar| bar.a.min(bar.b) as usize;
    let hi = |bar: &Bar| bar.a.max(bar.b);
    let mut start = vec![0u32; particles + 1];
    for bar in bars {
        start[lo(bar) + 1] += 1;
    }
    for i in 0..particles {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut order = vec![0u32; bars.len()];
    for (i, bar) in bars.iter().enumerate() {
        let slot = &mut fill[lo(bar)];
        order[*slot as usize] = i as u32;
        *slot += 1;
    }
    let mut first: Option<usize> = None;
    let mut bucket: Vec<(u32, u32)> = Vec::new();
    for p in 0..particles {
        let members = &order[start[p] as usize..start[p + 1] as usize];
        if members.len() < 2 {
            continue;
        }
        // A cloth's buckets hold a handful of bars: compare every pair.
        // Their upper ends are read once, into a local array.
        if members.len() <= 16 {
            let mut upper = [0u32; 16];
            for (u, &i) in upper.iter_mut().zip(members) {
                *u = hi(&bars[i as usize]);
            }
            let upper = &upper[..members.len()];
            if let Some(k) = (1..upper.len()).find(|&k| upper[..k].contains(&upper[k])) {
                let j = members[k] as usize;
                first = Some(first.map_or(j, |f| f.min(j)));
            }
            continue;
        }
        // (upper particle, bar index), sorted: a repeat is a neighbour with
        // the same upper particle, and the later of the two is the repeat.
        bucket.clear();
        bucket.extend(members.iter().map(|&i| (hi(&bars[i as usize]), i)));
        bucket.sort_unstable();
        for w in bucket.windows(2) {
            if w[0].0 == w[1].0 {
                let repeat = w[1].1 as usize;
                first = Some(first.map_or(repeat, |f| f.min(repeat)));
            }
        }
    }
    first
}

/// Most particles a mesh may have (4096², about 0.5 GiB of solver state).
pub const MAX_PARTICLES: usize = 1 << 24;
/// Most bars a mesh may have.
pub const MAX_BARS: usize = 1 << 27;
/// Largest accepted magnitude of a coordinate, in metres.
pub const MAX_COORDINATE: f32 = 1e6;
/// Shortest accepted bar, metres (1 µm): its square, which the solvers
/// compute, stays a normal f32 with room for strain to be resolved.
pub const MIN_BAR_LENGTH: f32 = 1e-6;
/// Shortest accepted bar relative to the mesh's largest coordinate
/// magnitude: f32 spaces positions 1.2e-7 of their magnitude apart, so a
/// bar 1e-4 of it is resolved to about 0.1 % of its length.
pub const MIN_BAR_RATIO: f32 = 1e-4;

pub use error::MeshError;
pub use grid::{Grid, GridPlane, Pins};

/// What a bar stands for; solvers may treat the kinds differently (for
/// example a different compliance) and the viewer draws them separately.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BarKind {
    /// A bar between immediate neighbours along the cloth's threads: a
    /// grid's horizontal and vertical bars, the edges of a triangle mesh,
    /// every bar of an adjacency list.
    Structural,
    /// A grid's diagonal bar, across a cell: it resists shear, which woven
    /// cloth barely does (the seed counts it structural, and by default it
    /// is as stiff: `shear_compliance` unset takes `stretch_compliance`).
    Shear,
    /// A bar to a particle two away, which resists folding (the dashed bars of
    /// the seed's Figure 2, or the bar across an interior triangle edge).
    Bend,
}

impl BarKind {
    /// How many kinds there are.
    pub const COUNT: usize = 3;

    /// The kind's index into per-kind tables such as
    /// [`crate::sim::step::Substep::betas`]: 0 structural, 1 bend, 2 shear.
    pub fn index(self) -> usize {
        match self {
            BarKind::Structural => 0,
            BarKind::Bend => 1,
            BarKind::Shear => 2,
        }
    }
}

/// A bar: two particles that the relaxation keeps at `rest_length`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bar {
    /// First particle (index into the mesh's particles).
    pub a: u32,
    /// Second particle; never equal to `a`.
    pub b: u32,
    /// The length the bar is relaxed towards, in metres; always > 0.
    pub rest_length: f32,
    /// Structural, shear or bend.
    pub kind: BarKind,
}

/// Columns and rows of a mesh built by [`Grid`]; particle `(column, row)` has
/// index `row * columns + column`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GridShape {
    /// Particles per row, ≥ 1.
    pub columns: u32,
    /// Rows of particles, ≥ 1.
    pub rows: u32,
}

impl GridShape {
    /// Index of the particle at `(column, row)`.
    pub fn index(&self, column: u32, row: u32) -> u32 {
        row * self.columns + column
    }
}

/// The particles, bars and triangles of one cloth. See the module docs.
#[derive(Clone, Debug, PartialEq)]
pub struct ClothMesh {
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    fixed: Vec<bool>,
    bars: Vec<Bar>,
    triangles: Vec<[u32; 3]>,
    grid: Option<GridShape>,
    /// The rest shape's bounding box and longest bar (metres): constants of
    /// the mesh, kept so that per-frame checks need not recompute them.
    rest_bounds: (Vec3, Vec3),
    longest_bar: f32,
}

/// The raw parts of a mesh, checked by [`ClothMesh::new`].
#[derive(Clone, Debug, Default)]
pub struct MeshParts {
    /// x₀ of every particle, metres.
    pub positions: Vec<Vec3>,
    /// v₀ of every particle (equation 2), m/s; empty means all zero.
    pub velocities: Vec<Vec3>,
    /// Which particles are fixed; empty means none.
    pub fixed: Vec<bool>,
    /// Bars as particle pairs, in the order the relaxation visits them.
    pub bars: Vec<(u32, u32, BarKind)>,
    /// The bars' rest lengths when the builder knows them exactly (a grid:
    /// spacing, √2·spacing, 2·spacing); empty means the distance between the
    /// (f32-rounded) positions.
    pub rest_lengths: Vec<f32>,
    /// Triangles for drawing (may be empty: the viewer then draws bars).
    pub triangles: Vec<[u32; 3]>,
    /// Set when the particles form a grid in row-major order.
    pub grid: Option<GridShape>,
}

fn check_coordinate(what: &'static str, index: usize, v: Vec3) -> Result<(), MeshError> {
    if v.is_finite() && v.abs().max_element() <= MAX_COORDINATE {
        Ok(())
    } else {
        Err(MeshError::BadCoordinate { what, index, value: format!("[{}, {}, {}]", v.x, v.y, v.z) })
    }
}

fn check_index(what: impl FnOnce() -> String, index: u64, count: usize) -> Result<u32, MeshError> {
    if index < count as u64 {
        // count <= MAX_PARTICLES < u32::MAX, so the index fits.
        Ok(index as u32)
    } else {
        Err(MeshError::IndexOutOfRange { what: what(), index, last: count - 1 })
    }
}

/// Replaces −0.0 by +0.0 so that adding a zero correction never changes a
/// fixed particle's bits (−0 + +0 = +0 in IEEE 754).
fn canonical_zero(v: Vec3) -> Vec3 {
    v + Vec3::ZERO
}

impl ClothMesh {
    /// Checks and assembles a mesh from its parts; computes every bar's rest
    /// length from the positions.
    pub fn new(parts: MeshParts) -> Result<Self, MeshError> {
        let MeshParts { positions, mut velocities, mut fixed, bars, rest_lengths, triangles, grid } = parts;
        if !rest_lengths.is_empty() && rest_lengths.len() != bars.len() {
            return Err(MeshError::WrongLength { what: "rest lengths", got: rest_lengths.len(), expected: bars.len() });
        }
        let n = positions.len();
        if n == 0 {
            return Err(MeshError::Empty);
        }
        if n > MAX_PARTICLES {
            return Err(MeshError::TooManyParticles { count: n as u128 });
        }
        if bars.len() > MAX_BARS {
            return Err(MeshError::TooManyBars { count: bars.len() as u128 });
        }
        for (i, &p) in positions.iter().enumerate() {
            check_coordinate("position", i, p)?;
        }
        if velocities.is_empty() {
            velocities = vec![Vec3::ZERO; n];
        } else if velocities.len() != n {
            return Err(MeshError::WrongLength { what: "velocities", got: velocities.len(), expected: n });
        }
        for (i, &v) in velocities.iter().enumerate() {
            check_coordinate("velocity", i, v)?;
        }
        if fixed.is_empty() {
            fixed = vec![false; n];
        } else if fixed.len() != n {
            return Err(MeshError::WrongLength { what: "fixed flags", got: fixed.len(), expected: n });
        }
        let positions: Vec<Vec3> = positions.into_iter().map(canonical_zero).collect();

        let reach = positions.iter().map(|p| p.abs().max_element()).fold(0.0, f32::max);
        let minimum = MIN_BAR_LENGTH.max(MIN_BAR_RATIO * reach);
        let mut checked = Vec::with_capacity(bars.len());
        for (i, &(a, b, kind)) in bars.iter().enumerate() {
            let a = check_index(|| format!("bar {i}"), a.into(), n)?;
            let b = check_index(|| format!("bar {i}"), b.into(), n)?;
            if a == b {
                return Err(MeshError::SelfBar { particle: a });
            }
            let rest_length = match rest_lengths.get(i) {
                Some(&l) => l,
                None => positions[a as usize].distance(positions[b as usize]),
            };
            // `!(x >= min)` also refuses NaN.
            if !(rest_length >= minimum && rest_length.is_finite()) {
                return Err(MeshError::ShortBar { a, b, length: rest_length, minimum });
            }
            checked.push(Bar { a, b, rest_length, kind });
        }
        if let Some(i) = first_repeated_bar(&checked, n) {
            return Err(MeshError::DuplicateBar { a: checked[i].a, b: checked[i].b });
        }
        for (i, t) in triangles.iter().enumerate() {
            for &v in t {
                check_index(|| format!("triangle {i}"), v.into(), n)?;
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(MeshError::DegenerateTriangle { index: i, vertices: *t });
            }
        }
        if let Some(g) = grid {
            debug_assert_eq!(g.columns as usize * g.rows as usize, n);
        }
        let rest_bounds = bounds(&positions);
        let longest_bar = checked.iter().map(|b| b.rest_length).fold(0.0, f32::max);
        Ok(Self { positions, velocities, fixed, bars: checked, triangles, grid, rest_bounds, longest_bar })
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.positions.len()
    }
    /// Initial positions x₀, metres, in scene order.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }
    /// Initial velocities v₀ (equation 2), m/s.
    pub fn velocities(&self) -> &[Vec3] {
        &self.velocities
    }
    /// Which particles the scene fixes.
    pub fn fixed(&self) -> &[bool] {
        &self.fixed
    }
    /// Every bar of the topology, in creation order (including bars between two
    /// fixed particles, which the solvers leave out while both stay fixed).
    pub fn bars(&self) -> &[Bar] {
        &self.bars
    }
    /// Triangles for drawing; empty for a mesh given only as bars.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }
    /// The grid shape when the mesh was built by [`Grid`].
    pub fn grid(&self) -> Option<GridShape> {
        self.grid
    }
    /// Whether `bar` is an edge of the cloth's surface: on a grid, a
    /// structural bar between horizontal or vertical neighbours (not a
    /// diagonal, the warp and weft of a woven cloth); on any other mesh,
    /// every structural bar. The inextensible projection keeps the edges at
    /// their rest lengths ([`crate::sim::inextensible`]).
    pub fn is_edge(&self, bar: &Bar) -> bool {
        bar.kind == BarKind::Structural
    }
    /// The axis-aligned box around the initial positions: (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.rest_bounds
    }

    /// The longest bar's rest length, metres (0 for a mesh without bars).
    pub fn longest_bar(&self) -> f32 {
        self.longest_bar
    }
}

/// The axis-aligned box (min, max) around `points`; zero-size at the origin
/// when there are none.
pub fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    let mut it = points.iter().copied();
    let Some(first) = it.next() else {
        return (Vec3::ZERO, Vec3::ZERO);
    };
    it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_first_repeated_bar_is_the_later_of_the_earliest_pair() {
        let bar = |a, b| Bar { a, b, rest_length: 1.0, kind: BarKind::Structural };
        // Bars 3 and 4 repeat bars 0 and 1 (either way round); bar 3 comes
        // first. Bar 5 is a third copy of bar 1.
        let bars = [bar(0, 1), bar(2, 1), bar(3, 4), bar(4, 3), bar(1, 0), bar(1, 2)];
        assert_eq!(first_repeated_bar(&bars, 5), Some(3));
        assert_eq!(first_repeated_bar(&bars[..3], 5), None);
        assert_eq!(first_repeated_bar(&[bar(0, 1), bar(1, 2), bar(2, 1), bar(1, 2)], 3), Some(2));
        // A star of 40 bars from particle 0 (sorted bucket), bar 30 repeats bar 7.
        let mut star: Vec<Bar> = (1..=40).map(|i| bar(0, i)).collect();
        assert_eq!(first_repeated_bar(&star, 41), None);
        star[30] = bar(8, 0);
        assert_eq!(first_repeated_bar(&star, 41), Some(30));
    }

    use super::*;

    #[test]
    fn negative_zero_is_canonicalised() {
        let mesh = ClothMesh::from_adjacency(vec![Vec3::new(-0.0, 0.0, 0.0), Vec3::X], &[0], &[vec![1], vec![]], None)
            .unwrap();
        assert_eq!(mesh.positions()[0].x.to_bits(), 0.0f32.to_bits());
    }
}
