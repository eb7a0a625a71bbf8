//! The lane layout for grids (this file: the layout and its state;
//! `phases`: how each phase of a substep runs on it; `sweep`: the
//! relaxation sweeps): eight blocks of columns side by side in SIMD
//! lanes, swept row by row away from the pins.
//!
//! **Orientation.** The grid may be transposed and its rows reversed so that
//! the sweep (row 0 to row R−1) starts where the fixed particles are: a
//! Gauss–Seidel pass then carries a pin's correction down the whole cloth,
//! as the seed's creation order does for a cloth hung by its top row.
//!
//! **Lanes.** The C columns are cut into tiles of eight blocks of `block`
//! consecutive columns; lane `l` of a tile holds block `l`. The value at slot
//! `(ρ, k)` (slot index ρ·block + k) of lane l is the particle in row ρ,
//! column `l·block + k` of the tile. One 8-wide load reads eight particles a
//! block apart, and every bar of the grid is one lane of an 8-bar operation:
//!
//! ```text
//! class   offset (Δc, Δr)   operation on slots (ρ, k) → (ρ + Δr, k + Δc)
//! H       (1, 0)            same lane while k + Δc < block; otherwise the
//! BH      (2, 0)            far slot's lanes are rotated by one so that lane
//! V       (0, 1)            l meets lane l + 1 (the next block); lane 7 would
//! D       (1, 1)            meet the next tile and is masked
//! A       (−1, 1)
//! BV      (0, 2)
//! KnightH (2, 1), KnightHBack (−2, 1), KnightV (1, 2), KnightVBack (−1, 2):
//!         a triangulated sheet's bend bars (see `shape`)
//! ```
//!
//! A grid built by [`crate::sim::Grid`] has whole classes, one kind and
//! one rest length each. A triangle mesh numbered row by row ([`shape`])
//! may leave out bars (diagonals alternating as on a chequerboard, a gap
//! between two sheets): an operation runs when each of its lanes finds a
//! bar of one kind, and is left out when none does; a mix leaves the mesh
//! to the coloured path. Its rest shape need not be even either: where an
//! operation's eight rest lengths differ, each tile keeps them
//! ([`Tile::rests`]) and each lane takes its own.
//!
//! **Order.** Row by row; within a row class by class (H, V, D, A, BH, BV,
//! then the knight's moves);
//! within a class slot by slot (every other slot first for H and BH, whose
//! neighbours share particles). Lanes are far apart, so the eight bars of an
//! operation never share a particle. This is the seed's creation order up to
//! where each bar falls within its row, and converges as fast per pass:
//! mean RMS strain of the seed's scene over 2000 steps was 0.035 in this
//! order against 0.039 in creation order, while sweeping bands of rows in the
//! lanes (the first layout tried) left 0.054, and class by class over the
//! whole cloth 0.040.
//!
//! **Tiles and threads.** Bars between a tile's lane 7 and the next tile's
//! lane 0 ("seams") are projected by the tile on their left, after its own
//! bars, eight at a time in lanes: rows two apart share no seam particle, so
//! the seam bars are grouped even rows first, then odd ones ([`seam_groups`];
//! one at a time they cost 14 % of a 256 × 256 step, as a chain of scalar
//! projections each waiting for the last). Even tiles sweep first, then odd
//! ones, so no two tiles being swept at once share a particle. Tiles are
//! sized from the grid alone, never from the thread count, so one thread or
//! many give the same bits; grids of at least [`PARALLEL_PARTICLES`] sweep
//! their tiles on the rayon pool, a step's passes as a graph of tasks in
//! which a tile's pass waits only on its neighbours' ([`sweep::sweep_passes`]).
//!
//! Columns past the end of the grid are padding of inverse mass 0; every bar
//! touching them is a no-op (see [`super::kernel`]). So is every bar between
//! two fixed particles; such bars are kept, so that pinning or freeing a
//! particle is a write of its weight and never changes the layout.
//!
//! **Contact.** The collide phase gives every tile the colliders whose box
//! meets the tile's box of start and end positions, and resolves its
//! particles one by one with [`ContactStep::resolve`], the function the
//! reference solver calls, tiles in parallel on large grids.

mod ops;
mod phases;
mod scene;
mod shape;
mod sweep;
#[cfg(test)]
pub(crate) mod tests;

use glam::Vec3;

use super::THREAD_SHARES;
use super::kernel::{F32x8, LANES, Point, Real, Shares, Weights};
use crate::sim::mesh::{BarKind, ClothMesh, GridShape};
use crate::sim::tether::Tethers;
use ops::{KIND_SHIFT, Op, Ops, ROTATED};

