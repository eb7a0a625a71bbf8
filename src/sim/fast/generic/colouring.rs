//! The bars of one group of the coloured layout ([`super::blocks`]) in
//! greedy colours.
//!
//! **Colours.** The bars are grouped into units of one bar or two
//! ([`pairs`]); every unit gets the smallest colour not yet used by a unit
//! at any of its particles, in unit order. Bars are stored colour by
//! colour, and within a colour as octets of four paired units (lane l the
//! first bar, lane l + 4 the second), those paired at both ends first, then
//! those paired at end a, then the other bars. Bars of one colour share no
//! particle.
//!
//! **Order within a colour.** Each of those octet ranges holds its units
//! (and the other bars) by their nearest end, the lowest row either end
//! of a unit's first bar indexes, so that a colour's octets sweep the
//! particles' rows upwards and each octet's rows lie near the last one's.
//! In the order the units were made (from the bars' order) a colour's
//! octets jumped about its block. On disc-183, whose blocks of 11 000–15 000
//! rows (180–240 KB) do not fit a core's L1, an octet's sixteen ends had
//! spanned 1 300–3 700 rows on average (290–730 sorted), and consecutive
//! octets started 880–2 200 rows apart (100–230 sorted). The order within
//! a colour moves no bit (its bars share no particle).
//!
//! Measured on host F (an Intel Xeon, Emerald Rapids), the two orders
//! built side by side and stepped window by window in one process, sorted
//! against not (medians of 16–40 windows). Where a run is built matters
//! on that host: two builds of the same order differed by up to 6 % (the
//! 100-ring disc, the second build the quicker), so the comparisons were
//! run with the builds both ways round:
//!
//! - disc-183 on one thread: 0.955–0.993 with the sorted order built
//!   second (AVX-512, seven runs; AVX2 0.967, 0.976), 0.973–0.986 with it
//!   built first (three runs); on two threads 0.960, 0.987 (AVX-512) and
//!   0.965, 0.971 (AVX2);
//! - ring discs of 40, 60 and 100 rings (5 000–30 000 particles): 0.986,
//!   0.980 and 0.983, each the geometric mean of the two ways round (a
//!   probe that built twelve discs in a row read the sorted order 4–7 %
//!   slower at these sizes, but its identical builds differed by up to
//!   5 %: the effect at these sizes is not settled);
//! - the tablecloth (1 801 rows, in L1 either way): 1.000–1.020, no change.
//!
//! The builds' difference was the particles' place against the cache
//! lines (`fast/lines.rs`), which biased each of those readings by up to
//! ±5 %. With the particles on a line's start, disc-183 on one thread
//! (AVX-512, four pairs of runs, each pair both ways round, geometric
//! mean) read 0.983, 0.993, 0.987 and 0.982: the sorted order takes about
//! 1–2 % off the step, not the 1–4 % read before.
//!
//! The units are put in that order by a counting sort by nearest end
//! before the one by colour and class; sorting each class in the loop
//! from the units' first order instead had added 25–45 ms to disc-183's
//! build. It now takes 10–25 ms more than the unsorted order's (180–300 ms
//! in a busy hour, medians of 12 builds, three runs).
//!
//! **Still octets.** Within each of those three octet ranges the units
//! whose particles are all fixed when the layout is built come first. A
//! projection moves an end by w c d, so a bar whose ends both weigh 0 moves
//! nothing; a pass skips each range's leading octets whose sixteen ends all
//! weigh 0 now ([`Colouring::count_still`], counted again after any weight
//! is written). A pin stays a write: pinning elsewhere skips nothing new,
//! and freeing a particle ends the skip at its octet. On the tablecloth
//! (its table top fixed) the pass skips 952 of its 10 368 bars.

use super::pairs::{self, Class, Oriented, Unit};
use crate::sim::csr::csr;
use crate::sim::mesh::Bar;

/// Most colours tracked; bars that find none free go in one last group, which
/// is still a correct Gauss–Seidel sweep, only not free of dependencies.
const MAX_COLOURS: u32 = 63;

/// The bars in colour order, one column per field.
#[derive(Clone, Debug, Default)]
pub(super) struct BarColumns {
    /// Ends, as the offset of each end's row in the particles' `f32`s (4 ×
    /// its index in the particles the colouring is swept over): the AVX2
    /// sweep addresses a row with no shift. [`BarColumns::ends`] gives the
    /// indices.
    pub(super) a: Vec<u32>,
    pub(super) b: Vec<u32>,
    /// Rest length L (m).
    pub(super) rest: Vec<f32>,
    /// [`crate::sim::BarKind::index`]: an index into [`Substep::betas`](crate::sim::step::Substep::betas).
    pub(super) kind: Vec<u8>,
}

