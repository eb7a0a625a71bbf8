//! The fast path for any mesh: bars reordered by colour.
//!
//! A greedy colouring gives every bar the smallest colour not yet used by a
//! bar at either of its ends; bars are then relaxed colour by colour, eight
//! at a time in SIMD lanes ([`sweep`]). Bars of one colour share no
//! particle, so each projection is independent of the others in its
//! colour: the lanes compute what one bar at a time would, and the
//! creation-order loop's wait on the previous projection's result is gone.
//! Positions and the inverse mass sit together in 16 bytes, one row per
//! particle.
//!
//! The particles are renumbered into dimers ([`order::dimer_order`]): two
//! neighbours in consecutive rows, dimers side by side like rungs of a
//! ladder. Bars are then paired ([`pairs`]) so that an octet's lanes l and
//! l + 4 take the two rows of a dimer at one end or at both, which the AVX2
//! sweep loads and stores as one 32-byte access where it took two and a
//! shuffle.

mod ahead;
mod blocks;
mod collide;
mod colouring;
mod octets;
mod order;
mod pairs;
mod sweep;

use glam::Vec3;
use rayon::prelude::*;

use super::kernel::{Point, integrate, settle, tether};
use super::lines::LineAligned;
use crate::sim::contact::ContactStep;
use crate::sim::mesh::Bar;
use crate::sim::self_contact::{SelfContact, SelfContactStep};
use crate::sim::step::{Solver, Substep};
use crate::sim::tether::Tethers;
use blocks::BlockedBars;
use sweep::Sweep;

#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
struct Particle {
    position: Point<f32>,
    /// Inverse mass relative to m (0: fixed).
    weight: f32,
}

/// Particles in scene order (or renumbered, see [`colouring`]), bars in
/// colour order.
#[derive(Clone, Debug)]
pub(crate) struct GenericLayout {
    /// From a cache line's start: a dimer's two rows are one 32-byte
    /// access that never straddles two lines ([`LineAligned`]).
    particles: LineAligned<Particle>,
    displacement: Vec<[f32; 3]>,
    predicted: Vec<[f32; 3]>,
    bars: BlockedBars,
    /// Tethers, indexed and anchored in the layout's order.
    tethers: Option<Tethers>,
    /// The particles' order when it is not the scene's.
    renumbering: Option<Renumbering>,
    /// Whether that order starts from a breadth-first one.
    breadth_first: bool,
    /// A weight changed since the bars' still octets were counted
    /// ([`BlockedBars::count_still`]): they are counted again before the
    /// next pass.
    weights_changed: bool,
}

/// Where each particle sits when the layout renumbered them.
#[derive(Clone, Debug)]
struct Renumbering {
    /// `scene[k]`: the scene index of the particle in slot k.
    scene: Vec<u32>,
    /// `slot[i]`: the slot of scene particle i.
    slot: Vec<u32>,
}

/// Particles a task of the thread pool takes in the phases that go
/// particle by particle (integrate, settle, read, the finiteness check).
const CHUNK: usize = 4096;

/// Whether every `f32` of `rows` is finite: x · 0 is 0 for a finite x and
/// NaN otherwise, and one NaN makes its lane's sum NaN. Sixteen sums, so
/// the loop runs in SIMD lanes without a branch an element (the rows' w,
/// the inverse mass, is finite too).
fn rows_are_finite(rows: &[f32]) -> bool {
    let mut sums = [0.0f32; 16];
    let whole = rows.chunks_exact(16);
    let tail = whole.remainder();
    for block in whole {
        for (s, v) in sums.iter_mut().zip(block) {
            *s += v * 0.0;
        }
    }
    for (s, v) in sums.iter_mut().zip(tail) {
        *s += v * 0.0;
    }
    sums.iter().all(|s| *s == 0.0)
}

impl GenericLayout {
    /// Positions x and x − d in scene order, each as `to` makes it.
    /// In chunks of scene order, on the thread pool when the passes use it
    /// (each particle read alone: the same bits).
    fn read_as<T: Send>(&self, positions: &mut [T], previous: &mut [T], to: impl Fn(Vec3) -> T + Sync) {
        let chunk = |(c, (positions, previous)): (usize, (&mut [T], &mut [T]))| {
            for (j, (x, x_prev)) in positions.iter_mut().zip(previous).enumerate() {
                let k = self.slot(c * CHUNK + j);
                let p = Vec3::from_array(self.particles[k].position);
                *x = to(p);
                *x_prev = to(p - Vec3::from_array(self.displacement[k]));
            }
        };
        if self.uses_pool() {
            positions.par_chunks_mut(CHUNK).zip(previous.par_chunks_mut(CHUNK)).enumerate().for_each(chunk);
        } else {
            positions.chunks_mut(CHUNK).zip(previous.chunks_mut(CHUNK)).enumerate().for_each(chunk);
        }
    }

