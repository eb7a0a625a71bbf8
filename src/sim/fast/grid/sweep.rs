//! The relaxation sweeps of the lane layout: tiles, seam bars between
//! tiles, overlapped passes on a single tile, and the 8-bar operation.

use rayon::prelude::*;

use super::op_shares::{OpShares, ShareTable};
use super::{Op, Ops, SeamBar, Slot, Tile};
use crate::sim::fast::graph::{self, Chain, Schedule, Task};
use crate::sim::fast::kernel::{F32x8, LANES, Real, excess, relax_pair, relax_pair_shared};
use crate::sim::fast::simd::dispatch;

dispatch! {
    /// [`sweep_tile_pipelined_body`] at the chosen SIMD level, compiled for
    /// AVX2 and FMA at the AVX-512 level too: with AVX-512 enabled the
    /// compiler joins an operation's x and y rows into 512-bit registers
    /// (two `vinsertf64x4` an operation), which Zen 4 runs as two halves;
    /// the AVX2 code took the seed's step from 59.4–67.1 to 54.6–55.1 µs on
    /// host D (alternated runs). The tiles' own sweep ([`sweep_tile`]) keeps
    /// AVX-512 on AMD: there it was the faster (256 × 256 on one thread
    /// 6.05–6.17 against 6.34–6.43 ms); on Intel, 512-bit vectors made it
    /// the slower, and the AVX-512 level runs its AVX2 build
    /// ([`crate::sim::fast::simd::VectorWidth`]).
    pub(super) fn sweep_tile_pipelined(tile: &mut Tile, sweep: &Sweep, row_starts: &[u32], sweeps: u32)
        = sweep_tile_pipelined_body::<fused>, best = ["x86_64+avx2+fma"]
}

/// What every sweep of a substep needs.
#[derive(Clone, Copy)]
pub(super) struct Sweep<'a> {
    /// Every weight is 0 or 1: use the tiles' shares.
    pub(super) uniform: bool,
    pub(super) ops: &'a Ops,
    pub(super) tolerance: f32,
    /// β of structural, bend and shear bars.
    pub(super) betas: [f32; crate::sim::BarKind::COUNT],
    /// ω, over-relaxation.
    pub(super) omega: f32,
    /// Whether any bar is compliant (then μ is kept).
    pub(super) compliant: bool,
}

/// One sweep of every tile and of the seam bars between tiles. Tile t owns
/// the seam bars to tile t + 1 and relaxes them after its own bars. Even
/// tiles go first, in parallel (a pair (t, t + 1) each, so no two tasks touch
/// the same tile), then odd tiles. The order is fixed by the tiling alone, so
/// the result does not depend on the number of threads. Returns the largest
/// excess over tolerance (see [`excess`]).
pub(super) fn sweep_tiles(all: &mut [Tile], sweep: &Sweep, parallel: bool) -> f32 {
    let mut worst = f32::NEG_INFINITY;
    for first in [0, 1] {
        let count = all.len();
        let tiles = &mut all[first.min(count)..];
        let sweep_pair = |pair: &mut [Tile]| match pair {
            [a, b] => sweep_tile(a, sweep).max(relax_boundary(a, b, sweep)),
            [a] => sweep_tile(a, sweep),
            _ => f32::NEG_INFINITY,
        };
        let w = if parallel {
            tiles.par_chunks_mut(2).map(sweep_pair).reduce(|| f32::NEG_INFINITY, f32::max)
        } else {
            tiles.chunks_mut(2).map(sweep_pair).fold(f32::NEG_INFINITY, f32::max)
        };
        worst = worst.max(w);
    }
    worst
}

/// The tiles as the tasks of a [`Schedule`] reach them from several
/// threads.
struct Tiles {
    first: *mut Tile,
    len: usize,
}

// SAFETY: `Tiles` is shared only by `sweep_passes`'s tasks, which
// `graph::run` never runs at once when they touch a common tile (a task
// touches its tile and the next; the schedule orders every such pair:
// `graph`'s module docs and its test
// `tasks_that_share_a_particle_are_always_ordered`), while the tiles stay
// mutably borrowed by `sweep_passes`.
#[allow(unsafe_code)]
unsafe impl Sync for Tiles {}

