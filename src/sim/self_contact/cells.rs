//! The self-collide phase's neighbour search: a hash grid with the
//! particles sorted by cell.
//!
//! Cells have side s = 2r and are grouped in blocks of 4 × 4 × 4. Cell
//! c = ⌊x / s⌋ goes to one of 2^b ≥ n buckets: its place in its block,
//! c mod 4 (6 bits), under a hash of the block, B = ⌊c / 4⌋,
//!
//! ```text
//! bucket(c) = [(B_x·p_1 ⊕ B_y·p_2 ⊕ B_z·p_3) · φ ≫ (32 − b + 6)] · 64 + (c mod 4)
//! ```
//!
//! (φ = 2³² / golden ratio: Fibonacci hashing moves every bit of the block
//! into the top bits, where a plain `mod 2^b` would keep only the low bits
//! of each coordinate.) A counting sort by bucket, stable in the particle
//! index, puts each bucket's particles into one contiguous run of *slots*,
//! and their positions are copied there: neighbouring cells share a block,
//! so a query reads its candidates from a few short runs of nearby memory.
//!
//! **Queries.** Each pair is found once, by the query of its lower slot:
//! the query of slot k returns the slots j > k closer than r. The ball of
//! radius r around x reaches at most x's own cell and, along each axis, the
//! neighbour on the side of the cell x is nearer to: 8 cells. A cell whose
//! bucket comes before x's own holds only slots before k and is skipped
//! without a load; the others' bucket runs, from slot k + 1 on, are tested
//! eight slots at a time in lanes (|x − x_j|² < r²), and the query gets the
//! slots that pass, in order. No test of the cell is needed:
//! - the 8 cells differ pairwise by at most 1 along each axis, so their
//!   places in a block, c mod 4, differ: they never share a bucket, and no
//!   candidate counts twice;
//! - another cell in the same bucket has the same c mod 4, so it lies ≥ 4
//!   cells away along some axis, and its particles more than 3 · 2r from
//!   x: they fail the distance.
//!
//! The two cells along x are c and c + 1 for some c; when they share a
//! block (c mod 4 ≠ 3) their buckets are h and h + 1, whose slots are one
//! run, tested as one range: 4 runs a query instead of 8, most of the time.
//!
//! The order a query returns its candidates in — the 4 pairs of cells
//! along x in a fixed order, each pair's lower cell first, each cell's
//! particles by index — does not depend on the hash, the bucket count or
//! the thread count.

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::sim::fast::kernel::LANES;

/// The particles of one substep sorted by the cell they are in.
#[derive(Clone, Debug, Default)]
pub(super) struct Cells {
    /// 1/s, per metre.
    inverse_side: f32,
    /// b: the table has 2^b buckets.
    bits: u32,
    /// `start[h]..start[h + 1]`: the slots of bucket h.
    start: Vec<u32>,
    /// Slot → particle.
    pub(super) order: Vec<u32>,
    /// Particle → slot: the inverse of `order`.
    pub(super) slot: Vec<u32>,
    /// Each slot's position, one array per axis, padded with `LANES`
    /// slots so a lane load past a bucket's end stays in bounds.
    axes: [Vec<f32>; 3],
    /// Scratch: each particle's bucket.
    buckets: Vec<u32>,
}

/// The cell a point is in, for cells of side 1/`inverse_side`.
#[inline(always)]
fn cell_of(p: Vec3, inverse_side: f32) -> IVec3 {
    (p * inverse_side).floor().as_ivec3()
}

/// Cells per block along each axis (as a power of two).
const BLOCK_BITS: u32 = 2;

/// p_1, p_2, p_3: the block's coordinates are mixed by these primes.
const BLOCK_PRIMES: [u32; 3] = [92_837_111, 689_287_499, 283_923_481];
/// φ = 2³² / golden ratio, for Fibonacci hashing.
const FIBONACCI: u32 = 0x9E37_79B9;

