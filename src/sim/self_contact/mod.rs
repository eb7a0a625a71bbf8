//! The self-collide phase: cloth kept from passing through itself.
//!
//! With r the thickness, every pair of particles i, j that are closer than
//! r now is pushed apart to
//!
//! ```text
//! d_min = min(r, |X_i − X_j|)          X the rest positions
//! ```
//!
//! so pairs that are neighbours in the rest shape (closer than r there) are
//! only kept at their rest distance and the cloth does not push its own
//! neighbours apart (Ten Minute Physics 15). Each particle moves by its share
//! `w_i / (w_i + w_j)` of `d_min − |x_i − x_j|` along the pair's direction n.
//! Friction between layers is the collider's Coulomb rule applied to the
//! pair's relative motion over the substep, `Δ = (x_i − x0_i) − (x_j − x0_j)`:
//! its tangential part is removed up to μ times the push.
//!
//! **No pass-through.** Before the pairs are found, each particle's motion
//! in the substep is limited to `r/4`: two particles then close in on each
//! other by at most `r/2` per substep, less than the `r` they are kept
//! apart, so no pair can cross between two substeps unseen. The limit is a
//! top speed of `r / (4 h/n)` (2.4 m/s for r = 1 cm at 8 substeps of 1/60 s);
//! it applies only when self-collision is on, and the particles it holds
//! each substep are counted ([`SelfContact::held_to_top_speed`]) so that
//! a cloth slowed by it shows in reports. Testing paths instead would
//! need triangle–triangle continuous collision, which this phase does not do:
//! it keeps particles apart, so layers stay apart where the particle spacing
//! is about the thickness.
//!
//! **Neighbour search.** A hash grid, the particles sorted by cell and
//! their positions copied in that order. Each pair is found once, by the
//! query of the particle that comes first in the sorted table: its
//! candidates are the later particles of the 8 cells its ball can reach,
//! tested eight at a time in lanes (`self_contact/cells.rs`, which shows
//! why no candidate counts twice). No all-pairs loop. The search's pairs
//! are kept for the substeps after it, with a skin, while few particles
//! have moved far from where it found them; the particles that have are
//! searched for again each substep (`self_contact/list.rs`). A cloth that
//! keeps moving fast searches plainly every substep (cells of side 2r). The
//! pairs closer than r are then pushed apart eight at a time in lanes, both
//! ends of a pair at once (`self_contact/pair.rs`), each end with the bits
//! it gets when computed alone.
//!
//! **Determinism.** Corrections are computed for every pair from the same
//! snapshot of positions (Jacobi) and summed per particle from zero in the
//! order the pairs were found: the pairs where it is the later slot (by
//! the earlier slot), then its own, then a kept list's pairs of movers.
//! The order depends on neither the thread count nor the SIMD level; it
//! does depend on the order of the rows the phase is given (a solver may
//! give its own, [`SelfContact::apply_numbered`]: within a cell the
//! particles come in row order; both fast layouts give their own, the
//! grid its lane order). Large cloths search, test and compute
//! pairs in chunks of the table on the rayon pool, and sum each chunk's
//! slots on the pool too. The phase reads each pair's data (positions,
//! substep-start positions, weights, rest positions) from copies in the
//! table's order, so the particles near one another are near in memory. A
//! plain search copies the rows of its pairs' ends only: a cloth that
//! keeps moving finds few pairs (none on disc-183 draped over a ball, where
//! copying every row had cost more than the search), while a search with a
//! skin copies every row, as any slot may pair with a mover later.

mod cells;
mod list;
mod pair;

use crate::sim::fast::simd::dispatch;

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use cells::{Cells, PER_TASK, gather, gather_rows};
use list::{Candidates, PairList, Plan};
use pair::{Moves, PairSlots, Slots, d_min, pair_corrections};

pub use list::{LIFETIME, MOVERS, SKIN};

/// The most a particle moves in a substep, as a share of r (the module's
/// no-pass-through limit): a top speed of `TOP_SPEED_SHARE · r / (h/n)`.
pub const TOP_SPEED_SHARE: f32 = 0.25;

/// Cloths of at least this many particles find their corrections on the
/// thread pool.
pub const PARALLEL_PARTICLES: usize = 8192;

