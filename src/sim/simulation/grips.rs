//! The user's hand on the cloth: pins, holds and drags. Each is a write
//! of a particle's weight or position into the solver's layout, never a
//! rebuild: a pin sets the inverse mass to 0, a hold makes the particle
//! [`HAND_WEIGHT`] times as light as its own (the hand's pull is the hold
//! phase's, [`crate::sim::hold`]), a drag moves it and keeps the move as
//! velocity.

use glam::Vec3;

use super::setup::Derived;
use super::{SimError, Simulation};
use crate::sim::hold::Hold;
use crate::sim::params::ParamError;
use crate::sim::tether::Tethers;

impl Simulation {
    /// Fixes or frees a particle: a write of its inverse mass (0 or 1), not
    /// a rebuild. With tethers on, the attachments are recomputed (they
    /// depend on which particles are fixed).
    ///
    /// A particle being fixed comes to rest (its previous position becomes
    /// its current one), so one freed later starts from rest rather than
    /// with the velocity it had when it was fixed; moving it while fixed
    /// ([`Self::move_particle`], a drag) gives it that move's velocity.
    pub fn set_fixed(&mut self, index: usize, fixed: bool) -> Result<(), SimError> {
        self.check_index(index)?;
        if self.fixed[index] != fixed {
            self.fixed[index] = fixed;
            let weight = if fixed { 0.0 } else { self.free_weight(&self.material, index) };
            self.inverse_mass[index] = weight;
            self.solver.set_inverse_mass(index, weight);
            if fixed {
                self.previous[index] = self.positions[index];
                self.solver.set_particle(index, self.positions[index], self.previous[index]);
            }
            if self.params.tether_slack.is_some() {
                self.refresh_tethers();
            }
        }
        Ok(())
    }

    /// Holds free particle `index` toward `target` with a grip of at most
    /// `max_acceleration` m/s² (see [`crate::sim::hold`]); holding it again
    /// moves the target. It stays free, so the bars (and the inextensible
    /// projection) share the pull instead of stretching to wherever the
    /// hand is; and it has the hand's reach: every particle is kept within
    /// its rest path length of it, and it within the pins' reach, so a fast
    /// pull does not outrun the passes. A fixed particle is not moved by a
    /// hold.
    pub fn hold(&mut self, index: usize, target: Vec3, max_acceleration: f32) -> Result<(), SimError> {
        self.hold_with(index, target, max_acceleration, true)
    }

    /// [`Self::hold`] with the hand's reach (`reach`) or without it: the
    /// bounded pull alone, which a fast hand outruns. The choice is made
    /// when the particle is first held. Starting a hold with a reach finds
    /// the rest path to every particle (Dijkstra's algorithm over the bars).
    pub fn hold_with(
        &mut self,
        index: usize,
        target: Vec3,
        max_acceleration: f32,
        reach: bool,
    ) -> Result<(), SimError> {
        self.check_index(index)?;
        if !target.is_finite() {
            return Err(SimError::Param(ParamError::new("hold target", target, "finite coordinates")));
        }
        if !(max_acceleration > 0.0 && max_acceleration.is_finite()) {
            return Err(SimError::Param(ParamError::new(
                "hold max_acceleration",
                max_acceleration,
                "m/s², finite and > 0",
            )));
        }
        let hold = Hold { particle: index, target, max_acceleration };
        match self.holds.list.iter_mut().find(|h| h.particle == index) {
            Some(h) => *h = hold,
            None => {
                self.holds.list.push(hold);
                if !self.fixed[index] {
                    let weight = self.free_weight(&self.material, index);
                    self.inverse_mass[index] = weight;
                    self.solver.set_inverse_mass(index, weight);
                }
                let lengths = reach.then(|| self.reach_from(index));
                self.holds.set_reach(index, lengths);
            }
        }
        Ok(())
    }

    /// The rest path length along the bars from particle `index` to every
    /// particle (metres, infinite where no path leads).
    fn reach_from(&self, index: usize) -> Vec<f32> {
        let mut from = vec![false; self.positions.len()];
        from[index] = true;
        let tethers = Tethers::new(self.positions.len(), self.mesh.bars(), &from);
        tethers.anchor.iter().zip(tethers.length).map(|(a, l)| if a.is_some() { l } else { f32::INFINITY }).collect()
    }

    /// Lets go of particle `index` if it is held; it keeps its velocity
    /// and its own weight.
    pub fn release(&mut self, index: usize) {
        let before = self.holds.list.len();
        self.holds.list.retain(|h| h.particle != index);
        self.holds.set_reach(index, None);
        if self.holds.list.len() < before && !self.fixed[index] {
            let weight = self.material.weight[index];
            self.inverse_mass[index] = weight;
            self.solver.set_inverse_mass(index, weight);
        }
    }

    /// The weight (inverse mass relative to m̄) of free particle `i` under
    /// `material`: its own, or a hand's while it is held.
    pub(super) fn free_weight(&self, material: &Derived, i: usize) -> f32 {
        let held = self.holds.list.iter().any(|h| h.particle == i);
        material.weight[i] * if held { HAND_WEIGHT } else { 1.0 }
    }

    /// The particles held now.
    pub fn holds(&self) -> &[Hold] {
        &self.holds.list
    }

    /// Puts a particle at `position` (as a mouse drag does). Its previous
    /// position becomes its current one, so a free particle keeps the motion
    /// of the move as velocity.
    pub fn move_particle(&mut self, index: usize, position: Vec3) -> Result<(), SimError> {
        self.check_index(index)?;
        if !position.is_finite() {
            return Err(SimError::Param(ParamError::new("position", position, "finite coordinates")));
        }
        let previous = self.positions[index];
        self.positions[index] = position;
        self.previous[index] = previous;
        self.solver.set_particle(index, position, previous);
        Ok(())
    }
}

/// A held particle's weight relative to its own: the hand is 50 times
/// heavier, so the bars and the projection move the cloth toward the hand
/// rather than the hand back toward the cloth ([`crate::sim::hold`]).
const HAND_WEIGHT: f32 = 0.02;
