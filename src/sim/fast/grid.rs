//! The lane layout for grids: eight blocks of columns side by side in SIMD
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
//! within a class slot by slot. Lanes are far apart, so the eight bars of an
//! operation never share a particle. This is the seed's creation order up to
//! where each bar falls within its row, and converges as fast per pass.
//!
//! **Tiles and threads.** Bars between a tile's lane 7 and the next tile's
//! lane 0 ("seams") are projected one by one by the tile on their left, after
//! its own bars. Even tiles sweep first, then odd ones, so no two tiles being
//! swept at once share a particle. Tiles are sized from the grid alone, never
//! from the thread count, so one thread or many give the same bits; grids of
//! at least [`PARALLEL_PARTICLES`] sweep their tiles on the rayon pool.
//!
//! Columns past the end of the grid are padding, marked absent; every bar
//! touching them is a no-op (see [`super::kernel`]).

use glam::Vec3;
use multiversion::multiversion;
use rayon::prelude::*;

use super::kernel::{
    ABSENT, F32x8, FIXED, FREE, LANES, Point, Real, Shares, Weights, excess, integrate, relax_pair, settle,
};
use crate::sim::mesh::{ClothMesh, GridShape};

/// Columns per block the tiling aims at; a tile holds `8 · block` columns.
const TARGET_BLOCK: usize = 8;
/// Grids of at least this many particles sweep tiles on the thread pool.
pub(crate) const PARALLEL_PARTICLES: usize = 16_384;
/// Marks an operation whose far slot is rotated by one lane.
const ROTATED: u32 = 1 << 31;

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

/// One 8-bar operation: slots `a` and `b & !ROTATED` of a tile.
#[derive(Clone, Copy, Debug)]
struct Op {
    a: u32,
    b: u32,
    rest: f32,
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
}

#[derive(Clone, Debug)]
struct Tile {
    position: Vec<Slot>,
    displacement: Vec<Slot>,
    predicted: Vec<Slot>,
    state: Vec<F32x8>,
    /// The projection weights of `state` (kept in step with it).
    weights: Vec<Weights<F32x8>>,
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
    ops: Vec<Op>,
    /// `ops[row_starts[r]..row_starts[r + 1]]` are the bars starting in row r.
    row_starts: Vec<u32>,
    /// `seams[t]`: the bars between tile t and tile t + 1.
    seams: Vec<Vec<SeamBar>>,
    /// Scene particle index → location.
    locations: Vec<Location>,
    orientation: Orientation,
}

