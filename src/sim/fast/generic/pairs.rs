//! Bars paired for the AVX2 sweep's 32-byte loads.
//!
//! The octet's lanes l and l + 4 share a register half by half when a
//! particle's row is transposed into lanes ([`crate::sim::fast::avx`]), so
//! when the ends a of those two bars are particles 2p and 2p + 1 (a dimer
//! of [`super::order::dimer_order`]), both rows come in with one 32-byte load
//! and go out with one 32-byte store; otherwise each takes a 16-byte load
//! and a shuffle to join them (`vinsertf128`), and a shuffle and a 16-byte
//! store to part them (`vextractf128`). A *unit* is what one lane pair
//! holds:
//!
//! - [`Class::Both`]: bars 2p–2q and 2p+1–2q+1 (parallel rungs of a ladder):
//!   both ends in pairs;
//! - [`Class::AEnd`]: bars 2p–x and 2p+1–y, x ≠ y: end a in a pair;
//! - [`Class::Single`]: one bar, which takes any lane.
//!
//! A bar may be turned end for end to fit: its projection is symmetric (d
//! changes sign exactly, the moves swap), so the bits do not change.

use super::order::Neighbours;

/// How a unit's two bars meet the dimers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Class {
    /// Ends a at 2p, 2p + 1 and ends b at 2q, 2q + 1.
    Both,
    /// Ends a at 2p, 2p + 1.
    AEnd,
    /// One bar.
    Single,
}

/// A bar, with the end that goes first: `bar` indexes the bars paired.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Oriented {
    pub(super) bar: usize,
    pub(super) a: u32,
    pub(super) b: u32,
}

impl Oriented {
    /// Its nearer end to the first row: the lower of its two.
    pub(super) fn nearest(&self) -> u32 {
        self.a.min(self.b)
    }
}

/// One bar, or two bars that share a lane pair.
#[derive(Clone, Copy, Debug)]
pub(super) struct Unit {
    pub(super) class: Class,
    pub(super) first: Oriented,
    /// Ends `first.a + 1` and, for [`Class::Both`], `first.b + 1`.
    pub(super) second: Option<Oriented>,
}

impl Unit {
    /// Its bars.
    pub(super) fn bars(&self) -> impl Iterator<Item = Oriented> + Clone + use<> {
        std::iter::once(self.first).chain(self.second)
    }
}

/// The bars (ends below `particles`) as units: first every parallel pair,
/// in bar order, then pairs at a dimer's two particles, dimer by dimer,
/// then the bars left one by one. Every bar is in exactly one unit, and no
/// unit's two bars share a particle.
pub(super) fn units(ends: &[(u32, u32)], particles: usize) -> Vec<Unit> {
    let mut units = Vec::with_capacity(ends.len());
    let mut used = vec![false; ends.len()];
    let neighbours = Neighbours::new(particles, ends.iter().copied());
    // A bar between i and j not yet in a unit.
    let between = |used: &[bool], i: u32, j: u32| -> Option<usize> {
        neighbours.between(i as usize, j).map(|bar| bar as usize).find(|&bar| !used[bar])
    };
    let dimer = |i: u32| i / 2;
    let has_partner = |i: u32| (i | 1) < particles as u32;
    let oriented = |bar: usize, a: u32| {
        let (x, y) = ends[bar];
        Oriented { bar, a, b: if x == a { y } else { x } }
    };

    // Parallel pairs: 2p–2q with 2p+1–2q+1.
    for (bar, &(a, b)) in ends.iter().enumerate() {
        if used[bar] || dimer(a) == dimer(b) || a % 2 != b % 2 || !has_partner(a) || !has_partner(b) {
            continue;
        }
        let (p, q) = (a & !1, b & !1);
        if let (Some(e), Some(f)) = (between(&used, p, q), between(&used, p + 1, q + 1)) {
            used[e] = true;
            used[f] = true;
            units.push(Unit { class: Class::Both, first: oriented(e, p), second: Some(oriented(f, p + 1)) });
        }
    }
    // Pairs at a dimer: 2p–x with 2p+1–y, x ≠ y (neither in the dimer).
    let (mut zero, mut one) = (Vec::new(), Vec::new());
    for p in (0..particles as u32 / 2).map(|m| 2 * m) {
        for (i, free) in [(p, &mut zero), (p + 1, &mut one)] {
            free.clear();
            let at = neighbours.of(i as usize).iter().map(|&(n, bar)| (n, bar as usize));
            free.extend(at.filter(|&(n, bar)| dimer(n) != dimer(i) && !used[bar]).map(|(_, bar)| bar));
        }
        for &e in &zero {
            let x = oriented(e, p).b;
            if let Some(k) = one.iter().position(|&f| oriented(f, p + 1).b != x) {
                let f = one.remove(k);
                used[e] = true;
                used[f] = true;
                units.push(Unit { class: Class::AEnd, first: oriented(e, p), second: Some(oriented(f, p + 1)) });
            }
        }
    }
    for (bar, &(a, _)) in ends.iter().enumerate() {
        if !used[bar] {
            units.push(Unit { class: Class::Single, first: oriented(bar, a), second: None });
        }
    }
    units
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ladder_pairs_its_rails_and_leaves_its_rungs_and_diagonals() {
        // A ladder of 4 rungs, dimers (0, 1), (2, 3), (4, 5), (6, 7): rails
        // 0–2–4–6 and 1–3–5–7 (parallel pairs, 3 of them), rungs 2p–2p+1
        // (inside a dimer: single), and diagonals 0–3, 2–5: at dimer
        // (2, 3) they are 2–5 and 3–0, far ends 5 ≠ 0, so end a pairs.
        let mut ends = vec![];
        for p in 0..3u32 {
            ends.extend([(2 * p, 2 * p + 2), (2 * p + 3, 2 * p + 1)]);
        }
        ends.extend([(0, 1), (2, 3), (4, 5), (6, 7), (0, 3), (2, 5)]);
        let units = units(&ends, 8);
        let count = |c| units.iter().filter(|u| u.class == c).count();
        assert_eq!((count(Class::Both), count(Class::AEnd), count(Class::Single)), (3, 1, 4), "{units:?}");
        for u in units.iter().filter(|u| u.class == Class::Both) {
            if let Some(s) = u.second {
                // The second bar's ends are the first's plus one, the one
                // stored reversed (3–1) turned round.
                assert_eq!((s.a, s.b), (u.first.a + 1, u.first.b + 1));
                assert_eq!(u.first.a % 2, 0);
            }
        }
        // Every bar once.
        let mut seen: Vec<usize> = units.iter().flat_map(|u| u.bars().map(|o| o.bar)).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..ends.len()).collect::<Vec<_>>());
    }

    #[test]
    fn bars_at_a_dimers_two_particles_pair_when_their_far_ends_differ() {
        // Dimer (0, 1); bars 0–4, 1–4 (same far end: cannot share a
        // colour), 1–6. Pairs: 0–4 with 1–6 (end a paired); 1–4 single.
        let ends = [(0, 4), (1, 4), (6, 1)];
        let units = units(&ends, 8);
        let pair = units.iter().find(|u| u.class == Class::AEnd).expect("a pair at the dimer");
        assert_eq!((pair.first.a, pair.first.b), (0, 4));
        assert_eq!(pair.second.map(|s| (s.a, s.b)), Some((1, 6)));
        assert_eq!(units.iter().filter(|u| u.class == Class::Single).count(), 1);
    }
}
