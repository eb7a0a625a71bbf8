//! The coloured layout's bars in groups over blocks of particles.
//!
//! A mesh of more than [`BLOCK_PARTICLES`] particles is cut into blocks of
//! consecutive particle indices: one per [`BLOCK_PARTICLES`] particles
//! (256 KiB, which stay in a core's L2 cache while its colours are swept),
//! rounded up to a multiple of [`THREAD_SHARES`]. The cut gives each block
//! the same share of the bars a pass projects (those with an end not fixed
//! when the layout is built), not the same number of particles: a block of
//! pinned particles costs a pass almost nothing, and with equal particle
//! counts disc-183 (its middle third pinned) left one of two threads idle
//! for an eighth of each pass (see [`BlockedBars::starts`]). Each group's
//! bars are coloured on their own ([`super::colouring`]):
//!
//! - a bar with both ends in block k belongs to block k;
//! - a bar between blocks k and k + 1 to seam k, coloured over those two
//!   blocks' particles;
//! - the rare bar between blocks further apart to a last group.
//!
//! A pass relaxes every block (in parallel on the rayon pool: blocks share
//! no particle), then the seams after even blocks (in parallel: seam k
//! touches blocks k and k + 1 only), then those after odd blocks, then the
//! last group on one thread: three rounds, each ended by a barrier. A
//! step with no tolerance runs its passes instead as a graph of tasks
//! ([`crate::sim::fast::graph`]): each block's next pass starts as soon as
//! its own two seams are done, in the same order for every particle, so
//! with the same bits. The bars between blocks had been one group
//! relaxed on one thread while the other idled (2.3 % of disc-183's bars,
//! 35–65 µs a pass on two threads of host D); in seams, disc-183's step on
//! two threads went from 9.9–15.4 ms to 9.2–12.3 ms (five alternated
//! pairs, each seams' run the shorter). The cut depends on the mesh and
//! the fixed particles only, never on the thread count, so every thread
//! count computes the same bits.
//!
//! Meshes whose vertex order is local (rows of a sheet, rings of the
//! tablecloth) keep the bars between blocks few: 1.8 % of the bars of a
//! 320 × 320 sheet. When the scene's order puts more than 1 bar in 20
//! between blocks (a mesh whose vertices jump around, as subdivision leaves
//! them), the layout renumbers the particles in
//! [`super::order::breadth_first_order`] and keeps that if fewer bars then
//! cross. Blocks start at an even index, on a dimer.

use std::ops::Range;

use rayon::prelude::*;

use super::Particle;
use super::ahead::Ahead;
use super::colouring::Colouring;
use super::sweep::{Sweep, relax_pass};
use crate::sim::fast::THREAD_SHARES;
use crate::sim::fast::graph::{self, Chain, Schedule, Task};
use crate::sim::mesh::Bar;

/// Particles a block is sized for (16 bytes each: 256 KiB): the block
/// count is one per this many. A block that holds pinned particles may
/// hold more, as the cut shares out the bars a pass projects. Blocks of
/// 8 192 particles did not move disc-183's step on a 2 MiB L2 (host G),
/// nor blocks of 8 192 or 4 096 on a 512 KB one (host J, Zen 3):
/// `docs/performance.md`.
pub(super) const BLOCK_PARTICLES: usize = 16_384;

/// Coloured bars and their multipliers μ = βλ (in colour order), over the
/// particles from `first` on.
#[derive(Clone, Debug, Default)]
pub(super) struct Group {
    pub(super) colouring: Colouring,
    pub(super) multipliers: Vec<f32>,
    /// The first particle its ends index (they are numbered from it).
    first: usize,
}

impl Group {
    fn new(bars: &[&Bar], first: usize, particles: usize, fixed: &[bool]) -> Self {
        let colouring = Colouring::new(bars, first as u32, particles, &fixed[first..]);
        Group { colouring, multipliers: vec![0.0; bars.len()], first }
    }

    /// The particles the group's ends index.
    fn run(&self) -> Range<usize> {
        self.first..self.first + self.colouring.particles
    }