#[inline(always)]
fn bucket(c: IVec3, bits: u32) -> usize {
    let block = c >> BLOCK_BITS as i32;
    let mixed = (block.x as u32).wrapping_mul(BLOCK_PRIMES[0])
        ^ (block.y as u32).wrapping_mul(BLOCK_PRIMES[1])
        ^ (block.z as u32).wrapping_mul(BLOCK_PRIMES[2]);
    let block_bits = bits - 3 * BLOCK_BITS;
    let within = (1 << BLOCK_BITS) - 1;
    let local = (c.x as u32 & within) | (c.y as u32 & within) << BLOCK_BITS | (c.z as u32 & within) << (2 * BLOCK_BITS);
    ((mixed.wrapping_mul(FIBONACCI) >> (32 - block_bits)) << (3 * BLOCK_BITS) | local) as usize
}

/// Each point's bucket, for cells of side 1/`inverse_side` and
/// 2^`bits` buckets: in lanes at the AVX2 and AVX-512 levels (the
/// compiler kept the saturating float-to-integer conversions of
/// [`cell_of`] scalar there, 3 conversions and 6 conditional moves a
/// point: 580 µs of a 100 000-point table, 205 µs in lanes).
fn buckets_of(x: &[Vec3], inverse_side: f32, bits: u32, buckets: &mut [u32]) {
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    if crate::sim::fast::simd::level() != crate::sim::fast::simd::SimdLevel::Portable {
        // SAFETY: the level is AVX2 or above only when the CPU has AVX2.
        unsafe { avx2::buckets_of(x, inverse_side, bits, buckets) };
        return;
    }
    buckets_body(x, inverse_side, bits, buckets);
}

#[inline(always)]
fn buckets_body(x: &[Vec3], inverse_side: f32, bits: u32, buckets: &mut [u32]) {
    for (h, &p) in buckets.iter_mut().zip(x) {
        *h = bucket(cell_of(p, inverse_side), bits) as u32;
    }
}

/// Particles a task of the thread pool takes in the phase's per-particle
/// passes.
pub(super) const PER_TASK: usize = 4096;

/// `out[k] = pick(k, order[k])` for every slot k, on the thread pool with
/// `parallel`. (One table a pass: on the folded 256² cloth two such
/// passes took 4–7 % less of the phase than one pass writing both tables
/// through a generic loop, which kept a bounds check a table.)
pub(super) fn gather<T: Copy + Default + Send>(
    out: &mut Vec<T>,
    order: &[u32],
    parallel: bool,
    pick: impl Fn(usize, usize) -> T + Sync + Send,
) {
    out.resize(order.len(), T::default());
    let fill = |(t, (out, order)): (usize, (&mut [T], &[u32]))| {
        for (k, (o, &i)) in out.iter_mut().zip(order).enumerate() {
            *o = pick(t * PER_TASK + k, i as usize);
        }
    };
    if parallel {
        out.par_chunks_mut(PER_TASK).zip(order.par_chunks(PER_TASK)).enumerate().for_each(fill);
    } else {
        fill((0, (out, order)));
    }
}