/// `passes` sweeps with no tolerance. Where `parallel` and there are two
/// tiles or more, as a graph of tasks on the pool's threads
/// ([`crate::sim::fast::graph`], [`Chain::Tiles`]: tile t's task is its
/// sweep and its seam to tile t + 1, and waits only on the tasks of tiles
/// t ± 1); else round by round ([`sweep_tiles`]). The same bits either way.
///
/// Measured on the 256 × 256 cloth hanging (4 tiles, two threads, host
/// G, both schedules alternated in one process): the rounds' step 5.02–5.18
/// ms, the graph's 4.29–4.42 ms (−12 to −17 %). The rounds' 40 fork-joins
/// a step each woke the second worker, which had gone to sleep.
///
/// Kept out of line: inlined into the relax phase, it made the seed's
/// one-tile step (which never calls it) 0.049–0.052 → 0.066–0.073 ms in
/// the ratios benchmark's binary (not in a probe's), with the same
/// instructions in the sweep at the same alignment, and with every loop
/// aligned to 64 bytes.
#[allow(unsafe_code)]
#[inline(never)]
pub(super) fn sweep_passes(all: &mut [Tile], sweep: &Sweep, passes: u32, parallel: bool) {
    let (threads, count) = (rayon::current_num_threads(), all.len());
    if !parallel || threads == 1 || count < 2 {
        for _ in 0..passes {
            sweep_tiles(all, sweep, parallel);
        }
        return;
    }
    let tiles = &Tiles { first: all.as_mut_ptr(), len: count };
    let relax = |t: Task| {
        assert!(t.node < tiles.len, "tile {} of {}", t.node, tiles.len);
        // SAFETY: the pointer comes from a `&mut` borrow held for this
        // call, the tiles lie within it (asserted), and no other task that
        // touches tile t or t + 1 runs now (`Tiles`).
        let a = unsafe { &mut *tiles.first.add(t.node) };
        sweep_tile(a, sweep);
        if t.node + 1 < tiles.len {
            // SAFETY: as for tile t; tile t + 1 is another tile than a.
            let b = unsafe { &mut *tiles.first.add(t.node + 1) };
            relax_boundary(a, b, sweep);
        }
    };
    graph::run(Schedule::new(Chain::Tiles, count, passes as usize), threads.min(count), &relax);
}

dispatch! {
    /// Projects the seam bars between tile `a` and the next, `b`: group by
    /// group, the up to eight bars of a group (no shared particle, one kind
    /// and rest length: [`super::build::seam_groups`]) in the lanes of one
    /// operation.
    fn relax_boundary(a: &mut Tile, b: &mut Tile, sweep: &Sweep) -> f32
        = relax_boundary_body::<fused>, best = ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"]
}

#[inline(always)]
fn relax_boundary_body<const FUSED: bool>(a: &mut Tile, b: &mut Tile, sweep: &Sweep) -> f32 {
    if sweep.compliant { relax_seams::<true, FUSED>(a, b, sweep) } else { relax_seams::<false, FUSED>(a, b, sweep) }
}

#[inline(always)]
fn relax_seams<const XPBD: bool, const FUSED: bool>(a: &mut Tile, b: &mut Tile, sweep: &Sweep) -> f32 {
    // Slot and lane of a seam bar's end in `a`, then in `b`.
    let ends = |s: &SeamBar| (s.a.slot as usize, s.a.lane as usize, s.b.slot as usize, s.b.lane as usize);
    let mut worst = f32::NEG_INFINITY;
    let mut start = 0;
    for &end in &a.seam_ends {
        let end = end as usize;
        let group = &a.seams[start..end];
        // Lanes past the group's end stay at 0 with weight 0 at both ends:
        // they move nothing.
        let (mut pa, mut pb) = ([F32x8::splat(0.0); 3], [F32x8::splat(0.0); 3]);
        let (mut wa, mut wb, mut mu) = (F32x8::splat(0.0), F32x8::splat(0.0), F32x8::splat(0.0));
        let mut rest = F32x8::splat(group[0].rest);
        for (l, seam) in group.iter().enumerate() {
            rest.0[l] = seam.rest;
            let (sa, la, sb, lb) = ends(seam);
            for k in 0..3 {
                pa[k].0[l] = a.position[sa][k].0[la];
                pb[k].0[l] = b.position[sb][k].0[lb];
            }
            wa.0[l] = a.weight[sa].0[la];
            wb.0[l] = b.weight[sb].0[lb];
            if XPBD {
                mu.0[l] = a.seam_multipliers[start + l];
            }
        }
        let kind = group[0].kind as usize;
        let beta = if XPBD { sweep.betas[kind] } else { 0.0 };
        let v = relax_lanes::<XPBD, FUSED>(&mut pa, wa, &mut pb, wb, rest, &mut mu, beta, sweep.omega);
        for (l, seam) in group.iter().enumerate() {
            let (sa, la, sb, lb) = ends(seam);
            for k in 0..3 {
                a.position[sa][k].0[la] = pa[k].0[l];
                b.position[sb][k].0[lb] = pb[k].0[l];
            }
            if XPBD {
                a.seam_multipliers[start + l] = mu.0[l];
            }
            worst = worst.max(excess(v.0[l], wa.0[l], wb.0[l], sweep.tolerance * seam.rest));
        }
        start = end;
    }
    worst
}