impl GridLayout {
    /// Builds the lane layout of a grid mesh, or `None` when the mesh lacks
    /// the regular structure it needs (the coloured path runs instead).
    pub(crate) fn new(mesh: &ClothMesh, positions: &[Vec3], previous: &[Vec3], fixed: &[bool]) -> Option<Self> {
        let orientation = Orientation::choose(mesh.grid()?, fixed)?;
        let (columns, rows) = orientation.size();
        // Every bar must belong to a class, each class must be complete and
        // of one rest length (up to rounding).
        let mut classes: Vec<(Offset, f64, f32, f32, usize)> = Vec::new();
        for bar in mesh.bars() {
            let (ca, ra) = orientation.cell(bar.a as usize);
            let (cb, rb) = orientation.cell(bar.b as usize);
            let offset = Offset::from_delta(cb as isize - ca as isize, rb as isize - ra as isize)?;
            let l = bar.rest_length;
            match classes.iter_mut().find(|s| s.0 == offset) {
                Some(s) => *s = (offset, s.1 + f64::from(l), s.2.min(l), s.3.max(l), s.4 + 1),
                None => classes.push((offset, f64::from(l), l, l, 1)),
            }
        }
        let mut rests = Vec::new();
        for offset in Offset::ALL {
            if let Some(&(_, sum, lo, hi, count)) = classes.iter().find(|s| s.0 == offset) {
                if count != offset.full_count(columns, rows) || hi - lo > 1e-5 * hi {
                    return None;
                }
                rests.push((offset, (sum / count as f64) as f32));
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
            state: vec![F32x8::splat(ABSENT); slots],
            weights: vec![Weights::default(); slots],
        };
        let locations = (0..positions.len()).map(|i| orientation.cell(i)).map(|(c, r)| locate(c, r)).collect();
        let mut layout = GridLayout {
            block,
            tiles: vec![empty; tile_count],
            ops: Vec::new(),
            row_starts: Vec::with_capacity(rows + 1),
            seams: vec![Vec::new(); tile_count - 1],
            locations,
            orientation,
        };
        layout.write_state(positions, previous, fixed);

        let slot = |r: usize, k: usize| (r * block + k) as u32;
        for r in 0..rows {
            layout.row_starts.push(layout.ops.len() as u32);
            for &(offset, rest) in &rests {
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
                    let op = if kb < 0 {
                        // A bar to the previous block: seen from its lower end.
                        Op { a: slot(r + dr, (kb + block as isize) as usize), b: slot(r, k) | ROTATED, rest }
                    } else if kb as usize >= block {
                        Op { a: slot(r, k), b: slot(r + dr, kb as usize - block) | ROTATED, rest }
                    } else {
                        Op { a: slot(r, k), b: slot(r + dr, kb as usize), rest }
                    };
                    layout.ops.push(op);
                }
                // Bars from this row that cross into the next tile.
                for c in 0..columns {
                    let cb = c as isize + dc;
                    if (0..columns as isize).contains(&cb) && c / (LANES * block) != cb as usize / (LANES * block) {
                        let (a, b) = (locate(c, r), locate(cb as usize, r + dr));
                        // Stored with the lower tile first (A bars point left).
                        let (a, b) = if a.tile < b.tile { (a, b) } else { (b, a) };
                        layout.seams[a.tile as usize].push(SeamBar { a, b, rest });
                    }
                }
            }
        }
        layout.row_starts.push(layout.ops.len() as u32);
        Some(layout)
    }

    fn cell_mut(&mut self, loc: Location) -> (&mut Slot, &mut Slot, &mut F32x8) {
        let tile = &mut self.tiles[loc.tile as usize];
        let s = loc.slot as usize;
        (&mut tile.position[s], &mut tile.displacement[s], &mut tile.state[s])
    }

    /// Loads positions, displacements (x − x_prev) and fixed flags.
    pub(crate) fn write_state(&mut self, positions: &[Vec3], previous: &[Vec3], fixed: &[bool]) {
        for i in 0..positions.len() {
            let loc = self.locations[i];
            let l = loc.lane as usize;
            let (p, d, u) = self.cell_mut(loc);
            let dv = positions[i] - previous[i];
            for k in 0..3 {
                p[k].0[l] = positions[i][k];
                d[k].0[l] = dv[k];
            }
            u.0[l] = if fixed[i] { FIXED } else { FREE };
        }
        for tile in &mut self.tiles {
            tile.weights = tile.state.iter().map(|&u| Shares::RIGID.weights(u)).collect();
        }
    }

    /// Positions and previous positions (x − d) in scene order.
    pub(crate) fn read_state(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        for (i, loc) in self.locations.iter().enumerate() {
            let tile = &self.tiles[loc.tile as usize];
            let (s, l) = (loc.slot as usize, loc.lane as usize);
            let (p, d) = (&tile.position[s], &tile.displacement[s]);
            positions[i] = Vec3::new(p[0].0[l], p[1].0[l], p[2].0[l]);
            previous[i] = positions[i] - Vec3::new(d[0].0[l], d[1].0[l], d[2].0[l]);
        }
    }

