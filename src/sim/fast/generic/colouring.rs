//! The bars of the coloured layout: greedy colours, in blocks of particles.
//!
//! **Colours.** Every bar gets the smallest colour not yet used by a bar at
//! either of its ends, in creation order; bars are stored colour by colour
//! (creation order within a colour). Bars of one colour share no particle.
//!
//! **Blocks.** A mesh of more than [`BLOCK_PARTICLES`] particles is cut into
//! blocks of consecutive particle indices, each at most that many (256 KiB
//! of particles, which stay in a core's L2 cache while its colours are
//! swept), as many as the next multiple of [`THREAD_SHARES`]. A bar with
//! both ends in one block belongs to that block; the others, the boundary,
//! form a last group of their own. A pass relaxes every block (in parallel
//! on the rayon pool: blocks share no particle), then the boundary. The cut
//! depends on the particle count only, so every thread count computes the
//! same bits. Meshes whose vertex order is local (rows of a sheet, rings of
//! the tablecloth) keep the boundary small: 1.8 % of the bars of a 320 ×
//! 320 sheet. When the scene's order puts more than 1 bar in 20 on the
//! boundary (a mesh whose vertices jump around, as
//! subdivision leaves them), the layout renumbers the particles in
//! [`breadth_first_order`] and keeps that if its boundary is smaller.

use rayon::prelude::*;

use super::Particle;
use super::sweep::{Sweep, relax_pass};
use crate::sim::fast::THREAD_SHARES;
use crate::sim::mesh::Bar;

/// Most particles in a block (16 bytes each: 256 KiB).
pub(super) const BLOCK_PARTICLES: usize = 16_384;

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
    /// [`crate::sim::BarKind::index`]: an index into [`Sweep::betas`].
    pub(super) kind: Vec<u8>,
}

/// `f32`s in a particle's row (x, y, z, w).
const ROW: u32 = 4;

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
    /// Colours `0..independent` share no particle between their bars; the
    /// rest (at most one group) is relaxed in order.
    pub(super) independent: usize,
    /// How many particles the ends index: every end is below this (the
    /// AVX2 sweep loads and stores through it unchecked).
    pub(super) particles: usize,
}