dispatch! {
    /// One relaxation sweep over every bar inside a tile. Returns the largest
    /// excess over tolerance among movable bars (−∞ when not asked for).
    fn sweep_tile(tile: &mut Tile, sweep: &Sweep) -> f32
        = sweep_tile_body::<fused>, best = ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"]
}

#[inline(always)]
fn sweep_tile_body<const FUSED: bool>(tile: &mut Tile, sweep: &Sweep) -> f32 {
    match (sweep.compliant, sweep.uniform, tile.presence.is_empty()) {
        (true, true, _) => sweep_ops::<true, false, true, FUSED>(tile, sweep),
        (false, true, _) => sweep_ops::<false, false, true, FUSED>(tile, sweep),
        (true, false, true) => sweep_ops::<true, false, false, FUSED>(tile, sweep),
        (true, false, false) => sweep_ops::<true, true, false, FUSED>(tile, sweep),
        (false, false, true) => sweep_ops::<false, false, false, FUSED>(tile, sweep),
        (false, false, false) => sweep_ops::<false, true, false, FUSED>(tile, sweep),
    }
}

#[inline(always)]
#[allow(unsafe_code)]
fn sweep_ops<const XPBD: bool, const PADDED: bool, const UNIFORM: bool, const FUSED: bool>(
    tile: &mut Tile,
    sweep: &Sweep,
) -> f32 {
    let track = sweep.tolerance > 0.0;
    let mut worst = F32x8::splat(f32::NEG_INFINITY);
    assert!(covers::<XPBD, PADDED, UNIFORM>(tile, sweep.ops), "a tile's columns are shorter than its operations need");
    let Tile { position, weight, presence, op_shares, multipliers, rests, .. } = tile;
    for (j, &op) in sweep.ops.iter().enumerate() {
        // SAFETY: j is below the operations' count and `op` is one of them,
        // which the tile's columns cover (asserted above).
        let (violation, wa, wb, rest) = unsafe {
            let rest = op_rest(rests, j, op);
            let (violation, wa, wb) = relax_op::<XPBD, PADDED, UNIFORM, FUSED>(
                position,
                weight,
                presence,
                op_shares,
                multipliers,
                j,
                op,
                rest,
                sweep,
            );
            (violation, wa, wb, rest)
        };
        if track {
            worst = worst.max(excess(violation, wa, wb, rest * F32x8::splat(sweep.tolerance)));
        }
    }
    worst.max_lane()
}