/// The spatial hash and the scratch space of the self-collide phase.
#[derive(Clone, Debug, Default)]
pub struct SelfContact {
    rest: Vec<Vec3>,
    cells: Cells,
    /// The movers' own table (`self_contact/list.rs`).
    mover_cells: Cells,
    /// The pairs of the last search, kept while few particles have moved
    /// far from where it found them (`self_contact/list.rs`).
    list: PairList,
    /// Per slot of `cells` (the particles sorted by cell at the last
    /// search), as the pairs read them: position and inverse mass,
    /// substep-start position, rest position (`[x, y, z, w or 0]`); and the
    /// correction.
    slot_point: Vec<[f32; 4]>,
    slot_start: Vec<[f32; 4]>,
    slot_rest: Vec<[f32; 4]>,
    correction: Vec<Vec3A>,
    /// Scratch: the slots a plain search's pairs end in.
    ends: Vec<bool>,
    /// Each chunk's pairs of the last substep, for their buffers.
    found: Vec<Pairs>,
    /// Searches and substeps since the phase was made (for reports).
    searches: u64,
    substeps: u64,
    /// Particles whose motion the top speed limited: in the last substep,
    /// and summed over every substep since the phase was made (for
    /// reports).
    held_last: usize,
    held_total: u64,
    /// Positions, substep-start positions and weights in scene order, for
    /// solvers whose own layout is not scene order.
    pub(crate) x: Vec<Vec3>,
    pub(crate) x0: Vec<Vec3>,
    pub(crate) w: Vec<f32>,
}

/// What one self-collide phase needs besides the positions.
#[derive(Clone, Copy, Debug)]
pub struct SelfContactStep {
    /// r, metres.
    pub thickness: f32,
    /// μ between layers.
    pub friction: f32,
    /// Find corrections on the thread pool.
    pub parallel: bool,
}

/// The pairs of a run of slots (chunk c of the table) that act this
/// substep, each pair once, and what its two slots do to each other; and
/// the run's candidates when they are to be kept. Kept from substep to
/// substep for their buffers (refilled, not reallocated).
#[derive(Clone, Debug, Default)]
struct Pairs {
    /// The kept list's pairs of chunk c (`list.chunks[c]`, not tested
    /// against r, not copied here): their count, 0 unless the list is kept.
    listed: usize,
    /// The pairs found this substep.
    own: Vec<u32>,
    other: Vec<u32>,
    /// The moves of the listed pairs' ends, then of the found ones'.
    moved_own: Vec<Vec3A>,
    moved_other: Vec<Vec3A>,
    /// The found pairs' `other` ends again, by the chunk of the table they
    /// are in (stable): chunk t's are `to[ends[t]..ends[t + 1]]`.
    to: Vec<(u32, Vec3A)>,
    ends: Vec<u32>,
    kept: Candidates,
}

impl Pairs {
    /// Whether no pair acts.
    fn is_empty(&self) -> bool {
        self.listed == 0 && self.own.is_empty()
    }
}

dispatch! {
    /// The pairs of slots `chunk · CHUNK ..` with later slots that act now
    /// (their moves not yet computed): from a search of radius r + s
    /// (`plan`'s skin s; 0: the plain search, whose pairs are all closer
    /// than r, some maybe with two pinned ends), or from the kept list and
    /// the movers searched again.
    fn pairs_of(phase: &SelfContact, chunk: usize, plan: Plan, step: &SelfContactStep, pairs: &mut Pairs)
        = pairs_body, best = ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"]
}