impl Colouring {
    /// Colours `bars`, whose ends (less `first`) index `particles`
    /// particles.
    fn new(bars: &[&Bar], first: u32, particles: usize) -> Self {
        assert!(particles <= (u32::MAX / ROW) as usize, "{particles} particles: a row offset would not fit 32 bits");
        let mut used = vec![0u64; particles];
        let mut coloured: Vec<(u32, usize)> = Vec::with_capacity(bars.len());
        for (i, bar) in bars.iter().enumerate() {
            let (a, b) = ((bar.a - first) as usize, (bar.b - first) as usize);
            let colour = (!(used[a] | used[b])).trailing_zeros().min(MAX_COLOURS);
            if colour < MAX_COLOURS {
                used[a] |= 1 << colour;
                used[b] |= 1 << colour;
            }
            coloured.push((colour, i));
        }
        coloured.sort_by_key(|&(colour, i)| (colour, i));
        let mut colouring = Colouring { particles, ..Colouring::default() };
        for (n, &(colour, i)) in coloured.iter().enumerate() {
            if n > 0 && coloured[n - 1].0 != colour {
                colouring.ends.push(n);
            }
            colouring.bars.a.push(ROW * (bars[i].a - first));
            colouring.bars.b.push(ROW * (bars[i].b - first));
            colouring.bars.rest.push(bars[i].rest_length);
            colouring.bars.kind.push(bars[i].kind.index() as u8);
        }
        if !coloured.is_empty() {
            colouring.ends.push(coloured.len());
        }
        // Greedy colours are 0, 1, … without gaps, then MAX_COLOURS.
        colouring.independent =
            coloured.iter().filter(|&&(c, _)| c < MAX_COLOURS).map(|&(c, _)| c as usize + 1).max().unwrap_or(0);
        colouring
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

/// Coloured bars and their multipliers μ = βλ (in colour order).
#[derive(Clone, Debug, Default)]
pub(super) struct Group {
    pub(super) colouring: Colouring,
    pub(super) multipliers: Vec<f32>,
}

impl Group {
    fn new(bars: &[&Bar], first: u32, particles: usize) -> Self {
        Group { colouring: Colouring::new(bars, first, particles), multipliers: vec![0.0; bars.len()] }
    }
}

/// Every bar of the layout: the blocks' and the boundary's.
#[derive(Clone, Debug)]
pub(super) struct BlockedBars {
    /// Particles per block (the last may have fewer).
    block_size: usize,
    /// Block k holds the bars within particles `k·block_size..`, indexed
    /// from its first particle.
    pub(super) blocks: Vec<Group>,
    /// Bars between blocks (global indices).
    pub(super) boundary: Group,
}

impl BlockedBars {
    pub(super) fn new(bars: &[Bar], particles: usize) -> Self {
        let count = particles.div_ceil(BLOCK_PARTICLES).max(1);
        let count = if count > 1 { count.next_multiple_of(THREAD_SHARES) } else { 1 };
        let block_size = particles.div_ceil(count).max(1);
        let mut inside: Vec<Vec<&Bar>> = vec![Vec::new(); count];
        let mut boundary = Vec::new();
        for bar in bars {
            let (ka, kb) = (bar.a as usize / block_size, bar.b as usize / block_size);
            if ka == kb { inside[ka].push(bar) } else { boundary.push(bar) }
        }
        let blocks = inside
            .iter()
            .enumerate()
            .map(|(k, bars)| {
                let first = k * block_size;
                Group::new(bars, first as u32, block_size.min(particles.saturating_sub(first)))
            })
            .collect();
        BlockedBars { block_size, blocks, boundary: Group::new(&boundary, 0, particles) }
    }

    /// The most colours of any block, and of the boundary.
    pub(super) fn colours(&self) -> (usize, usize) {
        let blocks = self.blocks.iter().map(|b| b.colouring.colours()).max().unwrap_or(0);
        (blocks, self.boundary.colouring.colours())
    }

    /// Whether the boundary holds more than 1 bar in 20: the particles'
    /// order is not local, and a renumbering may help.
    pub(super) fn boundary_is_large(&self) -> bool {
        let (boundary, all) = self.boundary_share();
        boundary * 20 > all
    }

    /// Bars in the boundary, and in all.
    pub(super) fn boundary_share(&self) -> (usize, usize) {
        let all = self.blocks.iter().map(|b| b.multipliers.len()).sum::<usize>() + self.boundary.multipliers.len();
        (self.boundary.multipliers.len(), all)
    }

    /// Zeroes every μ (the start of a substep).
    pub(super) fn reset_multipliers(&mut self) {
        for group in self.blocks.iter_mut().chain([&mut self.boundary]) {
            group.multipliers.fill(0.0);
        }
    }

    /// One pass: every block (in parallel when the pool has threads), then
    /// the boundary. Returns the largest excess ([`relax_pass`]).
    pub(super) fn relax_pass(&mut self, particles: &mut [Particle], sweep: &Sweep) -> f32 {
        let relax = |(p, group): (&mut [Particle], &mut Group)| {
            relax_pass(p, &group.colouring, &mut group.multipliers, sweep, true)
        };
        let inside = if self.blocks.len() > 1 && rayon::current_num_threads() > 1 {
            let pairs = particles.par_chunks_mut(self.block_size).zip(self.blocks.par_iter_mut());
            pairs.map(relax).reduce(|| f32::NEG_INFINITY, f32::max)
        } else {
            particles
                .chunks_mut(self.block_size)
                .zip(self.blocks.iter_mut())
                .map(relax)
                .fold(f32::NEG_INFINITY, f32::max)
        };
        let boundary = relax_pass(particles, &self.boundary.colouring, &mut self.boundary.multipliers, sweep, true);
        inside.max(boundary)
    }
}

/// A breadth-first (Cuthill–McKee) order of the particles over the bars:
/// each connected piece from a particle of least degree, neighbours in order
/// of degree, then index. Particles a bar apart get nearby indices, so blocks
/// of consecutive indices are bands of the mesh with few bars between them.
/// `order[k]` is the particle placed k-th.
pub(super) fn breadth_first_order(particles: usize, bars: &[Bar]) -> Vec<u32> {
    let mut degree = vec![0u32; particles];
    for bar in bars {
        degree[bar.a as usize] += 1;
        degree[bar.b as usize] += 1;
    }
    // Neighbour lists in one array: particle i's are first[i]..first[i + 1].
    let mut first = vec![0usize; particles + 1];
    for i in 0..particles {
        first[i + 1] = first[i] + degree[i] as usize;
    }
    let mut fill = first.clone();
    let mut neighbours = vec![0u32; first[particles]];
    for bar in bars {
        for (from, to) in [(bar.a, bar.b), (bar.b, bar.a)] {
            neighbours[fill[from as usize]] = to;
            fill[from as usize] += 1;
        }
    }
    let by_degree = |&i: &u32| (degree[i as usize], i);
    for i in 0..particles {
        neighbours[first[i]..first[i + 1]].sort_unstable_by_key(by_degree);
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
            for &j in &neighbours[first[i]..first[i + 1]] {
                if !placed[j as usize] {
                    placed[j as usize] = true;
                    order.push(j);
                }
            }
        }
    }
    order
}