    /// `f` on every particle, its displacement d and its predicted
    /// position, in chunks, on the thread pool when the passes use it
    /// (each particle alone: the same bits on any thread count).
    fn each_particle(&mut self, f: impl Fn(&mut Particle, &mut [f32; 3], &mut [f32; 3]) + Sync) {
        self.each_chunk(|p, d, q| {
            for ((p, d), q) in p.iter_mut().zip(d).zip(q) {
                f(p, d, q);
            }
        });
    }

    /// `f` on every chunk of [`CHUNK`] particles, their displacements d and
    /// predicted positions, on the thread pool when the passes use it.
    fn each_chunk(&mut self, f: impl Fn(&mut [Particle], &mut [[f32; 3]], &mut [[f32; 3]]) + Sync) {
        type Chunk<'a> = ((&'a mut [Particle], &'a mut [[f32; 3]]), &'a mut [[f32; 3]]);
        let chunk = |((p, d), q): Chunk| f(p, d, q);
        if self.uses_pool() {
            let (p, d) = (self.particles.par_chunks_mut(CHUNK), self.displacement.par_chunks_mut(CHUNK));
            p.zip(d).zip(self.predicted.par_chunks_mut(CHUNK)).for_each(chunk);
        } else {
            let (p, d) = (self.particles.chunks_mut(CHUNK), self.displacement.chunks_mut(CHUNK));
            p.zip(d).zip(self.predicted.chunks_mut(CHUNK)).for_each(chunk);
        }
    }

    /// `f` on every particle's row, its slot in the layout and its scene
    /// index, in chunks of the layout's order, on the thread pool when the
    /// passes use it.
    fn each_row(&mut self, f: impl Fn(&mut Particle, usize, usize) + Sync) {
        let renumbering = self.renumbering.as_ref();
        let chunk = |(c, particles): (usize, &mut [Particle])| {
            for (j, p) in particles.iter_mut().enumerate() {
                let k = c * CHUNK + j;
                f(p, k, renumbering.map_or(k, |r| r.scene[k] as usize));
            }
        };
        if self.uses_pool() {
            self.particles.par_chunks_mut(CHUNK).enumerate().for_each(chunk);
        } else {
            self.particles.chunks_mut(CHUNK).enumerate().for_each(chunk);
        }
    }

    /// The layout of a mesh: its particles in [`order::dimer_order`] (over
    /// the scene's order, or a breadth-first one where the scene's would
    /// put more than 1 bar in 20 between blocks), its bars coloured.
    pub(crate) fn new(
        positions: &[Vec3],
        previous: &[Vec3],
        inverse_mass: &[f32],
        bars: &[Bar],
        tethers: Option<Tethers>,
    ) -> Self {
        let n = positions.len();
        let renumber = |scene: &[u32]| {
            let mut slot = vec![0u32; n];
            for (k, &i) in scene.iter().enumerate() {
                slot[i as usize] = k as u32;
            }
            let moved: Vec<Bar> =
                bars.iter().map(|b| Bar { a: slot[b.a as usize], b: slot[b.b as usize], ..*b }).collect();
            (Renumbering { scene: scene.to_vec(), slot }, moved)
        };
        // More than 1 bar in 20 between blocks: the scene's order is not
        // local, and a breadth-first one may do better.
        let mut base = None;
        let boundary = BlockedBars::boundary_count(bars, n);
        if boundary * 20 > bars.len() {
            let (breadth_first, moved) = renumber(&order::breadth_first_order(n, bars));
            if BlockedBars::boundary_count(&moved, n) < boundary {
                base = Some((breadth_first, moved));
            }
        }
        let (base_scene, base_bars) = match &base {
            Some((r, moved)) => (Some(&r.scene), &moved[..]),
            None => (None, bars),
        };
        let dimers = order::dimer_order(n, base_bars);
        let scene: Vec<u32> = dimers.iter().map(|&k| base_scene.map_or(k, |s| s[k as usize])).collect();
        let (renumbering, moved) = renumber(&scene);
        let mut layout = Self::in_order(positions, previous, inverse_mass, &moved, tethers, Some(renumbering));
        layout.breadth_first = base.is_some();
        layout
    }

    /// The layout with the particles in the order `renumbering` gives (or
    /// the scene's), `bars` numbered in that order.
    fn in_order(
        positions: &[Vec3],
        previous: &[Vec3],
        inverse_mass: &[f32],
        bars: &[Bar],
        tethers: Option<Tethers>,
        renumbering: Option<Renumbering>,
    ) -> Self {
        let n = positions.len();
        let scene = |k: usize| renumbering.as_ref().map_or(k, |r| r.scene[k] as usize);
        let fixed: Vec<bool> = (0..n).map(|k| inverse_mass[scene(k)] == 0.0).collect();
        let mut layout = GenericLayout {
            particles: LineAligned::zeroed(n),
            displacement: vec![[0.0; 3]; n],
            predicted: vec![[0.0; 3]; n],
            bars: BlockedBars::new(bars, n, &fixed),
            tethers: None,
            renumbering,
            breadth_first: false,
            weights_changed: true,
        };
        layout.set_tethers(tethers);
        for i in 0..n {
            layout.set_inverse_mass(i, inverse_mass[i]);
            layout.set_particle(i, positions[i], previous[i]);
        }
        layout.bars.count_still(&layout.particles);
        layout.weights_changed = false;
        layout
    }

    /// The slot of scene particle `i`.
    fn slot(&self, i: usize) -> usize {
        self.renumbering.as_ref().map_or(i, |r| r.slot[i] as usize)
    }

    /// The scene index of the particle in slot `k`.
    fn scene(&self, k: usize) -> usize {
        self.renumbering.as_ref().map_or(k, |r| r.scene[k] as usize)
    }

    fn set_initial_velocity(&mut self, velocity: &[Vec3], dt: f32, extra: Vec3) {
        for k in 0..self.particles.len() {
            let w = self.particles[k].weight;
            if w > 0.0 {
                self.displacement[k] = (velocity[self.scene(k)] * dt + extra * w).to_array();
            }
        }
    }
}