    /// Sets one particle's position and previous position.
    pub(crate) fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        let loc = self.locations[index];
        let l = loc.lane as usize;
        let (p, d, _) = self.cell_mut(loc);
        for k in 0..3 {
            p[k].0[l] = position[k];
            d[k].0[l] = position[k] - previous[k];
        }
    }

    /// Sets every free particle's displacement to `dt · v₀` (equation 2).
    pub(crate) fn set_initial_velocity(&mut self, velocity: &[Vec3], dt: f32) {
        for (i, &v) in velocity.iter().enumerate() {
            let loc = self.locations[i];
            let l = loc.lane as usize;
            let (_, d, u) = self.cell_mut(loc);
            if u.0[l] == FREE {
                for k in 0..3 {
                    d[k].0[l] = v[k] * dt;
                }
            }
        }
    }

    /// The first scene particle with a non-finite coordinate, if any.
    pub(crate) fn first_non_finite(&self) -> Option<usize> {
        if self.tiles.iter().all(|t| all_finite(&t.position)) {
            return None;
        }
        self.locations.iter().position(|loc| {
            let p = &self.tiles[loc.tile as usize].position[loc.slot as usize];
            !p.iter().all(|c| c.0[loc.lane as usize].is_finite())
        })
    }

    /// A few words on the layout.
    pub(crate) fn describe(&self) -> String {
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

    /// One step: integrate with `keep = 1 − δ` and `accel = h²f/m` (the first
    /// step passes keep = 1, accel = 0 after [`Self::set_initial_velocity`]),
    /// then up to `relaxations` sweeps; when `tolerance > 0`, stops after a
    /// sweep in which every movable bar was within `tolerance` (relative)
    /// before its projection. Returns the sweeps done.
    pub(crate) fn step(&mut self, keep: f32, accel: Vec3, relaxations: u32, tolerance: f32, parallel: bool) -> u32 {
        let accel = accel.to_array();
        for_each_tile(&mut self.tiles, parallel, |tile| {
            integrate_tile(tile, keep, accel);
            f32::NEG_INFINITY
        });
        let mut sweeps = 0;
        if tolerance <= 0.0 && self.tiles.len() == 1 {
            // One tile and a fixed number of sweeps: overlap them.
            for tile in &mut self.tiles {
                sweep_tile_pipelined(tile, &self.ops, &self.row_starts, relaxations);
            }
            sweeps = relaxations;
        }
        while sweeps < relaxations {
            sweeps += 1;
            let worst = self.sweep_tiles(tolerance, parallel);
            if tolerance > 0.0 && worst <= 0.0 {
                break;
            }
        }
        for_each_tile(&mut self.tiles, parallel, |tile| {
            settle_tile(tile);
            f32::NEG_INFINITY
        });
        sweeps
    }

    /// One sweep of every tile and of the seam bars between tiles. Tile t
    /// owns the seam bars to tile t + 1 and relaxes them after its own bars.
    /// Even tiles go first, in parallel (a pair (t, t + 1) each, so no two
    /// tasks touch the same tile), then odd tiles. The order is fixed by the
    /// tiling alone, so the result does not depend on the number of threads.
    /// Returns the largest excess over tolerance (see [`excess`]).
    fn sweep_tiles(&mut self, tolerance: f32, parallel: bool) -> f32 {
        let (ops, seams) = (&self.ops[..], &self.seams[..]);
        let mut worst = f32::NEG_INFINITY;
        for first in [0, 1] {
            let sweep_pair = |(i, pair): (usize, &mut [Tile])| {
                let t = first + 2 * i;
                match pair {
                    [a, b] => sweep_tile(a, ops, tolerance).max(relax_boundary(a, b, &seams[t], tolerance)),
                    [a] => sweep_tile(a, ops, tolerance),
                    _ => f32::NEG_INFINITY,
                }
            };
            let count = self.tiles.len();
            let tiles = &mut self.tiles[first.min(count)..];
            let w = if parallel {
                tiles.par_chunks_mut(2).enumerate().map(sweep_pair).reduce(|| f32::NEG_INFINITY, f32::max)
            } else {
                tiles.chunks_mut(2).enumerate().map(sweep_pair).fold(f32::NEG_INFINITY, f32::max)
            };
            worst = worst.max(w);
        }
        worst
    }
}

