//! One substep as a sequence of named phases, and the [`Solver`] trait that
//! says how each phase runs on a solver's layout.
//!
//! This module imports neither solver: [`super::simulation`] drives any
//! [`Solver`] through [`run_substep`], which is the only place that says in
//! which order the phases run (after NvCloth's `iterateCloth`):
//!
//! ```text
//! 0. air         (with the "air" wind) drag and lift on every triangle from
//!                the air's velocity relative to last substep's motion
//!                ([`super::aero`]): a displacement Δ_i per particle
//! 1. integrate   forces, then equation 1 (or the Euler start, equation 2)
//!                for every particle of non-zero inverse mass:
//!                d ← (1 − δ) d + w h² f/m + h² g,  x ← x + d + w Δ
//!                (x_pred = x + d: the air's push is a force settled into d)
//!    hold        (while a particle is held) each held particle moved
//!                toward its target, at most a_max (h/n)², and kept within
//!                the pins' reach ([`super::hold`])
//! 2. relax       tethers, then `relaxations` Gauss–Seidel passes over the
//!                bars (the seed's Figure 3, XPBD when compliant)
//!    coarse      (grids, when on) the stretch the passes left taken out
//!                on the grid coarsened 2, 4, 8, … times, coarsest first,
//!                and interpolated down as a push ([`super::hierarchy`])
//!    reach       (while a particle is held) every free particle kept within
//!                its rest path length of the held one ([`super::hold`])
//!    project     (when inextensible) Newton iterations that put every
//!                edge back to its rest length at once
//!                ([`super::inextensible`]), each followed by
//!                Gauss–Seidel passes over the edges alone
//! 3. self-collide (when on) particles of the cloth kept a thickness apart
//!                from each other ([`super::self_contact`])
//! 4. collide     every particle near a collider is pushed out to the
//!                thickness along the path it took this substep, and
//!                Coulomb friction removes (part of) its motion along the
//!                surface relative to the collider ([`super::contact`])
//! 5. settle      bookkeeping: d ← d + (x − x_pred), the substep's motion
//! ```
//!
//! A phase that a scene does not need is skipped here, not inside the
//! solvers: no colliders, no collide phase; self-collision off, no
//! self-collide phase; no "air" wind, no air phase (no triangle loop).
//! Friction is not a pass of its own: Coulomb's bound
//! needs each contact's push and normal, so it is applied where the contact
//! is resolved, particle by particle (as NvCloth does).
//!
//! **Weights.** Every particle carries an inverse mass `w`, relative to the
//! scene's particle mass m (`w = m / m_i`): 1 for a free particle of a
//! uniform cloth, 0 for a fixed one. Pinning, unpinning or grabbing a
//! particle is a write of its weight ([`Solver::set_inverse_mass`]); nothing
//! is rebuilt. A bar projection moves its ends in proportion to their
//! weights, and the force moves a particle by `w · h² f/m`.

use std::fmt::Debug;

use glam::Vec3;

use super::aero::{AeroStep, Aerodynamics, PointLanes};
use super::contact::ContactStep;
use super::hierarchy::{CoarseStep, Hierarchy};
use super::hold::Holds;
use super::inextensible::{FastProjection, ProjectionStep};
use super::self_contact::{SelfContact, SelfContactStep};
use super::tether::Tethers;

/// Everything one substep of h/n needs, derived from the parameters by
/// [`super::Simulation`]; the solvers take it as it is.
#[derive(Clone, Copy, Debug)]
pub struct Substep<'a> {
    /// h/n, seconds.
    pub dt: f32,
    /// 1 − δ_n, the share of last substep's motion that is kept.
    pub keep: f32,
    /// (h/n)² f / m: what the force adds to the displacement of a particle
    /// of weight 1 (a particle of weight w gets w times it).
    pub accel: Vec3,
    /// (h/n)² g: what an acceleration (gravity given as `g`) adds to the
    /// displacement of every particle of non-zero weight, whatever its mass.
    pub gravity: Vec3,
    /// For the very first substep: v₀ and the displacement added to h v₀
    /// (zero for the seed's Euler start, ½ (h/n)² f/m for the second-order one).
    pub first: Option<(&'a [Vec3], Vec3)>,
    /// Passes over the bars.
    pub relaxations: u32,
    /// Relative strain that ends the passes early (0: off).
    pub tolerance: f32,
    /// ω, the over-relaxation of each projection.
    pub over_relaxation: f32,
    /// α m / (h/n)² for structural bars (0: rigid), dimensionless.
    pub stretch_beta: f32,
    /// α m / (h/n)² for bend bars.
    pub bend_beta: f32,
    /// α m / (h/n)² for shear bars (a grid's diagonals).
    pub shear_beta: f32,
    /// The tether slack when tethers are on.
    pub tether_slack: Option<f32>,
}