impl Solver for GenericLayout {
    fn integrate(&mut self, s: &Substep) {
        let (keep, accel, gravity) = match s.first {
            Some((v0, extra)) => {
                self.set_initial_velocity(v0, s.dt, extra);
                (1.0, [0.0; 3], [0.0; 3])
            }
            None => (s.keep, s.accel.to_array(), s.gravity.to_array()),
        };
        self.each_particle(|p, d, q| *q = integrate(&mut p.position, d, p.weight, keep, accel, gravity));
    }

    /// Each particle alone, [`GenericLayout::each_row`]: the same bits.
    fn push(&mut self, displacement: &[Vec3]) {
        self.each_row(|p, _, i| {
            if p.weight > 0.0 {
                let delta = displacement[i];
                for k in 0..3 {
                    p.position[k] += p.weight * delta[k];
                }
            }
        });
    }

    fn relax(&mut self, s: &Substep) -> u32 {
        if let (Some(tethers), Some(slack)) = (&self.tethers, s.tether_slack) {
            for i in 0..self.particles.len() {
                if let Some(anchor) = tethers.anchor[i] {
                    let from = self.particles[anchor as usize].position;
                    let p = &mut self.particles[i];
                    tether(&mut p.position, from, tethers.length[i] * (1.0 + slack), p.weight);
                }
            }
        }
        if s.compliant() {
            self.bars.reset_multipliers();
        }
        if self.weights_changed {
            self.bars.count_still(&self.particles);
            self.weights_changed = false;
        }
        let sweep = Sweep { betas: s.betas(), omega: s.over_relaxation, tolerance: s.tolerance };
        if s.tolerance <= 0.0 {
            let _ = self.bars.relax_passes(&mut self.particles, &sweep, s.relaxations as usize);
            return s.relaxations;
        }
        let mut sweeps = 0;
        for _ in 0..s.relaxations {
            sweeps += 1;
            if self.bars.relax_pass(&mut self.particles, &sweep) <= 0.0 {
                break;
            }
        }
        sweeps
    }

    /// Chunk by chunk, on the thread pool when the passes use it, eight
    /// particles at a time in lanes ([`collide`]): the bits of every
    /// particle against every collider, on any thread count.
    fn collide(&mut self, contact: &ContactStep) {
        self.each_chunk(|particles, d, q| collide::collide_chunk(particles, d, q, contact));
    }