/// Columns per block the tiling aims at; a tile holds `8 · block` columns.
const TARGET_BLOCK: usize = 8;
/// Grids of at least this many particles sweep tiles on the thread pool.
pub(crate) const PARALLEL_PARTICLES: usize = 16_384;
/// Bar kinds with their own shares and compliance.
const KINDS: usize = BarKind::COUNT;

type Slot = Point<F32x8>;

/// The bar classes a grid can have (see the module docs): the seed's six,
/// and the four knight's moves that a triangulated sheet's bend bars make
/// (across an edge, to the vertex opposite it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Offset {
    H,
    BH,
    V,
    D,
    A,
    BV,
    /// (1, 2) and (−1, 2): across a horizontal edge of a triangulated sheet.
    KnightV,
    KnightVBack,
    /// (2, 1) and (−2, 1): across a vertical edge.
    KnightH,
    KnightHBack,
}

impl Offset {
    /// In the order a row's bars are relaxed.
    const ALL: [Offset; 10] = [
        Offset::H,
        Offset::V,
        Offset::D,
        Offset::A,
        Offset::BH,
        Offset::BV,
        Offset::KnightH,
        Offset::KnightHBack,
        Offset::KnightV,
        Offset::KnightVBack,
    ];

    /// (Δc, Δr) from the first particle to the second, with Δr ≥ 0.
    fn delta(self) -> (isize, usize) {
        match self {
            Offset::H => (1, 0),
            Offset::BH => (2, 0),
            Offset::V => (0, 1),
            Offset::D => (1, 1),
            Offset::A => (-1, 1),
            Offset::BV => (0, 2),
            Offset::KnightV => (1, 2),
            Offset::KnightVBack => (-1, 2),
            Offset::KnightH => (2, 1),
            Offset::KnightHBack => (-2, 1),
        }
    }

    fn from_delta(dc: isize, dr: isize) -> Option<Offset> {
        // Normalise so the second particle is below, or right on the same row.
        let (dc, dr) = if dr < 0 || (dr == 0 && dc < 0) { (-dc, -dr) } else { (dc, dr) };
        Offset::ALL.into_iter().find(|o| o.delta() == (dc, dr as usize))
    }
}

/// For each scene row, the first slot of the layout row that holds it,
/// when the scene is numbered as the lanes hold it: scene row r of `width`
/// = tiles · 8 · `block` particles is, in tile t, lane l, slot s₀ + k, the
/// particle r · width + t · 8 · block + l · block + k (a grid that is not
/// transposed, flipped or not, with no padding). Then the scene order is
/// read out of the lanes without a particle looked up. Empty when any
/// particle is elsewhere.
fn scene_rows(tiles: &[Tile], locations: &[Location], block: usize) -> Vec<u32> {
    let width = tiles.len() * LANES * block;
    if width == 0 || locations.is_empty() || !locations.len().is_multiple_of(width) {
        return Vec::new();
    }
    let mut starts = Vec::with_capacity(locations.len() / width);
    for r in 0..locations.len() / width {
        let start = locations[r * width].slot as usize;
        for (t, tile) in tiles.iter().enumerate() {
            for k in 0..block {
                let Some(scene) = tile.scene.get(start + k) else {
                    return Vec::new();
                };
                let first = r * width + t * LANES * block + k;
                if (0..LANES).any(|l| scene[l] as usize != first + l * block) {
                    return Vec::new();
                }
            }
        }
        starts.push(start as u32);
    }
    starts
}

/// Where a particle lives.
#[derive(Clone, Copy, Debug)]
struct Location {
    tile: u32,
    slot: u32,
    lane: u8,
}

/// A bar between two tiles, `a` in the lower one.
#[derive(Clone, Copy, Debug)]
struct SeamBar {
    a: Location,
    b: Location,
    rest: f32,
    kind: u8,
}

