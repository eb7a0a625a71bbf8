//! The seed's solver written the plain way: the yardstick for every other.
//!
//! One step, exactly as the seed describes it:
//!
//! 1. visit the particles one by one; move every free particle by equation 1
//!    (or, on the very first step, by the Euler step of equation 2);
//! 2. `relaxations` times, visit every bar in creation order and move its
//!    ends so that it regains its rest length (Figure 3), Gauss–Seidel: each
//!    projection sees the positions the previous ones left;
//! 3. (with colliders) visit the particles one by one and resolve contact
//!    and friction ([`super::contact`]).
//!
//! These are the phases of [`super::step`]; this file says how each runs
//! on the plain layout.
//!
//! The state is an array of structures (`Vec<Vec3>`) and every loop is scalar.
//! Consecutive bars share particles, so each projection waits for the one
//! before it: this is the latency-bound loop that [`super::fast`] is measured
//! against. The accuracy options ([`super::params`]: substeps, compliance,
//! over-relaxation, tethers) are written the same plain way, so that every
//! method can be compared on both solvers.

use glam::Vec3;

use super::contact::ContactStep;
use super::mesh::Bar;
use super::relax::{project_bar, project_bar_compliant};
use super::self_contact::{SelfContact, SelfContactStep};
use super::step::{Solver, Substep};
use super::tether::{Tethers, pull_within};

/// The seed-faithful solver's state, in scene order.
#[derive(Clone, Debug)]
pub struct ReferenceSolver {
    /// x_i: current positions, metres.
    pub positions: Vec<Vec3>,
    /// x_{i−1}: positions one (sub)step ago, metres.
    pub previous: Vec<Vec3>,
    /// Inverse mass relative to m: 1 for a free particle of the scene's
    /// mass, 0 if fixed. The force enters through [`Substep::accel`], which
    /// is already divided by m.
    pub inverse_mass: Vec<f32>,
    /// Every bar of the mesh, in creation order (a bar whose ends both weigh
    /// 0 moves nothing).
    pub bars: Vec<Bar>,
    /// λ of every bar (XPBD), reset every substep; unused for rigid bars.
    pub lambda: Vec<f32>,
    /// Attachments, when tethers are on.
    pub tethers: Option<Tethers>,
}

impl ReferenceSolver {
    /// The solver for this state, these weights and these bars.
    pub fn new(
        positions: &[Vec3],
        previous: &[Vec3],
        inverse_mass: &[f32],
        bars: &[Bar],
        tethers: Option<Tethers>,
    ) -> Self {
        Self {
            positions: positions.to_vec(),
            previous: previous.to_vec(),
            inverse_mass: inverse_mass.to_vec(),
            bars: bars.to_vec(),
            lambda: vec![0.0; bars.len()],
            tethers,
        }
    }

    /// One relaxation pass over every bar, in creation order: the seed's
    /// Figure 3 with rigid bars and no over-relaxation.
    pub fn relax_once(&mut self) {
        for bar in &self.bars {
            let (a, b) = (bar.a as usize, bar.b as usize);
            let (wa, wb) = (self.inverse_mass[a], self.inverse_mass[b]);
            let (da, db) = project_bar(self.positions[a], self.positions[b], bar.rest_length, wa, wb);
            self.positions[a] += da;
            self.positions[b] += db;
        }
    }

    /// One pass with compliance and over-relaxation; returns the largest
    /// relative strain met before a projection among bars that can move (0
    /// when there are none).
    fn relax_once_general(&mut self, s: &Substep) -> f32 {
        let mut worst = 0.0f32;
        for (bar, lambda) in self.bars.iter().zip(&mut self.lambda) {
            let (a, b) = (bar.a as usize, bar.b as usize);
            let (wa, wb) = (self.inverse_mass[a], self.inverse_mass[b]);
            let (xa, xb) = (self.positions[a], self.positions[b]);
            if wa + wb > 0.0 {
                worst = worst.max((xa.distance(xb) - bar.rest_length).abs() / bar.rest_length);
            }
            let beta = s.betas()[bar.kind.index()];
            let (da, db) = project_bar_compliant(xa, xb, bar.rest_length, wa, wb, beta, lambda, s.over_relaxation);
            self.positions[a] += da;
            self.positions[b] += db;
        }
        worst
    }
}