    /// Copies positions, start positions (x_pred − d) and weights in the
    /// layout's order, runs the phase on them (rows numbered by the
    /// renumbering), writes the positions back; in chunks on the thread
    /// pool when the passes use it. (Gathering them into scene order
    /// instead had one thread scatter every row: 1.2 ms a step on
    /// disc-183.)
    fn self_collide(&mut self, phase: &mut SelfContact, step: &SelfContactStep) {
        let (mut x, mut x0, mut w) =
            (std::mem::take(&mut phase.x), std::mem::take(&mut phase.x0), std::mem::take(&mut phase.w));
        let n = self.particles.len();
        x.resize(n, Vec3::ZERO);
        x0.resize(n, Vec3::ZERO);
        w.resize(n, 0.0);
        let (particles, displacement, predicted) = (&self.particles, &self.displacement, &self.predicted);
        type Rows<'a> = (usize, ((&'a mut [Vec3], &'a mut [Vec3]), &'a mut [f32]));
        let copy = |(c, ((x, x0), w)): Rows| {
            let at = c * CHUNK;
            let rows = particles[at..].iter().zip(&displacement[at..]).zip(&predicted[at..]);
            for ((((p, d), q), x), (x0, w)) in rows.zip(x.iter_mut()).zip(x0.iter_mut().zip(w.iter_mut())) {
                (*x, *x0, *w) = (Vec3::from_array(p.position), Vec3::from_array(*q) - Vec3::from_array(*d), p.weight);
            }
        };
        if self.uses_pool() {
            x.par_chunks_mut(CHUNK)
                .zip(x0.par_chunks_mut(CHUNK))
                .zip(w.par_chunks_mut(CHUNK))
                .enumerate()
                .for_each(copy);
        } else {
            x.chunks_mut(CHUNK).zip(x0.chunks_mut(CHUNK)).zip(w.chunks_mut(CHUNK)).enumerate().for_each(copy);
        }
        phase.apply_numbered(&mut x, &x0, &w, self.renumbering.as_ref().map(|r| &r.scene[..]), step);
        self.each_row(|p, k, _| p.position = x[k].to_array());
        (phase.x, phase.x0, phase.w) = (x, x0, w);
    }

    fn settle(&mut self) {
        self.each_particle(|p, d, q| settle(d, p.position, *q, p.weight));
    }

    fn read(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        self.read_as(positions, previous, |p| p);
    }

    fn read_rows(&self, positions: &mut [[f32; 4]], previous: &mut [[f32; 4]]) {
        self.read_as(positions, previous, |p| p.extend(0.0).to_array());
    }

    fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        let k = self.slot(index);
        self.particles[k].position = position.to_array();
        self.displacement[k] = (position - previous).to_array();
    }

    fn set_inverse_mass(&mut self, index: usize, weight: f32) {
        let k = self.slot(index);
        self.particles[k].weight = weight;
        self.weights_changed = true;
    }

    /// Keeps them in the layout's order: particle and anchor renumbered.
    fn set_tethers(&mut self, tethers: Option<Tethers>) {
        self.tethers = match (tethers, &self.renumbering) {
            (Some(t), Some(r)) => {
                let mut moved = Tethers { anchor: vec![None; t.anchor.len()], length: vec![0.0; t.length.len()] };
                for (i, (anchor, length)) in t.anchor.iter().zip(&t.length).enumerate() {
                    let k = r.slot[i] as usize;
                    moved.anchor[k] = anchor.map(|a| r.slot[a as usize]);
                    moved.length[k] = *length;
                }
                Some(moved)
            }
            (tethers, _) => tethers,
        };
    }

    /// A scan of the rows in the layout's order (in chunks on the pool when
    /// the passes use it); only when one is not finite, a search in scene
    /// order for the first.
    fn first_non_finite(&self) -> Option<usize> {
        let finite = |chunk: &[Particle]| rows_are_finite(bytemuck::cast_slice(chunk));
        let all = if self.uses_pool() {
            self.particles.par_chunks(CHUNK).all(finite)
        } else {
            self.particles.chunks(CHUNK).all(finite)
        };
        if all {
            return None;
        }
        (0..self.particles.len()).find(|&i| !self.particles[self.slot(i)].position.iter().all(|c| c.is_finite()))
    }

    fn uses_pool(&self) -> bool {
        self.bars.blocks.len() > 1 && rayon::current_num_threads() > 1
    }

    fn describe(&self) -> String {
        let (colours, boundary_colours) = self.bars.colours();
        let ([both, a_end], all) = self.bars.paired_share();
        let percent = |n: usize| (100 * n).checked_div(all).unwrap_or(0);
        let lanes = if super::simd::level() >= super::simd::SimdLevel::Avx2 {
            format!("8 bars a lane op ({} % paired at both ends, {} % at one)", percent(both), percent(a_end))
        } else {
            "8 bars a lane op (the portable level's vectors: NEON or SSE)".to_string()
        };
        let lanes = match self.bars.still_share().0 {
            0 => lanes,
            still => format!("{lanes}, {still} bars between fixed particles skipped ({} %)", percent(still)),
        };
        match self.bars.blocks.len() {
            1 => format!("coloured: {colours} colours, {lanes}, one thread"),
            blocks => {
                let (boundary, all) = self.bars.boundary_share();
                let order = if self.breadth_first { "particles renumbered breadth-first, " } else { "" };
                let far = match self.bars.far_bars() {
                    0 => String::new(),
                    far => format!(", {far} of them between blocks further apart (one thread)"),
                };
                format!(
                    "coloured: {order}{blocks} blocks of ≤ {colours} colours on {} threads, {lanes}; boundary {boundary} of {all} bars in seams of ≤ {boundary_colours} colours{far}",
                    rayon::current_num_threads()
                )
            }
        }
    }

    fn boxed_clone(&self) -> Box<dyn Solver> {
        Box::new(self.clone())
    }
}

#[cfg(test)]
mod tests;