#[derive(Clone, Debug, Default)]
struct Tile {
    position: Vec<Slot>,
    displacement: Vec<Slot>,
    predicted: Vec<Slot>,
    /// Inverse mass relative to m (0: fixed or padding).
    weight: Vec<F32x8>,
    /// 1 for a particle of the grid, 0 for padding past its last column:
    /// a bar to padding does not exist, and must not pull a real particle
    /// as a weightless (fixed) partner would. Empty when the tile has no
    /// padding, which is then never looked at.
    presence: Vec<F32x8>,
    /// The scene index of each slot's particle in each lane (`u32::MAX` for
    /// padding), so a phase given scene-order values can run tile by tile.
    scene: Vec<[u32; LANES]>,
    /// The equal-mass shares of every slot for structural, bend and shear bars
    /// (see [`super::kernel::relax_pair_shared`]), kept in step with
    /// `weight` while every weight is 0 or 1.
    shared: [Vec<Weights<F32x8>>; KINDS],
    /// Every operation's shares ([`sweep::op_shares`], from `shared`) while
    /// the layout is in the share form: an operation loads its two where it
    /// loaded its slots' four. Empty otherwise. Recomputed before the next
    /// relaxation when `op_shares_stale` (a weight of the tile was written).
    op_shares: Vec<sweep::OpShares>,
    op_shares_stale: bool,
    /// μ = βλ of every operation's eight bars (compliant bars only).
    multipliers: Vec<F32x8>,
    /// Every operation's eight rest lengths, when some operation's bars
    /// differ from lane to lane (a sheet whose rest shape is not even);
    /// empty otherwise, when each operation's one [`Op::rest`] serves.
    rests: Vec<F32x8>,
    /// Each particle's tether anchor position, and its rest path length
    /// (+∞ without one); empty when tethers are off.
    tether_anchor: Vec<Slot>,
    tether_length: Vec<F32x8>,
    /// The bars from this tile's lane 7 to the next tile's lane 0, and their μ,
    /// in groups of at most eight that share no particle ([`seam_groups`]).
    seams: Vec<SeamBar>,
    seam_multipliers: Vec<f32>,
    /// Group g is `seams[seam_ends[g − 1]..seam_ends[g]]` (from 0 for g = 0).
    seam_ends: Vec<u32>,
}

impl Tile {
    /// Whether every lane of slot `s` holds a particle: any slot of a tile
    /// without padding (`presence` empty), else the slot's scene indices.
    fn slot_is_full(&self, s: usize) -> bool {
        self.presence.is_empty() || self.scene[s].iter().all(|&i| i != u32::MAX)
    }
}

/// A tile's seam bars (in row order, as built) in groups of at most eight
/// that share no particle, and where each group ends.
///
/// A seam bar starting in row r touches rows r to r + s only, where s, its
/// span, is 1 (it joins columns across a tile's edge: H, BH, D, A or a
/// triangulated sheet's KnightH and KnightHBack, never V or BV) or 2 (KnightV, KnightVBack). So bars
/// of rows s + 1 apart never share a particle. The rows are taken by their
/// residue modulo s + 1 (even ones first, then odd ones, when s is 1),
/// eight rows at a time, and the k-th seam bar of each of those rows forms
/// a group: eight independent projections, one operation in lanes. Within a
/// residue the groups go k by k, each k over every eight rows: two groups
/// in a row then share no particle either (the eights of one residue touch
/// disjoint rows), so one group's projection need not wait for the last
/// one's. The groups run in this order one after the other, a Gauss–Seidel
/// sweep over the seam bars like any other. `block`: columns per lane (slot
/// = row · block + column in the block).
fn seam_groups(seams: &[SeamBar], block: u32) -> (Vec<SeamBar>, Vec<u32>) {
    let row = |s: &SeamBar| s.a.slot.min(s.b.slot) / block;
    let span = seams.iter().map(|s| s.a.slot.max(s.b.slot) / block - row(s)).max().unwrap_or(1).max(1) as usize;
    let mut rows: Vec<Vec<SeamBar>> = Vec::new();
    for s in seams {
        match rows.last_mut() {
            Some(last) if row(&last[0]) == row(s) => last.push(*s),
            _ => rows.push(vec![*s]),
        }
    }
    // Within a row, bars are told apart by kind and how many of that kind
    // came before: the second bend bar, say (a group's bars share their
    // kind, so their β; rest lengths go lane by lane). The last row lacks
    // some (no diagonal leaves it); every row has its bars in the order of
    // the fullest row.
    let key = |row: &[SeamBar], i: usize| (row[i].kind, row[..i].iter().filter(|s| s.kind == row[i].kind).count());
    let keys = |row: &[SeamBar]| (0..row.len()).map(|i| key(row, i)).collect::<Vec<_>>();
    let fullest = rows.iter().max_by_key(|r| r.len()).map(|r| keys(r)).unwrap_or_default();
    let (mut out, mut ends) = (Vec::with_capacity(seams.len()), Vec::new());
    for residue in 0..=span {
        let chosen: Vec<&Vec<SeamBar>> = rows.iter().filter(|r| row(&r[0]) as usize % (span + 1) == residue).collect();
        for k in &fullest {
            for chunk in chosen.chunks(LANES) {
                let before = out.len();
                out.extend(chunk.iter().filter_map(|r| keys(r).iter().position(|x| x == k).map(|i| r[i])));
                if out.len() > before {
                    ends.push(out.len() as u32);
                }
            }
        }
    }
    debug_assert_eq!(out.len(), seams.len(), "every seam bar in one group");
    (out, ends)
}