    /// One pass over `particles`, the ones the group's ends index (from its
    /// first), prefetching `ahead` as it goes ([`super::ahead`]).
    fn relax(&mut self, particles: &mut [Particle], sweep: &Sweep, ahead: &mut Ahead) -> f32 {
        relax_pass(particles, &self.colouring, &mut self.multipliers, sweep, true, ahead)
    }
}

/// Every bar of the layout: the blocks', the seams' between neighbouring
/// blocks, and any others'.
#[derive(Clone, Debug)]
pub(super) struct BlockedBars {
    /// Block k holds the bars within particles `starts[k]..starts[k + 1]`
    /// ([`BlockedBars::starts`]), indexed from its first.
    pub(super) blocks: Vec<Group>,
    /// Seam k holds the bars between blocks k and k + 1, indexed from block
    /// k's first particle; `seams[0]` the seams after even blocks, which
    /// share no particle with one another, `seams[1]` those after odd ones.
    seams: [Vec<Group>; 2],
    /// Bars between blocks further apart (global indices): none in a mesh
    /// whose order is local.
    far: Group,
}

/// One pass of each group over the particles it indexes ([`Group::run`]:
/// increasing and disjoint within a round), on the thread pool when
/// `parallel`, as the runs share no particle. Returns the largest excess (max
/// is order-free: the same on any thread count). On one thread with
/// `prefetch` (the blocks' round), each group prefetches the rows of the
/// group after it, the last those of the first (the next pass's).
fn relax_runs(particles: &mut [Particle], groups: &mut [Group], parallel: bool, sweep: &Sweep, prefetch: bool) -> f32 {
    if !(parallel && groups.len() > 1) {
        let (at, len, count) = (particles.as_ptr(), particles.len(), groups.len());
        let mut worst = f32::NEG_INFINITY;
        for k in 0..count {
            let mut ahead = match prefetch && count > 1 {
                true => Ahead::rows(at, len, groups[graph::next_at_home(k, count, 1)].run()),
                false => Ahead::none(),
            };
            let run = groups[k].run();
            worst = worst.max(groups[k].relax(&mut particles[run], sweep, &mut ahead));
        }
        return worst;
    }
    let mut runs = Vec::with_capacity(groups.len());
    let (mut rest, mut at) = (particles, 0);
    for group in groups.iter_mut() {
        let run = group.run();
        let (_, tail) = std::mem::take(&mut rest).split_at_mut(run.start - at);
        let (slice, tail) = tail.split_at_mut(run.len());
        runs.push((slice, group));
        (rest, at) = (tail, run.end);
    }
    // `par_iter_mut`, not `into_par_iter`: the latter (same eight runs)
    // made disc-183's step on two threads 11.3–12.7 ms against 8.3–8.6 ms
    // (host D, three alternated pairs); not investigated further.
    let relax = |(p, group): &mut (&mut [Particle], &mut Group)| group.relax(p, sweep, &mut Ahead::none());
    runs.par_iter_mut().map(relax).reduce(|| f32::NEG_INFINITY, f32::max)
}

/// The block of particle `i` (`starts` as [`BlockedBars::starts`]).
fn block_of(starts: &[usize], i: u32) -> usize {
    starts.partition_point(|&s| s <= i as usize) - 1
}