/// [`gather`] into three row tables at once, for the slots `wanted` keeps:
/// `out[t][k] = pick(order[k])[t]`, each particle read once; the other
/// slots' rows are left as they were.
pub(super) fn gather_rows(
    out: [&mut Vec<[f32; 4]>; 3],
    order: &[u32],
    parallel: bool,
    wanted: impl Fn(usize) -> bool + Sync,
    pick: impl Fn(usize) -> [[f32; 4]; 3] + Sync + Send,
) {
    let [a, b, c] = out;
    for table in [&mut *a, &mut *b, &mut *c] {
        table.resize(order.len(), [0.0; 4]);
    }
    type Chunk<'a> = (usize, (((&'a mut [[f32; 4]], &'a mut [[f32; 4]]), &'a mut [[f32; 4]]), &'a [u32]));
    let fill = |(t, (((a, b), c), order)): Chunk| {
        let rows = a.iter_mut().zip(b.iter_mut()).zip(c.iter_mut()).zip(order).enumerate();
        for (_, (((a, b), c), &i)) in rows.filter(|&(k, _)| wanted(t * PER_TASK + k)) {
            [*a, *b, *c] = pick(i as usize);
        }
    };
    if parallel {
        let tables = a.par_chunks_mut(PER_TASK).zip(b.par_chunks_mut(PER_TASK)).zip(c.par_chunks_mut(PER_TASK));
        tables.zip(order.par_chunks(PER_TASK)).enumerate().for_each(fill);
    } else {
        let tables = a.chunks_mut(PER_TASK).zip(b.chunks_mut(PER_TASK)).zip(c.chunks_mut(PER_TASK));
        tables.zip(order.chunks(PER_TASK)).enumerate().for_each(fill);
    }
}

impl Cells {
    /// Sorts the particles at `x` into cells of side `side` (metres, > 0).
    /// With `parallel`, the per-particle passes run on the thread pool (the
    /// counting sort itself does not; the result is the same).
    pub(super) fn build(&mut self, x: &[Vec3], side: f32, parallel: bool) {
        // 2^b ≥ n buckets, and at least two blocks' worth. (2^b ≥ 2n held
        // a 1 MiB table for disc-183's 101 017 particles, whose loads were
        // a third of the search's run lookups: with half the table its
        // self-collide phase costs 1.32–1.33× the step, 1.35–1.39× with the
        // whole, on host G alternated in one process. A fuller table only
        // gives a query more candidates that fail the distance; the pairs
        // and their order do not depend on it: module docs.)
        let bits = x.len().max(1).next_power_of_two().trailing_zeros().max(3 * BLOCK_BITS + 1);
        self.build_with(x, side, bits, parallel);
    }