/// How far apart the rest lengths of an operation's eight bars may be, as
/// a share of the longest, for them to be projected with their mean (one
/// number an operation); further apart, each lane takes its own. A flat
/// sheet's bars of one kind and direction differ by the rounding of its
/// positions (2 × 10⁻⁵ for a 320 × 320 sheet 2 cm apart); 10⁻⁴ of a length
/// is far below the strain a solve leaves (the seed's cloth stretches by
/// 51 %, the inextensible scenes stop at 0.8 %).
const LANE_REST_SPREAD: f32 = 1e-4;

/// What the lanes of one operation find: a bar of one kind and rest length
/// in every lane that holds one (up to [`LANE_REST_SPREAD`]); a bar of one
/// kind in every lane, of rest lengths that differ (each tile's eight,
/// lanes without a bar given the mean, which their zero weights never
/// use); no bar in any; or a mix, which the layout cannot run.
enum OpBar {
    Every(u8, f32),
    Shaped(u8, f32, Vec<[f32; LANES]>),
    None,
    Mixed,
}

/// The bars an operation of `offset` from slot `(r, k)` projects: in every
/// tile, the lanes `lanes` (by their first end's lane), leaving out lanes
/// whose ends lie past the last column (padding).
#[allow(clippy::too_many_arguments)]
fn op_bar(
    table: &shape::BarTable,
    offset: Offset,
    r: usize,
    k: usize,
    lanes: std::ops::Range<usize>,
    tiles: usize,
    tile_columns: usize,
    block: usize,
) -> OpBar {
    let (dc, _) = offset.delta();
    let Some(class) = shape::BarTable::class(offset) else {
        return OpBar::None;
    };
    // (tile, lane, column) of every lane whose bar is within the grid.
    let lane_columns = || {
        let lanes = lanes.clone();
        (0..tiles).flat_map(move |t| lanes.clone().map(move |l| (t, l, t * tile_columns + l * block + k))).filter(
            move |&(_, _, c)| {
                let cb = c as isize + dc;
                c < table.columns() && cb >= 0 && (cb as usize) < table.columns()
            },
        )
    };
    let (mut found, mut missing) = (None::<(u8, f32, f32, f64, usize)>, false);
    for (_, _, c) in lane_columns() {
        match (table.get_class(c, r, class), &mut found) {
            (None, _) => missing = true,
            (Some((kind, rest)), None) => found = Some((kind, rest, rest, f64::from(rest), 1)),
            (Some((kind, rest)), Some(f)) => {
                if kind != f.0 {
                    return OpBar::Mixed;
                }
                *f = (kind, f.1.min(rest), f.2.max(rest), f.3 + f64::from(rest), f.4 + 1);
            }
        }
    }
    let Some((kind, lo, hi, sum, count)) = found else {
        return OpBar::None;
    };
    let mean = if lo == hi { lo } else { (sum / count as f64) as f32 };
    if missing {
        OpBar::Mixed
    } else if hi - lo > LANE_REST_SPREAD * hi {
        // Every lane's own rest length (only for shaped meshes: the common
        // case allocates nothing). Lanes are by the bar's first end; a
        // rotated operation seen from its lower end (Δc < 0) holds it one
        // lane down. Lanes past the grid's edge take the mean.
        let mut lane_rests = vec![[mean; LANES]; tiles];
        for (t, l, c) in lane_columns() {
            let lane = if (k as isize + dc) < 0 { l - 1 } else { l };
            if let Some((_, rest)) = table.get_class(c, r, class) {
                lane_rests[t][lane] = rest;
            }
        }
        OpBar::Shaped(kind, mean, lane_rests)
    } else {
        OpBar::Every(kind, mean)
    }
}

/// How scene cells map to internal ones.
#[derive(Clone, Copy, Debug)]
struct Orientation {
    shape: GridShape,
    transposed: bool,
    flipped: bool,
}

impl Orientation {
    /// Internal (columns, rows).
    fn size(&self) -> (usize, usize) {
        let (c, r) = (self.shape.columns as usize, self.shape.rows as usize);
        if self.transposed { (r, c) } else { (c, r) }
    }

    /// Internal (column, row) of scene particle `i`.
    fn cell(&self, i: usize) -> (usize, usize) {
        let (c, r) = (i % self.shape.columns as usize, i / self.shape.columns as usize);
        let (c, r) = if self.transposed { (r, c) } else { (c, r) };
        let rows = self.size().1;
        if self.flipped { (c, rows - 1 - r) } else { (c, r) }
    }

