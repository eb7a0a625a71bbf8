//! The fast path for any mesh: bars reordered by colour.
//!
//! A greedy colouring gives every bar the smallest colour not yet used by a
//! bar at either of its ends; bars are then relaxed colour by colour (in
//! creation order within a colour), eight at a time in SIMD lanes
//! ([`sweep`]). Bars of one colour share no particle, so each projection is
//! independent of the others in its colour: the lanes compute what one bar at
//! a time would, and the creation-order loop's wait on the previous
//! projection's result is gone. Positions and the inverse mass sit together
//! in 16 bytes, one load per bar end.

mod colouring;
mod sweep;

use glam::Vec3;

use super::kernel::{Point, integrate, settle, tether};
use crate::sim::contact::ContactStep;
use crate::sim::mesh::Bar;
use crate::sim::self_contact::{SelfContact, SelfContactStep};
use crate::sim::step::{Solver, Substep};
use crate::sim::tether::Tethers;
use colouring::BlockedBars;
use sweep::Sweep;

#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
struct Particle {
    position: Point<f32>,
    /// Inverse mass relative to m (0: fixed).
    weight: f32,
}

/// Particles in scene order, bars in colour order.
#[derive(Clone, Debug)]
pub(crate) struct GenericLayout {
    particles: Vec<Particle>,
    displacement: Vec<[f32; 3]>,
    predicted: Vec<[f32; 3]>,
    bars: BlockedBars,
    tethers: Option<Tethers>,
}

impl GenericLayout {
    pub(crate) fn new(
        positions: &[Vec3],
        previous: &[Vec3],
        inverse_mass: &[f32],
        bars: &[Bar],
        tethers: Option<Tethers>,
    ) -> Self {
        let mut layout = GenericLayout {
            particles: vec![Particle::default(); positions.len()],
            displacement: vec![[0.0; 3]; positions.len()],
            predicted: vec![[0.0; 3]; positions.len()],
            bars: BlockedBars::new(bars, positions.len()),
            tethers,
        };
        for (p, &w) in layout.particles.iter_mut().zip(inverse_mass) {
            p.weight = w;
        }
        for i in 0..positions.len() {
            layout.set_particle(i, positions[i], previous[i]);
        }
        layout
    }

    fn set_initial_velocity(&mut self, velocity: &[Vec3], dt: f32, extra: Vec3) {
        for (i, (d, p)) in self.displacement.iter_mut().zip(&self.particles).enumerate() {
            if p.weight > 0.0 {
                *d = (velocity[i] * dt + extra * p.weight).to_array();
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
        for ((p, d), q) in self.particles.iter_mut().zip(&mut self.displacement).zip(&mut self.predicted) {
            *q = integrate(&mut p.position, d, p.weight, keep, accel, gravity);
        }
    }

    fn push(&mut self, displacement: &[Vec3]) {
        for (p, delta) in self.particles.iter_mut().zip(displacement) {
            if p.weight > 0.0 {
                for k in 0..3 {
                    p.position[k] += p.weight * delta[k];
                }
            }
        }
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
        let sweep = Sweep { betas: s.betas(), omega: s.over_relaxation, tolerance: s.tolerance };
        let mut sweeps = 0;
        for _ in 0..s.relaxations {
            sweeps += 1;
            let worst = self.bars.relax_pass(&mut self.particles, &sweep);
            if s.tolerance > 0.0 && worst <= 0.0 {
                break;
            }
        }
        sweeps
    }

    /// Particles in scene order; each started the substep at x_pred − d.
    fn collide(&mut self, contact: &ContactStep) {
        let all = contact.all();
        for ((p, d), q) in self.particles.iter_mut().zip(&self.displacement).zip(&self.predicted) {
            if p.weight > 0.0 {
                let x0 = Vec3::from_array(*q) - Vec3::from_array(*d);
                p.position = contact.resolve(&all, x0, Vec3::from_array(p.position)).to_array();
            }
        }
    }

    /// Gathers positions, start positions (x_pred − d) and weights, runs
    /// the phase, writes the positions back.
    fn self_collide(&mut self, phase: &mut SelfContact, step: &SelfContactStep) {
        let (mut x, mut x0, mut w) =
            (std::mem::take(&mut phase.x), std::mem::take(&mut phase.x0), std::mem::take(&mut phase.w));
        x.clear();
        x0.clear();
        w.clear();
        for ((p, d), q) in self.particles.iter().zip(&self.displacement).zip(&self.predicted) {
            x.push(Vec3::from_array(p.position));
            x0.push(Vec3::from_array(*q) - Vec3::from_array(*d));
            w.push(p.weight);
        }
        phase.apply(&mut x, &x0, &w, step);
        for (p, x) in self.particles.iter_mut().zip(&x) {
            p.position = x.to_array();
        }
        (phase.x, phase.x0, phase.w) = (x, x0, w);
    }

    fn settle(&mut self) {
        for ((p, d), q) in self.particles.iter().zip(&mut self.displacement).zip(&self.predicted) {
            settle(d, p.position, *q, p.weight);
        }
    }

    fn read(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        for (i, (p, d)) in self.particles.iter().zip(&self.displacement).enumerate() {
            positions[i] = Vec3::from_array(p.position);
            previous[i] = positions[i] - Vec3::from_array(*d);
        }
    }

    fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        self.particles[index].position = position.to_array();
        self.displacement[index] = (position - previous).to_array();
    }

    fn set_inverse_mass(&mut self, index: usize, weight: f32) {
        self.particles[index].weight = weight;
    }

    fn set_tethers(&mut self, tethers: Option<Tethers>) {
        self.tethers = tethers;
    }

    fn first_non_finite(&self) -> Option<usize> {
        self.particles.iter().position(|p| !p.position.iter().all(|c| c.is_finite()))
    }

    fn describe(&self) -> String {
        let (colours, boundary_colours) = self.bars.colours();
        let lanes =
            if super::simd::level() >= super::simd::SimdLevel::Avx2 { "8 bars a lane op" } else { "one bar at a time" };
        match self.bars.blocks.len() {
            1 => format!("coloured: {colours} colours, {lanes}, one thread"),
            blocks => {
                let (boundary, all) = self.bars.boundary_share();
                format!(
                    "coloured: {blocks} blocks of ≤ {colours} colours on {} threads, {lanes}; boundary {boundary} of {all} bars in {boundary_colours} colours",
                    rayon::current_num_threads()
                )
            }
        }
    }

    fn boxed_clone(&self) -> Box<dyn Solver> {
        Box::new(self.clone())
    }
}