#[inline(always)]
fn pairs_body(phase: &SelfContact, chunk: usize, plan: Plan, step: &SelfContactStep, pairs: &mut Pairs) {
    (pairs.listed, pairs.kept) = (0, Candidates::default());
    pairs.own.clear();
    pairs.other.clear();
    let first = chunk * CHUNK;
    let count = CHUNK.min(phase.cells.order.len() - first);
    let point = &phase.slot_point;
    let r2 = acting_distance2(step);
    match plan {
        Plan::Search { skin: 0.0 } => {
            // Pairs of two pinned ends are dropped in `corrections`, once
            // their rows are copied.
            phase.cells.pairs_after(first, count, step.thickness, &mut pairs.own, &mut pairs.other);
        }
        Plan::Search { skin } => {
            let mut kept = Candidates::default();
            phase.cells.pairs_after(first, count, step.thickness + skin, &mut kept.own, &mut kept.other);
            kept.sort_by_other(phase.cells.order.len().div_ceil(CHUNK));
            // Each candidate's d_min, for the substeps that keep the list.
            let rest = |s: u32| {
                let row = phase.slot_rest[s as usize];
                [row[0], row[1], row[2]]
            };
            let own_other = kept.own.iter().zip(&kept.other);
            kept.d_min = own_other.map(|(&i, &j)| d_min(rest(i), rest(j), step.thickness)).collect();
            push_close(&kept, point, r2, pairs);
            pairs.kept = kept;
        }
        Plan::Keep => {
            let list = &phase.list;
            let candidates = &list.chunks[chunk];
            let mover = &list.mover;
            // The list's pairs go to the rule untested: nearly all are
            // closer than r (about 120 000 of 124 000 candidates on the
            // settled folded 256² cloth), and the rule gives nothing to the
            // others; those with a mover end are masked out there.
            pairs.listed = candidates.own.len();
            // Each mover of the run against the others in the table (the
            // movers among them are paired in `mover_pairs`).
            let reach = step.thickness + list.skin;
            let mut near = Vec::new();
            for k in first..first + count {
                if mover[k] {
                    near.clear();
                    let p = point[k];
                    phase.cells.push_near(Vec3::new(p[0], p[1], p[2]), reach, &mut near);
                    for &j in &near {
                        if !mover[j as usize] && acts(point, r2, k as u32, j) {
                            pairs.own.push(k as u32);
                            pairs.other.push(j);
                        }
                    }
                }
            }
        }
    }
}

/// The squared distance under which a pair acts ([`acts`]): r², with a
/// margin for rounding (the rule gives nothing to the extra pairs:
/// |d| ≥ r ≥ d_min).
fn acting_distance2(step: &SelfContactStep) -> f32 {
    step.thickness * step.thickness * (1.0 + 1e-4)
}

/// Whether slots i and j are closer than √`r2` and not both pinned.
#[inline(always)]
fn acts(point: &[[f32; 4]], r2: f32, i: u32, j: u32) -> bool {
    let (a, b) = (point[i as usize], point[j as usize]);
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < r2) & ((a[3] > 0.0) | (b[3] > 0.0))
}

/// Appends to `pairs` the candidates that act now ([`acts`]), in order.
/// Every candidate is written and the end moves past it when kept: with a
/// skin, a share of the candidates fails, and a branch each would be
/// mispredicted for them.
#[inline(always)]
fn push_close(candidates: &Candidates, point: &[[f32; 4]], r2: f32, pairs: &mut Pairs) {
    let (own, other) = (&mut pairs.own, &mut pairs.other);
    let start = own.len();
    own.resize(start + candidates.own.len(), 0);
    other.resize(start + candidates.own.len(), 0);
    let mut end = start;
    for (&i, &j) in candidates.own.iter().zip(&candidates.other) {
        own[end] = i;
        other[end] = j;
        end += usize::from(acts(point, r2, i, j));
    }
    own.truncate(end);
    other.truncate(end);
}

/// The moves of both ends of each of `pairs`, into its buffers: first of
/// the `pairs.listed` pairs of `listed` (a kept list's chunk), which give
/// nothing where an end is a mover (marked in its start row) or both are
/// pinned; then of the pairs found. With `unpinned`, the found pairs of
/// two pinned ends are dropped first (w_i + w_j = 0: they do not touch
/// each other).
fn corrections(
    phase: &SelfContact,
    pairs: &mut Pairs,
    listed: Option<&Candidates>,
    step: &SelfContactStep,
    unpinned: bool,
) {
    if unpinned {
        let free = |slot: u32| phase.slot_point[slot as usize][3] > 0.0;
        let mut kept = 0;
        for k in 0..pairs.own.len() {
            if free(pairs.own[k]) || free(pairs.other[k]) {
                (pairs.own[kept], pairs.other[kept]) = (pairs.own[k], pairs.other[k]);
                kept += 1;
            }
        }
        pairs.own.truncate(kept);
        pairs.other.truncate(kept);
    }
    // Every move is written below: the buffers' old values need no
    // clearing.
    let count = pairs.listed + pairs.own.len();
    for moved in [&mut pairs.moved_own, &mut pairs.moved_other] {
        moved.truncate(count);
        moved.resize(count, Vec3A::ZERO);
    }
    let slots = Slots { point: &phase.slot_point, start: &phase.slot_start, rest: &phase.slot_rest };
    let (own_listed, own_found) = pairs.moved_own.split_at_mut(pairs.listed);
    let (other_listed, other_found) = pairs.moved_other.split_at_mut(pairs.listed);
    if let Some(listed) = listed.filter(|_| pairs.listed > 0) {
        let moves = Moves { own: own_listed, other: other_listed };
        let pairs = PairSlots { own: &listed.own, other: &listed.other, listed: Some(&listed.d_min) };
        pair_corrections(&slots, &pairs, moves, step);
    }
    let moves = Moves { own: own_found, other: other_found };
    pair_corrections(&slots, &PairSlots { own: &pairs.own, other: &pairs.other, listed: None }, moves, step);
    // The found pairs' other ends by chunk, so each chunk's sums can run
    // on their own (a kept list's pairs were sorted so when it was made).
    let (other, moved) = (&pairs.other, &pairs.moved_other[pairs.listed..]);
    let to = &mut pairs.to;
    to.clear();
    to.resize(other.len(), (0, Vec3A::ZERO));
    pairs.ends = sort_by_chunk(other, phase.cells.order.len().div_ceil(CHUNK), |k, at| to[at] = (other[k], moved[k]));
}

