//! The phases of a substep ([`crate::sim::step`]) on the lane layout:
//! integration, tethers and settling tile by tile (eight lanes at a time,
//! tiles on the thread pool for large grids), relaxation through
//! [`super::sweep`], and contact.

use glam::Vec3;
use rayon::prelude::*;

use super::sweep::{Sweep, sweep_passes, sweep_tile_pipelined, sweep_tiles};
use super::{GridLayout, Location, Slot, Tile};
use crate::sim::aero::PointLanes;
use crate::sim::contact::ContactStep;
use crate::sim::fast::kernel::{F32x8, LANES, Real, Shares, integrate, lane, settle, tether};
use crate::sim::fast::rows::Rows;
use crate::sim::fast::simd::dispatch;
#[cfg(target_arch = "x86_64")]
use crate::sim::fast::simd::{self, SimdLevel};
use crate::sim::self_contact::{SelfContact, SelfContactStep};
use crate::sim::step::{LanePlaces, Lanes, Solver, Substep};
use crate::sim::tether::Tethers;

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

impl Solver for GridLayout {
    fn integrate(&mut self, s: &Substep) {
        let (keep, accel, gravity) = match s.first {
            Some((v0, extra)) => {
                self.set_initial_velocity(v0, s.dt, extra);
                (1.0, [0.0; 3], [0.0; 3])
            }
            None => (s.keep, s.accel.to_array(), s.gravity.to_array()),
        };
        let parallel = self.parallel();
        for_each_tile(&mut self.tiles, parallel, |tile| {
            integrate_tile(tile, keep, accel, gravity);
            f32::NEG_INFINITY
        });
    }

    /// Adds the scene-order displacements to the lanes, times each
    /// particle's weight: tile by tile (on the pool for large grids), each
    /// slot reading its particles' displacements through `Tile::scene`.
    fn push(&mut self, displacement: &[Vec3]) {
        let parallel = self.parallel();
        for_each_tile(&mut self.tiles, parallel, |tile| {
            for ((p, w), scene) in tile.position.iter_mut().zip(&tile.weight).zip(&tile.scene) {
                for (l, &i) in scene.iter().enumerate() {
                    // Padding weighs 0 and is never read.
                    let w = w.0[l];
                    if w > 0.0 {
                        let delta = displacement[i as usize];
                        for k in 0..3 {
                            p[k].0[l] += w * delta[k];
                        }
                    }
                }
            }
            f32::NEG_INFINITY
        });
    }

    /// Tethers, then up to `relaxations` sweeps; when `tolerance > 0`, stops
    /// after a sweep in which every movable bar was within `tolerance`
    /// (relative) before its projection. Returns the sweeps done.
    fn relax(&mut self, s: &Substep) -> u32 {
        let parallel = self.parallel();
        if let Some(scale) = s.tether_slack.filter(|_| self.tethers.is_some()).map(|slack| 1.0 + slack) {
            for_each_tile(&mut self.tiles, parallel, |tile| {
                tether_tile(tile, scale);
                f32::NEG_INFINITY
            });
        }
        let compliant = s.compliant();
        if compliant {
            for tile in &mut self.tiles {
                tile.multipliers.clear();
                tile.multipliers.resize(self.ops.len(), F32x8::splat(0.0));
                tile.seam_multipliers.fill(0.0);
            }
        }
        self.use_shares(s.betas().map(|beta| Shares::new(beta, s.over_relaxation)));
        let sweep = Sweep {
            uniform: self.uniform,
            ops: &self.ops,
            tolerance: s.tolerance,
            betas: s.betas(),
            omega: s.over_relaxation,
            compliant,
        };
        let mut sweeps = 0;
        if s.tolerance <= 0.0 && self.tiles.len() == 1 {
            // One tile and a fixed number of sweeps: overlap them.
            sweep_tile_pipelined(&mut self.tiles[0], &sweep, &self.row_starts, s.relaxations);
            sweeps = s.relaxations;
        } else if s.tolerance <= 0.0 {
            sweep_passes(&mut self.tiles, &sweep, s.relaxations, parallel);
            sweeps = s.relaxations;
        }
        while sweeps < s.relaxations {
            sweeps += 1;
            let worst = sweep_tiles(&mut self.tiles, &sweep, parallel);
            if s.tolerance > 0.0 && worst <= 0.0 {
                break;
            }
        }
        sweeps
    }

    /// Tile by tile: the colliders near the tile's box of start (x_pred − d)
    /// and end positions, then eight particles at a time, those of non-zero
    /// weight the lane filter keeps resolved by `ContactStep::resolve_lanes`
    /// (the bits of `ContactStep::resolve`).
    fn collide(&mut self, contact: &ContactStep) {
        let parallel = self.parallel();
        for_each_tile(&mut self.tiles, parallel, |tile| {
            collide_tile(tile, contact);
            f32::NEG_INFINITY
        });
    }