    /// [`Self::build`] into 2^`bits` buckets (`bits` in 7..=32).
    fn build_with(&mut self, x: &[Vec3], side: f32, bits: u32, parallel: bool) {
        self.sort_with(x, side, bits, parallel);
        // Each slot's position, each particle read once.
        let n = x.len();
        let [xs, ys, zs] = &mut self.axes;
        for values in [&mut *xs, &mut *ys, &mut *zs] {
            values.resize(n + LANES, f32::INFINITY);
            values[n..].fill(f32::INFINITY);
        }
        type Chunk<'a> = (((&'a mut [f32], &'a mut [f32]), &'a mut [f32]), &'a [u32]);
        let fill = |(((xs, ys), zs), order): Chunk| {
            for (((px, py), pz), &i) in xs.iter_mut().zip(ys.iter_mut()).zip(zs.iter_mut()).zip(order) {
                [*px, *py, *pz] = x[i as usize].to_array();
            }
        };
        let (xs, ys, zs) = (&mut xs[..n], &mut ys[..n], &mut zs[..n]);
        if parallel {
            let axes = xs.par_chunks_mut(PER_TASK).zip(ys.par_chunks_mut(PER_TASK)).zip(zs.par_chunks_mut(PER_TASK));
            axes.zip(self.order.par_chunks(PER_TASK)).for_each(fill);
        } else {
            fill((((xs, ys), zs), &self.order));
        }
    }

    /// The counting sort of [`Self::build`]: `order`, `slot` and `start`.
    fn sort_with(&mut self, x: &[Vec3], side: f32, bits: u32, parallel: bool) {
        let n = x.len();
        self.inverse_side = 1.0 / side;
        self.bits = bits;
        let size = 1usize << self.bits;
        self.buckets.resize(n, 0);
        let (inverse_side, bits) = (self.inverse_side, self.bits);
        let keys = |(out, x): (&mut [u32], &[Vec3])| buckets_of(x, inverse_side, bits, out);
        if parallel {
            self.buckets.par_chunks_mut(PER_TASK).zip(x.par_chunks(PER_TASK)).for_each(keys);
        } else {
            self.buckets.chunks_mut(PER_TASK).zip(x.chunks(PER_TASK)).for_each(keys);
        }
        // Bucket h's count at h + 2, summed so that h + 1 holds where h
        // starts; filling each bucket moves its h + 1 to where it ends,
        // which is where h + 1 starts: then h holds where h starts.
        self.start.clear();
        self.start.resize(size + 2, 0);
        for &h in &self.buckets {
            self.start[h as usize + 2] += 1;
        }
        // (The running sum in a register: adding each entry to the next
        // in the table waited on the store before it, 720–760 µs for the
        // 2¹⁸ buckets of a 100 000-particle table then, 100–120 µs so.)
        let mut sum = 0;
        for count in &mut self.start[2..=size] {
            sum += *count;
            *count = sum;
        }
        // Stable in the particle index: each bucket filled in index order.
        self.order.clear();
        self.order.resize(n, 0);
        self.slot.resize(n, 0);
        for ((i, &h), slot) in self.buckets.iter().enumerate().zip(&mut self.slot) {
            let next = &mut self.start[h as usize + 1];
            self.order[*next as usize] = i as u32;
            *slot = *next;
            *next += 1;
        }
        self.start.pop();
    }

    /// The position copied into `slot`.
    #[inline(always)]
    pub(super) fn position(&self, slot: usize) -> Vec3 {
        Vec3::new(self.axes[0][slot], self.axes[1][slot], self.axes[2][slot])
    }

    /// For each slot k of `first..first + count` in turn, appends to
    /// `other` every slot j > k whose position is closer than `radius`
    /// (metres, ≤ s/2) to k's, in the order the module docs give, and k to
    /// `own` as many times.
    #[inline(always)]
    pub(super) fn pairs_after(
        &self,
        first: usize,
        count: usize,
        radius: f32,
        own: &mut Vec<u32>,
        other: &mut Vec<u32>,
    ) {
        #[cfg(target_arch = "x86_64")]
        #[allow(unsafe_code)]
        if crate::sim::fast::simd::level() != crate::sim::fast::simd::SimdLevel::Portable {
            // SAFETY: the level is AVX2 or above only when the CPU has AVX2.
            unsafe { avx2::pairs_after(self, first, count, radius, own, other) };
            return;
        }
        self.pairs_after_portable(first, count, radius, own, other);
    }

    /// [`Self::pairs_after`] without `std::arch`.
    #[inline(always)]
    fn pairs_after_portable(&self, first: usize, count: usize, radius: f32, own: &mut Vec<u32>, other: &mut Vec<u32>) {
        for slot in first..first + count {
            self.push_after(slot, radius, other);
            own.resize(other.len(), slot as u32);
        }
    }

    /// The slots of [`Self::pairs_after`] for one slot.
    #[inline(always)]
    fn push_after(&self, slot: usize, radius: f32, near: &mut Vec<u32>) {
        self.push_around(self.position(slot), Some(slot), radius, near);
    }

    /// Appends every slot whose table position is closer than `radius`
    /// (metres, ≤ s/2) to `p`, in the order of the module docs; `p` need
    /// not be a slot's position.
    pub(super) fn push_near(&self, p: Vec3, radius: f32, near: &mut Vec<u32>) {
        self.push_around(p, None, radius, near);
    }

    /// The slots closer than `radius` to `p`, one cell pair at a time; with
    /// `after`, only the slots after it (`p` is its position).
    #[inline(always)]
    fn push_around(&self, p: Vec3, after: Option<usize>, radius: f32, near: &mut Vec<u32>) {
        let scaled = p * self.inverse_side;
        let centre = scaled.floor().as_ivec3();
        let toward = (scaled - scaled.floor()).cmplt(Vec3::splat(0.5));
        let side = IVec3::select(toward, IVec3::splat(-1), IVec3::ONE);
        let r2 = radius * radius;
        // Buckets before the query's own hold only slots before it.
        let (own, from) = after.map_or((0, 0), |slot| (bucket(centre, self.bits), slot + 1));
        // Along x the two cells are the lower one and the next: within a
        // block their buckets are h and h + 1, one run of slots, tested as
        // one range.
        // (Wrapping, as the lanes add: a cell at the end of i32's range,
        // a point beyond ±2³¹ cells, has its neighbour at the other end.)
        let low_x = centre.x.wrapping_add(side.x.min(0));
        let within = (1 << BLOCK_BITS) - 1;
        for dz in [0, side.z] {
            for dy in [0, side.y] {
                let low = IVec3::new(low_x, centre.y.wrapping_add(dy), centre.z.wrapping_add(dz));
                let h = bucket(low, self.bits);
                if low.x & within != within {
                    self.push_run(h, h + 1, own, from, p, r2, near);
                } else {
                    self.push_run(h, h, own, from, p, r2, near);
                    let next = bucket(low.wrapping_add(IVec3::X), self.bits);
                    self.push_run(next, next, own, from, p, r2, near);
                }
            }
        }
    }

    /// Appends the slots from `from` on (in buckets from `own` on) of
    /// buckets `first..=last` near `p`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn push_run(&self, first: usize, last: usize, own: usize, from: usize, p: Vec3, r2: f32, near: &mut Vec<u32>) {
        if last < own {
            // Every slot of these buckets comes before `own`'s, so before `from`.
            return;
        }
        let (from, to) = ((self.start[first] as usize).max(from), self.start[last + 1] as usize);
        let mut lane = from;
        while lane < to {
            let mut hits = self.near_lanes(lane, to, p, r2);
            while hits != 0 {
                near.push((lane + hits.trailing_zeros() as usize) as u32);
                hits &= hits - 1;
            }
            lane += LANES;
        }
    }

    /// Bit l set when slot `first + l` is before `to` and lies closer than
    /// √`r2` to `p`.
    #[inline(always)]
    fn near_lanes(&self, first: usize, to: usize, p: Vec3, r2: f32) -> u8 {
        let xs: &[f32; LANES] = lanes(&self.axes[0], first);
        let ys: &[f32; LANES] = lanes(&self.axes[1], first);
        let zs: &[f32; LANES] = lanes(&self.axes[2], first);
        let mut mask = 0u8;
        for l in 0..LANES {
            let (dx, dy, dz) = (p.x - xs[l], p.y - ys[l], p.z - zs[l]);
            let d2 = dx * dx + dy * dy + dz * dz;
            let slot = first + l;
            let hit = (d2 < r2) & (slot < to);
            mask |= u8::from(hit) << l;
        }
        mask
    }
}