/// Projects the seam bars between tiles `a` and the next, `b`, in order.
fn relax_boundary(a: &mut Tile, b: &mut Tile, seams: &[SeamBar], tolerance: f32) -> f32 {
    let mut worst = f32::NEG_INFINITY;
    let lane = |w: &Weights<F32x8>, l: usize| Weights { own: w.own.0[l], partner: w.partner.0[l] };
    for seam in seams {
        let (sa, la, sb, lb) = (seam.a.slot as usize, seam.a.lane as usize, seam.b.slot as usize, seam.b.lane as usize);
        let mut pa = a.position[sa].map(|c| c.0[la]);
        let mut pb = b.position[sb].map(|c| c.0[lb]);
        let (wa, wb) = (lane(&a.weights[sa], la), lane(&b.weights[sb], lb));
        let v = relax_pair(&mut pa, wa, &mut pb, wb, seam.rest);
        for k in 0..3 {
            a.position[sa][k].0[la] = pa[k];
            b.position[sb][k].0[lb] = pb[k];
        }
        worst = worst.max(excess(v, wa, wb, tolerance * seam.rest));
    }
    worst
}

/// Applies `f` to every tile, on the thread pool when `parallel`, and returns
/// the largest result. max is exact and order-free, so the result is the same
/// on any number of threads.
fn for_each_tile(tiles: &mut [Tile], parallel: bool, f: impl Fn(&mut Tile) -> f32 + Sync + Send) -> f32 {
    if parallel {
        tiles.par_iter_mut().map(f).reduce(|| f32::NEG_INFINITY, f32::max)
    } else {
        tiles.iter_mut().map(f).fold(f32::NEG_INFINITY, f32::max)
    }
}

fn all_finite(slots: &[Slot]) -> bool {
    // x·0 is 0 for finite x and NaN otherwise; one NaN makes the sum NaN.
    let mut acc = F32x8::splat(0.0);
    for s in slots {
        for c in s {
            acc = acc + *c * F32x8::splat(0.0);
        }
    }
    acc.0.iter().all(|a| *a == 0.0)
}

#[multiversion(targets("x86_64+avx2+fma"))]
fn integrate_tile(tile: &mut Tile, keep: f32, accel: [f32; 3]) {
    let (keep, accel) = (F32x8::splat(keep), accel.map(F32x8::splat));
    let Tile { position, displacement, predicted, state, .. } = tile;
    for (((x, d), q), u) in position.iter_mut().zip(displacement).zip(predicted).zip(state.iter()) {
        *q = integrate(x, d, *u, keep, accel);
    }
}

#[multiversion(targets("x86_64+avx2+fma"))]
fn settle_tile(tile: &mut Tile) {
    let Tile { position, displacement, predicted, state, .. } = tile;
    for (((x, d), q), u) in position.iter().zip(displacement).zip(predicted.iter()).zip(state.iter()) {
        settle(d, *x, *q, *u);
    }
}

/// One relaxation sweep over every bar inside a tile. Returns the largest
/// excess over tolerance among movable bars (−∞ when not asked for).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn sweep_tile(tile: &mut Tile, ops: &[Op], tolerance: f32) -> f32 {
    let track = tolerance > 0.0;
    let mut worst = F32x8::splat(f32::NEG_INFINITY);
    let Tile { position, weights, .. } = tile;
    for op in ops {
        let (ia, ib) = (op.a as usize, (op.b & !ROTATED) as usize);
        let (violation, wa, wb) = if op.b & ROTATED == 0 {
            relax_slots(position, weights, ia, ib, op.rest)
        } else {
            relax_slots_rotated(position, weights, ia, ib, op.rest)
        };
        if track {
            worst = worst.max(excess(violation, wa, wb, F32x8::splat(op.rest * tolerance)));
        }
    }
    worst.max_lane()
}

