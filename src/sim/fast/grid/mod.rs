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
//! the seam bars are grouped even rows first, then odd ones ([`build::seam_groups`];
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
//!
//! [`ContactStep::resolve`]: crate::sim::contact::ContactStep::resolve

mod build;
mod op_shares;
mod ops;
mod phases;
mod scene;
mod shape;
mod sweep;
#[cfg(test)]
pub(crate) mod tests;

use glam::Vec3;

use super::kernel::{F32x8, LANES, Point, Real, Shares, Weights};
use crate::sim::mesh::BarKind;
use crate::sim::tether::Tethers;
use build::Orientation;
use ops::{Op, Ops};

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
    /// Every operation's shares ([`op_shares::op_shares`], from `shared`),
    /// each distinct value once, while the layout is in the share form: an
    /// operation loads its two where it loaded its slots' four. Empty
    /// otherwise. Recomputed before the next relaxation when
    /// `op_shares_stale` (a weight of the tile was written).
    op_shares: op_shares::ShareTable,
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
    /// in groups of at most eight that share no particle ([`build::seam_groups`]).
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
    /// order ([`build::scene_rows`]); empty otherwise.
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
                tile.op_shares = op_shares::ShareTable::default();
            } else if tile.op_shares_stale {
                tile.op_shares = op_shares::ShareTable::build(self.ops.iter(), &tile.shared);
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
