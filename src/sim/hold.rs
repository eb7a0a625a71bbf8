//! The hold phase: particles pulled toward targets by a hand with a
//! bounded grip (a grab in the viewer).
//!
//! A hard grab (fixing a particle and moving it) puts the whole cloth's
//! strain on the bars around it: the solver cannot move the held particle,
//! so however far the hand goes in a step, its bars must stretch that far.
//! A hold instead leaves the particle free, with the weight of a hand (50
//! times its own mass, so the bars move the cloth toward the hand more than
//! the hand toward the cloth), and, once per substep after integration,
//! moves it toward its target:
//!
//! ```text
//! Δ = target − x,      x ← x + Δ · min(1, a_max (h/n)² / |Δ|)
//! ```
//!
//! That is a force of at most m_i a_max (the hand's grip), applied as a
//! displacement that settling carries into the particle's velocity, as
//! every force is. The bars then share the pull by the weights: with the
//! inextensible projection on, the cloth follows the hand as far as its
//! pins let it, and the held particle lags behind the hand rather than
//! stretching the cloth. A fixed particle (a pin) cannot be held this way;
//! it is moved by hand ([`super::Simulation::move_particle`]).
//!
//! **The hand's reach.** Passes carry a pull one bar a pass, so a hand that
//! moves a bar's length a substep outruns them, however the pull is
//! bounded. So a hold also ties every particle to the held one, as tethers
//! tie a cloth to its pins (Kim, Chentanez & Müller 2012): after the
//! relaxation passes, a free particle j farther from the held particle h
//! than the rest path between them along the bars is put back at that
//! distance, toward h; and the pull itself keeps h within the same reach of
//! every pin, so the hand lifts the cloth it cannot stretch instead of
//! tearing it from its pins:
//!
//! ```text
//! pull:   x_h ← x_h + Δ (as above), then for every pin p, a few sweeps:
//!         |x_h − x_p| > L_hp  →  x_h ← x_p + (x_h − x_p) · L_hp / |x_h − x_p|
//! reach:  d = x_j − x_h,   |d| > L_hj  →  x_j ← x_h + d · L_hj / |d|
//! ```
//!
//! In the rest state every particle satisfies both (a straight line is never
//! longer than a path along bars). L_h· comes from Dijkstra's algorithm
//! when the hold starts ([`super::tether::Tethers::new`] from the held
//! particle). A 64 × 64 cloth's corner pulled at 10 m/s with 8 passes:
//! 169 % worst edge strain without the reach, 56 % with it (72 % and 44 %
//! with 2 coarse passes).

use glam::Vec3;

use super::tether::pull_within;

/// Sweeps over the pins that keep a held particle within their reach.
const PIN_SWEEPS: usize = 4;

/// A particle pulled toward a target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    /// The particle held, scene order.
    pub particle: usize,
    /// Where the hand is, metres.
    pub target: Vec3,
    /// a_max: the largest acceleration the grip gives the particle, m/s²
    /// (> 0, finite).
    pub max_acceleration: f32,
}

/// The phase's state: the holds and the buffers one substep works in.
#[derive(Clone, Debug, Default)]
pub struct Holds {
    /// The holds, at most one per particle.
    pub list: Vec<Hold>,
    /// The reach of the holds that have one: the held particle and L_hj,
    /// the rest path length along the bars from it to each particle j
    /// (metres; infinite where no path leads).
    reach: Vec<(usize, Vec<f32>)>,
    /// Positions after integration, scene order (the solver writes them).
    pub x: Vec<Vec3>,
    /// Positions at the start of the substep (read along with `x`, unused).
    pub x_prev: Vec<Vec3>,
    push: Vec<Vec3>,
}

impl Holds {
    /// No holds, with buffers for `particles` particles.
    pub fn new(particles: usize) -> Self {
        Self { x: vec![Vec3::ZERO; particles], x_prev: vec![Vec3::ZERO; particles], ..Self::default() }
    }

    /// Gives the hold of `particle` a reach (the rest path lengths from it
    /// to every particle), or takes it away (`None`).
    pub fn set_reach(&mut self, particle: usize, lengths: Option<Vec<f32>>) {
        self.reach.retain(|(p, _)| *p != particle);
        if let Some(lengths) = lengths {
            self.reach.push((particle, lengths));
        }
    }

    /// Whether any hold has a reach.
    pub fn has_reach(&self) -> bool {
        !self.reach.is_empty()
    }