/// A stable counting sort of slots by the chunk of the table they are in:
/// `place(k, at)` for each `slots[k]` and the place it sorts to; returns
/// where each of the `chunks` chunks starts (chunk t's are
/// `ends[t]..ends[t + 1]`).
fn sort_by_chunk(slots: &[u32], chunks: usize, mut place: impl FnMut(usize, usize)) -> Vec<u32> {
    let mut ends = vec![0; chunks + 1];
    for &j in slots {
        ends[j as usize / CHUNK + 1] += 1;
    }
    for t in 0..chunks {
        ends[t + 1] += ends[t];
    }
    let mut next = ends.clone();
    for (k, &j) in slots.iter().enumerate() {
        let at = &mut next[j as usize / CHUNK];
        place(k, *at as usize);
        *at += 1;
    }
    ends
}

/// Slots of the sorted table one task of the thread pool takes.
const CHUNK: usize = 1024;

impl SelfContact {
    /// For a cloth whose rest shape is `rest`.
    pub fn new(rest: &[Vec3]) -> Self {
        Self { rest: rest.to_vec(), ..Self::default() }
    }

    /// Searches for pairs and substeps since the phase was made: how often
    /// the kept list spared a search.
    pub fn searches(&self) -> (u64, u64) {
        (self.searches, self.substeps)
    }

    /// Particles the top speed held back (their motion in the substep cut
    /// to r/4, module docs): `(in the last substep, summed over every
    /// substep since the phase was made)`. Where many are, the cloth moves
    /// slower than it would without self-collision.
    pub fn held_to_top_speed(&self) -> (usize, u64) {
        (self.held_last, self.held_total)
    }

    /// The phase on positions `x` (scene order) that started the substep at
    /// `x0`, with inverse masses `w`.
    pub fn apply(&mut self, x: &mut [Vec3], x0: &[Vec3], w: &[f32], step: &SelfContactStep) {
        self.apply_numbered(x, x0, w, None, step);
    }