impl BlockedBars {
    /// Where the blocks start, and the particle count last: one block when
    /// `particles` ≤ [`BLOCK_PARTICLES`], else one per [`BLOCK_PARTICLES`]
    /// rounded up to a multiple of [`THREAD_SHARES`]. Block k ends where the
    /// bars a pass projects (an end not `fixed`), counted at their lower
    /// end, reach k + 1 shares of them (equal particle counts when every
    /// end is fixed). Each start is even (a block starts on a dimer, two
    /// rows of one 32-byte load).
    pub(super) fn starts(bars: &[Bar], particles: usize, fixed: &[bool]) -> Vec<usize> {
        let count = particles.div_ceil(BLOCK_PARTICLES).max(1);
        if count == 1 {
            return vec![0, particles];
        }
        let count = count.next_multiple_of(THREAD_SHARES);
        let mut work = vec![0u64; particles];
        for bar in bars.iter().filter(|b| !(fixed[b.a as usize] && fixed[b.b as usize])) {
            work[bar.a.min(bar.b) as usize] += 1;
        }
        if work.iter().all(|&w| w == 0) {
            work.fill(1);
        }
        let total: u64 = work.iter().sum();
        let mut starts = vec![0];
        let mut done = 0;
        for (i, w) in work.into_iter().enumerate() {
            // Blocks 0..k are full once k shares are done (never at i = 0,
            // where none is: total > 0): block k starts at the next even
            // index, so the starts increase.
            let k = starts.len() as u64;
            if i % 2 == 0 && k < count as u64 && done * count as u64 >= k * total {
                starts.push(i);
            }
            done += w;
        }
        starts.push(particles);
        starts
    }

    /// How many of `bars` would join two blocks of a cut with no particle
    /// fixed (without colouring them): how local a numbering is.
    pub(super) fn boundary_count(bars: &[Bar], particles: usize) -> usize {
        let starts = Self::starts(bars, particles, &vec![false; particles]);
        bars.iter().filter(|b| block_of(&starts, b.a) != block_of(&starts, b.b)).count()
    }

    /// The layout's bars, the still ones of each class first where
    /// `fixed` (by particle) holds both their ends.
    pub(super) fn new(bars: &[Bar], particles: usize, fixed: &[bool]) -> Self {
        let starts = Self::starts(bars, particles, fixed);
        let count = starts.len() - 1;
        let mut inside: Vec<Vec<&Bar>> = vec![Vec::new(); count];
        let mut seams: Vec<Vec<&Bar>> = vec![Vec::new(); count.saturating_sub(1)];
        let mut far = Vec::new();
        for bar in bars {
            let (ka, kb) = (block_of(&starts, bar.a), block_of(&starts, bar.b));
            match ka.abs_diff(kb) {
                0 => inside[ka].push(bar),
                1 => seams[ka.min(kb)].push(bar),
                _ => far.push(bar),
            }
        }
        // Particles from block k's first: `blocks` blocks' worth.
        let group = |(k, bars): (usize, &Vec<&Bar>), blocks: usize| {
            Group::new(bars, starts[k], starts[k + blocks] - starts[k], fixed)
        };
        let blocks = inside.iter().enumerate().map(|b| group(b, 1)).collect();
        let mut paired: [Vec<Group>; 2] = [Vec::new(), Vec::new()];
        for (k, bars) in seams.iter().enumerate() {
            paired[k % 2].push(group((k, bars), 2));
        }
        BlockedBars { blocks, seams: paired, far: Group::new(&far, 0, particles, fixed) }
    }

    /// Every group: blocks, seams, the far bars.
    fn groups(&self) -> impl Iterator<Item = &Group> {
        self.blocks.iter().chain(self.seams.iter().flatten()).chain([&self.far])
    }

    /// [`BlockedBars::groups`], to change.
    fn groups_mut(&mut self) -> impl Iterator<Item = &mut Group> {
        self.blocks.iter_mut().chain(self.seams.iter_mut().flatten()).chain([&mut self.far])
    }

    /// The bars between blocks: the seams and the far bars.
    fn between(&self) -> impl Iterator<Item = &Group> {
        self.seams.iter().flatten().chain([&self.far])
    }

    /// [`Colouring::count_still`] for every group, from the particles'
    /// weights.
    pub(super) fn count_still(&mut self, particles: &[Particle]) {
        for group in self.groups_mut() {
            let first = group.first;
            group.colouring.count_still(|i| particles[first + i].weight);
        }
    }

    /// Bars a pass skips (all ends fixed), and in all.
    pub(super) fn still_share(&self) -> (usize, usize) {
        let still = self.groups().map(|g| g.colouring.still_bars()).sum();
        (still, self.boundary_share().1)
    }

