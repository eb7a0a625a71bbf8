//! Orders of the particles for the coloured layout.
//!
//! **Breadth-first** ([`breadth_first_order`]): particles a bar apart get
//! nearby indices, so blocks of consecutive indices are bands of the mesh
//! with few bars between them (see [`super::colouring`]).
//!
//! **Dimers** ([`dimer_order`]): slots 2m and 2m + 1 hold two particles
//! joined by a structural bar, chosen so that dimers lie side by side like
//! the rungs of a ladder. Two bars p₀–q₀ and p₁–q₁ between the dimers
//! (p₀, p₁) and (q₀, q₁) then have their ends in consecutive rows at both
//! ends, and the AVX2 sweep loads and stores each end pair with one 32-byte
//! access instead of two 16-byte ones and a shuffle ([`super::pairs`]).

use crate::sim::BarKind;
use crate::sim::mesh::Bar;

/// Each particle's neighbours over a set of bars, with the bar to each
/// (numbered in the order given), in one array sorted by neighbour then
/// bar: particle i's are `list[first[i]..first[i + 1]]`.
pub(super) struct Neighbours {
    first: Vec<usize>,
    list: Vec<(u32, u32)>,
}

impl Neighbours {
    /// The neighbours of `particles` particles over `bars`.
    pub(super) fn new(particles: usize, bars: impl Iterator<Item = (u32, u32)> + Clone) -> Self {
        let mut first = vec![0usize; particles + 1];
        for (a, b) in bars.clone() {
            first[a as usize + 1] += 1;
            first[b as usize + 1] += 1;
        }
        for i in 0..particles {
            first[i + 1] += first[i];
        }
        let mut fill = first.clone();
        let mut list = vec![(0, 0); first[particles]];
        for (bar, (a, b)) in bars.enumerate() {
            for (from, to) in [(a, b), (b, a)] {
                list[fill[from as usize]] = (to, bar as u32);
                fill[from as usize] += 1;
            }
        }
        for i in 0..particles {
            list[first[i]..first[i + 1]].sort_unstable();
        }
        Neighbours { first, list }
    }

    /// Particle `i`'s neighbours and the bar to each, by neighbour.
    pub(super) fn of(&self, i: usize) -> &[(u32, u32)] {
        &self.list[self.first[i]..self.first[i + 1]]
    }

    /// Particle `i`'s neighbours, as a mutable slice (to reorder them).
    fn of_mut(&mut self, i: usize) -> &mut [(u32, u32)] {
        &mut self.list[self.first[i]..self.first[i + 1]]
    }

    /// The bars between `i` and `j` (a mesh may repeat a bar).
    pub(super) fn between(&self, i: usize, j: u32) -> impl Iterator<Item = u32> + '_ {
        let at = self.of(i);
        let k = at.partition_point(|&(n, _)| n < j);
        at[k..].iter().take_while(move |&&(n, _)| n == j).map(|&(_, bar)| bar)
    }

    /// Whether a bar joins `i` and `j`.
    pub(super) fn joined(&self, i: usize, j: u32) -> bool {
        self.between(i, j).next().is_some()
    }
}

/// The ends of every bar.
fn ends(bars: &[Bar]) -> impl Iterator<Item = (u32, u32)> + Clone + '_ {
    bars.iter().map(|b| (b.a, b.b))
}

/// A breadth-first (Cuthill–McKee) order of the particles over the bars:
/// each connected piece from a particle of least degree, neighbours in order
/// of degree, then index. `order[k]` is the particle placed k-th.
pub(super) fn breadth_first_order(particles: usize, bars: &[Bar]) -> Vec<u32> {
    let mut neighbours = Neighbours::new(particles, ends(bars));
    let degree: Vec<u32> = (0..particles).map(|i| neighbours.of(i).len() as u32).collect();
    let by_degree = |&i: &u32| (degree[i as usize], i);
    for i in 0..particles {
        neighbours.of_mut(i).sort_unstable_by_key(|(j, _)| by_degree(j));
    }
    let mut roots: Vec<u32> = (0..particles as u32).collect();
    roots.sort_unstable_by_key(by_degree);
    let mut placed = vec![false; particles];
    let mut order = Vec::with_capacity(particles);
    for root in roots {
        if placed[root as usize] {
            continue;
        }
        placed[root as usize] = true;
        let mut next = order.len();
        order.push(root);
        // `order` is the queue: everything after `next` waits its turn.
        while next < order.len() {
            let i = order[next] as usize;
            next += 1;
            for &(j, _) in neighbours.of(i) {
                if !placed[j as usize] {
                    placed[j as usize] = true;
                    order.push(j);
                }
            }
        }
    }
    order
}

