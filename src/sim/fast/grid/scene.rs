//! The grid's lanes as rows of particles, for the phases that work on
//! rows:
//! - *scene order* (x with x − d, the positions a substep ago): row by row
//!   of the scene where each scene row is a row of slots in every tile
//!   ([`super::build::scene_rows`]), a slot's eight lanes transposed into eight
//!   rows, else particle by particle through its location;
//! - *lane order* (the self-collide phase's x, x_pred − d and w, and x
//!   written back): the particles as the tiles hold them, tile by tile,
//!   slot by slot, lane by lane, padding skipped ([`GridLayout::lane_rows`]
//!   names each row's particle). A slot of eight particles is eight
//!   consecutive rows, so it is transposed whole both ways and no scene
//!   index is looked up; the phase takes the rows in this order
//!   ([`SelfContact::apply_numbered`](crate::sim::self_contact::SelfContact::apply_numbered)),
//!   as it takes the coloured layout's in that layout's own order.

use glam::Vec3;
use rayon::prelude::*;

use super::{GridLayout, Tile};
use crate::sim::fast::kernel::{F32x8, LANES, lane};
use crate::sim::fast::rows::Rows;
#[cfg(target_arch = "x86_64")]
use crate::sim::fast::simd::{self, SimdLevel};

/// Particles a task of the thread pool takes when the lanes are copied to
/// or from scene order.
const CHUNK: usize = 4096;

impl GridLayout {
    /// Positions x and x − d in scene order, each as `to` makes it: row by
    /// row of the scene where each is a row of slots in every tile
    /// ([`super::build::scene_rows`]), else particle by particle; in chunks on the
    /// thread pool for large grids.
    pub(super) fn read_as<T: Send>(&self, positions: &mut [T], previous: &mut [T], to: impl Fn(Vec3) -> T + Sync) {
        if !self.scene_rows.is_empty() {
            self.read_scene_rows(positions, previous, to);
        } else {
            self.read_by_location(positions, previous, to);
        }
    }

    /// [`Self::read_as`] row by row of the scene ([`super::build::scene_rows`]):
    /// each tile's slots of the row, each slot's eight lanes transposed
    /// into rows ([`Rows`]) and written to their places in the scene row,
    /// `block` apart. The same bits as particle by particle; with AVX2 the
    /// 256 × 256 cloth is read in about 0.65 times the time (no location
    /// read for each particle, no lane read alone).
    #[allow(unsafe_code)]
    fn read_scene_rows<T: Send>(&self, positions: &mut [T], previous: &mut [T], to: impl Fn(Vec3) -> T + Sync) {
        let (tiles, block) = (&self.tiles, self.block);
        let width = positions.len() / self.scene_rows.len();
        let to = &to;
        let row = |((x, x_prev), &start): ((&mut [T], &mut [T]), &u32)| {
            #[cfg(target_arch = "x86_64")]
            if simd::level() >= SimdLevel::Avx2 {
                // SAFETY: the level is AVX2 or above only when the CPU
                // reports AVX2 and FMA, the features `scene_row_avx2` is
                // compiled for.
                unsafe { scene_row_avx2(tiles, block, start as usize, x, x_prev, to) };
                return;
            }
            scene_row::<F32x8, T>(tiles, block, start as usize, x, x_prev, to);
        };
        if self.parallel() {
            let rows = positions.par_chunks_mut(width).zip(previous.par_chunks_mut(width));
            rows.zip(self.scene_rows.par_iter()).with_min_len(CHUNK.div_ceil(width)).for_each(row);
        } else {
            let rows = positions.chunks_mut(width).zip(previous.chunks_mut(width));
            rows.zip(&self.scene_rows).for_each(row);
        }
    }