    /// The most colours of any block, and of any group between blocks.
    pub(super) fn colours(&self) -> (usize, usize) {
        let most = |groups: &mut dyn Iterator<Item = &Group>| groups.map(|g| g.colouring.colours()).max().unwrap_or(0);
        (most(&mut self.blocks.iter()), most(&mut self.between()))
    }

    /// Bars in octets paired at both ends and at end a, and in all.
    pub(super) fn paired_share(&self) -> ([usize; 2], usize) {
        let mut paired = [0; 2];
        for colouring in self.groups().map(|g| &g.colouring) {
            for c in 0..colouring.independent {
                let [both, a_end] = colouring.paired[c];
                paired[0] += both - colouring.colour(c).start;
                paired[1] += a_end - both;
            }
        }
        (paired, self.boundary_share().1)
    }

    /// Bars between blocks, and in all.
    pub(super) fn boundary_share(&self) -> (usize, usize) {
        let count = |groups: &mut dyn Iterator<Item = &Group>| groups.map(|g| g.multipliers.len()).sum::<usize>();
        (count(&mut self.between()), count(&mut self.groups()))
    }

    /// Bars between blocks further apart than neighbours (relaxed on one
    /// thread).
    pub(super) fn far_bars(&self) -> usize {
        self.far.multipliers.len()
    }

    /// Every multiplier, group by group (blocks, seams, far bars).
    #[cfg(test)]
    pub(super) fn multipliers(&self) -> impl Iterator<Item = f32> + '_ {
        self.groups().flat_map(|g| g.multipliers.iter().copied())
    }

    /// Zeroes every μ (the start of a substep).
    pub(super) fn reset_multipliers(&mut self) {
        for group in self.groups_mut() {
            group.multipliers.fill(0.0);
        }
    }

    /// One pass: every block, then the seams after even blocks, then those
    /// after odd ones (each round in parallel when the pool has threads:
    /// its groups share no particle), then the far bars. Returns the
    /// largest excess ([`relax_pass`]).
    pub(super) fn relax_pass(&mut self, particles: &mut [Particle], sweep: &Sweep) -> f32 {
        let parallel = rayon::current_num_threads() > 1;
        let [even, odd] = &mut self.seams;
        let inside = relax_runs(particles, &mut self.blocks, parallel, sweep, true);
        let even = relax_runs(particles, even, parallel, sweep, false);
        let odd = relax_runs(particles, odd, parallel, sweep, false);
        let far = match self.far.multipliers.is_empty() {
            true => f32::NEG_INFINITY,
            false => self.far.relax(particles, sweep, &mut Ahead::none()),
        };
        inside.max(even).max(odd).max(far)
    }
}

/// The groups and the particles of a blocked layout, as the tasks of a
/// [`Schedule`] reach them from several threads.
struct Nodes {
    /// Node n's group: block n, or seam n − blocks.
    groups: Vec<*mut Group>,
    particles: *mut Particle,
    len: usize,
}

// SAFETY: `Nodes` is shared only by `BlockedBars::relax_passes`'s tasks,
// which `graph::run` never runs at once when they share a group or a
// particle (the schedule orders every such pair: `graph`'s module docs and
// its test `tasks_that_share_a_particle_are_always_ordered`), while the
// groups and particles stay mutably borrowed by `relax_passes`.
#[allow(unsafe_code)]
unsafe impl Sync for Nodes {}

