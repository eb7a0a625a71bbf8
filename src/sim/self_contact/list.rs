//! The pair list: the candidate pairs of a search kept for the substeps
//! after it, and searched again only around the particles that have moved.
//!
//! A search with radius r + s (s the *skin*) finds every pair closer than
//! r + s at the positions x_b of that substep. Later, for two particles
//! that are both still within s/2 of where they were,
//!
//! ```text
//! |x_i − x_j| ≥ |x_b,i − x_b,j| − |x_i − x_b,i| − |x_j − x_b,j| > (r + s) − s/2 − s/2 = r
//! ```
//!
//! unless the search found them: a pair of such particles closer than r
//! now is in the list (Verlet's neighbour list with a skin, as in molecular
//! dynamics). The few particles that have travelled further, the *movers*,
//! are searched for again each substep:
//! - a mover i against the others, in the search's table: a particle j
//!   that is not a mover lies within s/2 of its table position, so if
//!   |x_i − x_j| < r then |x_i − x_b,j| < r + s/2, inside the table's reach
//!   (cells of side 2(r + s));
//! - movers against movers, in a small table of their own, built each
//!   substep at their present positions.
//!
//! Each substep the list's pairs go to the rule untested (it gives nothing
//! at r or beyond), those with a mover end masked out (the movers are
//! marked in the fourth lane of their start rows, which the rule reads
//! anyway: `self_contact/pair.rs`); each mover's pairs
//! are tested against r at the present positions first. A new search runs
//! when the movers pass 1 in [`MOVERS`] of the particles.
//!
//! **When a skin pays.** A list with a skin costs more to build than the
//! plain search (a ball of radius r + s, cells of side 2(r + s)) and adds a
//! test per candidate each substep; it pays when it serves several
//! substeps. So before a search the phase measures how far each particle
//! has travelled per substep since the last search (reading the rows in
//! order beside a copy of where they were at the search), and takes the skin
//! s = [`SKIN`]·r only when no more than 1 in [`MOVERS`] particles would
//! become movers within [`LIFETIME`] substeps at that pace; otherwise s = 0,
//! the plain search of radius r, whose pairs serve only their own substep.
//! A cloth that falls or flaps thus searches every substep as before; a
//! cloth that lies or drapes, with a few particles still sliding, searches
//! once in many substeps. The first search is plain (no pace known yet). A
//! change of r or of the particle count searches anew.
//!
//! **Same result, other order.** The rule gives nothing to a pair at r or
//! beyond (d_min ≤ r), so the extra candidates give nothing and every pair
//! closer than r gets the rule's bits for its two ends. Only the order in
//! which a particle sums its pairs can differ from a fresh search, which
//! changes bits only for particles with three or more pairs; the order is
//! fixed by the positions, never by the thread count.

use glam::Vec3;
use rayon::prelude::*;

use super::cells::PER_TASK;

/// s / r, the skin of a list that is kept (dimensionless). 0.25: the
/// search's cells grow from 2r to 2.5r, and a particle becomes a mover
/// after travelling r/8. (On the folded 256² cloth, r = 1.5 cm and 2 cm
/// between particles, a kept substep took 2.04–2.12 ms against 2.46–2.71
/// ms with s = r/2, whose radius r + s takes in the cloth's own
/// neighbours; the step was 1–4 % faster, with 44 searches in 205
/// substeps against 36.)
pub const SKIN: f32 = 0.25;

/// A search takes the skin when the pace since the last one would keep its
/// list this many substeps.
pub const LIFETIME: f32 = 3.0;

/// A list is kept while no more than 1 particle in `MOVERS` is a mover.
pub const MOVERS: usize = 32;

/// The travel that makes a mover, as a share of s/2: a margin for the
/// rounding of the distances compared (|x − x_b| and the search's
/// |x_i − x_j|, each within a few ulps of the exact values).
const MARGIN: f32 = 0.999;

/// Candidate pairs of slots of the sorted table: `own[k] < other[k]`.
/// A kept list's are in order of the chunk of the table `other[k]` is in
/// (stable): chunk t's are `ends[t]..ends[t + 1]`, so each chunk's sums
/// find their other ends without sorting them each substep.
#[derive(Clone, Debug, Default)]
pub(super) struct Candidates {
    pub(super) own: Vec<u32>,
    pub(super) other: Vec<u32>,
    pub(super) ends: Vec<u32>,
    /// d_min = min(r, |X_i − X_j|) of each pair, metres (filled once the
    /// pairs are in their final order, when the list is to be kept).
    pub(super) d_min: Vec<f32>,
}