    /// Gathers positions, start positions (x_pred − d) and weights into scene
    /// order, runs the phase, scatters the positions back.
    fn self_collide(&mut self, phase: &mut SelfContact, step: &SelfContactStep) {
        let (mut x, mut x0, mut w) =
            (std::mem::take(&mut phase.x), std::mem::take(&mut phase.x0), std::mem::take(&mut phase.w));
        let n = self.locations.len();
        x.resize(n, Vec3::ZERO);
        x0.resize(n, Vec3::ZERO);
        w.resize(n, 0.0);
        let parallel = step.parallel && self.parallel();
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
            pick(&self.locations, &mut x, &mut x0, &mut w);
        }
        phase.apply(&mut x, &x0, &w, &SelfContactStep { parallel, ..*step });
        // Each tile takes its own particles' positions back.
        let x_new = &x;
        let write = |tile: &mut Tile| {
            for (position, scene) in tile.position.iter_mut().zip(&tile.scene) {
                for (l, &i) in scene.iter().enumerate().filter(|&(_, &i)| i != u32::MAX) {
                    for k in 0..3 {
                        position[k].0[l] = x_new[i as usize][k];
                    }
                }
            }
        };
        if parallel {
            self.tiles.par_iter_mut().for_each(write);
        } else {
            self.tiles.iter_mut().for_each(write);
        }
        (phase.x, phase.x0, phase.w) = (x, x0, w);
    }

    fn settle(&mut self) {
        let parallel = self.parallel();
        for_each_tile(&mut self.tiles, parallel, |tile| {
            settle_tile(tile);
            f32::NEG_INFINITY
        });
    }

    /// Positions and previous positions (x − d) in scene order
    /// ([`GridLayout::read_as`]: row by row where the scene's rows are whole
    /// rows of slots, else particle by particle; the same bits either way),
    /// in chunks on the thread pool for large cloths.
    fn read(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        self.read_as(positions, previous, |p| p);
    }

    fn read_rows(&self, positions: &mut [[f32; 4]], previous: &mut [[f32; 4]]) {
        self.read_as(positions, previous, |p| p.extend(0.0).to_array());
    }

    fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        let loc = self.locations[index];
        let l = loc.lane as usize;
        let (p, d, w) = self.cell_mut(loc);
        for k in 0..3 {
            p[k].0[l] = position[k];
            d[k].0[l] = position[k] - previous[k];
        }
        if w.0[l] == 0.0 {
            // A moved fixed particle may be an anchor: its tethered particles
            // follow it (no reallocation, so a drag costs one pass per frame).
            self.copy_anchor_positions(Some(index as u32));
        }
    }

    fn set_inverse_mass(&mut self, index: usize, weight: f32) {
        self.write_weight(index, weight);
    }

    fn set_tethers(&mut self, tethers: Option<Tethers>) {
        self.tethers = tethers;
        self.refresh_tethers();
    }

    fn first_non_finite(&self) -> Option<usize> {
        if self.tiles.iter().all(|t| all_finite(&t.position)) {
            return None;
        }
        self.locations.iter().position(|loc| {
            let p = &self.tiles[loc.tile as usize].position[loc.slot as usize];
            !p.iter().all(|c| c.0[loc.lane as usize].is_finite())
        })
    }

    fn uses_pool(&self) -> bool {
        self.parallel()
    }

    fn lanes(&self) -> Option<&dyn Lanes> {
        Some(self)
    }

    fn lanes_mut(&mut self) -> Option<&mut dyn Lanes> {
        Some(self)
    }

    fn describe(&self) -> String {
        format!(
            "lanes: {}, {}{}",
            self.layout_words(),
            crate::sim::fast::simd_name(),
            if self.parallel { ", threaded" } else { "" }
        )
    }

    fn boxed_clone(&self) -> Box<dyn Solver> {
        Box::new(self.clone())
    }
}

impl GridLayout {
    /// Slots in each tile (every tile has as many).
    fn slots_per_tile(&self) -> usize {
        self.tiles.first().map_or(0, |t| t.position.len())
    }
}

/// The air phase reads the tiles as they are: tile t's slot s is element
/// t · slots + s (every tile has as many slots), lane l of it place
/// 8 (t · slots + s) + l.
impl Lanes for GridLayout {
    fn places(&self) -> LanePlaces {
        let slots = self.slots_per_tile();
        let place = self
            .locations
            .iter()
            .map(|loc| ((loc.tile as usize * slots + loc.slot as usize) * LANES) as u32 + u32::from(loc.lane));
        LanePlaces { place: place.collect(), tiles: vec![slots; self.tiles.len()] }
    }

    fn tiles(&self) -> Vec<(&[PointLanes], &[PointLanes])> {
        self.tiles
            .iter()
            .map(|t| (bytemuck::cast_slice(&t.position[..]), bytemuck::cast_slice(&t.displacement[..])))
            .collect()
    }

    /// Eight lanes at a time, tile by tile.
    fn push_lanes(&mut self, displacement: &(dyn Fn(usize) -> PointLanes + Sync)) {
        let slots = self.slots_per_tile();
        let push = |(t, tile): (usize, &mut Tile)| push_tile(tile, t * slots, displacement);
        if self.parallel() {
            self.tiles.par_iter_mut().enumerate().for_each(push);
        } else {
            self.tiles.iter_mut().enumerate().for_each(push);
        }
    }
}

