//! The phases of a substep ([`crate::sim::step`]) on the lane layout:
//! integration, tethers and settling tile by tile (eight lanes at a time,
//! tiles on the thread pool for large grids), relaxation through
//! [`super::sweep`], and contact.

use glam::Vec3;
use rayon::prelude::*;

use super::sweep::{Sweep, sweep_passes, sweep_tile_pipelined, sweep_tiles};
use super::{GridLayout, Slot, Tile};
use crate::sim::aero::PointLanes;
use crate::sim::contact::ContactStep;
use crate::sim::fast::kernel::{F32x8, LANES, Real, Shares, integrate, settle, tether};
use crate::sim::fast::simd::dispatch;
use crate::sim::self_contact::{SelfContact, SelfContactStep};
use crate::sim::step::{LanePlaces, Lanes, Solver, Substep};
use crate::sim::tether::Tethers;

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

    /// Reads positions, start positions (x_pred − d) and weights out in
    /// lane order (`scene.rs`: whole slots transposed, no scene index
    /// looked up), runs the phase on those rows, writes the positions back.
    fn self_collide(&mut self, phase: &mut SelfContact, step: &SelfContactStep) {
        let (mut x, mut x0, mut w) =
            (std::mem::take(&mut phase.x), std::mem::take(&mut phase.x0), std::mem::take(&mut phase.w));
        let n = self.locations.len();
        x.resize(n, Vec3::ZERO);
        x0.resize(n, Vec3::ZERO);
        w.resize(n, 0.0);
        let parallel = step.parallel && self.parallel();
        self.read_starts(&mut x, &mut x0, &mut w, parallel);
        let step = SelfContactStep { parallel, ..*step };
        phase.apply_numbered(&mut x, &x0, &w, Some(self.lane_rows()), &step);
        self.write_positions(&x, parallel);
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
    ///
    /// Its AVX2 build at the AVX-512 level too, whatever the vector width:
    /// its lanes are eight (256 bits), and the AVX-512 build wrote a
    /// resolved particle's x, y and z into its lane of the three axes'
    /// vectors as one masked scatter (`vscatterqps`, its mask copied again
    /// before each since a scatter clears it), where the AVX2 build, which
    /// has no scatter, makes three plain stores. On a Zen 5 EPYC (host H),
    /// with the AVX-512 build, the step on the draped 256 × 256 cloth took
    /// 1.29–1.35× the step without colliders, against 1.18–1.22× with the
    /// AVX2 build in the same processes (six `ratios` runs, two threads),
    /// and the build's hot instructions were those around its scatters.
    fn collide_tile(tile: &mut Tile, contact: &ContactStep)
        = collide_tile_body, best = ["x86_64+avx2+fma"]
}

#[inline(always)]
fn collide_tile_body(tile: &mut Tile, contact: &ContactStep) {
    let Tile { position, displacement, predicted, weight, .. } = tile;
    let (lo, hi) = tile_box(position, displacement, predicted, weight);
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

/// The box of the start and end positions (x0 = x_pred − d, x) of a tile's
/// moving particles (weight > 0), lane by lane, then across the lanes; +∞
/// to −∞ when none moves. Minima and maxima are exact, so for finite
/// positions this is the box one particle at a time gives (but for the
/// sign of a zero, which no comparison sees).
///
/// It had been taken one particle at a time, each lane's x and x0 read out
/// of the slot and folded into a `Vec3` box: 20 % of the collide phase's
/// samples on the draped 256 × 256 cloth (`perf`, host G). In lanes, the
/// draped cloth's step with / without (alternated window by window in one
/// process, host G, two threads): 0.952, 0.988, 0.959 at AVX2, 0.958 at
/// AVX-512, 0.955 on one thread; the same bits (a probe compared every
/// particle after 30 steps, draped and folded, at AVX2 and portable).
#[inline(always)]
fn tile_box(position: &[Slot], displacement: &[Slot], predicted: &[Slot], weight: &[F32x8]) -> (Vec3, Vec3) {
    let (up, down) = (F32x8::splat(f32::INFINITY), F32x8::splat(f32::NEG_INFINITY));
    let (mut lo, mut hi) = ([up; 3], [down; 3]);
    for (((x, d), q), w) in position.iter().zip(displacement).zip(predicted).zip(weight) {
        for k in 0..3 {
            let x0 = q[k] - d[k];
            // min as `Vec3::min` takes it (`if a < b { a } else { b }`), max
            // as `Vec3::max`, lane by lane; a still particle's lane keeps
            // the box as it was.
            let low = F32x8::if_greater(x0, x[k], x[k], x0);
            let high = F32x8::if_greater(x[k], x0, x[k], x0);
            lo[k] = F32x8::if_moving(*w, F32x8::if_greater(low, lo[k], lo[k], low), lo[k]);
            hi[k] = F32x8::if_moving(*w, F32x8::if_greater(high, hi[k], high, hi[k]), hi[k]);
        }
    }
    (Vec3::from_array(lo.map(F32x8::min_lane)), Vec3::from_array(hi.map(F32x8::max_lane)))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::fast::kernel::lane;

    #[test]
    fn a_tiles_box_in_lanes_is_the_box_particle_by_particle() {
        // Three slots of eight lanes with coordinates spread over ±5 m, a
        // third of the lanes still (weight 0, placed far outside the others'
        // box, at ±100 m, so that counting one would show), against the
        // moving particles' x and x0 = q − d folded one at a time with
        // `Vec3::min` and `max`.
        let value = |s: usize, l: usize, k: usize, salt: f32| ((s * 31 + l * 7 + k * 3) as f32 * salt).sin() * 5.0;
        let slots = 0..3;
        let weight: Vec<F32x8> =
            slots.clone().map(|s| F32x8(std::array::from_fn(|l| if (s + l) % 3 == 0 { 0.0 } else { 1.0 }))).collect();
        let far =
            |s: usize, l: usize, v: f32| if weight[s].0[l] == 0.0 { 100.0 * (1.0 - 2.0 * ((l % 2) as f32)) } else { v };
        let slot = |salt: f32| -> Vec<Slot> {
            slots
                .clone()
                .map(|s| std::array::from_fn(|k| F32x8(std::array::from_fn(|l| far(s, l, value(s, l, k, salt))))))
                .collect()
        };
        let (position, displacement, predicted) = (slot(0.37), slot(0.11), slot(0.73));
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for s in slots {
            for l in (0..LANES).filter(|&l| weight[s].0[l] > 0.0) {
                let (x, x0) = (lane(&position[s], l), lane(&predicted[s], l) - lane(&displacement[s], l));
                (lo, hi) = (lo.min(x).min(x0), hi.max(x).max(x0));
            }
        }
        // The reference holds the moving lanes only (x within ±5 m, x0 = q − d
        // within ±10 m).
        assert!(lo.min_element() >= -10.0 && hi.max_element() <= 10.0, "{lo} {hi}");
        assert_eq!(tile_box(&position, &displacement, &predicted, &weight), (lo, hi));
        // No lane moving: an empty box (+∞ to −∞), which the phase skips.
        let still = vec![F32x8::splat(0.0); 3];
        let (lo, hi) = tile_box(&position, &displacement, &predicted, &still);
        assert!(lo.x > hi.x && lo == Vec3::INFINITY && hi == Vec3::NEG_INFINITY);
    }
}