    /// The orientation whose sweep starts nearest the fixed particles (their
    /// mean row, as a share of the rows, is smallest), among those with at
    /// least 17 columns so a block has 3 or more. Ties keep the scene's own.
    fn choose(shape: GridShape, fixed: &[bool]) -> Option<Orientation> {
        let mut best: Option<(f64, Orientation)> = None;
        for (transposed, flipped) in [(false, false), (false, true), (true, false), (true, true)] {
            let o = Orientation { shape, transposed, flipped };
            let (columns, rows) = o.size();
            // Blocks of at least three columns: with two, a bend bar (Δc = 2)
            // would join lane l of a slot to lane l + 1 of the same slot,
            // and the eight bars of that operation would share particles.
            if columns <= 2 * LANES {
                continue;
            }
            let (mut sum, mut count) = (0.0, 0usize);
            for i in (0..fixed.len()).filter(|&i| fixed[i]) {
                sum += o.cell(i).1 as f64 / (rows.max(2) - 1) as f64;
                count += 1;
            }
            let score = if count == 0 { 0.5 } else { sum / count as f64 };
            if best.is_none_or(|(s, _)| score < s) {
                best = Some((score, o));
            }
        }
        best.map(|(_, o)| o)
    }
}

/// The whole grid in lane layout.
#[derive(Clone, Debug)]
pub(crate) struct GridLayout {
    block: usize,
    tiles: Vec<Tile>,
    ops: Ops,
    /// `ops[row_starts[r]..row_starts[r + 1]]` are the bars starting in row r.
    row_starts: Vec<u32>,
    /// Scene particle index → location.
    locations: Vec<Location>,
    /// The first slot of the layout row holding each scene row, when every
    /// scene row is one row of slots in every tile, lane by lane in scene
    /// order ([`scene_rows`]); empty otherwise.
    scene_rows: Vec<u32>,
    /// The scene index of every particle in lane order (tile by tile, slot
    /// by slot, lane by lane, padding skipped): the rows the self-collide
    /// phase works on (`scene.rs`). Tile t's are
    /// `lane_rows[tile_rows[t]..tile_rows[t + 1]]`.
    lane_rows: Vec<u32>,
    tile_rows: Vec<usize>,
    orientation: Orientation,
    /// How the grid was found when the mesh did not say it was one
    /// ([`shape::implied_grid`]): in its numbering, or its triangles.
    found: Option<&'static str>,
    /// Tether anchors by scene index, to refresh anchor positions.
    tethers: Option<Tethers>,
    /// Sweep tiles on the thread pool.
    parallel: bool,
    /// Every inverse mass is 0 or 1: the sweeps use the shares.
    uniform: bool,
    /// The shares `shared` was computed with: structural, bend and shear.
    shares: [Shares; KINDS],
    /// A weight of 0 or 1 was written while `uniform` was false: the next
    /// relaxation recomputes `uniform` and the shares, once for every write
    /// before it.
    reshare: bool,
}

