//! The seed's solver written the plain way: the yardstick for every other.
//!
//! One step, exactly as the seed describes it:
//!
//! 1. visit the particles one by one; move every free particle by equation 1
//!    (or, on the very first step, by the Euler step of equation 2);
//! 2. `relaxations` times, visit every bar in creation order and move its
//!    ends so that it regains its rest length (Figure 3), Gauss–Seidel: each
//!    projection sees the positions the previous ones left.
//!
//! The state is an array of structures (`Vec<Vec3>`) and every loop is scalar.
//! Consecutive bars share particles, so each projection waits for the one
//! before it: this is the latency-bound loop that [`super::fast`] is measured
//! against, and the order every faster solver must agree with.

use glam::Vec3;

use super::mesh::Bar;
use super::relax::project_bar;

/// The seed-faithful solver's state, in scene order.
#[derive(Clone, Debug)]
pub struct ReferenceSolver {
    /// x_i: current positions, metres.
    pub positions: Vec<Vec3>,
    /// x_{i−1}: positions one step ago, metres.
    pub previous: Vec<Vec3>,
    /// 1/m for a free particle, 0 for a fixed one, 1/kg.
    pub inverse_mass: Vec<f32>,
    /// The bars that can move (none joins two fixed particles), in creation order.
    pub bars: Vec<Bar>,
}

impl ReferenceSolver {
    /// One step: integrate (equation 1, or equation 2 when `first_velocity`
    /// gives v₀), then relax `relaxations` times, or fewer once a pass finds
    /// every bar within `tolerance` (relative) before projecting it, when
    /// `tolerance > 0`. Returns the passes done.
    ///
    /// `displacement` is `h²/m · f` for the step's force (equations 3–5), the
    /// same for every particle.
    pub fn step(
        &mut self,
        dt: f32,
        damping: f32,
        displacement: Vec3,
        first_velocity: Option<&[Vec3]>,
        relaxations: u32,
        tolerance: f32,
    ) -> u32 {
        let keep = 1.0 - damping;
        for i in 0..self.positions.len() {
            if self.inverse_mass[i] == 0.0 {
                continue;
            }
            let x = self.positions[i];
            let next = match first_velocity {
                // Equation 2: x₁ = x₀ + h v₀.
                Some(v0) => x + dt * v0[i],
                // Equation 1: x_{i+1} = x_i + (1 − δ)(x_i − x_{i−1}) + h²/m f.
                None => x + keep * (x - self.previous[i]) + displacement,
            };
            self.previous[i] = x;
            self.positions[i] = next;
        }
        if tolerance <= 0.0 {
            for _ in 0..relaxations {
                self.relax_once();
            }
            return relaxations;
        }
        let mut passes = 0;
        for _ in 0..relaxations {
            passes += 1;
            if self.relax_once_measured() <= tolerance {
                break;
            }
        }
        passes
    }

    /// One relaxation pass over every bar, in creation order.
    pub fn relax_once(&mut self) {
        for bar in &self.bars {
            let (a, b) = (bar.a as usize, bar.b as usize);
            let (wa, wb) = (self.inverse_mass[a], self.inverse_mass[b]);
            let (da, db) = project_bar(self.positions[a], self.positions[b], bar.rest_length, wa, wb);
            self.positions[a] += da;
            self.positions[b] += db;
        }
    }

    /// [`Self::relax_once`], also returning the largest relative strain met
    /// before a projection (0 when there are no bars).
    pub fn relax_once_measured(&mut self) -> f32 {
        let mut worst = 0.0f32;
        for bar in &self.bars {
            let (a, b) = (bar.a as usize, bar.b as usize);
            let (wa, wb) = (self.inverse_mass[a], self.inverse_mass[b]);
            let (xa, xb) = (self.positions[a], self.positions[b]);
            worst = worst.max((xa.distance(xb) - bar.rest_length).abs() / bar.rest_length);
            let (da, db) = project_bar(xa, xb, bar.rest_length, wa, wb);
            self.positions[a] += da;
            self.positions[b] += db;
        }
        worst
    }
}