    /// [`Self::read_as`] particle by particle, each through its location.
    pub(super) fn read_by_location<T: Send>(
        &self,
        positions: &mut [T],
        previous: &mut [T],
        to: impl Fn(Vec3) -> T + Sync,
    ) {
        let tiles = &self.tiles;
        let chunk = |((locations, positions), previous): ((&[super::Location], &mut [T]), &mut [T])| {
            for ((loc, x), x_prev) in locations.iter().zip(positions).zip(previous) {
                let tile = &tiles[loc.tile as usize];
                let (s, l) = (loc.slot as usize, loc.lane as usize);
                let (p, d) = (&tile.position[s], &tile.displacement[s]);
                let at = Vec3::new(p[0].0[l], p[1].0[l], p[2].0[l]);
                *x = to(at);
                *x_prev = to(at - Vec3::new(d[0].0[l], d[1].0[l], d[2].0[l]));
            }
        };
        if self.parallel() {
            let parts = self.locations.par_chunks(CHUNK).zip(positions.par_chunks_mut(CHUNK));
            parts.zip(previous.par_chunks_mut(CHUNK)).for_each(chunk);
        } else {
            let parts = self.locations.chunks(CHUNK).zip(positions.chunks_mut(CHUNK));
            parts.zip(previous.chunks_mut(CHUNK)).for_each(chunk);
        }
    }
}

impl GridLayout {
    /// The scene index of each row of [`Self::read_starts`] and
    /// [`Self::write_positions`]: the particles in lane order.
    pub(super) fn lane_rows(&self) -> &[u32] {
        &self.lane_rows
    }

    /// Positions x, where the substep started (x_pred − d) and weights in
    /// lane order ([`Self::lane_rows`]; the self-collide phase's input):
    /// tile by tile, on the thread pool with `parallel`, each slot whose
    /// eight lanes hold particles transposed into eight rows at once.
    #[allow(unsafe_code)]
    pub(super) fn read_starts(&self, x: &mut [Vec3], x0: &mut [Vec3], w: &mut [f32], parallel: bool) {
        let read = |(tile, out): (&Tile, StartRows)| {
            #[cfg(target_arch = "x86_64")]
            if simd::level() >= SimdLevel::Avx2 {
                // SAFETY: the level is AVX2 or above only when the CPU
                // reports AVX2 and FMA, the features `tile_starts_avx2` is
                // compiled for.
                unsafe { tile_starts_avx2(tile, out) };
                return;
            }
            tile_starts::<F32x8>(tile, out);
        };
        let parts = split_rows(&self.tile_rows, x, x0, w);
        if parallel {
            self.tiles.par_iter().zip(parts).for_each(read);
        } else {
            self.tiles.iter().zip(parts).for_each(read);
        }
    }

    /// Sets every particle's position from `x`, in lane order
    /// ([`Self::lane_rows`]): tile by tile, on the thread pool with
    /// `parallel`, a slot whose eight lanes hold particles from eight rows
    /// at once.
    pub(super) fn write_positions(&mut self, x: &[Vec3], parallel: bool) {
        let rows = &self.tile_rows;
        let write = |(t, tile): (usize, &mut Tile)| {
            let x = &x[rows[t]..rows[t + 1]];
            let mut k = 0;
            for s in 0..tile.position.len() {
                let full = tile.slot_is_full(s);
                let (position, scene) = (&mut tile.position[s], &tile.scene[s]);
                if full {
                    let eight = &x[k..k + LANES];
                    // One bounds check a slot: `eight` is eight rows long.
                    for (c, axis) in position.iter_mut().enumerate() {
                        *axis = F32x8(std::array::from_fn(|l| eight[l][c]));
                    }
                    k += LANES;
                    continue;
                }
                for l in (0..LANES).filter(|&l| scene[l] != u32::MAX) {
                    for (c, axis) in position.iter_mut().enumerate() {
                        axis.0[l] = x[k][c];
                    }
                    k += 1;
                }
            }
        };
        if parallel {
            self.tiles.par_iter_mut().enumerate().for_each(write);
        } else {
            self.tiles.iter_mut().enumerate().for_each(write);
        }
    }
}

/// One tile's rows of [`GridLayout::read_starts`]: x, x0 and w.
type StartRows<'a> = ((&'a mut [Vec3], &'a mut [Vec3]), &'a mut [f32]);