impl BlockedBars {
    /// `passes` passes with no tolerance: as a graph of tasks on the pool's
    /// threads ([`crate::sim::fast::graph`]) where it has more than one and
    /// the layout two blocks or more and no far bars; else pass by pass
    /// ([`BlockedBars::relax_pass`]). The same bits either way. Returns
    /// whether the passes ran as a graph.
    #[allow(unsafe_code)]
    pub(super) fn relax_passes(&mut self, particles: &mut [Particle], sweep: &Sweep, passes: usize) -> bool {
        let (threads, blocks) = (rayon::current_num_threads(), self.blocks.len());
        if threads == 1 || blocks < 2 || !self.far.multipliers.is_empty() {
            for _ in 0..passes {
                self.relax_pass(particles, sweep);
            }
            return false;
        }
        // Each block's particles, for the prefetch of the block its worker
        // likely takes next (taken now: during the passes that block may be
        // another worker's).
        let runs: Vec<Range<usize>> = self.blocks.iter().map(Group::run).collect();
        let [even, odd] = &mut self.seams;
        let pointers = |groups: &mut Vec<Group>| groups.iter_mut().map(|g| g as *mut Group).collect::<Vec<_>>();
        let (even, odd) = (pointers(even), pointers(odd));
        let mut groups = pointers(&mut self.blocks);
        groups.extend((0..blocks - 1).map(|s| [&even, &odd][s % 2][s / 2]));
        let nodes = &Nodes { groups, particles: particles.as_mut_ptr(), len: particles.len() };
        // At most one worker a block: tasks that may run at once touch
        // different blocks (the graph orders any two that share one), and
        // a worker with nothing to take spins.
        let workers = threads.min(blocks);
        let relax = |t: Task| {
            // SAFETY: the pointers come from `&mut` borrows held for this
            // call; no other task that shares this group or a particle of
            // its run runs now (`Nodes`), and the run lies within the
            // particles (asserted).
            let pointer = nodes.groups[t.node];
            let group = unsafe { &mut *pointer };
            let run = group.run();
            assert!(run.end <= nodes.len, "a group's particles {run:?} past the layout's {}", nodes.len);
            let particles = unsafe { std::slice::from_raw_parts_mut(nodes.particles.add(run.start), run.len()) };
            // A block prefetches the block its worker likely takes next
            // (addresses only: that block may be another worker's now).
            let mut ahead = match t.node < blocks {
                true => {
                    Ahead::rows(nodes.particles, nodes.len, runs[graph::next_at_home(t.node, blocks, workers)].clone())
                }
                false => Ahead::none(),
            };
            group.relax(particles, sweep, &mut ahead);
        };
        graph::run(Schedule::new(Chain::BlocksAndSeams, blocks, passes), workers, &relax);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::BarKind;
    use crate::sim::fast::simd::{self, SimdLevel};

    #[test]
    fn blocks_share_the_bars_a_pass_projects_not_the_particles() {
        // A 200 × 200 sheet (40 000 particles: ⌈40 000 / 16 384⌉ = 3, so 4
        // blocks) of horizontal and vertical bars, rows 0–99 fixed. The bars
        // a pass projects, counted at their lower end: row 99's 200 vertical
        // bars into row 100, rows 100–198's 199 + 200 each, row 199's 199:
        // 200 + 99 · 399 + 199 = 39 900, so 9 975 a block. A block ends at
        // the first even index past its share; a particle adds at most 2
        // bars, so each end is at most 4 bars late and each block's count
        // within 8 of 9 975. Cut by particle count instead (10 000 each),
        // blocks 0 and 1 would hold 0 and 200 of those bars and blocks 2
        // and 3 about 19 850 each: one of two threads idle for half a pass.
        let n = 200u32;
        let at = |c: u32, r: u32| r * n + c;
        let mut bars = Vec::new();
        for r in 0..n {
            for c in 0..n {
                let mut bar = |b: u32| bars.push(Bar { a: at(c, r), b, rest_length: 0.1, kind: BarKind::Structural });
                if c + 1 < n {
                    bar(at(c + 1, r));
                }
                if r + 1 < n {
                    bar(at(c, r + 1));
                }
            }
        }
        let count = (n * n) as usize;
        let fixed: Vec<bool> = (0..count).map(|i| i < count / 2).collect();
        let starts = BlockedBars::starts(&bars, count, &fixed);
        assert_eq!(starts.len(), 5, "{starts:?}");
        assert_eq!((starts[0], starts[4]), (0, count));
        assert!(starts.windows(2).all(|w| w[0] < w[1]) && starts.iter().all(|s| s % 2 == 0), "{starts:?}");
        let moving = |b: &&Bar| !(fixed[b.a as usize] && fixed[b.b as usize]);
        for k in 0..4 {
            let inside = |b: &&Bar| (starts[k]..starts[k + 1]).contains(&(b.a.min(b.b) as usize));
            let share = bars.iter().filter(moving).filter(inside).count();
            assert!(share.abs_diff(9_975) <= 8, "block {k} holds {share} of the bars a pass projects: {starts:?}");
        }
        // The first block takes every fixed particle and 25 rows after them.
        assert!((124 * 200..125 * 200).contains(&starts[1]), "{starts:?}");
        // With nothing fixed the cut is by the bars alone: near-equal rows.
        let loose = BlockedBars::starts(&bars, count, &vec![false; count]);
        assert!(loose.windows(2).all(|w| (w[1] - w[0]).abs_diff(count / 4) <= 2 * n as usize), "{loose:?}");
    }

    /// The positions' and multipliers' bits.
    fn bits(b: &BlockedBars, x: &[Particle]) -> Vec<u32> {
        let positions = x.iter().flat_map(|p| p.position.map(f32::to_bits));
        positions.chain(b.multipliers().map(f32::to_bits)).collect()
    }

    /// A 130 × 130 sheet (16 900 particles: four blocks, seams 0 and 2
    /// after even blocks, seam 1 after an odd one) of structural, diagonal
    /// and bend bars, stretched 3 %, with (if `far`) four bars from the
    /// first row to the last (blocks 0 and 3: far bars). Unequal masses
    /// and compliant bars, so every group's multipliers move too. Its bars,
    /// particles and particle count.
    fn stretched_sheet(far: bool) -> (Vec<Bar>, Vec<Particle>, usize) {
        let n = 130u32;
        let at = |c: u32, r: u32| r * n + c;
        let mut bars = Vec::new();
        let mut bar = |a: u32, b: u32, kind: BarKind, rest: f32| bars.push(Bar { a, b, rest_length: rest, kind });
        for r in 0..n {
            for c in 0..n {
                if c + 1 < n {
                    bar(at(c, r), at(c + 1, r), BarKind::Structural, 0.1);
                }
                if r + 1 < n {
                    bar(at(c, r), at(c, r + 1), BarKind::Structural, 0.1);
                }
                if c + 1 < n && r + 1 < n {
                    bar(at(c, r), at(c + 1, r + 1), BarKind::Shear, 0.1 * std::f32::consts::SQRT_2);
                }
                if r + 2 < n {
                    bar(at(c, r), at(c, r + 2), BarKind::Bend, 0.2);
                }
            }
        }
        if far {
            for c in [0, 40, 80, 120] {
                bar(at(c, 0), at(c + 1, n - 1), BarKind::Structural, 11.0);
            }
        }
        let count = (n * n) as usize;
        let particles: Vec<Particle> = (0..count as u32)
            .map(|i| {
                let (c, r) = ((i % n) as f32, (i / n) as f32);
                let weight = [1.0, 0.5, 1.0 / 3.0][i as usize % 3];
                Particle { position: [c * 0.103, r * 0.103, 0.01 * (c * 0.7 + r).sin()], weight }
            })
            .collect();
        (bars, particles, count)
    }

    #[test]
    fn a_pass_is_its_groups_one_after_another_in_the_documented_order() {
        let (bars, particles, count) = stretched_sheet(true);
        let blocked = BlockedBars::new(&bars, count, &vec![false; count]);
        assert_eq!((blocked.blocks.len(), blocked.seams[0].len(), blocked.seams[1].len()), (4, 2, 1));
        assert_eq!(blocked.far_bars(), 4);
        let sweep = Sweep { betas: [0.3, 2.0, 0.7], omega: 1.2, tolerance: 0.0 };

        // Blocks, even seams and odd seams in parallel rounds on two threads.
        let (mut rounds, mut x_rounds) = (blocked.clone(), particles.clone());
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("a pool");
        pool.install(|| rounds.relax_pass(&mut x_rounds, &sweep));
        // The same groups one after another, each over its own particles.
        let (mut alone, mut x_alone) = (blocked, particles.clone());
        let [even, odd] = &mut alone.seams;
        let groups = alone.blocks.iter_mut().chain(even.iter_mut()).chain(odd.iter_mut()).chain([&mut alone.far]);
        for group in groups {
            let (first, last) = (group.first, group.first + group.colouring.particles);
            group.relax(&mut x_alone[first..last], &sweep, &mut Ahead::none());
        }
        assert_eq!(bits(&rounds, &x_rounds), bits(&alone, &x_alone));
        // Every group moved something: its multipliers are not all zero.
        let [even, odd] = &rounds.seams;
        for group in rounds.blocks.iter().chain(even).chain(odd).chain([&rounds.far]) {
            assert!(group.multipliers.iter().any(|&m| m != 0.0), "a group starting at {} did not move", group.first);
        }
    }

    #[test]
    fn a_block_prefetches_the_next_blocks_rows_as_it_goes() {
        // The sheet without far bars: four blocks of about 130² / 4 = 4 225
        // particles, so block 1's rows are about 4 225 / 4 = 1 057 lines of
        // four, and block 0 holds about 4 bars a particle (≈ 2 100
        // octets). A pass over block 0 takes one line an octet, so with the
        // octets (AVX2 and above) it prefetches every line of block 1; the
        // portable level does not prefetch, and the cursor stays put.
        let (bars, mut particles, count) = stretched_sheet(false);
        let mut blocked = BlockedBars::new(&bars, count, &vec![false; count]);
        let sweep = Sweep { betas: [0.0; 3], omega: 1.0, tolerance: 0.0 };
        let (run, next) = (blocked.blocks[0].run(), blocked.blocks[1].run());
        let mut ahead = Ahead::rows(particles.as_ptr(), particles.len(), next.clone());
        // Blocks start on an even index (32 bytes), so the lines are ⌈rows / 4⌉.
        let lines = ahead.lines_left();
        assert!(lines.abs_diff(next.len() / 4) <= 1, "{lines} lines for {} rows", next.len());
        let colouring = &blocked.blocks[0].colouring;
        let octets: usize = (0..colouring.independent).flat_map(|c| colouring.live(c).0).map(|r| r.len() / 8).sum();
        assert!(octets > lines, "{octets} octets, {lines} lines");
        blocked.blocks[0].relax(&mut particles[run], &sweep, &mut ahead);
        let octets_run = cfg!(target_arch = "x86_64") && simd::level() >= SimdLevel::Avx2;
        assert_eq!(ahead.lines_left(), if octets_run { 0 } else { lines });
    }

    #[test]
    fn the_graph_of_tasks_gives_the_rounds_bits_on_any_thread_count() {
        // The sheet without far bars: four blocks, three seams. Five passes
        // as a graph of tasks on two and on three threads against five
        // passes of rounds on one: the same positions and multipliers, bit
        // for bit, and the graph was used (not the rounds again).
        let (bars, particles, count) = stretched_sheet(false);
        let blocked = BlockedBars::new(&bars, count, &vec![false; count]);
        assert_eq!((blocked.blocks.len(), blocked.far_bars()), (4, 0));
        let sweep = Sweep { betas: [0.3, 2.0, 0.7], omega: 1.2, tolerance: 0.0 };
        let (mut rounds, mut x_rounds) = (blocked.clone(), particles.clone());
        for _ in 0..5 {
            rounds.relax_pass(&mut x_rounds, &sweep);
        }
        for threads in [2, 3] {
            let (mut graph, mut x_graph) = (blocked.clone(), particles.clone());
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
            assert!(pool.install(|| graph.relax_passes(&mut x_graph, &sweep, 5)), "{threads} threads: rounds used");
            assert!(bits(&graph, &x_graph) == bits(&rounds, &x_rounds), "{threads} threads: other bits");
        }
        // One thread keeps the rounds; and the passes moved every group.
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a pool");
        assert!(!one.install(|| blocked.clone().relax_passes(&mut particles.clone(), &sweep, 1)));
        let [even, odd] = &rounds.seams;
        assert!(rounds.blocks.iter().chain(even).chain(odd).all(|g| g.multipliers.iter().any(|&m| m != 0.0)));
    }
}
