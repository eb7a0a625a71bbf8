//! The fast path for any mesh: bars reordered by colour.
//!
//! A greedy colouring gives every bar the smallest colour not yet used by a
//! bar at either of its ends; bars are then relaxed colour by colour (in
//! creation order within a colour). Bars of one colour share no particle, so
//! each projection is independent of the one before it and the CPU overlaps
//! them, instead of waiting on the previous projection's result as the
//! creation-order loop does. Positions and the inverse mass sit together in 16
//! bytes, one load per bar end.

use glam::Vec3;

use super::kernel::{Point, excess, integrate, relax_pair, settle, tether};
use crate::sim::contact::ContactStep;
use crate::sim::mesh::Bar;
use crate::sim::self_contact::{SelfContact, SelfContactStep};
use crate::sim::step::{Solver, Substep};
use crate::sim::tether::Tethers;

#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
struct Particle {
    position: Point<f32>,
    /// Inverse mass relative to m (0: fixed).
    weight: f32,
}

#[derive(Clone, Copy, Debug)]
struct ColouredBar {
    a: u32,
    b: u32,
    rest: f32,
    /// [`crate::sim::BarKind::index`]: an index into [`Substep::betas`].
    kind: u8,
}

/// Particles in scene order, bars in colour order.
#[derive(Clone, Debug)]
pub(crate) struct GenericLayout {
    particles: Vec<Particle>,
    displacement: Vec<[f32; 3]>,
    predicted: Vec<[f32; 3]>,
    bars: Vec<ColouredBar>,
    /// μ = βλ of every bar (compliant bars only).
    multipliers: Vec<f32>,
    colours: usize,
    tethers: Option<Tethers>,
}

/// Most colours tracked; bars that find none free go in one last group, which
/// is still a correct Gauss–Seidel sweep, only not free of dependencies.
const MAX_COLOURS: u32 = 63;

impl GenericLayout {
    pub(crate) fn new(
        positions: &[Vec3],
        previous: &[Vec3],
        inverse_mass: &[f32],
        bars: &[Bar],
        tethers: Option<Tethers>,
    ) -> Self {
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
        let bars: Vec<ColouredBar> = coloured
            .iter()
            .map(|&(_, i)| ColouredBar {
                a: bars[i].a,
                b: bars[i].b,
                rest: bars[i].rest_length,
                kind: bars[i].kind.index() as u8,
            })
            .collect();
        let mut layout = GenericLayout {
            particles: vec![Particle::default(); positions.len()],
            displacement: vec![[0.0; 3]; positions.len()],
            predicted: vec![[0.0; 3]; positions.len()],
            multipliers: vec![0.0; bars.len()],
            bars,
            colours,
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

    /// Number of colours the bars were split into.
    pub(crate) fn colours(&self) -> usize {
        self.colours
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
        let compliant = s.compliant();
        if compliant {
            self.multipliers.fill(0.0);
        }
        let sweep = Sweep { betas: s.betas(), omega: s.over_relaxation, tolerance: s.tolerance };
        let mut sweeps = 0;
        for _ in 0..s.relaxations {
            sweeps += 1;
            let worst = if compliant {
                relax_all::<true>(&mut self.particles, &self.bars, &mut self.multipliers, &sweep)
            } else {
                relax_all::<false>(&mut self.particles, &self.bars, &mut self.multipliers, &sweep)
            };
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
        format!("coloured: {} colours, one thread", self.colours())
    }

    fn boxed_clone(&self) -> Box<dyn Solver> {
        Box::new(self.clone())
    }
}

/// What a sweep needs, by bar kind (0 structural, 1 bend, 2 shear).
struct Sweep {
    betas: [f32; crate::sim::BarKind::COUNT],
    omega: f32,
    tolerance: f32,
}

/// One sweep over every bar; returns `max(|len − rest| − tolerance·rest)` over
/// the bars that can move.
fn relax_all<const XPBD: bool>(
    particles: &mut [Particle],
    bars: &[ColouredBar],
    multipliers: &mut [f32],
    sweep: &Sweep,
) -> f32 {
    let mut worst = f32::NEG_INFINITY;
    for (bar, mu) in bars.iter().zip(multipliers) {
        let kind = usize::from(bar.kind);
        let (mut a, mut b) = (particles[bar.a as usize], particles[bar.b as usize]);
        let (wa, wb) = (a.weight, b.weight);
        let v = relax_pair::<f32, XPBD>(
            &mut a.position,
            wa,
            &mut b.position,
            wb,
            bar.rest,
            mu,
            sweep.betas[kind],
            sweep.omega,
        );
        particles[bar.a as usize] = a;
        particles[bar.b as usize] = b;
        if sweep.tolerance > 0.0 {
            worst = worst.max(excess(v, wa, wb, sweep.tolerance * bar.rest));
        }
    }
    worst
}