/// `f32`s in a particle's row (x, y, z, w).
pub(super) const ROW: u32 = 4;

impl BarColumns {
    /// The particle indices of bar `i`'s ends.
    #[inline(always)]
    pub(super) fn ends(&self, i: usize) -> (usize, usize) {
        ((self.a[i] / ROW) as usize, (self.b[i] / ROW) as usize)
    }
}

/// Bars in colour order and where each colour ends.
#[derive(Clone, Debug, Default)]
pub(super) struct Colouring {
    pub(super) bars: BarColumns,
    /// Colour c is `bars[ends[c − 1]..ends[c]]` (`ends[−1]` = 0).
    pub(super) ends: Vec<usize>,
    /// Where colour c's octets of [`Class::Both`] units end, and then its
    /// octets of [`Class::AEnd`] units: `bars[colour start..paired[c][0]]`
    /// are octets whose lanes l and l + 4 hold bars 2p–2q and 2p+1–2q+1,
    /// `..paired[c][1]` octets whose lanes l and l + 4 start at 2p and
    /// 2p + 1; the rest of the colour is bars in any lane.
    pub(super) paired: Vec<[usize; 2]>,
    /// Colours `0..independent` share no particle between their bars; the
    /// rest (at most one group) is relaxed in order.
    pub(super) independent: usize,
    /// How many particles the ends index: every end is below this (the
    /// AVX2 sweep loads and stores through it unchecked).
    pub(super) particles: usize,
    /// Per independent colour, per octet range (paired at both ends, at
    /// end a, the other octets): how many of its first octets have all
    /// sixteen ends fixed, so that a pass skips them ([`Colouring::live`]).
    /// Derived from the weights by [`Colouring::count_still`].
    still: Vec<[usize; 3]>,
}