    /// [`Self::apply`] on arrays in a solver's own order: row k holds scene
    /// particle `scene[k]` (a permutation; `None`: scene order). The pairs
    /// and their pushes are the same; within a cell the particles come in
    /// the rows' order, which sets the order of each particle's sum (so
    /// its last bits, for particles with three or more pairs).
    pub fn apply_numbered(
        &mut self,
        x: &mut [Vec3],
        x0: &[Vec3],
        w: &[f32],
        scene: Option<&[u32]>,
        step: &SelfContactStep,
    ) {
        let r = step.thickness;
        let n = x.len();
        if n < 2 || r <= 0.0 {
            self.held_last = 0;
            return;
        }
        debug_assert_eq!(n, self.rest.len(), "one rest position a particle");
        let parallel = step.parallel && n >= PARALLEL_PARTICLES && rayon::current_num_threads() > 1;
        // Motion per substep at most r/4.
        let limit = TOP_SPEED_SHARE * r;
        // |d|² at most `within` has |d| ≤ limit whatever the roundings
        // (each within 2⁻²⁴ of its value, far less than the 10⁻⁵ margin):
        // most particles are tested without a square root.
        let within = limit * limit * (1.0 - 1e-5);
        // Returns how many particles it held back.
        let bound = |((x, x0), w): ((&mut [Vec3], &[Vec3]), &[f32])| {
            let mut held = 0;
            for ((x, &x0), &w) in x.iter_mut().zip(x0).zip(w) {
                let d = *x - x0;
                let len2 = d.length_squared();
                if w > 0.0 && (len2 > within || len2.is_nan()) {
                    let len = len2.sqrt();
                    if len > limit {
                        *x = x0 + d * (limit / len);
                        held += 1;
                    }
                }
            }
            held
        };
        self.held_last = if parallel {
            x.par_chunks_mut(PER_TASK).zip(x0.par_chunks(PER_TASK)).zip(w.par_chunks(PER_TASK)).map(bound).sum()
        } else {
            bound(((x, x0), w))
        };
        self.held_total += self.held_last as u64;
        self.substeps += 1;
        let x_now: &[Vec3] = x;
        let plan = if self.list.serves(r, n) {
            self.list.plan(x_now, &self.cells.slot, parallel)
        } else {
            Plan::Search { skin: 0.0 }
        };
        let rest = &self.rest;
        let rest_of = |i: usize| rest[scene.map_or(i, |scene| scene[i] as usize)];
        let rows = |i: usize| [row(x_now[i], w[i]), row(x0[i], 0.0), row(rest_of(i), 0.0)];
        let slots = [&mut self.slot_point, &mut self.slot_start, &mut self.slot_rest];
        match plan {
            Plan::Keep => {
                // The movers marked in their start rows, for the mask.
                let [point, start, _] = slots;
                let mover = &self.list.mover;
                let order = &self.cells.order;
                gather(point, order, parallel, |_, i| row(x_now[i], w[i]));
                gather(start, order, parallel, |k, i| row(x0[i], f32::from(u8::from(mover[k]))));
            }
            Plan::Search { skin } => {
                self.searches += 1;
                self.cells.build(x_now, 2.0 * (r + skin), parallel);
                if skin > 0.0 {
                    // Every slot may pair with a mover later.
                    gather_rows(slots, &self.cells.order, parallel, |_| true, rows);
                }
            }
        }
        let chunks = n.div_ceil(CHUNK);
        // One per chunk (a kept list's movers' pairs, pushed after them
        // last substep, are dropped here).
        let mut found = std::mem::take(&mut self.found);
        found.resize_with(chunks, Pairs::default);
        let this = &*self;
        let find = |(c, pairs): (usize, &mut Pairs)| pairs_of(this, c, plan, step, pairs);
        if parallel {
            found.par_iter_mut().enumerate().for_each(find);
        } else {
            found.iter_mut().enumerate().for_each(find);
        }
        let plain = plan == Plan::Search { skin: 0.0 };
        if plain {
            // Only the pairs' ends read their rows: a moving cloth finds
            // few pairs (none on disc-183 draped over a ball), and copying
            // every row cost more than the search.
            let slots = [&mut self.slot_point, &mut self.slot_start, &mut self.slot_rest];
            copy_ends(&found, slots, &mut self.ends, &self.cells.order, parallel, rows);
        }
        let this = &*self;
        let listed = &self.list.chunks;
        let moves = |(c, pairs): (usize, &mut Pairs)| corrections(this, pairs, listed.get(c), step, plain);
        if parallel {
            found.par_iter_mut().enumerate().for_each(moves);
        } else {
            found.iter_mut().enumerate().for_each(moves);
        }
        match plan {
            Plan::Search { skin } => {
                let kept = found.iter_mut().map(|pairs| std::mem::take(&mut pairs.kept)).collect();
                self.list.searched(r, skin, kept, x, parallel);
            }
            Plan::Keep => found.push(self.mover_pairs(step)),
        }
        if found.iter().all(Pairs::is_empty) {
            // No pair acts: nothing to sum or take (a sliding cloth's
            // substeps, often).
            self.found = found;
            return;
        }
        // Each slot sums its pairs from zero in the order they were found:
        // the pairs where it is the other end (by the run that found them),
        // then those it owns. For a search that is: its pairs with earlier
        // slots (by the earlier slot), then its own query's. The movers'
        // pairs of a kept list come last.
        let mut correction = std::mem::take(&mut self.correction);
        correction.resize(n, Vec3A::ZERO);
        let listed = &self.list.chunks;
        let sum = |(t, out): (usize, &mut [Vec3A])| {
            out.fill(Vec3A::ZERO);
            let base = t * CHUNK;
            for (c, pairs) in found.iter().enumerate() {
                if pairs.listed > 0 {
                    let list = &listed[c];
                    let (from, to) = (list.ends[t] as usize, list.ends[t + 1] as usize);
                    for (&j, &moved) in list.other[from..to].iter().zip(&pairs.moved_other[from..to]) {
                        out[j as usize - base] += moved;
                    }
                }
                for &(j, moved) in &pairs.to[pairs.ends[t] as usize..pairs.ends[t + 1] as usize] {
                    out[j as usize - base] += moved;
                }
            }
            if let Some(pairs) = found.get(t) {
                let own = listed.get(t).filter(|_| pairs.listed > 0).map_or(&[][..], |list| &list.own);
                for (&i, &moved) in own.iter().chain(&pairs.own).zip(&pairs.moved_own) {
                    out[i as usize - base] += moved;
                }
            }
        };
        if parallel {
            correction.par_chunks_mut(CHUNK).enumerate().for_each(sum);
        } else {
            correction.chunks_mut(CHUNK).enumerate().for_each(sum);
        }
        for pairs in &found[chunks..] {
            for (&i, &moved) in pairs.own.iter().zip(&pairs.moved_own) {
                correction[i as usize] += moved;
            }
        }
        // Each particle takes its slot's sum, in row order.
        let (slot_of, sums) = (&self.cells.slot, &correction);
        let take = |(c, x): (usize, &mut [Vec3])| {
            for (x, &k) in x.iter_mut().zip(&slot_of[c * PER_TASK..]) {
                *x += Vec3::from(sums[k as usize]);
            }
        };
        if parallel {
            x.par_chunks_mut(PER_TASK).enumerate().for_each(take);
        } else {
            x.chunks_mut(PER_TASK).enumerate().for_each(take);
        }
        self.correction = correction;
        self.found = found;
    }