impl GridLayout {
    /// Builds the lane layout of a grid mesh, or `None` when the mesh lacks
    /// the regular structure it needs (the coloured path runs instead).
    pub(crate) fn new(
        mesh: &ClothMesh,
        positions: &[Vec3],
        previous: &[Vec3],
        inverse_mass: &[f32],
        tethers: Option<Tethers>,
    ) -> Option<Self> {
        let fixed: Vec<bool> = inverse_mass.iter().map(|&w| w == 0.0).collect();
        let implied = mesh.grid().is_none();
        let (shape, number) = match mesh.grid() {
            Some(shape) => (shape, None),
            None => {
                let found = shape::implied_grid(mesh)?;
                (found.shape, found.number)
            }
        };
        // Scene particle → grid index r·C + c.
        let grid_index = |i: usize| number.as_ref().map_or(i, |n| n[i] as usize);
        let mut fixed_by_index = vec![false; fixed.len()];
        for (i, &f) in fixed.iter().enumerate() {
            fixed_by_index[grid_index(i)] = f;
        }
        let orientation = Orientation::choose(shape, &fixed_by_index)?;
        let cell = |i: usize| orientation.cell(grid_index(i));
        let (columns, rows) = orientation.size();
        let table = shape::BarTable::new(mesh, cell, (columns, rows))?;
        let parallel = positions.len() >= PARALLEL_PARTICLES;
        let mut tile_count = columns.div_ceil(LANES * TARGET_BLOCK);
        if parallel && tile_count > 1 {
            // The nearest multiple of THREAD_SHARES (at least one): blocks
            // of columns stay near TARGET_BLOCK.
            tile_count = ((tile_count + THREAD_SHARES / 2) / THREAD_SHARES).max(1) * THREAD_SHARES;
        }
        let mut block = columns.div_ceil(LANES * tile_count);
        if implied && block % 2 == 1 {
            // A triangle mesh's pattern may repeat every two columns (a
            // chequerboard of diagonals): lanes an even number of columns
            // apart find the same bars.
            block += 1;
        }
        let locate = |c: usize, r: usize| Location {
            tile: (c / (LANES * block)) as u32,
            slot: (r * block + c % block) as u32,
            lane: ((c % (LANES * block)) / block) as u8,
        };
        let slots = rows * block;
        let empty = Tile {
            position: vec![[F32x8::default(); 3]; slots],
            displacement: vec![[F32x8::default(); 3]; slots],
            predicted: vec![[F32x8::default(); 3]; slots],
            weight: vec![F32x8::splat(0.0); slots],
            ..Tile::default()
        };
        let locations = (0..positions.len()).map(cell).map(|(c, r)| locate(c, r)).collect();
        let mut layout = GridLayout {
            block,
            tiles: vec![empty; tile_count],
            ops: Ops::default(),
            row_starts: Vec::with_capacity(rows + 1),
            locations,
            scene_rows: Vec::new(),
            lane_rows: Vec::new(),
            tile_rows: Vec::new(),
            orientation,
            found: match (implied, &number) {
                (false, _) => None,
                (true, None) => Some(" (a grid found in the mesh's vertex order)"),
                (true, Some(_)) => Some(" (a grid found in the mesh's triangles, particles renumbered)"),
            },
            tethers,
            parallel,
            uniform: true,
            shares: [Shares::new(0.0, 1.0); KINDS],
            reshare: false,
        };
        layout.write_state(positions, previous, inverse_mass);

        let slot = |r: usize, k: usize| (r * block + k) as u32;
        let tile_columns = LANES * block;
        // Each operation's rest lengths by tile, when they differ by lane.
        let mut lane_rests: Vec<Option<Vec<[f32; LANES]>>> = Vec::new();
        let mut ops = Vec::new();
        for r in 0..rows {
            layout.row_starts.push(ops.len() as u32);
            for offset in Offset::ALL {
                let (dc, dr) = offset.delta();
                if r + dr >= rows {
                    continue;
                }
                // Bars along a row share particles with their neighbours:
                // relax every other one (H) or every other pair (BH) first,
                // so consecutive operations are independent.
                let period = 2 * dc.unsigned_abs().max(1);
                let order =
                    (0..period).flat_map(|phase| (0..block).filter(move |k| k % period / (period / 2) == phase));
                let order: Vec<usize> = if dr == 0 { order.collect() } else { (0..block).collect() };
                for k in order {
                    let kb = k as isize + dc;
                    // The lanes whose bar this operation projects (the
                    // others' partner is in another tile: a seam bar).
                    let lanes = if kb < 0 {
                        1..LANES
                    } else if kb as usize >= block {
                        0..LANES - 1
                    } else {
                        0..LANES
                    };
                    let (kind, rest) = match op_bar(&table, offset, r, k, lanes, tile_count, tile_columns, block) {
                        OpBar::Every(kind, rest) => {
                            lane_rests.push(None);
                            (kind, rest)
                        }
                        OpBar::Shaped(kind, mean, rests) => {
                            lane_rests.push(Some(rests));
                            (kind, mean)
                        }
                        OpBar::None => continue,
                        OpBar::Mixed => return None,
                    };
                    let kind_bits = u32::from(kind) << KIND_SHIFT;
                    let op = if kb < 0 {
                        // A bar to the previous block: seen from its lower end.
                        Op {
                            a: slot(r + dr, (kb + block as isize) as usize) | kind_bits,
                            b: slot(r, k) | ROTATED,
                            rest,
                        }
                    } else if kb as usize >= block {
                        Op { a: slot(r, k) | kind_bits, b: slot(r + dr, kb as usize - block) | ROTATED, rest }
                    } else {
                        Op { a: slot(r, k) | kind_bits, b: slot(r + dr, kb as usize), rest }
                    };
                    // Bars between fixed particles stay, as weightless
                    // no-ops, so a pin is a write of a weight.
                    ops.push(op);
                }
                // Bars from this row that cross into the next tile: only
                // the |Δc| columns on either side of a tile's edge can, so
                // look at those alone, in ascending order (a seam list's
                // order is its projection order). |Δc| ≤ 2 is below a
                // tile's width (≥ 8 columns), so each such bar's ends lie
                // in the two tiles beside the edge.
                let reach = dc.unsigned_abs();
                let edges = (1..tile_count).map(|t| t * tile_columns);
                let near_edges = edges.flat_map(|e| if dc > 0 { e.saturating_sub(reach)..e } else { e..e + reach });
                for c in near_edges {
                    let cb = c as isize + dc;
                    if c >= columns || !(0..columns as isize).contains(&cb) {
                        continue;
                    }
                    debug_assert_ne!(c / tile_columns, cb as usize / tile_columns, "a seam bar within one tile");
                    if let Some((kind, rest)) = table.get(c, r, offset) {
                        let (a, b) = (locate(c, r), locate(cb as usize, r + dr));
                        // Stored with the lower tile first (A bars point left).
                        let (a, b) = if a.tile < b.tile { (a, b) } else { (b, a) };
                        layout.tiles[a.tile as usize].seams.push(SeamBar { a, b, rest, kind });
                    }
                }
            }
        }
        layout.row_starts.push(ops.len() as u32);
        layout.ops = Ops::new(ops);
        if lane_rests.iter().any(Option::is_some) {
            for (t, tile) in layout.tiles.iter_mut().enumerate() {
                let rest = |(op, rests): (&Op, &Option<Vec<[f32; LANES]>>)| {
                    rests.as_ref().map_or(F32x8::splat(op.rest), |r| F32x8(r[t]))
                };
                tile.rests = layout.ops.iter().zip(&lane_rests).map(rest).collect();
            }
        }
        for tile in &mut layout.tiles {
            let (seams, ends) = seam_groups(&tile.seams, block as u32);
            (tile.seams, tile.seam_ends) = (seams, ends);
            tile.seam_multipliers = vec![0.0; tile.seams.len()];
        }
        let mut presence = vec![vec![F32x8::splat(0.0); slots]; tile_count];
        for tile in &mut layout.tiles {
            tile.scene = vec![[u32::MAX; LANES]; slots];
        }
        for (i, loc) in layout.locations.iter().enumerate() {
            presence[loc.tile as usize][loc.slot as usize].0[loc.lane as usize] = 1.0;
            layout.tiles[loc.tile as usize].scene[loc.slot as usize][loc.lane as usize] = i as u32;
        }
        for (tile, presence) in layout.tiles.iter_mut().zip(presence) {
            if presence.iter().any(|p| p.0.contains(&0.0)) {
                tile.presence = presence;
            }
        }
        layout.scene_rows = scene_rows(&layout.tiles, &layout.locations, block);
        layout.tile_rows = vec![0];
        for tile in &layout.tiles {
            layout.lane_rows.extend(tile.scene.iter().flatten().filter(|&&i| i != u32::MAX));
            layout.tile_rows.push(layout.lane_rows.len());
        }
        layout.refresh_shares();
        Some(layout)
    }