    /// The hand's tethers (module docs) on [`Self::x`], each particle's
    /// move divided by its weight (what [`super::Solver::push`] multiplies
    /// back); zero for particles within reach and for weight 0.
    pub fn tether(&mut self, weights: &[f32]) -> &[Vec3] {
        self.push.clear();
        self.push.resize(self.x.len(), Vec3::ZERO);
        for (held, lengths) in &self.reach {
            let anchor = self.x[*held];
            for (j, ((x, push), (&reach, &w))) in
                self.x.iter_mut().zip(self.push.iter_mut()).zip(lengths.iter().zip(weights)).enumerate()
            {
                if j == *held || w <= 0.0 {
                    continue;
                }
                let delta = pull_within(*x, anchor, reach) - *x;
                *x += delta;
                *push += delta / w;
            }
        }
        &self.push
    }

    /// Each particle's move toward its target for a substep of `dt`
    /// seconds, divided by its weight (what [`super::Solver::push`]
    /// multiplies back); zero for particles not held or of weight 0.
    pub fn compute(&mut self, dt: f32, weights: &[f32]) -> &[Vec3] {
        self.push.clear();
        self.push.resize(self.x.len(), Vec3::ZERO);
        for hold in &self.list {
            let (i, w) = (hold.particle, weights[hold.particle]);
            if w <= 0.0 {
                continue;
            }
            let delta = hold.target - self.x[i];
            let cap = hold.max_acceleration * dt * dt;
            let length = delta.length();
            let delta = if length > cap { delta * (cap / length) } else { delta };
            let mut at = self.x[i] + delta;
            // With a reach, the hand cannot take the particle farther from a
            // pin than the cloth between them is long.
            if let Some((_, lengths)) = self.reach.iter().find(|(p, _)| *p == i) {
                let pins: Vec<(Vec3, f32)> =
                    (0..weights.len()).filter(|&p| weights[p] == 0.0).map(|p| (self.x[p], lengths[p])).collect();
                for _ in 0..PIN_SWEEPS {
                    for &(pin, reach) in &pins {
                        at = pull_within(at, pin, reach);
                    }
                }
            }
            self.push[i] = (at - self.x[i]) / w;
        }
        &self.push
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hold_moves_at_most_a_max_dt_squared_and_never_moves_a_pin() {
        let mut holds = Holds {
            list: vec![
                Hold { particle: 0, target: Vec3::new(10.0, 0.0, 0.0), max_acceleration: 100.0 },
                Hold { particle: 1, target: Vec3::new(1.0, 0.001, 0.0), max_acceleration: 100.0 },
                Hold { particle: 2, target: Vec3::ONE, max_acceleration: 100.0 },
            ],
            x: vec![Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::ZERO],
            ..Holds::default()
        };
        // dt = 0.01 s: the cap is 100 · 1e-4 = 0.01 m. Particle 0 is 10 m
        // away and moves 0.01 m (its weight 2 halves what push gets, push
        // doubles it back); particle 1 is 1 mm away and goes all the way;
        // particle 2 is fixed.
        let push = holds.compute(0.01, &[2.0, 1.0, 0.0]).to_vec();
        assert!((push[0] * 2.0 - Vec3::new(0.01, 0.0, 0.0)).length() < 1e-7, "{}", push[0]);
        assert!((push[1] - Vec3::new(0.0, 0.001, 0.0)).length() < 1e-7, "{}", push[1]);
        assert_eq!(push[2], Vec3::ZERO);
    }

    #[test]
    fn a_held_particle_keeps_a_hands_weight_through_other_changes() {
        use crate::sim::{Grid, Simulation, SolverParams};
        let mesh = Grid { columns: 3, rows: 3, ..Grid::default() }.build().unwrap();
        let mut sim = Simulation::new(mesh, SolverParams::default()).unwrap();
        let held = 8;
        sim.hold(held, Vec3::ZERO, 100.0).unwrap();
        // Equal masses: weight 1, held 0.02 (a hand of 50 particles).
        assert_eq!(sim.inverse_masses()[held], 0.02);
        // A new density changes every weight; the held one stays a hand's
        // share of its new own (it used to come back whole while held).
        let dense = SolverParams { density: Some(0.3), ..SolverParams::default() };
        sim.set_params(dense).unwrap();
        let own = {
            let mut free = sim.clone();
            free.release(held);
            free.inverse_masses()[held]
        };
        assert!((sim.inverse_masses()[held] - 0.02 * own).abs() < 1e-7, "{} vs {own}", sim.inverse_masses()[held]);
        // Pinned and freed again while held: a hand's weight again.
        sim.set_fixed(held, true).unwrap();
        assert_eq!(sim.inverse_masses()[held], 0.0);
        sim.set_fixed(held, false).unwrap();
        assert!((sim.inverse_masses()[held] - 0.02 * own).abs() < 1e-7);
        sim.release(held);
        assert_eq!(sim.inverse_masses()[held], own);
    }
}
