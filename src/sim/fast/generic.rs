//! The fast path for any mesh: bars reordered by colour.
//!
//! A greedy colouring gives every bar the smallest colour not yet used by a
//! bar at either of its ends; bars are then relaxed colour by colour (in
//! creation order within a colour). Bars of one colour share no particle, so
//! each projection is independent of the one before it and the CPU overlaps
//! them, instead of waiting on the previous projection's result as the
//! creation-order loop does. Positions and the state code sit together in 16
//! bytes, one load per bar end.

use glam::Vec3;

use super::kernel::{FIXED, FREE, Point, Shares, excess, integrate, relax_pair, settle};
use crate::sim::mesh::Bar;

#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
struct Particle {
    position: Point<f32>,
    state: f32,
}

#[derive(Clone, Copy, Debug)]
struct ColouredBar {
    a: u32,
    b: u32,
    rest: f32,
}

/// Particles in scene order, bars in colour order.
#[derive(Clone, Debug)]
pub(crate) struct GenericLayout {
    particles: Vec<Particle>,
    displacement: Vec<[f32; 3]>,
    predicted: Vec<[f32; 3]>,
    bars: Vec<ColouredBar>,
    colours: usize,
}

/// Most colours tracked; bars that find none free go in one last group, which
/// is still a correct Gauss–Seidel sweep, only not free of dependencies.
const MAX_COLOURS: u32 = 63;

impl GenericLayout {
    pub(crate) fn new(positions: &[Vec3], previous: &[Vec3], fixed: &[bool], bars: &[Bar]) -> Self {
        let mut used = vec![0u64; positions.len()];
        let mut coloured: Vec<(u32, usize)> = Vec::with_capacity(bars.len());
        for (i, bar) in bars.iter().enumerate() {
            let (a, b) = (bar.a as usize, bar.b as usize);
            let colour = (!(used[a] | used[b])).trailing_zeros().min(MAX_COLOURS);
            if colour < MAX_COLOURS {
                used[a] |= 1 << colour;
                used[b] |= 1 << colour;
            }
            coloured.push((colour, i));
        }
        coloured.sort_by_key(|&(colour, i)| (colour, i));
        let colours = coloured.last().map_or(0, |&(c, _)| c as usize + 1);
        let bars = coloured
            .iter()
            .map(|&(_, i)| ColouredBar { a: bars[i].a, b: bars[i].b, rest: bars[i].rest_length })
            .collect();
        let mut layout = GenericLayout {
            particles: vec![Particle::default(); positions.len()],
            displacement: vec![[0.0; 3]; positions.len()],
            predicted: vec![[0.0; 3]; positions.len()],
            bars,
            colours,
        };
        for (i, p) in layout.particles.iter_mut().enumerate() {
            p.state = if fixed[i] { FIXED } else { FREE };
        }
        layout.write_state(positions, previous);
        layout
    }

    /// Number of colours the bars were split into.
    pub(crate) fn colours(&self) -> usize {
        self.colours
    }

    pub(crate) fn write_state(&mut self, positions: &[Vec3], previous: &[Vec3]) {
        for i in 0..positions.len() {
            self.set_particle(i, positions[i], previous[i]);
        }
    }

    pub(crate) fn read_state(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        for (i, (p, d)) in self.particles.iter().zip(&self.displacement).enumerate() {
            positions[i] = Vec3::from_array(p.position);
            previous[i] = positions[i] - Vec3::from_array(*d);
        }
    }

    pub(crate) fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        self.particles[index].position = position.to_array();
        self.displacement[index] = (position - previous).to_array();
    }

    pub(crate) fn set_initial_velocity(&mut self, velocity: &[Vec3], dt: f32) {
        for (i, (d, p)) in self.displacement.iter_mut().zip(&self.particles).enumerate() {
            if p.state == FREE {
                *d = (velocity[i] * dt).to_array();
            }
        }
    }

    pub(crate) fn first_non_finite(&self) -> Option<usize> {
        self.particles.iter().position(|p| !p.position.iter().all(|c| c.is_finite()))
    }

    /// One step; see [`super::grid::GridLayout::step`].
    pub(crate) fn step(&mut self, keep: f32, accel: Vec3, relaxations: u32, tolerance: f32) -> u32 {
        let accel = accel.to_array();
        for ((p, d), q) in self.particles.iter_mut().zip(&mut self.displacement).zip(&mut self.predicted) {
            *q = integrate(&mut p.position, d, p.state, keep, accel);
        }
        let mut sweeps = 0;
        for _ in 0..relaxations {
            sweeps += 1;
            let worst = relax_all(&mut self.particles, &self.bars, tolerance);
            if tolerance > 0.0 && worst <= 0.0 {
                break;
            }
        }
        for ((p, d), q) in self.particles.iter().zip(&mut self.displacement).zip(&self.predicted) {
            settle(d, p.position, *q, p.state);
        }
        sweeps
    }
}

/// One sweep over every bar; returns `max(|len − rest| − tolerance·rest)` over
/// the bars that can move.
fn relax_all(particles: &mut [Particle], bars: &[ColouredBar], tolerance: f32) -> f32 {
    let mut worst = f32::NEG_INFINITY;
    for bar in bars {
        let (mut a, mut b) = (particles[bar.a as usize], particles[bar.b as usize]);
        let (wa, wb) = (Shares::RIGID.weights(a.state), Shares::RIGID.weights(b.state));
        let v = relax_pair(&mut a.position, wa, &mut b.position, wb, bar.rest);
        particles[bar.a as usize] = a;
        particles[bar.b as usize] = b;
        if tolerance > 0.0 {
            worst = worst.max(excess(v, wa, wb, tolerance * bar.rest));
        }
    }
    worst
}