/// Sweeps a tile `sweeps` times, giving exactly the result of
/// [`sweep_tile`] called `sweeps` times, but with up to [`PIPELINE_DEPTH`]
/// sweeps in flight: sweep s + 1 works on row r − 3 while sweep s works on
/// row r.
///
/// This is exact because the bars starting in row r touch rows r to r + 2
/// only: operations of rows three or more apart touch disjoint particles and
/// commute, so every pair of operations that share a particle still runs in
/// the sequential order. Interleaving the independent rows op by op gives the
/// CPU several dependency chains to overlap instead of one: a row of a narrow
/// cloth is otherwise one long chain of projections, each waiting for the
/// square root and division of the last.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn sweep_tile_pipelined(tile: &mut Tile, ops: &[Op], row_starts: &[u32], sweeps: u32) {
    const LAG: usize = 3;
    let rows = row_starts.len() - 1;
    let Tile { position, weights, .. } = tile;
    let mut done = 0;
    while done < sweeps {
        let depth = (sweeps - done).min(PIPELINE_DEPTH as u32) as usize;
        for t in 0..rows + LAG * (depth - 1) {
            // The rows in flight at time t, one per sweep.
            let mut groups = [(0usize, 0usize); PIPELINE_DEPTH];
            let mut longest = 0;
            for (s, group) in groups.iter_mut().enumerate().take(depth) {
                if let Some(r) = t.checked_sub(LAG * s).filter(|&r| r < rows) {
                    *group = (row_starts[r] as usize, row_starts[r + 1] as usize);
                    longest = longest.max(group.1 - group.0);
                }
            }
            for j in 0..longest {
                for &(start, end) in &groups[..depth] {
                    if start + j < end {
                        let op = ops[start + j];
                        let (ia, ib) = (op.a as usize, (op.b & !ROTATED) as usize);
                        if op.b & ROTATED == 0 {
                            relax_slots(position, weights, ia, ib, op.rest);
                        } else {
                            relax_slots_rotated(position, weights, ia, ib, op.rest);
                        }
                    }
                }
            }
        }
        done += depth as u32;
    }
}

/// Sweeps in flight in [`sweep_tile_pipelined`].
const PIPELINE_DEPTH: usize = 4;

/// Projects lane l of `a` against lane l of `b` for every lane: the scalar
/// kernel in a loop that the compiler vectorises lane for lane.
#[inline(always)]
fn relax_lanes(a: &mut Slot, wa: &Weights<F32x8>, b: &mut Slot, wb: &Weights<F32x8>, rest: f32) -> F32x8 {
    let mut violation = F32x8::default();
    for l in 0..LANES {
        let mut pa = [a[0].0[l], a[1].0[l], a[2].0[l]];
        let mut pb = [b[0].0[l], b[1].0[l], b[2].0[l]];
        let wal = Weights { own: wa.own.0[l], partner: wa.partner.0[l] };
        let wbl = Weights { own: wb.own.0[l], partner: wb.partner.0[l] };
        violation.0[l] = relax_pair(&mut pa, wal, &mut pb, wbl, rest);
        for k in 0..3 {
            a[k].0[l] = pa[k];
            b[k].0[l] = pb[k];
        }
    }
    violation
}

/// Projects the eight bars between slot `ia` and slot `ib` (lane l to lane l).
#[inline(always)]
fn relax_slots(
    position: &mut [Slot],
    weights: &[Weights<F32x8>],
    ia: usize,
    ib: usize,
    rest: f32,
) -> (F32x8, Weights<F32x8>, Weights<F32x8>) {
    let (mut a, mut b, wa, wb) = (position[ia], position[ib], weights[ia], weights[ib]);
    let v = relax_lanes(&mut a, &wa, &mut b, &wb, rest);
    position[ib] = b;
    position[ia] = a;
    (v, wa, wb)
}