impl Colouring {
    /// Colours `bars`, whose ends (less `first`) index `particles`
    /// particles: their [`pairs::units`], each the smallest colour that no
    /// unit at any of its particles has (in unit order), then within a
    /// colour the units of each [`Class`] in turn, four to an octet, those
    /// whose particles are all `fixed` (indexed less `first`) first.
    pub(super) fn new(bars: &[&Bar], first: u32, particles: usize, fixed: &[bool]) -> Self {
        assert!(particles <= (u32::MAX / ROW) as usize, "{particles} particles: a row offset would not fit 32 bits");
        let ends: Vec<(u32, u32)> = bars.iter().map(|b| (b.a - first, b.b - first)).collect();
        let units = pairs::units(&ends, particles);
        let mut used = vec![0u64; particles];
        let mut coloured: Vec<(u32, Class, usize)> = Vec::with_capacity(units.len());
        for (k, unit) in units.iter().enumerate() {
            let touched = unit.bars().flat_map(|o| [o.a as usize, o.b as usize]);
            let taken = touched.clone().fold(0, |m, i| m | used[i]);
            let colour = (!taken).trailing_zeros().min(MAX_COLOURS);
            if colour < MAX_COLOURS {
                touched.for_each(|i| used[i] |= 1 << colour);
            }
            coloured.push((colour, unit.class, k));
        }
        // By nearest end (the lower row of a unit's first bar), then stably
        // by colour and class: each class of a colour comes in the order of
        // its rows (module docs), and the sorts in the loop below (still
        // units first, then by nearest end) have little left to do. Both
        // are counting sorts ([`csr`]): the keys are rows, and colours
        // times classes.
        let nearest = coloured.iter().enumerate().map(|(i, u)| (units[u.2].first.nearest(), i as u32));
        let (_, by_row) = csr(particles, nearest);
        let group = |i: u32| coloured[i as usize].0 * 3 + coloured[i as usize].1 as u32;
        let (_, order) = csr((MAX_COLOURS as usize + 1) * 3, by_row.iter().map(|&i| (group(i), i)));
        let coloured: Vec<(u32, Class, usize)> = order.iter().map(|&i| coloured[i as usize]).collect();
        let mut colouring = Colouring { particles, ..Colouring::default() };
        let push = |columns: &mut BarColumns, o: Oriented| {
            columns.a.push(ROW * o.a);
            columns.b.push(ROW * o.b);
            columns.rest.push(bars[o.bar].rest_length);
            columns.kind.push(bars[o.bar].kind.index() as u8);
        };
        // Bars and units whose ends are all fixed go first in their octet
        // range: they make the octets a pass skips while the weights keep
        // them still. Then by nearest end, so that the octets sweep the rows
        // upwards (module docs).
        let still_bar = |o: &Oriented| fixed[o.a as usize] && fixed[o.b as usize];
        let still = |u: &Unit| u.bars().all(|o| still_bar(&o));
        for colour in coloured.chunk_by(|x, y| x.0 == y.0) {
            let of = |class| colour.iter().filter(move |u| u.1 == class).map(|u| units[u.2]);
            let mut paired = [colouring.bars.a.len(); 2];
            let mut singles: Vec<Oriented> = Vec::new();
            if colour[0].0 < MAX_COLOURS {
                // Four units an octet: lane l holds the first bars, lane
                // l + 4 the second. A class's last units (fewer than four)
                // go on in the next class, and then one bar at a time.
                let mut carried: Vec<Unit> = Vec::new();
                for (k, class) in [Class::Both, Class::AEnd].into_iter().enumerate() {
                    carried.extend(of(class));
                    carried.sort_by_cached_key(|u| (!still(u), u.first.nearest()));
                    let whole = carried.len() / 4 * 4;
                    for octet in carried[..whole].chunks_exact(4) {
                        for unit in octet {
                            push(&mut colouring.bars, unit.first);
                        }
                        for unit in octet {
                            push(&mut colouring.bars, unit.second.unwrap_or_else(|| unreachable!("a pair")));
                        }
                    }
                    paired[k] = colouring.bars.a.len();
                    carried.drain(..whole);
                }
                singles.extend(carried.iter().flat_map(Unit::bars));
                singles.extend(of(Class::Single).flat_map(|u| u.bars()));
                singles.sort_by_cached_key(|o| (!still_bar(o), o.nearest()));
            } else {
                // The last group (no free colour) goes one bar at a time.
                singles.extend(colour.iter().flat_map(|u| units[u.2].bars()));
            }
            for o in singles {
                push(&mut colouring.bars, o);
            }
            colouring.paired.push(paired);
            colouring.ends.push(colouring.bars.a.len());
        }
        // Greedy colours are 0, 1, … without gaps, then MAX_COLOURS.
        colouring.independent =
            coloured.iter().filter(|u| u.0 < MAX_COLOURS).map(|u| u.0 as usize + 1).max().unwrap_or(0);
        debug_assert!(colouring.pairs_are_neighbouring_rows());
        colouring.still = vec![[0; 3]; colouring.independent];
        colouring
    }

    /// The three octet ranges of independent colour `c` (paired at both
    /// ends, at end a, the others: each a multiple of eight bars), and
    /// where the colour's bars after its octets start (one at a time).
    fn octet_ranges(&self, c: usize) -> ([std::ops::Range<usize>; 3], usize) {
        let range = self.colour(c);
        let [both, a_end] = self.paired[c];
        let octets_end = a_end + (range.end - a_end) / 8 * 8;
        ([range.start..both, both..a_end, a_end..octets_end], octets_end)
    }

    /// [`Colouring::octet_ranges`] less their still octets: what a pass
    /// projects.
    pub(super) fn live(&self, c: usize) -> ([std::ops::Range<usize>; 3], usize) {
        let (ranges, rest) = self.octet_ranges(c);
        (std::array::from_fn(|k| ranges[k].start + 8 * self.still[c][k]..ranges[k].end), rest)
    }

    /// Counts each octet range's leading octets whose ends all weigh 0
    /// (`weight` of a row, indexed as the ends are): their projections
    /// move nothing (w_a c = w_b c = 0), so a pass skips them. Called
    /// whenever a weight changes, before the next pass; a pin elsewhere
    /// skips nothing new, and a freed particle ends the skip where it is.
    pub(super) fn count_still(&mut self, weight: impl Fn(usize) -> f32) {
        for c in 0..self.independent {
            let (ranges, _) = self.octet_ranges(c);
            let bars = &self.bars;
            let still = |i: usize| (i..i + 8).all(|i| weight(bars.ends(i).0) == 0.0 && weight(bars.ends(i).1) == 0.0);
            let counts = ranges.map(|r| r.step_by(8).take_while(|&i| still(i)).count());
            self.still[c] = counts;
        }
    }