impl Substep<'_> {
    /// β of each bar kind, by [`crate::sim::BarKind::index`].
    pub fn betas(&self) -> [f32; crate::sim::BarKind::COUNT] {
        [self.stretch_beta, self.bend_beta, self.shear_beta]
    }

    /// Whether any bar is compliant (then the passes keep λ).
    pub fn compliant(&self) -> bool {
        self.betas().iter().any(|&b| b > 0.0)
    }
}

/// A solver: the state of the cloth in some layout, and how each phase of
/// [`run_substep`] runs on it.
pub trait Solver: Debug + Send + Sync {
    /// Phase 1: forces and integration (equation 1, or equation 2 on the
    /// first substep). Keeps x_pred for [`Solver::settle`].
    fn integrate(&mut self, s: &Substep);
    /// After phase 1, with the air: x_i ← x_i + w_i Δ_i for every particle
    /// of non-zero weight (`displacement` in scene order), a force's
    /// displacement that [`Solver::settle`] carries into the velocity.
    fn push(&mut self, displacement: &[Vec3]);
    /// Phase 2: tethers, then the relaxation passes. Returns the passes made.
    fn relax(&mut self, s: &Substep) -> u32;
    /// Phase 3: contact and friction with the colliders, for every particle
    /// of non-zero weight, on the path from where it started the substep to
    /// where it is now.
    fn collide(&mut self, contact: &ContactStep);
    /// Phase 3 (when on): the cloth against itself, through `phase`'s hash
    /// grid, on the positions and the substep-start positions in scene order.
    fn self_collide(&mut self, phase: &mut SelfContact, step: &SelfContactStep);
    /// Phase 4: the substep's displacement, d ← d + (x − x_pred).
    fn settle(&mut self);

    /// Current and previous positions, scene order.
    fn read(&self, positions: &mut [Vec3], previous: &mut [Vec3]);
    /// [`Solver::read`] as `[x, y, z, 0]` rows (the same bits), the form the
    /// lane kernels load one row at a time. The default goes through
    /// [`Solver::read`] and two buffers of its own (the reference solver
    /// uses it); the fast layouts write the rows directly.
    fn read_rows(&self, positions: &mut [[f32; 4]], previous: &mut [[f32; 4]]) {
        let (mut x, mut x_prev) = (vec![Vec3::ZERO; positions.len()], vec![Vec3::ZERO; previous.len()]);
        self.read(&mut x, &mut x_prev);
        for (row, p) in positions.iter_mut().zip(&x).chain(previous.iter_mut().zip(&x_prev)) {
            *row = p.extend(0.0).to_array();
        }
    }
    /// The layout's SIMD lanes, when the air phase can read and write them
    /// as they are ([`Lanes`]); `None` (the default): the phase reads rows
    /// in scene order.
    fn lanes(&self) -> Option<&dyn Lanes> {
        None
    }
    /// [`Solver::lanes`], to write.
    fn lanes_mut(&mut self) -> Option<&mut dyn Lanes> {
        None
    }
    /// Sets one particle's position and previous position.
    fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3);
    /// Sets one particle's inverse mass (relative to m; 0 fixes it). A write,
    /// not a rebuild.
    fn set_inverse_mass(&mut self, index: usize, weight: f32);
    /// Replaces the tethers (after the set of fixed particles changed), or
    /// removes them.
    fn set_tethers(&mut self, tethers: Option<Tethers>);
    /// The first particle (scene order) with a non-finite coordinate.
    fn first_non_finite(&self) -> Option<usize>;
    /// How the solver works, in a few words (layout, SIMD, threads).
    fn describe(&self) -> String;
    /// Whether its relaxation runs loops on rayon's thread pool (a large
    /// cloth's layout on more than one thread): then a step is best run
    /// on the pool as a whole ([`Simulation::advance`](super::Simulation::advance)).
    fn uses_pool(&self) -> bool {
        false
    }
    /// A copy behind a new box (solvers are cloned with their simulation).
    fn boxed_clone(&self) -> Box<dyn Solver>;
}