impl Candidates {
    /// Puts the pairs in order of their other end's chunk of the table
    /// (stable), of `chunks` chunks, and records where each chunk's start.
    pub(super) fn sort_by_other(&mut self, chunks: usize) {
        let (mut own, mut other) = (vec![0; self.own.len()], vec![0; self.other.len()]);
        self.ends =
            super::sort_by_chunk(&self.other, chunks, |k, at| (own[at], other[at]) = (self.own[k], self.other[k]));
        (self.own, self.other) = (own, other);
    }
}

/// What the phase does this substep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Plan {
    /// The kept list holds every pair of two non-movers closer than r.
    Keep,
    /// Search anew with this skin (metres; 0: the plain search).
    Search { skin: f32 },
}

/// The list of the last search.
#[derive(Clone, Debug, Default)]
pub(super) struct PairList {
    /// r of the search, metres.
    thickness: f32,
    /// s of the search, metres (0: the pairs were not kept).
    pub(super) skin: f32,
    /// Substeps since the search, its own included.
    served: u32,
    /// The search's pairs, per chunk of the table (empty when s = 0).
    pub(super) chunks: Vec<Candidates>,
    /// Per slot: has it travelled s/2 since the search? And the movers'
    /// slots, in order.
    pub(super) mover: Vec<bool>,
    pub(super) movers: Vec<u32>,
    /// Each row's position at the search.
    at: Vec<Vec3>,
}

impl PairList {
    /// Whether the last search serves thickness `r` and `n` particles (so [`Self::plan`] can be asked).
    pub(super) fn serves(&self, r: f32, n: usize) -> bool {
        self.served > 0 && self.thickness == r && self.at.len() == n
    }

    /// What to do with the particles at `x` (row order; row i sits in slot
    /// `slot[i]` of the search's table): keep the list (and mark the
    /// movers), or search with the skin the pace since the last search
    /// affords. Read in the rows' order, beside where they were at the
    /// search.
    pub(super) fn plan(&mut self, x: &[Vec3], slot: &[u32], parallel: bool) -> Plan {
        let n = x.len();
        let cap = n / MOVERS;
        // The travel that makes a mover, for skin s.
        let reach = |s: f32| MARGIN * 0.5 * s;
        let at = &self.at;
        // Squared travel since the search, past `limit2`.
        let beyond_since = |i: usize, limit2: f32| beyond(x[i].distance_squared(at[i]), limit2);
        if self.skin > 0.0 {
            let reach2 = reach(self.skin) * reach(self.skin);
            // Each chunk's movers' slots, listed while there are few.
            let movers = |c: usize| {
                let (mut count, mut slots) = (0, Vec::new());
                let rows = c * PER_TASK..n.min((c + 1) * PER_TASK);
                for (i, &k) in rows.clone().zip(&slot[rows]) {
                    if beyond_since(i, reach2) {
                        count += 1;
                        if count <= cap {
                            slots.push(k);
                        }
                    }
                }
                (count, slots)
            };
            let chunks = n.div_ceil(PER_TASK);
            let found: Vec<(usize, Vec<u32>)> = if parallel {
                (0..chunks).into_par_iter().map(movers).collect()
            } else {
                (0..chunks).map(movers).collect()
            };
            if found.iter().map(|(count, _)| count).sum::<usize>() <= cap {
                self.movers.clear();
                for (_, slots) in found {
                    self.movers.extend(slots);
                }
                self.movers.sort_unstable();
                self.mover.clear();
                self.mover.resize(n, false);
                for &k in &self.movers {
                    self.mover[k as usize] = true;
                }
                self.served += 1;
                return Plan::Keep;
            }
        }
        // Movers of a list with the skin within LIFETIME substeps, at the
        // pace since the search (NaN travel, a non-finite position, counts).
        let skin = SKIN * self.thickness;
        let soon = reach(skin) / LIFETIME * self.served as f32;
        let count = |i: usize| usize::from(beyond_since(i, soon * soon));
        let movers = if parallel { (0..n).into_par_iter().map(count).sum() } else { (0..n).map(count).sum::<usize>() };
        Plan::Search { skin: if movers <= cap { skin } else { 0.0 } }
    }