/// Sweeps a tile `sweeps` times, giving exactly the result of
/// [`sweep_tile`] called `sweeps` times, but with up to [`PIPELINE_DEPTH`]
/// sweeps in flight: sweep s + 1 works on row r − 3 (or further back) while
/// sweep s works on row r, and a sweep starts as soon as one of the four
/// has finished (and it is three rows behind the last to start), so that
/// four are in flight but at the first and last rows of the substep.
///
/// This is exact because the bars starting in row r touch rows r to r + 2
/// only: operations of rows three or more apart touch disjoint particles and
/// commute, so every pair of operations that share a particle still runs in
/// the sequential order. (With compliant bars each operation keeps its own μ,
/// which is reset once per substep, before the first sweep.) Interleaving the
/// independent rows op by op gives the CPU several dependency chains to
/// overlap instead of one: a row of a narrow cloth is otherwise one long
/// chain of projections, each waiting for the square root and division of
/// the last.
#[inline(always)]
fn sweep_tile_pipelined_body<const FUSED: bool>(tile: &mut Tile, sweep: &Sweep, row_starts: &[u32], sweeps: u32) {
    match (sweep.compliant, sweep.uniform, tile.presence.is_empty()) {
        (true, true, _) => sweep_pipelined::<true, false, true, FUSED>(tile, sweep, row_starts, sweeps),
        (false, true, _) => sweep_pipelined::<false, false, true, FUSED>(tile, sweep, row_starts, sweeps),
        (true, false, true) => sweep_pipelined::<true, false, false, FUSED>(tile, sweep, row_starts, sweeps),
        (true, false, false) => sweep_pipelined::<true, true, false, FUSED>(tile, sweep, row_starts, sweeps),
        (false, false, true) => sweep_pipelined::<false, false, false, FUSED>(tile, sweep, row_starts, sweeps),
        (false, false, false) => sweep_pipelined::<false, true, false, FUSED>(tile, sweep, row_starts, sweeps),
    }
}

#[inline(always)]
#[allow(unsafe_code)]
fn sweep_pipelined<const XPBD: bool, const PADDED: bool, const UNIFORM: bool, const FUSED: bool>(
    tile: &mut Tile,
    sweep: &Sweep,
    row_starts: &[u32],
    sweeps: u32,
) {
    const LAG: usize = 3;
    let rows = row_starts.len() - 1;
    let sweeps = sweeps as usize;
    if rows == 0 {
        return;
    }
    let count = sweep.ops.len();
    assert!(
        covers::<XPBD, PADDED, UNIFORM>(tile, sweep.ops) && row_starts.iter().all(|&s| s as usize <= count),
        "a tile's columns or the rows' starts do not match its operations"
    );
    let Tile { position, weight, presence, op_shares, multipliers, rests, .. } = tile;
    // When each sweep in flight started (sweep k at `begun[k % DEPTH]`):
    // sweeps `oldest..started` are in flight, the oldest the furthest on.
    let mut begun = [0usize; PIPELINE_DEPTH];
    let (mut oldest, mut started, mut t) = (0usize, 0usize, 0usize);
    while oldest < sweeps {
        while oldest < started && t - begun[oldest % PIPELINE_DEPTH] >= rows {
            oldest += 1;
        }
        let behind_the_last = started == 0 || t >= begun[(started - 1) % PIPELINE_DEPTH] + LAG;
        if started < sweeps && started - oldest < PIPELINE_DEPTH && behind_the_last {
            begun[started % PIPELINE_DEPTH] = t;
            started += 1;
        }
        // The rows in flight at time t, one per sweep.
        let in_flight = started - oldest;
        let mut groups = [(0usize, 0usize); PIPELINE_DEPTH];
        let mut longest = 0;
        for (i, group) in groups.iter_mut().enumerate().take(in_flight) {
            let r = t - begun[(oldest + i) % PIPELINE_DEPTH];
            *group = (row_starts[r] as usize, row_starts[r + 1] as usize);
            longest = longest.max(group.1 - group.0);
        }
        for j in 0..longest {
            for &(start, end) in &groups[..in_flight] {
                if start + j < end {
                    // SAFETY: start + j < end, a row's start, which is at
                    // most the operations' count, and the tile's columns
                    // cover the operations (both asserted above).
                    unsafe {
                        let op = *sweep.ops.get_unchecked(start + j);
                        relax_op::<XPBD, PADDED, UNIFORM, FUSED>(
                            position,
                            weight,
                            presence,
                            op_shares,
                            multipliers,
                            start + j,
                            op,
                            op_rest(rests, start + j, op),
                            sweep,
                        );
                    }
                }
            }
        }
        t += 1;
    }
}

/// Sweeps in flight in [`sweep_tile_pipelined`].
const PIPELINE_DEPTH: usize = 4;