dispatch! {
    /// The air's displacements added to one tile's lanes.
    fn push_tile(tile: &mut Tile, first: usize, displacement: &(dyn Fn(usize) -> PointLanes + Sync)) = push_tile_body, best = ["x86_64+avx2+fma"]
}

#[inline(always)]
fn push_tile_body(tile: &mut Tile, first: usize, displacement: &(dyn Fn(usize) -> PointLanes + Sync)) {
    let zero = F32x8::splat(0.0);
    for (s, (p, &w)) in tile.position.iter_mut().zip(&tile.weight).enumerate() {
        let delta = displacement(first + s);
        for k in 0..3 {
            // Padding and fixed particles weigh 0 and stay (a NaN Δ too).
            p[k] = F32x8::if_greater(w, zero, p[k] + w * F32x8(delta[k]), p[k]);
        }
    }
}

dispatch! {
    /// The collide phase on one tile (its lanes compiled for the SIMD level).
    fn collide_tile(tile: &mut Tile, contact: &ContactStep)
        = collide_tile_body, best = ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"]
}

#[inline(always)]
fn collide_tile_body(tile: &mut Tile, contact: &ContactStep) {
    let Tile { position, displacement, predicted, weight, .. } = tile;
    // The tile's box of start and end positions of moving particles.
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (((x, d), q), w) in position.iter().zip(displacement.iter()).zip(predicted.iter()).zip(weight.iter()) {
        for l in 0..LANES {
            if w.0[l] > 0.0 {
                let (x, x0) = (lane(x, l), lane(q, l) - lane(d, l));
                lo = lo.min(x).min(x0);
                hi = hi.max(x).max(x0);
            }
        }
    }
    if lo.x > hi.x {
        return;
    }
    let near = contact.near(lo, hi);
    if near.is_empty() {
        return;
    }
    for (((x, d), q), w) in position.iter_mut().zip(displacement.iter()).zip(predicted.iter()).zip(weight.iter()) {
        // The lanes a collider may move: most slots have none.
        let x0: Slot = [q[0] - d[0], q[1] - d[1], q[2] - d[2]];
        let moving = || (0..LANES).fold(0u8, |m, l| m | (u8::from(w.0[l] > 0.0) << l));
        contact.collide_lanes(&near, (lo, hi), moving, &x0, x);
    }
}

/// Applies `f` to every tile, on the thread pool when `parallel`, and returns
/// the largest result. max is exact and order-free, so the result is the same
/// on any number of threads.
pub(super) fn for_each_tile(tiles: &mut [Tile], parallel: bool, f: impl Fn(&mut Tile) -> f32 + Sync + Send) -> f32 {
    if parallel {
        tiles.par_iter_mut().map(f).reduce(|| f32::NEG_INFINITY, f32::max)
    } else {
        tiles.iter_mut().map(f).fold(f32::NEG_INFINITY, f32::max)
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

fn all_finite(slots: &[Slot]) -> bool {
    // x·0 is 0 for finite x and NaN otherwise; one NaN makes the sum NaN.
    let mut acc = F32x8::splat(0.0);
    for s in slots {
        for c in s {
            acc = acc + *c * F32x8::splat(0.0);
        }
    }
    acc.0.iter().all(|a| *a == 0.0)
}

dispatch! {
    fn integrate_tile(tile: &mut Tile, keep: f32, accel: [f32; 3], gravity: [f32; 3]) = integrate_tile_body, best = ["x86_64+avx2+fma"]
}

#[inline(always)]
fn integrate_tile_body(tile: &mut Tile, keep: f32, accel: [f32; 3], gravity: [f32; 3]) {
    let (keep, accel, gravity) = (F32x8::splat(keep), accel.map(F32x8::splat), gravity.map(F32x8::splat));
    let Tile { position, displacement, predicted, weight, .. } = tile;
    for (((x, d), q), w) in position.iter_mut().zip(displacement).zip(predicted).zip(weight.iter()) {
        *q = integrate(x, d, *w, keep, accel, gravity);
    }
}

dispatch! {
    /// Pulls tethered particles back within `scale` × their rest path length.
    fn tether_tile(tile: &mut Tile, scale: f32) = tether_tile_body, best = ["x86_64+avx2+fma"]
}

#[inline(always)]
fn tether_tile_body(tile: &mut Tile, scale: f32) {
    let Tile { position, weight, tether_anchor, tether_length, .. } = tile;
    let scale = F32x8::splat(scale);
    for (((x, w), anchor), length) in
        position.iter_mut().zip(weight.iter()).zip(tether_anchor.iter()).zip(tether_length.iter())
    {
        tether(x, *anchor, *length * scale, *w);
    }
}

dispatch! {
    fn settle_tile(tile: &mut Tile) = settle_tile_body, best = ["x86_64+avx2+fma"]
}

#[inline(always)]
fn settle_tile_body(tile: &mut Tile) {
    let Tile { position, displacement, predicted, weight, .. } = tile;
    for (((x, d), q), w) in position.iter().zip(displacement).zip(predicted.iter()).zip(weight.iter()) {
        settle(d, *x, *q, *w);
    }
}