    /// Records a search with thickness `r` and skin `skin` at positions `x`
    /// (row order), whose pairs are `chunks` (kept only when `skin` > 0);
    /// `x` copied on the thread pool with `parallel`.
    pub(super) fn searched(&mut self, r: f32, skin: f32, chunks: Vec<Candidates>, x: &[Vec3], parallel: bool) {
        (self.thickness, self.skin, self.served) = (r, skin, 1);
        self.chunks = if skin > 0.0 { chunks } else { Vec::new() };
        self.at.resize(x.len(), Vec3::ZERO);
        if parallel {
            let copy = |(at, x): (&mut [Vec3], &[Vec3])| at.copy_from_slice(x);
            self.at.par_chunks_mut(PER_TASK).zip(x.par_chunks(PER_TASK)).for_each(copy);
        } else {
            self.at.copy_from_slice(x);
        }
        self.mover.clear();
        self.movers.clear();
    }
}

/// A squared travel `d2` past `limit2`; NaN (a non-finite position) is.
fn beyond(d2: f32, limit2: f32) -> bool {
    d2.is_nan() || d2 > limit2
}

#[cfg(test)]
mod tests {
    use super::super::cells::Cells;
    use super::*;

    #[test]
    fn a_list_is_kept_while_few_particles_have_travelled_half_the_skin() {
        // 64 particles 0.1 apart, r = 0.04: s = 0.01, a mover has travelled
        // more than 0.999 · 0.005 = 0.004995, and 64 / 32 = 2 movers are
        // allowed.
        let r = 0.04;
        let x: Vec<Vec3> = (0..64).map(|i| Vec3::new((i % 8) as f32, (i / 8) as f32, 0.0) * 0.1).collect();
        let mut cells = Cells::default();
        cells.build(&x, 2.0 * (r + SKIN * r), false);
        let mut list = PairList::default();
        assert!(!list.serves(r, 64), "nothing searched yet");
        list.searched(r, 0.01, Vec::new(), &x, false);
        assert!(list.serves(r, 64) && !list.serves(0.03, 64) && !list.serves(r, 65));
        let slot_of = |i: u32| cells.slot[i as usize];
        // The positions, some particles moved along y.
        let rows = |moved: &[(u32, f32)]| -> Vec<Vec3> {
            let mut p = x.clone();
            for &(i, d) in moved {
                p[i as usize].y += d;
            }
            p
        };
        assert_eq!(list.plan(&rows(&[(5, 0.0049)]), &cells.slot, false), Plan::Keep);
        assert!(list.movers.is_empty(), "0.0049 is within reach");
        assert_eq!(list.plan(&rows(&[(5, 0.0051), (9, -0.006)]), &cells.slot, false), Plan::Keep);
        let mut movers = vec![slot_of(5), slot_of(9)];
        movers.sort();
        assert_eq!(list.movers, movers, "the movers' slots, in order");
        assert!(list.mover[slot_of(9) as usize] && !list.mover[slot_of(8) as usize]);
        // A third mover: search. The list has served 3 substeps; at that
        // pace (0.0051 / 3 a substep) particles 5 and 9 and 12 would be
        // movers within 3 substeps: more than 2, so the plain search.
        let three = [(5, 0.0051), (9, -0.006), (12, 0.0051)];
        assert_eq!(list.plan(&rows(&three), &cells.slot, false), Plan::Search { skin: 0.0 });
        // The same travel over 4 substeps is 0.001275 a substep, 0.0038 in 3:
        // no mover soon, so the skin again.
        list.served = 4;
        assert_eq!(
            list.plan(&rows(&[(5, 0.0051), (9, 0.0051), (12, 0.0051)]), &cells.slot, false),
            Plan::Search { skin: 0.01 }
        );
        // A NaN counts as a mover, on the pool too.
        let mut bad = rows(&[]);
        bad[7].y = f32::NAN;
        list.served = 1;
        assert_eq!(list.plan(&bad, &cells.slot, true), Plan::Keep);
        assert_eq!(list.movers, [slot_of(7)]);
    }
}