    fn cell_mut(&mut self, loc: Location) -> (&mut Slot, &mut Slot, &mut F32x8) {
        let tile = &mut self.tiles[loc.tile as usize];
        let s = loc.slot as usize;
        (&mut tile.position[s], &mut tile.displacement[s], &mut tile.weight[s])
    }

    /// Loads positions, displacements (x − x_prev) and inverse masses; sets
    /// up the tether arrays.
    pub(crate) fn write_state(&mut self, positions: &[Vec3], previous: &[Vec3], inverse_mass: &[f32]) {
        for i in 0..positions.len() {
            let loc = self.locations[i];
            let l = loc.lane as usize;
            let (p, d, w) = self.cell_mut(loc);
            let dv = positions[i] - previous[i];
            for k in 0..3 {
                p[k].0[l] = positions[i][k];
                d[k].0[l] = dv[k];
            }
            w.0[l] = inverse_mass[i];
        }
        self.refresh_tethers();
        self.refresh_shares();
    }

    /// Recomputes `uniform`, every slot's shares and every operation's.
    fn refresh_shares(&mut self) {
        self.reshare = false;
        self.uniform = self.tiles.iter().all(|t| t.weight.iter().all(|w| w.0.iter().all(|&w| w == 0.0 || w == 1.0)));
        let shares = self.shares;
        for tile in &mut self.tiles {
            for (shared, s) in tile.shared.iter_mut().zip(shares) {
                shared.clear();
                shared.extend((0..tile.weight.len()).map(|slot| {
                    let lane = |l: usize| {
                        let present = tile.presence.is_empty() || tile.presence[slot].0[l] > 0.0;
                        s.weights(tile.weight[slot].0[l], present)
                    };
                    let lanes: [Weights<f32>; LANES] = std::array::from_fn(lane);
                    Weights { own: F32x8(lanes.map(|w| w.own)), partner: F32x8(lanes.map(|w| w.partner)) }
                }));
            }
            tile.op_shares_stale = true;
        }
        self.refresh_op_shares();
    }