/// Eight values of `column` from `first` (the padding keeps them in
/// bounds).
#[inline(always)]
fn lanes<T>(column: &[T], first: usize) -> &[T; LANES] {
    column[first..first + LANES].first_chunk().expect("padded by LANES")
}

#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx2;

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pair i < j closer than r, found by testing all pairs.
    fn all_pairs(x: &[Vec3], r: f32) -> Vec<(usize, usize)> {
        let mut pairs = Vec::new();
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                if x[i].distance_squared(x[j]) < r * r {
                    pairs.push((i, j));
                }
            }
        }
        pairs
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    #[allow(unsafe_code)]
    fn the_buckets_in_lanes_are_the_scalar_buckets_for_every_point() {
        if !is_x86_feature_detected!("avx2") {
            return;
        }
        // Points on cell boundaries (multiples of s = 0.04, where ⌊·⌋ must
        // not round), either side of zero, beyond i32's range of cells
        // (saturating: i32::MIN and i32::MAX) and not a number (cell 0),
        // 21 of them: two whole groups of eight and a remainder of five.
        let odd = [0.0, -0.0, 0.04, -0.04, 0.0399999, -1e-9, 7.3, -7.3, 1e12, -1e12, f32::NAN, f32::INFINITY];
        let x: Vec<Vec3> = (0..21)
            .map(|k| Vec3::new(odd[k % odd.len()], odd[(5 * k + 3) % odd.len()], 0.04 * k as f32 - 0.4))
            .collect();
        for bits in [7, 18] {
            let mut scalar = vec![0; x.len()];
            buckets_body(&x, 25.0, bits, &mut scalar);
            let mut lanes = vec![0; x.len()];
            // SAFETY: the CPU has AVX2 (checked above).
            unsafe { avx2::buckets_of(&x, 25.0, bits, &mut lanes) };
            assert_eq!(lanes, scalar, "{bits} bits");
        }
    }

    #[test]
    fn the_search_finds_every_pair_closer_than_r_once_in_index_order_per_cell() {
        // 600 points in a 0.2 m box (600 · (4π/3 · 0.02³) / 0.2³ ≈ 2.5 within
        // r = 0.02 of each: about 750 pairs), some
        // on cell boundaries (multiples of s = 0.04), and a few points 4
        // cells (0.16 m) away, whose cells share buckets with near ones.
        let mut seed = 12345u32;
        let mut random = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        let r = 0.02;
        let mut x: Vec<Vec3> = (0..600).map(|_| Vec3::new(random(), random(), random()) * 0.2).collect();
        for k in 0..20 {
            x.push(Vec3::new(0.04 * (k % 5) as f32, 0.04, 0.08));
            x.push(Vec3::new(0.04 * (k % 5) as f32 + 0.16, 0.04, 0.08));
        }
        // And points whose cells are out of i32's range or not a number
        // (the conversions saturate; they pair with nothing).
        x.extend([Vec3::new(1e12, 0.0, 0.0), Vec3::new(-1e12, 0.1, 0.1), Vec3::new(f32::NAN, 0.1, 0.0)]);
        // The table as the phase sizes it, and one of two blocks, where
        // nearly every bucket holds several cells.
        let expected = all_pairs(&x, r);
        assert!(expected.len() > 500, "the test has pairs to find: {}", expected.len());
        for bits in [None, Some(7)] {
            let mut cells = Cells::default();
            match bits {
                None => cells.build(&x, 2.0 * r, false),
                Some(bits) => cells.build_with(&x, 2.0 * r, bits, false),
            }
            let mut found = Vec::new();
            for slot in 0..x.len() {
                let i = cells.order[slot] as usize;
                let (mut own, mut slots) = (Vec::new(), Vec::new());
                cells.pairs_after(slot, 1, r, &mut own, &mut slots);
                assert!(own.iter().all(|&k| k as usize == slot) && own.len() == slots.len());
                assert!(slots.iter().all(|&j| j as usize > slot), "only later slots: {slots:?}");
                let near: Vec<usize> = slots.iter().map(|&j| cells.order[j as usize] as usize).collect();
                // Within one cell the particles come by index.
                let cell = |j: usize| cell_of(x[j], 1.0 / (2.0 * r));
                for w in near.windows(2) {
                    if cell(w[0]) == cell(w[1]) {
                        assert!(w[0] < w[1], "{near:?}");
                    }
                }
                found.extend(near.into_iter().map(|j| (i.min(j), i.max(j))));
            }
            // The level's query gives the portable one's slots in its order
            // (the order sets the bits of each particle's sum).
            let (mut own, mut other) = (Vec::new(), Vec::new());
            cells.pairs_after_portable(0, x.len(), r, &mut own, &mut other);
            let (mut own_level, mut other_level) = (Vec::new(), Vec::new());
            cells.pairs_after(0, x.len(), r, &mut own_level, &mut other_level);
            assert_eq!((own, other), (own_level, other_level), "{bits:?} bits");
            // Each pair once: sorted, with no pair twice, they are all pairs.
            found.sort_unstable();
            assert_eq!(found, expected, "{bits:?} bits");
        }
    }
}
