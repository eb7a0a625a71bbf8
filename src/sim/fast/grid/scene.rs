//! The grid's lanes in scene order, for the phases that work there: x
//! with x − d (the positions a substep ago) read out row by row where each
//! scene row is a row of slots in every tile ([`super::scene_rows`]), else
//! particle by particle; and the self-collide phase's x, x_pred − d (where
//! the substep started) and weights read out and x written back.

use glam::Vec3;
use rayon::prelude::*;

use super::{GridLayout, Location, Tile};
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
    /// ([`super::scene_rows`]), else particle by particle; in chunks on the
    /// thread pool for large grids.
    pub(super) fn read_as<T: Send>(&self, positions: &mut [T], previous: &mut [T], to: impl Fn(Vec3) -> T + Sync) {
        if !self.scene_rows.is_empty() {
            self.read_scene_rows(positions, previous, to);
        } else {
            self.read_by_location(positions, previous, to);
        }
    }

    /// [`Self::read_as`] row by row of the scene ([`super::scene_rows`]):
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
    /// Positions x, where the substep started (x_pred − d) and weights in
    /// scene order (the self-collide phase's input), particle by particle
    /// through each one's location; on the thread pool with `parallel`.
    pub(super) fn read_starts(&self, x: &mut [Vec3], x0: &mut [Vec3], w: &mut [f32], parallel: bool) {
        let tiles = &self.tiles;
        let pick = |locations: &[Location], x: &mut [Vec3], x0: &mut [Vec3], w: &mut [f32]| {
            for (k, loc) in locations.iter().enumerate() {
                let tile = &tiles[loc.tile as usize];
                let (s, l) = (loc.slot as usize, loc.lane as usize);
                x[k] = lane(&tile.position[s], l);
                x0[k] = lane(&tile.predicted[s], l) - lane(&tile.displacement[s], l);
                w[k] = tile.weight[s].0[l];
            }
        };
        if parallel {
            let (out, rest) = (x.par_chunks_mut(CHUNK), x0.par_chunks_mut(CHUNK).zip(w.par_chunks_mut(CHUNK)));
            self.locations.par_chunks(CHUNK).zip(out).zip(rest).for_each(|((l, x), (x0, w))| pick(l, x, x0, w));
        } else {
            pick(&self.locations, x, x0, w);
        }
    }

    /// Sets every particle's position from `x` (scene order): each tile
    /// takes its own particles' positions, on the thread pool with
    /// `parallel`.
    pub(super) fn write_positions(&mut self, x: &[Vec3], parallel: bool) {
        let write = |tile: &mut Tile| {
            for (position, scene) in tile.position.iter_mut().zip(&tile.scene) {
                for (l, &i) in scene.iter().enumerate().filter(|&(_, &i)| i != u32::MAX) {
                    for k in 0..3 {
                        position[k].0[l] = x[i as usize][k];
                    }
                }
            }
        };
        if parallel {
            self.tiles.par_iter_mut().for_each(write);
        } else {
            self.tiles.iter_mut().for_each(write);
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
/// `start..start + block` of every tile ([`super::scene_rows`]): lane l of
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