    /// Bars the next pass skips.
    pub(super) fn still_bars(&self) -> usize {
        self.still.iter().flatten().sum::<usize>() * 8
    }

    /// Whether every paired octet's lane l + 4 has the row after lane l's
    /// at end a (and, paired at both ends, at end b): what the AVX2 sweep's
    /// 32-byte loads and stores take for granted.
    fn pairs_are_neighbouring_rows(&self) -> bool {
        let next = |column: &[u32], i: usize| column[i + 4] == column[i] + ROW;
        (0..self.independent).all(|c| {
            let [both, a_end] = self.paired[c];
            let start = self.colour(c).start;
            // Lanes 0..4 of the octets from the colour's start.
            let lanes = |from: usize, to: usize| (from..to).filter(move |i| (i - start) % 8 < 4);
            lanes(start, both).all(|i| next(&self.bars.a, i) && next(&self.bars.b, i))
                && lanes(both, a_end).all(|i| next(&self.bars.a, i))
        })
    }

    /// Number of colours (groups).
    pub(super) fn colours(&self) -> usize {
        self.ends.len()
    }

    /// The range of bars of colour `c`.
    pub(super) fn colour(&self, c: usize) -> std::ops::Range<usize> {
        let start = if c == 0 { 0 } else { self.ends[c - 1] };
        start..self.ends[c]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::BarKind;

    #[test]
    fn paired_octets_hold_neighbouring_rows_and_a_broken_pair_is_caught() {
        // A ladder of 17 rungs (dimers 2p, 2p + 1), its two rails only:
        // units 2p–2p+2 with 2p+1–2p+3, each touching the next, so two
        // colours of eight units: two octets paired at both ends each.
        let bars: Vec<Bar> = (0..16)
            .flat_map(|p| [(2 * p, 2 * p + 2), (2 * p + 1, 2 * p + 3)])
            .map(|(a, b)| Bar { a, b, rest_length: 1.0, kind: BarKind::Structural })
            .collect();
        let refs: Vec<&Bar> = bars.iter().collect();
        let mut colouring = Colouring::new(&refs, 0, 34, &[false; 34]);
        assert_eq!((colouring.independent, colouring.paired.clone()), (2, vec![[16, 16], [32, 32]]));
        assert!(colouring.pairs_are_neighbouring_rows());
        // Lane 4 of the first octet given another row at end b: the 32-byte
        // store would write a row that bar does not own.
        colouring.bars.b[4] += ROW;
        assert!(!colouring.pairs_are_neighbouring_rows());
    }

    #[test]
    fn a_colours_octets_sweep_the_particles_in_order_whatever_the_bar_order() {
        // The ladder's rails (units 2p–2p+2 with 2p+1–2p+3, both ends
        // paired) and its rungs 2p–2p+1 (inside a dimer: single bars),
        // given last rung first: in unit order each colour's octets would
        // run from the top of the ladder down. Sorted, each octet range
        // steps through the rows upwards, so an octet's rows lie near the
        // last one's (the colours' sweep stays in cache).
        let rails = (0..16).flat_map(|p| [(2 * p, 2 * p + 2), (2 * p + 1, 2 * p + 3)]);
        let rungs = (0..17).map(|p| (2 * p, 2 * p + 1));
        let mut ends: Vec<(u32, u32)> = rails.chain(rungs).collect();
        ends.reverse();
        let bars: Vec<Bar> =
            ends.iter().map(|&(a, b)| Bar { a, b, rest_length: 1.0, kind: BarKind::Structural }).collect();
        let refs: Vec<&Bar> = bars.iter().collect();
        let colouring = Colouring::new(&refs, 0, 34, &[false; 34]);
        let near = |i: usize| colouring.bars.ends(i).0.min(colouring.bars.ends(i).1);
        let mut octets = 0;
        for c in 0..colouring.independent {
            for range in colouring.octet_ranges(c).0 {
                let firsts: Vec<usize> = range.step_by(8).map(near).collect();
                assert!(firsts.is_sorted(), "colour {c}: octets start at rows {firsts:?}");
                octets += firsts.len().saturating_sub(1);
            }
        }
        // Not a vacuous check: consecutive octets were compared (the rails
        // alone make two octets in each of their two colours).
        assert!(octets >= 2, "{octets} pairs of octets compared");
    }
}