    /// Recomputes the operations' shares of every tile whose weights were
    /// written since (once however many were), or drops them when the
    /// layout left the share form. O(operations) a tile, between steps.
    fn refresh_op_shares(&mut self) {
        for tile in &mut self.tiles {
            if !self.uniform {
                tile.op_shares = Vec::new();
            } else if tile.op_shares_stale {
                tile.op_shares.clear();
                tile.op_shares.extend(self.ops.iter().map(|&op| sweep::op_shares(&tile.shared[op.kind()], op)));
            }
            tile.op_shares_stale = false;
        }
    }

    /// Sets the shares for β and ω, recomputing the slots' if they changed
    /// or a weight written since asks for it ([`Self::write_weight`]).
    fn use_shares(&mut self, shares: [Shares; KINDS]) {
        if shares != self.shares || self.reshare {
            self.shares = shares;
            self.refresh_shares();
        } else {
            self.refresh_op_shares();
        }
    }

    /// Writes one particle's weight; keeps its shares in step (a write of
    /// one lane, and its tile's operations' shares marked for recomputing
    /// before the next relaxation), or leaves the share form if the weight
    /// is not 0 or 1.
    /// A 0 or 1 written outside the share form may let the layout return to
    /// it: the next relaxation checks, once, however many weights were
    /// written (checking at every write made a change of every weight
    /// quadratic: 5.4 s for the 256 × 256 cloth going back from a density to
    /// a mass per particle).
    fn write_weight(&mut self, index: usize, weight: f32) {
        let loc = self.locations[index];
        let (t, s, l) = (loc.tile as usize, loc.slot as usize, loc.lane as usize);
        self.tiles[t].weight[s].0[l] = weight;
        if weight != 0.0 && weight != 1.0 {
            self.uniform = false;
        } else if self.uniform {
            for (shared, s_kind) in self.tiles[t].shared.iter_mut().zip(self.shares) {
                let w = s_kind.weights(weight, true);
                shared[s].own.0[l] = w.own;
                shared[s].partner.0[l] = w.partner;
            }
            self.tiles[t].op_shares_stale = true;
        } else {
            self.reshare = true;
        }
    }

    /// Sets up the lane arrays of tether anchor positions and rest path
    /// lengths (+∞ for untethered particles).
    fn refresh_tethers(&mut self) {
        if self.tethers.is_none() {
            return;
        }
        for tile in &mut self.tiles {
            tile.tether_anchor = vec![[F32x8::default(); 3]; tile.position.len()];
            tile.tether_length = vec![F32x8::splat(f32::INFINITY); tile.position.len()];
        }
        self.copy_anchor_positions(None);
    }

    /// Copies anchor positions into the lane arrays of the particles tied to
    /// `only` (every tethered particle when `None`).
    fn copy_anchor_positions(&mut self, only: Option<u32>) {
        let Some(tethers) = &self.tethers else {
            return;
        };
        for (i, anchor) in tethers.anchor.iter().enumerate() {
            let Some(anchor) = *anchor else { continue };
            if only.is_some_and(|o| o != anchor) {
                continue;
            }
            let (at, loc) = (self.locations[anchor as usize], self.locations[i]);
            let from = self.tiles[at.tile as usize].position[at.slot as usize].map(|c| c.0[at.lane as usize]);
            let tile = &mut self.tiles[loc.tile as usize];
            let (s, l) = (loc.slot as usize, loc.lane as usize);
            for (k, &c) in from.iter().enumerate() {
                tile.tether_anchor[s][k].0[l] = c;
            }
            tile.tether_length[s].0[l] = tethers.length[i];
        }
    }

    /// Sets every free particle's displacement to `dt · v₀ + w · extra` (equation 2).
    fn set_initial_velocity(&mut self, velocity: &[Vec3], dt: f32, extra: Vec3) {
        for (i, &v) in velocity.iter().enumerate() {
            let loc = self.locations[i];
            let l = loc.lane as usize;
            let (_, d, w) = self.cell_mut(loc);
            let w = w.0[l];
            if w > 0.0 {
                for k in 0..3 {
                    d[k].0[l] = v[k] * dt + extra[k] * w;
                }
            }
        }
    }

    /// A few words on the layout.
    fn layout_words(&self) -> String {
        let o = &self.orientation;
        let (columns, rows) = o.size();
        let sweep = match (o.transposed, o.flipped) {
            (false, false) => "top to bottom",
            (false, true) => "bottom to top",
            (true, false) => "left to right",
            (true, true) => "right to left",
        };
        let tiles = self.tiles.len();
        format!(
            "{tiles} tile{} × 8 lanes × {} columns, {rows} rows of {columns} swept {sweep}{}",
            if tiles == 1 { "" } else { "s" },
            self.block,
            self.found.unwrap_or_default()
        )
    }

    fn parallel(&self) -> bool {
        self.parallel && rayon::current_num_threads() > 1
    }
}
