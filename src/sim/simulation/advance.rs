//! The clock: [`Simulation::advance`] takes steps of h, each as
//! `substeps` substeps of h/n run through the phases in the order
//! [`run_substep`] gives them.
//!
//! Per step: the wind force f_w(t) is sampled once, at the step's start
//! (equations 3–5), and added to gravity, the seed's force f_g or m̄·g; the
//! displacement a substep adds is f·(h/n)²/m̄ (equation 1's last term). The
//! first substep of the first step starts from the mesh's velocities
//! (equation 2's Euler start, or its second-order form). A step that leaves
//! a non-finite position stops the simulation with [`SimError::Diverged`].

use glam::Vec3;

use super::{SimError, Simulation};
use crate::sim::aero::AeroStep;
use crate::sim::collider::{Collider, Motion, Pose};
use crate::sim::contact::ContactStep;
use crate::sim::hierarchy::CoarseStep;
use crate::sim::inextensible::ProjectionStep;
use crate::sim::params::{SolverParams, Start};
use crate::sim::self_contact::SelfContactStep;
use crate::sim::step::{Phases, Substep, run_substep};

impl Simulation {
    /// One step of h.
    pub fn step(&mut self) -> Result<(), SimError> {
        self.advance(1)
    }

    /// `n` steps of h. Stops with [`SimError::Diverged`] at the first step that
    /// leaves a non-finite position; the positions then stay those of the last
    /// call that succeeded.
    ///
    /// A large cloth's step runs many short loops on rayon's thread pool
    /// (two per relaxation pass on a grid of 16 384 particles or more).
    /// Called from a thread outside the pool, each loop would hand its work
    /// to the pool and put the caller to sleep until it is done; so when the
    /// solver's relaxation uses the pool ([`Solver::uses_pool`](crate::sim::step::Solver::uses_pool)), such a call
    /// hands the pool the whole call once, and the loops start on a worker
    /// at once (5–8 % off a 256 × 256 step on two threads, host D). A
    /// smaller cloth stays on the calling thread (moving its step to a
    /// worker cost a 100 × 100 grid 4–10 %). The result is the same either
    /// way.
    pub fn advance(&mut self, n: u64) -> Result<(), SimError> {
        if self.solver.uses_pool() && rayon::current_thread_index().is_none() {
            return rayon::scope(|_| self.advance_on_this_thread(n));
        }
        self.advance_on_this_thread(n)
    }

    /// [`Self::advance`] on the calling thread.
    fn advance_on_this_thread(&mut self, n: u64) -> Result<(), SimError> {
        if let Some(e) = &self.diverged {
            return Err(e.clone());
        }
        let p = self.params.clone();
        let dt = p.substep_dt();
        let mass = self.material.mean;
        let beta = |alpha: f32| alpha * mass / (dt * dt);
        // Gravity is a force (the seed's) or an acceleration (g).
        let (gravity_force, gravity) = match p.gravity_acceleration {
            Some(g) => (Vec3::ZERO, g * (dt * dt)),
            None => (p.gravity, Vec3::ZERO),
        };
        for _ in 0..n {
            // The wind is sampled once per step, at its start.
            let mut force = gravity_force;
            if !p.wind.is_none() {
                force += p.wind.force(self.time);
            }
            let accel = force * (dt * dt / mass);
            let mut substep = Substep {
                dt,
                keep: 1.0 - p.substep_damping(),
                accel,
                gravity,
                first: None,
                relaxations: p.relaxations,
                tolerance: p.tolerance,
                over_relaxation: p.over_relaxation,
                stretch_beta: beta(self.material.stretch_compliance),
                bend_beta: beta(self.material.bend_compliance),
                shear_beta: beta(self.material.shear_compliance),
                tether_slack: p.tether_slack,
            };
            for k in 0..p.substeps {
                substep.first = (self.steps == 0 && k == 0).then(|| {
                    let extra = match p.start {
                        Start::Euler => Vec3::ZERO,
                        // Exact for equal masses; with a density and g, a
                        // particle of weight w gets ½h²g·w (w ≠ 1 only at edges).
                        Start::SecondOrder => 0.5 * (accel + gravity),
                    };
                    (self.mesh.velocities(), extra)
                });
                let contact = (!self.colliders.is_empty())
                    .then(|| contact_step(&self.colliders, &self.dragged, &p, self.time, k));
                let self_step = SelfContactStep { thickness: p.thickness, friction: p.friction, parallel: true };
                let air_step = p.wind.air().map(|&air| AeroStep {
                    air,
                    time: self.time + f64::from(dt) * f64::from(k),
                    dt,
                    displacement_per_newton: dt * dt / mass,
                    parallel: true,
                });
                let project_step = ProjectionStep {
                    weights: &self.inverse_mass,
                    beta: substep.stretch_beta,
                    iterations: p.newton_iterations,
                    tolerance: p.newton_tolerance,
                    smoothing: p.newton_smoothing,
                };
                let coarse_step = CoarseStep { weights: &self.inverse_mass, passes: p.coarse_passes, parallel: true };
                let holding = !self.holds.list.is_empty();
                let phases = Phases {
                    air: self.aero.as_mut().zip(air_step.as_ref()),
                    hold: holding.then_some((&mut self.holds, &self.inverse_mass[..])),
                    coarse: self.hierarchy.as_mut().map(|phase| (phase, &coarse_step)),
                    project: self.projection.as_mut().map(|phase| (phase, &project_step)),
                    self_contact: self.self_contact.as_mut().map(|phase| (phase, &self_step)),
                    contact: contact.as_ref(),
                };
                self.last_passes = run_substep(self.solver.as_mut(), &substep, phases);
            }
            self.steps += 1;
            self.time += f64::from(p.dt);
            self.finish_drags();
            if let Some(particle) = self.solver.first_non_finite() {
                let e = SimError::Diverged { step: self.steps, particle };
                self.diverged = Some(e.clone());
                return Err(e);
            }
        }
        self.solver.read(&mut self.positions, &mut self.previous);
        Ok(())
    }

    /// Colliders moved by hand stay where they were put.
    fn finish_drags(&mut self) {
        for (index, _, to) in self.dragged.drain(..) {
            let c = &mut self.colliders[index];
            c.pose = to;
            c.motion = Motion::Fixed;
        }
    }
}

/// The colliders placed for substep `k` of the step that starts at `time`;
/// a collider moved by hand goes from where it was to where it was put.
fn contact_step<'a>(
    colliders: &'a [Collider],
    dragged: &[(usize, Pose, Pose)],
    p: &SolverParams,
    time: f64,
    k: u32,
) -> ContactStep<'a> {
    let n = p.substeps as f32;
    let (s0, s1) = (k as f32 / n, (k + 1) as f32 / n);
    let h = f64::from(p.dt);
    let (t0, t1) = (time + h * f64::from(s0), time + h * f64::from(s1));
    let placed = colliders.iter().enumerate().map(move |(i, c)| match dragged.iter().find(|d| d.0 == i) {
        Some(&(_, from, to)) => (c, from.lerp(&to, s0), from.lerp(&to, s1)),
        None => (c, c.pose_at(t0), c.pose_at(t1)),
    });
    ContactStep::with_poses(placed, p.thickness, p.friction)
}