/// A layout's SIMD lanes as the air phase reads them where they are:
/// eight places an element (a slot of eight lanes), the elements in tiles
/// (runs of consecutive elements, each a task of the thread pool), each
/// particle at one place.
pub trait Lanes {
    /// Where each particle is.
    fn places(&self) -> LanePlaces;
    /// Each tile's positions x and displacements d = x − x_prev, element
    /// by element, tile after tile.
    fn tiles(&self) -> Vec<(&[PointLanes], &[PointLanes])>;
    /// x ← x + w Δ at every place of weight w > 0 (the bits of
    /// [`Solver::push`]), Δ of element e from `displacement(e)`, tiles on
    /// the thread pool where the layout uses it.
    fn push_lanes(&mut self, displacement: &(dyn Fn(usize) -> PointLanes + Sync));
}

/// Where a solver keeps each particle in its lanes ([`Lanes::places`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LanePlaces {
    /// Place of scene particle i: element `place[i] / 8`, lane
    /// `place[i] % 8`.
    pub place: Vec<u32>,
    /// Elements in each tile ([`Lanes::tiles`]), tile after tile.
    pub tiles: Vec<usize>,
}

impl Clone for Box<dyn Solver> {
    fn clone(&self) -> Self {
        self.boxed_clone()
    }
}

/// The optional phases of one substep, each with what it needs; `None`
/// skips a phase.
#[derive(Default)]
pub struct Phases<'a, 'b> {
    /// The air phase, with the wind model "air".
    pub air: Option<(&'a mut Aerodynamics, &'a AeroStep)>,
    /// The hold phase, while particles are held, with every particle's
    /// weight.
    pub hold: Option<(&'a mut Holds, &'a [f32])>,
    /// The coarse phase, on a grid with coarse passes.
    pub coarse: Option<(&'a mut Hierarchy, &'a CoarseStep<'b>)>,
    /// The project phase, when the cloth is inextensible.
    pub project: Option<(&'a mut FastProjection, &'a ProjectionStep<'b>)>,
    /// The self-collide phase, when self-collision is on.
    pub self_contact: Option<(&'a mut SelfContact, &'a SelfContactStep)>,
    /// The collide phase, when there are colliders.
    pub contact: Option<&'a ContactStep<'b>>,
}

/// Runs one substep: the phases in their order, skipping what the scene
/// does not need. Returns the relaxation passes made.
pub fn run_substep(solver: &mut dyn Solver, s: &Substep, phases: Phases) -> u32 {
    let Phases { air, hold, coarse, project, self_contact, contact } = phases;
    // The Euler start (equation 2) ignores every force, the air's too.
    let air = air.filter(|_| s.first.is_none()).map(|(phase, step)| {
        phase.compute(solver, step);
        phase
    });
    solver.integrate(s);
    if let Some(phase) = air {
        phase.push(solver);
    }
    let mut hold = hold;
    if let Some((holds, weights)) = hold.as_mut() {
        solver.read(&mut holds.x, &mut holds.x_prev);
        solver.push(holds.compute(s.dt, weights));
    }
    let passes = solver.relax(s);
    if let Some((phase, step)) = coarse {
        solver.read(&mut phase.x, &mut phase.x_prev);
        solver.push(phase.compute(step));
    }
    if let Some((holds, weights)) = hold.filter(|(holds, _)| holds.has_reach()) {
        solver.read(&mut holds.x, &mut holds.x_prev);
        solver.push(holds.tether(weights));
    }
    if let Some((phase, step)) = project {
        solver.read(&mut phase.x, &mut phase.x_prev);
        solver.push(phase.compute(step));
    }
    if let Some((phase, step)) = self_contact {
        solver.self_collide(phase, step);
    }
    if let Some(contact) = contact {
        solver.collide(contact);
    }
    solver.settle();
    passes
}