    /// The pairs of two movers that act now: a table of the movers alone,
    /// at their present positions, searched with radius r.
    fn mover_pairs(&mut self, step: &SelfContactStep) -> Pairs {
        let movers = &self.list.movers;
        let mut pairs = Pairs::default();
        if movers.len() >= 2 {
            let point = &self.slot_point;
            let at: Vec<Vec3> = movers.iter().map(|&k| Vec3::from_slice(&point[k as usize][..3])).collect();
            self.mover_cells.build(&at, 2.0 * step.thickness, false);
            let (mut own, mut other) = (Vec::new(), Vec::new());
            self.mover_cells.pairs_after(0, at.len(), step.thickness, &mut own, &mut other);
            let slot = |s: u32| movers[self.mover_cells.order[s as usize] as usize];
            let r2 = acting_distance2(step);
            for (&a, &b) in own.iter().zip(&other) {
                let (i, j) = (slot(a), slot(b));
                if acts(point, r2, i, j) {
                    pairs.own.push(i);
                    pairs.other.push(j);
                }
            }
        }
        corrections(self, &mut pairs, None, step, false);
        pairs
    }
}

/// The rows of the slots that `found`'s pairs end in, into `slots` (point,
/// start, rest), `pick(particle)` each ([`gather_rows`]); the other slots'
/// rows are left as they were. `ends` is scratch, all false before and
/// after.
fn copy_ends(
    found: &[Pairs],
    slots: [&mut Vec<[f32; 4]>; 3],
    ends: &mut Vec<bool>,
    order: &[u32],
    parallel: bool,
    pick: impl Fn(usize) -> [[f32; 4]; 3] + Sync + Send,
) {
    ends.resize(order.len(), false);
    let mut any = false;
    for pairs in found {
        for (&i, &j) in pairs.own.iter().zip(&pairs.other) {
            (ends[i as usize], ends[j as usize]) = (true, true);
            any = true;
        }
    }
    if any {
        gather_rows(slots, order, parallel, |k| ends[k], pick);
        ends.fill(false);
    }
}

/// A particle's row in the slot tables: `[x, y, z, w]`.
fn row(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

#[cfg(test)]
mod tests;
