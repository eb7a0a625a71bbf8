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
//! ```
//!
//! **Order.** Row by row; within a row class by class (H, V, D, A, BH, BV);
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
//! projections each waiting for the last). Even tiles sweep first, then odd ones, so no two tiles being
//! swept at once share a particle. Tiles are sized from the grid alone, never
//! from the thread count, so one thread or many give the same bits; grids of
//! at least [`PARALLEL_PARTICLES`] sweep their tiles on the rayon pool.
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

mod phases;
mod sweep;
#[cfg(test)]
mod tests;

use glam::Vec3;

use super::kernel::{F32x8, LANES, Point, Real, Shares, Weights};
use crate::sim::mesh::{BarKind, ClothMesh, GridShape};
use crate::sim::tether::Tethers;

/// Columns per block the tiling aims at; a tile holds `8 · block` columns.
const TARGET_BLOCK: usize = 8;
/// Grids of at least this many particles sweep tiles on the thread pool.
pub(crate) const PARALLEL_PARTICLES: usize = 16_384;
/// Marks an operation whose far slot is rotated by one lane (in `Op::b`).
const ROTATED: u32 = 1 << 31;
/// The bar kind of an operation ([`BarKind::index`]) sits in the top two
/// bits of `Op::a`.
const KIND_SHIFT: u32 = 30;
/// Bar kinds with their own shares and compliance.
const KINDS: usize = BarKind::COUNT;

type Slot = Point<F32x8>;

/// The six bar classes a grid can have (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Offset {
    H,
    BH,
    V,
    D,
    A,
    BV,
}

impl Offset {
    /// In the order a row's bars are relaxed.
    const ALL: [Offset; 6] = [Offset::H, Offset::V, Offset::D, Offset::A, Offset::BH, Offset::BV];

    /// (Δc, Δr) from the first particle to the second, with Δr ≥ 0.
    fn delta(self) -> (isize, usize) {
        match self {
            Offset::H => (1, 0),
            Offset::BH => (2, 0),
            Offset::V => (0, 1),
            Offset::D => (1, 1),
            Offset::A => (-1, 1),
            Offset::BV => (0, 2),
        }
    }

    fn from_delta(dc: isize, dr: isize) -> Option<Offset> {
        // Normalise so the second particle is below, or right on the same row.
        let (dc, dr) = if dr < 0 || (dr == 0 && dc < 0) { (-dc, -dr) } else { (dc, dr) };
        Offset::ALL.into_iter().find(|o| o.delta() == (dc, dr as usize))
    }

    /// How many bars of this class a full C × R grid has.
    fn full_count(self, columns: usize, rows: usize) -> usize {
        let (dc, dr) = self.delta();
        columns.saturating_sub(dc.unsigned_abs()) * rows.saturating_sub(dr)
    }
}

/// One 8-bar operation: slots `a` (below its kind bits) and `b & !ROTATED`
/// of a tile.
#[derive(Clone, Copy, Debug)]
struct Op {
    a: u32,
    b: u32,
    rest: f32,
}