/// `x`, `x0` and `w` cut at the tiles' first rows `starts` (the last entry
/// the end).
fn split_rows<'a>(
    starts: &[usize],
    mut x: &'a mut [Vec3],
    mut x0: &'a mut [Vec3],
    mut w: &'a mut [f32],
) -> Vec<StartRows<'a>> {
    let mut parts = Vec::with_capacity(starts.len());
    for bounds in starts.windows(2) {
        let n = bounds[1] - bounds[0];
        let (a, rest_x) = std::mem::take(&mut x).split_at_mut(n);
        let (b, rest_x0) = std::mem::take(&mut x0).split_at_mut(n);
        let (c, rest_w) = std::mem::take(&mut w).split_at_mut(n);
        parts.push(((a, b), c));
        (x, x0, w) = (rest_x, rest_x0, rest_w);
    }
    parts
}

/// [`tile_starts`] in AVX registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn tile_starts_avx2(tile: &Tile, out: StartRows) {
    tile_starts::<crate::sim::fast::avx::Avx>(tile, out);
}

/// One tile's x, x_pred − d and w in lane order: a slot of eight particles
/// transposed into eight rows, others lane by lane (the same bits).
#[inline(always)]
fn tile_starts<R: Rows>(tile: &Tile, ((x, x0), w): StartRows) {
    let zero = R::splat(0.0);
    let lanes = |p: &[F32x8; 3]| [R::from_values(p[0].0), R::from_values(p[1].0), R::from_values(p[2].0)];
    let mut k = 0;
    let slots = tile.position.iter().zip(&tile.predicted).zip(&tile.displacement).zip(&tile.weight).zip(&tile.scene);
    for (s, ((((p, q), d), weight), scene)) in slots.enumerate() {
        if tile.slot_is_full(s) {
            let (p, q, d) = (lanes(p), lanes(q), lanes(d));
            let now = R::to_rows([p[0], p[1], p[2], zero]);
            let start = R::to_rows([q[0] - d[0], q[1] - d[1], q[2] - d[2], zero]);
            // One bounds check a slot and table: each is eight rows long.
            let rows = (&mut x[k..k + LANES], &mut x0[k..k + LANES], &mut w[k..k + LANES]);
            for l in 0..LANES {
                rows.0[l] = Vec3::new(now[l][0], now[l][1], now[l][2]);
                rows.1[l] = Vec3::new(start[l][0], start[l][1], start[l][2]);
                rows.2[l] = weight.0[l];
            }
            k += LANES;
            continue;
        }
        for l in (0..LANES).filter(|&l| scene[l] != u32::MAX) {
            x[k] = lane(p, l);
            x0[k] = lane(q, l) - lane(d, l);
            w[k] = weight.0[l];
            k += 1;
        }
    }
}

/// [`scene_row`] in AVX registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn scene_row_avx2<T>(
    tiles: &[Tile],
    block: usize,
    start: usize,
    x: &mut [T],
    x_prev: &mut [T],
    to: &impl Fn(Vec3) -> T,
) {
    scene_row::<crate::sim::fast::avx::Avx, T>(tiles, block, start, x, x_prev, to);
}

/// One scene row's x and x − d, as `to` makes them, from the slots
/// `start..start + block` of every tile ([`super::build::scene_rows`]): lane l of
/// slot start + k of tile t is the row's particle
/// t · 8 · block + l · block + k.
#[inline(always)]
fn scene_row<R: Rows, T>(
    tiles: &[Tile],
    block: usize,
    start: usize,
    x: &mut [T],
    x_prev: &mut [T],
    to: &impl Fn(Vec3) -> T,
) {
    let zero = R::splat(0.0);
    for (t, tile) in tiles.iter().enumerate() {
        let base = t * LANES * block;
        let slots = start..start + block;
        for (k, (p, d)) in tile.position[slots.clone()].iter().zip(&tile.displacement[slots]).enumerate() {
            let p = [R::from_values(p[0].0), R::from_values(p[1].0), R::from_values(p[2].0)];
            let d = [R::from_values(d[0].0), R::from_values(d[1].0), R::from_values(d[2].0)];
            let now = R::to_rows([p[0], p[1], p[2], zero]);
            let before = R::to_rows([p[0] - d[0], p[1] - d[1], p[2] - d[2], zero]);
            for l in 0..LANES {
                let i = base + l * block + k;
                x[i] = to(Vec3::new(now[l][0], now[l][1], now[l][2]));
                x_prev[i] = to(Vec3::new(before[l][0], before[l][1], before[l][2]));
            }
        }
    }
}