impl Solver for ReferenceSolver {
    /// Visits the particles one by one and moves every one of non-zero
    /// weight by equation 1 (or, on the very first substep, equation 2).
    fn integrate(&mut self, s: &Substep) {
        for i in 0..self.positions.len() {
            let w = self.inverse_mass[i];
            if w == 0.0 {
                continue;
            }
            let x = self.positions[i];
            let next = match s.first {
                // Equation 2: x₁ = x₀ + h v₀ (+ ½h²f/m for the second-order start).
                Some((v0, extra)) => x + s.dt * v0[i] + extra * w,
                // Equation 1: x_{i+1} = x_i + (1 − δ)(x_i − x_{i−1}) + h²/m f.
                // (+ h²g with g, an acceleration: whatever the particle's mass.)
                None => x + s.keep * (x - self.previous[i]) + s.accel * w + s.gravity,
            };
            self.previous[i] = x;
            self.positions[i] = next;
        }
    }

    fn push(&mut self, displacement: &[Vec3]) {
        for ((x, &w), delta) in self.positions.iter_mut().zip(&self.inverse_mass).zip(displacement) {
            if w > 0.0 {
                *x += w * *delta;
            }
        }
    }

    /// Pulls tethered particles back within reach, then relaxes
    /// `relaxations` times, or fewer once a pass finds every bar within
    /// `tolerance` (relative) before projecting it, when `tolerance > 0`.
    fn relax(&mut self, s: &Substep) -> u32 {
        if let (Some(tethers), Some(slack)) = (&self.tethers, s.tether_slack) {
            apply_tethers(&mut self.positions, &self.inverse_mass, tethers, slack);
        }
        let compliant = s.compliant();
        if compliant {
            self.lambda.fill(0.0);
        }
        if !compliant && s.over_relaxation == 1.0 && s.tolerance <= 0.0 {
            // The seed's own case: rigid bars, plain projections, every pass.
            for _ in 0..s.relaxations {
                self.relax_once();
            }
            return s.relaxations;
        }
        let mut passes = 0;
        for _ in 0..s.relaxations {
            passes += 1;
            if self.relax_once_general(s) <= s.tolerance {
                break;
            }
        }
        passes
    }

    /// Every particle of non-zero weight, in scene order, from where it
    /// started the substep (x_{i−1}) to where it is.
    fn collide(&mut self, contact: &ContactStep) {
        let all = contact.all();
        for i in 0..self.positions.len() {
            if self.inverse_mass[i] > 0.0 {
                self.positions[i] = contact.resolve(&all, self.previous[i], self.positions[i]);
            }
        }
    }

    /// Scene order already: the positions and x_{i−1} as they are, on one
    /// thread (the same bits as on many).
    fn self_collide(&mut self, phase: &mut SelfContact, step: &SelfContactStep) {
        let step = SelfContactStep { parallel: false, ..*step };
        phase.apply(&mut self.positions, &self.previous, &self.inverse_mass, &step);
    }

    /// Nothing to do: x_{i−1} was stored by the integration.
    fn settle(&mut self) {}

    fn read(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        positions.copy_from_slice(&self.positions);
        previous.copy_from_slice(&self.previous);
    }
    fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        self.positions[index] = position;
        self.previous[index] = previous;
    }
    fn set_inverse_mass(&mut self, index: usize, weight: f32) {
        self.inverse_mass[index] = weight;
    }
    fn set_tethers(&mut self, tethers: Option<Tethers>) {
        self.tethers = tethers;
    }
    fn first_non_finite(&self) -> Option<usize> {
        self.positions.iter().position(|p| !p.is_finite())
    }
    fn describe(&self) -> String {
        "creation order, scalar, one thread".to_string()
    }
    fn boxed_clone(&self) -> Box<dyn Solver> {
        Box::new(self.clone())
    }
}

/// Moves every tethered particle that is farther from its anchor than
/// `(1 + slack)` times its rest path length back onto that sphere.
pub fn apply_tethers(positions: &mut [Vec3], inverse_mass: &[f32], tethers: &Tethers, slack: f32) {
    for i in 0..positions.len() {
        if let (Some(anchor), true) = (tethers.anchor[i], inverse_mass[i] > 0.0) {
            let reach = tethers.length[i] * (1.0 + slack);
            positions[i] = pull_within(positions[i], positions[anchor as usize], reach);
        }
    }
}