/// An order in which slots 2m and 2m + 1 (a *dimer*) hold two particles a
/// structural bar apart wherever one is left, laid side by side.
///
/// Particles are taken in [`breadth_first_order`] (a walk over the mesh
/// that leaves fewer particles with no free neighbour than a walk in a
/// jumbled index order would). The next particle not yet placed takes as partner the neighbour not yet placed, over a structural
/// bar, that makes the most *parallel pairs* with dimers already placed: a
/// dimer (x₀, x₁) counts for (i, j) when bars i–x₀ and j–x₁ both exist (then
/// i goes first), or i–x₁ and j–x₀ (then j goes first). Ties go to the
/// neighbour with fewer free neighbours of its own (a greedy matching that
/// strands fewer particles), then to the lowest index. On a sheet this lays
/// the dimers as rungs of ladders, every rung parallel to the ones beside
/// it. A particle with no free neighbour over a structural bar takes one
/// over any bar; one with none at all shares its dimer with the next
/// particle taken.
///
/// `order[k]` is the particle in slot k.
pub(super) fn dimer_order(particles: usize, bars: &[Bar]) -> Vec<u32> {
    const FREE: u32 = u32::MAX;
    let structural = bars.iter().filter(|b| b.kind == BarKind::Structural).map(|b| (b.a, b.b));
    let (near, all) = (Neighbours::new(particles, structural), Neighbours::new(particles, ends(bars)));
    let mut slot = vec![FREE; particles];
    // Each particle's structural neighbours not yet placed.
    let mut free: Vec<u32> = (0..particles).map(|i| near.of(i).len() as u32).collect();
    let mut order: Vec<u32> = Vec::with_capacity(particles);
    let place = |slot: &mut [u32], free: &mut [u32], order: &mut Vec<u32>, i: u32| {
        slot[i as usize] = order.len() as u32;
        order.push(i);
        for &(k, _) in near.of(i as usize) {
            free[k as usize] -= 1;
        }
    };
    for i in breadth_first_order(particles, bars) {
        let i = i as usize;
        if slot[i] != FREE {
            continue;
        }
        if !order.len().is_multiple_of(2) {
            // The last particle placed found no partner: this one completes
            // its dimer.
            place(&mut slot, &mut free, &mut order, i as u32);
            continue;
        }
        // The partner: most parallel pairs, then fewest free neighbours
        // (who would be left alone sooner), then lowest index; over a
        // structural bar, or any bar if none is free.
        // ((−parallel pairs, free neighbours, index), whether i goes first)
        type Key = (std::cmp::Reverse<u32>, u32, u32);
        let mut best: Option<(Key, bool)> = None;
        let candidates = |list: &'_ [(u32, u32)]| {
            list.iter().map(|&(j, _)| j).filter(|&j| slot[j as usize] == FREE).collect::<Vec<_>>()
        };
        let mut partners = candidates(near.of(i));
        if partners.is_empty() {
            partners = candidates(all.of(i));
        }
        for j in partners {
            let (mut i_first, mut j_first) = (0, 0);
            for &(x, _) in all.of(i) {
                let s = slot[x as usize];
                // x's partner: the other slot of its dimer, if filled.
                if s == FREE || (s ^ 1) as usize >= order.len() {
                    continue;
                }
                if all.joined(j as usize, order[(s ^ 1) as usize]) {
                    if s.is_multiple_of(2) { i_first += 1 } else { j_first += 1 }
                }
            }
            let key = (std::cmp::Reverse(i_first.max(j_first)), free[j as usize], j);
            if best.is_none_or(|(b, _)| key < b) {
                best = Some((key, i_first >= j_first));
            }
        }
        match best {
            Some(((_, _, j), true)) => {
                place(&mut slot, &mut free, &mut order, i as u32);
                place(&mut slot, &mut free, &mut order, j);
            }
            Some(((_, _, j), false)) => {
                place(&mut slot, &mut free, &mut order, j);
                place(&mut slot, &mut free, &mut order, i as u32);
            }
            None => place(&mut slot, &mut free, &mut order, i as u32),
        }
    }
    order
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::super::pairs::{Class, units};
    use super::*;
    use crate::sim::mesh::ClothMesh;

    /// An n × n triangulated sheet's bars, its particles numbered in a
    /// shuffled order.
    fn shuffled_sheet(n: u32) -> Vec<Bar> {
        let mut number: Vec<u32> = (0..n * n).collect();
        let mut state = 99u64;
        for i in (1..number.len()).rev() {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            number.swap(i, (state >> 33) as usize % (i + 1));
        }
        let mut positions = vec![Vec3::ZERO; (n * n) as usize];
        for i in 0..n * n {
            positions[number[i as usize] as usize] = Vec3::new((i % n) as f32, (i / n) as f32, 0.0) * 0.1;
        }
        let mut triangles = Vec::new();
        for r in 0..n - 1 {
            for c in 0..n - 1 {
                let [a, b, d, e] =
                    [r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1].map(|v| number[v as usize]);
                triangles.extend([[a, d, e], [a, e, b]]);
            }
        }
        ClothMesh::from_triangles(positions, triangles, &[], None).expect("a valid sheet").bars().to_vec()
    }

    /// The share of bars in units of each class, with the particles in
    /// `order` (`order[k]` in slot k).
    fn shares(order: &[u32], bars: &[Bar]) -> [f64; 3] {
        let mut slot = vec![0u32; order.len()];
        for (k, &i) in order.iter().enumerate() {
            slot[i as usize] = k as u32;
        }
        let ends: Vec<(u32, u32)> = bars.iter().map(|b| (slot[b.a as usize], slot[b.b as usize])).collect();
        let units = units(&ends, order.len());
        [Class::Both, Class::AEnd, Class::Single].map(|class| {
            let bars: usize = units.iter().filter(|u| u.class == class).map(|u| u.bars().count()).sum();
            bars as f64 / ends.len() as f64
        })
    }

    #[test]
    fn a_shuffled_sheet_is_laid_out_as_rungs_of_ladders() {
        let n = 30;
        let bars = shuffled_sheet(n);
        let order = dimer_order((n * n) as usize, &bars);
        // A permutation.
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n * n).collect::<Vec<u32>>());
        // Every dimer is joined by a structural bar (a sheet has a free
        // neighbour for nearly every particle; allow a few lone ones).
        let structural =
            Neighbours::new(order.len(), bars.iter().filter(|b| b.kind == BarKind::Structural).map(|b| (b.a, b.b)));
        let joined = order.chunks_exact(2).filter(|d| structural.joined(d[0] as usize, d[1])).count();
        assert!(joined * 100 >= 97 * order.len() / 2, "{joined} of {} dimers joined", order.len() / 2);
        // Laid side by side, the dimers pair many bars at both ends, and
        // nearly all the others at end a. In the shuffled order
        // consecutive particles are rarely neighbours, and hardly a bar
        // pairs at both ends (end a pairs need only two bars with different
        // far ends at particles 2p and 2p + 1, which any order has).
        let [both, a_end, single] = shares(&order, &bars);
        let shuffled: Vec<u32> = (0..n * n).collect();
        let [both_shuffled, ..] = shares(&shuffled, &bars);
        eprintln!("dimers: {both:.3} {a_end:.3} {single:.3}; shuffled {both_shuffled:.3}");
        assert!(both > 0.35 && both + a_end > 0.85, "dimers: {both:.3} {a_end:.3} {single:.3}");
        assert!(both_shuffled < 0.01, "shuffled: {both_shuffled:.3}");
    }
}