impl Op {
    fn slots(self) -> (usize, usize) {
        ((self.a & ((1 << KIND_SHIFT) - 1)) as usize, (self.b & !ROTATED) as usize)
    }
    fn rotated(self) -> bool {
        self.b & ROTATED != 0
    }
    fn kind(self) -> usize {
        (self.a >> KIND_SHIFT) as usize
    }
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
    /// μ = βλ of every operation's eight bars (compliant bars only).
    multipliers: Vec<F32x8>,
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

/// A tile's seam bars (in row order, as built) in groups of at most eight
/// that share no particle, and where each group ends.
///
/// A seam bar starting in row r touches rows r and r + 1 only (it joins
/// columns across a tile's edge: H, BH, D or A, never V or BV), so bars of
/// rows two apart never share a particle. The rows are taken even ones
/// first, then odd ones, eight rows at a time, and the k-th seam bar of
/// each of those rows forms a group: eight independent projections, one
/// operation in lanes. Within a parity the groups go k by k, each k over
/// every eight rows: two groups in a row then share no particle either (the
/// eights of one parity touch disjoint rows), so one group's projection
/// need not wait for the last one's. The groups run in this order one after
/// the other, a Gauss–Seidel sweep over the seam bars like any other. `block`: columns
/// per lane (slot = row · block + column in the block).
fn seam_groups(seams: &[SeamBar], block: u32) -> (Vec<SeamBar>, Vec<u32>) {
    let row = |s: &SeamBar| s.a.slot.min(s.b.slot) / block;
    let mut rows: Vec<Vec<SeamBar>> = Vec::new();
    for s in seams {
        match rows.last_mut() {
            Some(last) if row(&last[0]) == row(s) => last.push(*s),
            _ => rows.push(vec![*s]),
        }
    }
    // Within a row, bars are told apart by kind, rest length and how many
    // of the same came before: the k-th bend bar of 2 spacings, say. The
    // last row lacks some (no diagonal leaves it); every row has its bars in
    // the order of the fullest row.
    let key = |row: &[SeamBar], i: usize| {
        let same = |s: &SeamBar| (s.kind, s.rest.to_bits()) == (row[i].kind, row[i].rest.to_bits());
        (row[i].kind, row[i].rest.to_bits(), row[..i].iter().filter(|s| same(s)).count())
    };
    let keys = |row: &[SeamBar]| (0..row.len()).map(|i| key(row, i)).collect::<Vec<_>>();
    let fullest = rows.iter().max_by_key(|r| r.len()).map(|r| keys(r)).unwrap_or_default();
    let (mut out, mut ends) = (Vec::with_capacity(seams.len()), Vec::new());
    for parity in 0..2 {
        let chosen: Vec<&Vec<SeamBar>> = rows.iter().skip(parity).step_by(2).collect();
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

    /// The scene particle at internal (column, row): the inverse of
    /// [`Self::cell`].
    fn index(&self, c: usize, r: usize) -> usize {
        let rows = self.size().1;
        let r = if self.flipped { rows - 1 - r } else { r };
        let (c, r) = if self.transposed { (r, c) } else { (c, r) };
        r * self.shape.columns as usize + c
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
    ops: Vec<Op>,
    /// `ops[row_starts[r]..row_starts[r + 1]]` are the bars starting in row r.
    row_starts: Vec<u32>,
    /// Scene particle index → location.
    locations: Vec<Location>,
    orientation: Orientation,
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
        let orientation = Orientation::choose(mesh.grid()?, &fixed)?;
        let (columns, rows) = orientation.size();
        // Every bar must belong to a class, each class must be complete, of
        // one kind and of one rest length (up to rounding).
        let mut classes: Vec<(Offset, BarKind, f64, f32, f32, usize)> = Vec::new();
        for bar in mesh.bars() {
            let (ca, ra) = orientation.cell(bar.a as usize);
            let (cb, rb) = orientation.cell(bar.b as usize);
            let offset = Offset::from_delta(cb as isize - ca as isize, rb as isize - ra as isize)?;
            let l = bar.rest_length;
            match classes.iter_mut().find(|s| s.0 == offset) {
                Some(s) if s.1 == bar.kind => *s = (offset, s.1, s.2 + f64::from(l), s.3.min(l), s.4.max(l), s.5 + 1),
                Some(_) => return None,
                None => classes.push((offset, bar.kind, f64::from(l), l, l, 1)),
            }
        }
        let mut rests = Vec::new();
        for offset in Offset::ALL {
            if let Some(&(_, kind, sum, lo, hi, count)) = classes.iter().find(|s| s.0 == offset) {
                if count != offset.full_count(columns, rows) || hi - lo > 1e-5 * hi {
                    return None;
                }
                rests.push((offset, kind, (sum / count as f64) as f32));
            }
        }
        let tile_count = columns.div_ceil(LANES * TARGET_BLOCK);
        let block = columns.div_ceil(LANES * tile_count);
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
        let locations = (0..positions.len()).map(|i| orientation.cell(i)).map(|(c, r)| locate(c, r)).collect();
        let mut layout = GridLayout {
            block,
            tiles: vec![empty; tile_count],
            ops: Vec::new(),
            row_starts: Vec::with_capacity(rows + 1),
            locations,
            orientation,
            tethers,
            parallel: positions.len() >= PARALLEL_PARTICLES,
            uniform: true,
            shares: [Shares::new(0.0, 1.0); KINDS],
            reshare: false,
        };
        layout.write_state(positions, previous, inverse_mass);

        let slot = |r: usize, k: usize| (r * block + k) as u32;
        for r in 0..rows {
            layout.row_starts.push(layout.ops.len() as u32);
            for &(offset, kind, rest) in &rests {
                let (dc, dr) = offset.delta();
                if r + dr >= rows {
                    continue;
                }
                let kind_bits = (kind.index() as u32) << KIND_SHIFT;
                // Bars along a row share particles with their neighbours:
                // relax every other one (H) or every other pair (BH) first,
                // so consecutive operations are independent.
                let period = 2 * dc.unsigned_abs().max(1);
                let order =
                    (0..period).flat_map(|phase| (0..block).filter(move |k| k % period / (period / 2) == phase));
                let order: Vec<usize> = if dr == 0 { order.collect() } else { (0..block).collect() };
                for k in order {
                    let kb = k as isize + dc;
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
                    // no-ops, so a pin is a write of a weight. (Lane 0 of
                    // tile 0 holds columns 0 to block − 1, all real, so every
                    // operation touches a particle.)
                    layout.ops.push(op);
                }
                // Bars from this row that cross into the next tile.
                for c in 0..columns {
                    let cb = c as isize + dc;
                    if (0..columns as isize).contains(&cb) && c / (LANES * block) != cb as usize / (LANES * block) {
                        let (a, b) = (locate(c, r), locate(cb as usize, r + dr));
                        // Stored with the lower tile first (A bars point left).
                        let (a, b) = if a.tile < b.tile { (a, b) } else { (b, a) };
                        let kind = kind.index() as u8;
                        layout.tiles[a.tile as usize].seams.push(SeamBar { a, b, rest, kind });
                    }
                }
            }
        }
        layout.row_starts.push(layout.ops.len() as u32);
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

    /// Recomputes `uniform` and every slot's shares.
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
        }
    }

    /// Sets the shares for β and ω, recomputing the slots' if they changed
    /// or a weight written since asks for it ([`Self::write_weight`]).
    fn use_shares(&mut self, shares: [Shares; KINDS]) {
        if shares != self.shares || self.reshare {
            self.shares = shares;
            self.refresh_shares();
        }
    }

    /// Writes one particle's weight; keeps its shares in step (a write of
    /// one lane), or leaves the share form if the weight is not 0 or 1.
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
            "{tiles} tile{} × 8 lanes × {} columns, {rows} rows of {columns} swept {sweep}",
            if tiles == 1 { "" } else { "s" },
            self.block
        )
    }

    fn parallel(&self) -> bool {
        self.parallel && rayon::current_num_threads() > 1
    }
}