/// Projects the bars from lane l of slot `ia` to lane l + 1 of slot `ib` (the
/// next block). Lane 7's partner is in the next tile (a seam bar), so its
/// weights are zeroed and it does not move.
#[inline(always)]
fn relax_slots_rotated(
    position: &mut [Slot],
    weights: &[Weights<F32x8>],
    ia: usize,
    ib: usize,
    rest: f32,
) -> (F32x8, Weights<F32x8>, Weights<F32x8>) {
    let (mut a, wa) = (position[ia], weights[ia]);
    let mut b = position[ib].map(F32x8::rotate_down);
    let mut wb = Weights { own: weights[ib].own.rotate_down(), partner: weights[ib].partner.rotate_down() };
    wb.own.0[LANES - 1] = 0.0;
    wb.partner.0[LANES - 1] = 0.0;
    let v = relax_lanes(&mut a, &wa, &mut b, &wb, rest);
    position[ib] = b.map(F32x8::rotate_up);
    position[ia] = a;
    (v, wa, wb)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::mesh::{Bar, Grid, Pins};
    use crate::sim::reference::ReferenceSolver;

    impl GridLayout {
        /// Scene particle at a location, if any.
        fn scene_index(&self) -> std::collections::HashMap<(u32, u32, u8), u32> {
            self.locations.iter().enumerate().map(|(i, l)| ((l.tile, l.slot, l.lane), i as u32)).collect()
        }

        /// The bars one sweep projects, as scene particle pairs, in an order
        /// equivalent to the sweep's: even tiles then odd ones, each followed
        /// by its seam bars to the next tile (the lanes of one operation are
        /// independent, so any lane order will do).
        fn projection_order(&self) -> Vec<(u32, u32)> {
            let at = self.scene_index();
            let mut order = Vec::new();
            let count = self.tiles.len() as u32;
            for t in (0..count).step_by(2).chain((1..count).step_by(2)) {
                for op in &self.ops {
                    let rotated = op.b & ROTATED != 0;
                    for l in 0..LANES as u8 {
                        let lb = if rotated { l + 1 } else { l };
                        if let (Some(&a), Some(&b)) = (at.get(&(t, op.a, l)), at.get(&(t, op.b & !ROTATED, lb))) {
                            order.push((a, b));
                        }
                    }
                }
                for s in self.seams.get(t as usize).into_iter().flatten() {
                    order.push((at[&(s.a.tile, s.a.slot, s.a.lane)], at[&(s.b.tile, s.b.slot, s.b.lane)]));
                }
            }
            order
        }
    }

    /// Deterministic jitter in [−amount, amount).
    fn jittered(points: &[Vec3], amount: f32) -> Vec<Vec3> {
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0) * amount
        };
        points.iter().map(|&p| p + Vec3::new(next(), next(), next())).collect()
    }

    fn shapes() -> Vec<(Grid, &'static str)> {
        let g = |columns, rows, pins| Grid { columns, rows, spacing: 0.1, pins, ..Grid::default() };
        vec![
            (g(20, 30, Pins::TopRow), "the seed's 20 × 30, top row"),
            (g(30, 20, Pins::LeftColumn), "wide, pinned left: transposed"),
            (g(17, 23, Pins::Cells(vec![[3, 22], [16, 22]])), "pinned at the bottom: flipped; 17 columns pad lane 7"),
            (g(130, 12, Pins::TopCorners), "130 columns: three tiles and two seams"),
            (g(17, 17, Pins::None), "the narrowest grid with lanes (blocks of 3)"),
            (Grid { shear: false, ..g(24, 16, Pins::TopRow) }, "no diagonals"),
            (Grid { bend: false, ..g(24, 16, Pins::TopRow) }, "no bend bars"),
        ]
    }

    #[test]
    fn every_movable_bar_is_projected_once_per_sweep() {
        for (grid, what) in shapes() {
            let mesh = grid.build().unwrap();
            let fixed = mesh.fixed().to_vec();
            let layout = GridLayout::new(&mesh, mesh.positions(), mesh.positions(), &fixed).expect(what);
            let mut seen: Vec<(u32, u32)> = layout
                .projection_order()
                .into_iter()
                .filter(|&(a, b)| !(fixed[a as usize] && fixed[b as usize]))
                .map(|(a, b)| (a.min(b), a.max(b)))
                .collect();
            seen.sort_unstable();
            let mut expected: Vec<(u32, u32)> = mesh
                .bars()
                .iter()
                .filter(|b| !(fixed[b.a as usize] && fixed[b.b as usize]))
                .map(|b| (b.a.min(b.b), b.a.max(b.b)))
                .collect();
            expected.sort_unstable();
            assert_eq!(seen, expected, "{what}");
        }
    }

    #[test]
    fn a_sweep_equals_the_reference_loop_in_the_same_order() {
        // One sweep of the lanes from a jittered state against the plain
        // Gauss–Seidel loop over the same bars in the equivalent order. The
        // two differ only by rounding (the kernels compute the shares as
        // own·partner, the reference as w_a / (w_a + w_b)): a few ulps of
        // positions near 1 m. A bar missing, doubled or with the wrong rest
        // length or weight would move particles by millimetres.
        for (grid, what) in shapes() {
            let mesh = grid.build().unwrap();
            let fixed = mesh.fixed().to_vec();
            let start = jittered(mesh.positions(), 0.02);
            let start: Vec<Vec3> =
                start.iter().zip(mesh.positions()).zip(&fixed).map(|((&j, &p), &f)| if f { p } else { j }).collect();
            let mut layout = GridLayout::new(&mesh, &start, &start, &fixed).expect(what);
            let rest: std::collections::HashMap<(u32, u32), f32> =
                mesh.bars().iter().map(|b| ((b.a.min(b.b), b.a.max(b.b)), b.rest_length)).collect();
            let bars = layout
                .projection_order()
                .into_iter()
                .map(|(a, b)| Bar {
                    a,
                    b,
                    rest_length: rest[&(a.min(b), a.max(b))],
                    kind: crate::sim::BarKind::Structural,
                })
                .collect();
            let mut reference = ReferenceSolver {
                positions: start.clone(),
                previous: start.clone(),
                inverse_mass: fixed.iter().map(|&f| if f { 0.0 } else { 5.0 }).collect(),
                bars,
            };
            reference.relax_once();
            layout.step(1.0, Vec3::ZERO, 1, 0.0, false);
            let (mut got, mut previous) = (start.clone(), start.clone());
            layout.read_state(&mut got, &mut previous);
            let worst = got.iter().zip(&reference.positions).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);

            assert!(worst < 2e-6, "{what}: lanes and reference differ by {worst} m after one sweep");
            let moved = got.iter().zip(&start).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
            assert!(moved > 1e-3, "{what}: the sweep moved nothing ({moved} m)");
        }
    }

    #[test]
    fn overlapped_sweeps_are_bit_identical_to_sequential_ones() {
        let mesh = Grid { columns: 20, rows: 30, spacing: 0.1, ..Grid::default() }.build().unwrap();
        let fixed = mesh.fixed().to_vec();
        let start = jittered(mesh.positions(), 0.02);
        let mut overlapped = GridLayout::new(&mesh, &start, &start, &fixed).unwrap();
        let mut sequential = overlapped.clone();
        // 7 sweeps: one group of 4 in flight, then one of 3.
        overlapped.step(0.98, Vec3::new(0.0, -1e-3, 0.0), 7, 0.0, false);
        let tile = &mut sequential.tiles[0];
        integrate_tile(tile, 0.98, [0.0, -1e-3, 0.0]);
        for _ in 0..7 {
            sweep_tile(tile, &sequential.ops, 0.0);
        }
        settle_tile(tile);
        let bits = |l: &GridLayout| {
            let (mut p, mut q) = (vec![Vec3::ZERO; 600], vec![Vec3::ZERO; 600]);
            l.read_state(&mut p, &mut q);
            p.iter().chain(&q).flat_map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>()
        };
        assert_eq!(bits(&overlapped), bits(&sequential));
    }

    #[test]
    fn orientation_puts_the_pins_where_the_sweep_starts() {
        let o = |columns, rows, pins| {
            let mesh = Grid { columns, rows, pins, ..Grid::default() }.build().unwrap();
            let o = Orientation::choose(mesh.grid().unwrap(), mesh.fixed()).unwrap();
            (o.transposed, o.flipped)
        };
        assert_eq!(o(20, 30, Pins::TopRow), (false, false));
        assert_eq!(o(20, 30, Pins::LeftColumn), (true, false));
        assert_eq!(o(20, 30, Pins::Cells((0..20).map(|c| [c, 29]).collect())), (false, true));
        // Too narrow one way: only the orientation with ≥ 9 columns is allowed.
        assert!(o(6, 30, Pins::LeftColumn).0);
        assert!(Orientation::choose(GridShape { columns: 16, rows: 16 }, &[false; 256]).is_none());
    }
}