/// Whether a tile's columns cover its operations `ops`: `position`,
/// `weight` and, with `PADDED`, `presence` hold every slot they name; with
/// `UNIFORM`, `op_shares`, with `XPBD`, `multipliers`, and `rests` when it
/// is not empty hold an entry an operation. The sweeps check it once a call
/// and then index the columns without a check (below).
fn covers<const XPBD: bool, const PADDED: bool, const UNIFORM: bool>(tile: &Tile, ops: &Ops) -> bool {
    let (slots, count) = (ops.slots(), ops.len());
    tile.position.len() >= slots
        && tile.weight.len() >= slots
        && (!PADDED || tile.presence.len() >= slots)
        && (!UNIFORM || tile.op_shares.len() >= count)
        && (!XPBD || tile.multipliers.len() >= count)
        && (tile.rests.is_empty() || tile.rests.len() >= count)
}

/// Operation `j`'s eight rest lengths: the tile's own when its bars differ
/// by lane ([`Tile::rests`]), else the operation's one.
///
/// # Safety
/// `rests` is empty or longer than `j`.
#[inline(always)]
#[allow(unsafe_code)]
unsafe fn op_rest(rests: &[F32x8], j: usize, op: Op) -> F32x8 {
    // SAFETY: the caller's promise.
    if rests.is_empty() { F32x8::splat(op.rest) } else { unsafe { *rests.get_unchecked(j) } }
}

/// Projects the eight bars of operation `j`. Returns the violations and the
/// weights used (for the tolerance test).
///
/// The columns are indexed without bounds checks. The checks (six compares
/// and branches an operation, with the kind's for β) were 12 of the seed's
/// loop's 80 instructions an operation; without them the seed's step took
/// 1–8 % less on host F (an Intel Xeon), the larger gains in its busy
/// periods (alternated in one process).
///
/// # Safety
/// `op` is one of the operations of `sweep.ops`, `j` is below their count,
/// and the columns cover them ([`covers`], with the same `XPBD`, `PADDED`
/// and `UNIFORM`).
#[inline(always)]
#[allow(clippy::too_many_arguments, unsafe_code)]
unsafe fn relax_op<const XPBD: bool, const PADDED: bool, const UNIFORM: bool, const FUSED: bool>(
    position: &mut [Slot],
    weight: &[F32x8],
    presence: &[F32x8],
    op_shares: &ShareTable,
    multipliers: &mut [F32x8],
    j: usize,
    op: Op,
    rest: F32x8,
    sweep: &Sweep,
) -> (F32x8, F32x8, F32x8) {
    let (ia, ib) = op.slots();
    // Ops::new checked every kind against the kinds' count; not compliant,
    // β is not read.
    let beta = if XPBD { sweep.betas[op.kind()] } else { 0.0 };
    let mut dummy = F32x8::splat(0.0);
    // SAFETY (each unchecked index below): `ia` and `ib` are slots of an
    // operation, below the columns' slots, and `j` is below the
    // operations' count, which the columns cover (the caller's promise).
    let mu = if XPBD { unsafe { multipliers.get_unchecked_mut(j) } } else { &mut dummy };
    if UNIFORM {
        // SAFETY: as above.
        return unsafe { relax_op_shared::<XPBD, FUSED>(position, op_shares.get_unchecked(j), mu, op, rest, beta) };
    }
    let at = |column: &[F32x8], i: usize| unsafe { *column.get_unchecked(i) };
    let (mut a, mut wa) = (unsafe { *position.get_unchecked(ia) }, at(weight, ia));
    if !op.rotated() {
        let (mut b, mut wb) = (unsafe { *position.get_unchecked(ib) }, at(weight, ib));
        if PADDED {
            // A bar to padding does not exist: neither end moves.
            (wa, wb) = (wa * at(presence, ib), wb * at(presence, ia));
        }
        let v = relax_lanes::<XPBD, FUSED>(&mut a, wa, &mut b, wb, rest, mu, beta, sweep.omega);
        unsafe {
            *position.get_unchecked_mut(ib) = b;
            *position.get_unchecked_mut(ia) = a;
        }
        (v, wa, wb)
    } else {
        // Lane l meets lane l + 1 of the far slot (the next block); lane 7's
        // partner is in the next tile (a seam bar, projected on its own), so
        // both ends' weights are zeroed there and neither moves.
        let mut b = unsafe { *position.get_unchecked(ib) }.map(F32x8::rotate_down);
        let mut wb = at(weight, ib).rotate_down();
        if PADDED {
            (wa, wb) = (wa * at(presence, ib).rotate_down(), wb * at(presence, ia));
        }
        wa.0[LANES - 1] = 0.0;
        wb.0[LANES - 1] = 0.0;
        let v = relax_lanes::<XPBD, FUSED>(&mut a, wa, &mut b, wb, rest, mu, beta, sweep.omega);
        unsafe {
            *position.get_unchecked_mut(ib) = b.map(F32x8::rotate_up);
            *position.get_unchecked_mut(ia) = a;
        }
        (v, wa, wb)
    }
}

