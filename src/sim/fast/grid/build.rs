//! Building the grid's lane layout ([`GridLayout::new`]): the orientation
//! whose sweep starts at the pins ([`Orientation::choose`]), the tiles and
//! block width, every operation found in the mesh's bar table
//! ([`op_bar`]), the seam bars grouped into independent eights
//! ([`seam_groups`]) and the scene's rows as the lanes hold them
//! ([`scene_rows`]). The layout itself and its state are in the parent
//! module, whose docs give the layout this builds.

use glam::Vec3;

use super::ops::{KIND_SHIFT, Op, Ops, ROTATED};
use super::{GridLayout, KINDS, Location, Offset, PARALLEL_PARTICLES, SeamBar, TARGET_BLOCK, Tile, shape};
use crate::sim::fast::THREAD_SHARES;
use crate::sim::fast::kernel::{F32x8, LANES, Real, Shares};
use crate::sim::mesh::{ClothMesh, GridShape};
use crate::sim::tether::Tethers;

/// For each scene row, the first slot of the layout row that holds it,
/// when the scene is numbered as the lanes hold it: scene row r of `width`
/// = tiles · 8 · `block` particles is, in tile t, lane l, slot s₀ + k, the
/// particle r · width + t · 8 · block + l · block + k (a grid that is not
/// transposed, flipped or not, with no padding). Then the scene order is
/// read out of the lanes without a particle looked up. Empty when any
/// particle is elsewhere.
pub(super) fn scene_rows(tiles: &[Tile], locations: &[Location], block: usize) -> Vec<u32> {
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
pub(super) fn seam_groups(seams: &[SeamBar], block: u32) -> (Vec<SeamBar>, Vec<u32>) {
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
pub(super) struct Orientation {
    /// The scene's grid.
    pub(super) shape: GridShape,
    /// Scene rows are internal columns.
    pub(super) transposed: bool,
    /// Internal rows run from the scene's last to its first.
    pub(super) flipped: bool,
}

impl Orientation {
    /// Internal (columns, rows).
    pub(super) fn size(&self) -> (usize, usize) {
        let (c, r) = (self.shape.columns as usize, self.shape.rows as usize);
        if self.transposed { (r, c) } else { (c, r) }
    }

    /// Internal (column, row) of scene particle `i`.
    pub(super) fn cell(&self, i: usize) -> (usize, usize) {
        let (c, r) = (i % self.shape.columns as usize, i / self.shape.columns as usize);
        let (c, r) = if self.transposed { (r, c) } else { (c, r) };
        let rows = self.size().1;
        if self.flipped { (c, rows - 1 - r) } else { (c, r) }
    }

    /// The orientation whose sweep starts nearest the fixed particles (their
    /// mean row, as a share of the rows, is smallest), among those with at
    /// least 17 columns so a block has 3 or more. Ties keep the scene's own.
    pub(super) fn choose(shape: GridShape, fixed: &[bool]) -> Option<Orientation> {
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
}