/// [`relax_op`] in the share form: the operation's precomputed shares
/// ([`super::op_shares::op_shares`]) instead of its ends' weights, two loads where the
/// slots' shares took four, two multiplies and, rotated, their shuffles.
/// Returns the violations and each end's share (for the tolerance test,
/// which only asks whether a bar can move).
///
/// # Safety
/// `op`'s slots are below `position`'s length.
#[inline(always)]
#[allow(unsafe_code)]
unsafe fn relax_op_shared<const XPBD: bool, const FUSED: bool>(
    position: &mut [Slot],
    [sa, sb]: OpShares,
    mu: &mut F32x8,
    op: Op,
    rest: F32x8,
    beta: f32,
) -> (F32x8, F32x8, F32x8) {
    let (ia, ib) = op.slots();
    // SAFETY (each unchecked index): `ia` and `ib` are below `position`'s
    // length (the caller's promise).
    let mut a = unsafe { *position.get_unchecked(ia) };
    let v = if !op.rotated() {
        let mut b = unsafe { *position.get_unchecked(ib) };
        let v = shared_lanes::<XPBD, FUSED>(&mut a, sa, &mut b, sb, rest, mu, beta);
        unsafe { *position.get_unchecked_mut(ib) = b };
        v
    } else {
        // Lane l meets lane l + 1 of the far slot (the next block).
        let mut b = unsafe { *position.get_unchecked(ib) }.map(F32x8::rotate_down);
        let v = shared_lanes::<XPBD, FUSED>(&mut a, sa, &mut b, sb, rest, mu, beta);
        unsafe { *position.get_unchecked_mut(ib) = b.map(F32x8::rotate_up) };
        v
    };
    unsafe { *position.get_unchecked_mut(ia) = a };
    (v, sa, sb)
}

/// [`relax_lanes`] in the share form.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn shared_lanes<const XPBD: bool, const FUSED: bool>(
    a: &mut Slot,
    sa: F32x8,
    b: &mut Slot,
    sb: F32x8,
    rest: F32x8,
    mu: &mut F32x8,
    beta: f32,
) -> F32x8 {
    let mut violation = F32x8::default();
    for l in 0..LANES {
        let mut pa = [a[0].0[l], a[1].0[l], a[2].0[l]];
        let mut pb = [b[0].0[l], b[1].0[l], b[2].0[l]];
        violation.0[l] =
            relax_pair_shared::<f32, XPBD, FUSED>(&mut pa, sa.0[l], &mut pb, sb.0[l], rest.0[l], &mut mu.0[l], beta);
        for k in 0..3 {
            a[k].0[l] = pa[k];
            b[k].0[l] = pb[k];
        }
    }
    violation
}

/// Projects lane l of `a` against lane l of `b` for every lane: the scalar
/// kernel in a loop that the compiler vectorises lane for lane.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn relax_lanes<const XPBD: bool, const FUSED: bool>(
    a: &mut Slot,
    wa: F32x8,
    b: &mut Slot,
    wb: F32x8,
    rest: F32x8,
    mu: &mut F32x8,
    beta: f32,
    omega: f32,
) -> F32x8 {
    let mut violation = F32x8::default();
    for l in 0..LANES {
        let mut pa = [a[0].0[l], a[1].0[l], a[2].0[l]];
        let mut pb = [b[0].0[l], b[1].0[l], b[2].0[l]];
        violation.0[l] =
            relax_pair::<f32, XPBD, FUSED>(&mut pa, wa.0[l], &mut pb, wb.0[l], rest.0[l], &mut mu.0[l], beta, omega);
        for k in 0..3 {
            a[k].0[l] = pa[k];
            b[k].0[l] = pb[k];
        }
    }
    violation
}
