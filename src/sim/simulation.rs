//! [`Simulation`]: a mesh, its parameters, a solver and the clock.

use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::aero::{AeroStep, Aerodynamics};
use super::collider::{Collider, Motion, Pose};
use super::contact::ContactStep;
use super::fast;
use super::hierarchy::{CoarseStep, Hierarchy};
use super::hold::{Hold, Holds};
use super::inextensible::{FastProjection, ProjectionError, ProjectionReport, ProjectionStep};
use super::mesh::{Bar, ClothMesh};
use super::metrics::{self, Strain};
use super::params::{ParamError, SolverParams, Start};
use super::reference::ReferenceSolver;
use super::self_contact::{SelfContact, SelfContactStep};
use super::step::{Phases, Solver, Substep, run_substep};
use super::tether::Tethers;
use super::units;

/// Which solver advances the cloth. Both implement the same equations; they
/// differ in order of work and speed (see [`super::reference`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// The same equations ordered for speed: coloured, SIMD lanes, threads for
    /// large grids ([`super::fast`]).
    #[default]
    Fast,
    /// The seed's loops as written: scalar, bars in creation order
    /// ([`super::reference`]).
    Reference,
}

impl SolverKind {
    /// Every solver, for menus and benchmarks.
    pub const ALL: [SolverKind; 2] = [SolverKind::Fast, SolverKind::Reference];

    /// A short name, as accepted by the CLI and scene files.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Fast => "fast",
            SolverKind::Reference => "reference",
        }
    }
}

/// What went wrong while simulating.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A parameter outside its range.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// Positions stopped being finite numbers.
    #[error(
        "the simulation blew up at step {step}: particle {particle} reached a non-finite position \
         (try a smaller dt, weaker forces, more damping or more relaxations)"
    )]
    Diverged {
        /// The step (counting from 1) after which a position was not finite.
        step: u64,
        /// The first particle found with a non-finite coordinate.
        particle: usize,
    },
    /// The inextensible projection could not be set up for this mesh.
    #[error(transparent)]
    Projection(#[from] ProjectionError),
    /// Coarse passes asked of a mesh that is not a grid.
    #[error(
        "coarse_passes = {passes} needs a grid mesh ([grid]): the coarse levels are the grid's rows and \
         columns taken 2, 4, 8, … apart; for OBJ and adjacency meshes use inextensible = true or tethers"
    )]
    CoarseNeedsGrid {
        /// The passes asked for.
        passes: u32,
    },
    /// A particle index outside the mesh.
    #[error("particle {index} does not exist: the mesh has {count} particles")]
    NoSuchParticle {
        /// The index given.
        index: usize,
        /// The number of particles.
        count: usize,
    },
}

/// A cloth being simulated: the mesh, the parameters, the solver's state and
/// the simulated clock.
///
/// ```
/// use drape::sim::{Grid, Simulation, SolverParams};
/// let mesh = Grid::default().build().unwrap(); // the seed's 20 × 30 cloth
/// let mut sim = Simulation::new(mesh, SolverParams::default()).unwrap();
/// sim.advance(100).unwrap();
/// // 100 steps of h = 0.05 s (h is an f32, so 0.05 is 0.050000000745...)
/// assert!((sim.time() - 5.0).abs() < 1e-6);
/// assert!(sim.strain().max < 0.5);
/// ```
#[derive(Clone, Debug)]
pub struct Simulation {
    mesh: Arc<ClothMesh>,
    /// The mesh's edges ([`ClothMesh::is_edge`]), for [`Self::edge_strain`].
    edges: Arc<[Bar]>,
    params: SolverParams,
    kind: SolverKind,
    /// Masses and compliances derived from the parameters and the mesh.
    material: Derived,
    /// Which particles are fixed now (inverse mass 0).
    fixed: Vec<bool>,
    /// Each particle's inverse mass relative to m̄ (0: fixed).
    inverse_mass: Vec<f32>,
    /// The air phase's state, with the wind model "air".
    aero: Option<Aerodynamics>,
    colliders: Vec<Collider>,
    /// A collider moved by hand since the last step: (index, from, to).
    dragged: Vec<(usize, Pose, Pose)>,
    /// The self-collide phase's hash grid, while self-collision is on.
    self_contact: Option<SelfContact>,
    /// The coarse phase, while coarse passes are asked for (grids only).
    hierarchy: Option<Hierarchy>,
    /// The project phase, while the cloth is inextensible.
    projection: Option<FastProjection>,
    /// Particles held toward targets (a grab).
    holds: Holds,
    solver: Box<dyn Solver>,
    positions: Vec<Vec3>,
    previous: Vec<Vec3>,
    steps: u64,
    time: f64,
    diverged: Option<SimError>,
    last_passes: u32,
}

impl Simulation {
    /// A simulation of `mesh` at its initial state, with the default solver.
    pub fn new(mesh: impl Into<Arc<ClothMesh>>, params: SolverParams) -> Result<Self, SimError> {
        Self::with_solver(mesh, params, SolverKind::default())
    }

    /// A simulation of `mesh` at its initial state, with the given solver.
    pub fn with_solver(
        mesh: impl Into<Arc<ClothMesh>>,
        params: SolverParams,
        kind: SolverKind,
    ) -> Result<Self, SimError> {
        Self::build(mesh.into(), params, kind, &mut None)
    }

    /// [`Self::with_solver`], on `reused` when it holds one: a solver of
    /// `kind` built for this mesh, its particles, weights and tethers
    /// written back to the mesh's initial state (every one a write, as a pin
    /// is) instead of a new layout built. The layout is what a large mesh's
    /// setup costs (colouring, ordering); it depends on the mesh alone.
    /// The air phase given beside it is kept too when the air blows: its
    /// triangles, masses and places depend on the mesh, the parameters and
    /// the layout, all unchanged, and each substep computes its forces anew
    /// before they are pushed (on the 256 × 256 cloth it is 6 ms of setup).
    /// `reused` is taken only after every check that can fail.
    fn build(
        mesh: Arc<ClothMesh>,
        params: SolverParams,
        kind: SolverKind,
        reused: &mut Option<(Box<dyn Solver>, Option<Aerodynamics>)>,
    ) -> Result<Self, SimError> {
        params.validate()?;
        units::check_surface(&params, &mesh)?;
        let material = Derived::new(&mesh, &params)?;
        let projection = if params.inextensible { Some(FastProjection::new(&mesh)?) } else { None };
        let hierarchy = hierarchy(&mesh, &params)?;
        // Nothing below fails: `reused` is taken only now.
        let fixed = mesh.fixed().to_vec();
        let inverse_mass: Vec<f32> =
            fixed.iter().zip(&material.weight).map(|(&f, &w)| if f { 0.0 } else { w }).collect();
        let positions = mesh.positions().to_vec();
        let previous = positions.clone();
        let tethers = params.tether_slack.map(|_| Tethers::new(positions.len(), mesh.bars(), &fixed));
        let (solver, aero) = match reused.take() {
            Some((mut solver, aero)) => {
                for (i, (&w, &x)) in inverse_mass.iter().zip(&positions).enumerate() {
                    solver.set_inverse_mass(i, w);
                    solver.set_particle(i, x, x);
                }
                solver.set_tethers(tethers);
                (solver, aero)
            }
            None => (build_solver(kind, &mesh, (&positions, &previous), &inverse_mass, tethers), None),
        };
        // A kept phase exists only where the air blows (the reset's own
        // parameters made it).
        let aero = aero.or_else(|| aerodynamics(&mesh, &params, &material, solver.as_ref()));
        let self_contact = params.self_collision.then(|| SelfContact::new(mesh.positions()));
        let edges = mesh.bars().iter().filter(|b| mesh.is_edge(b)).copied().collect();
        Ok(Self {
            mesh,
            edges,
            params,
            kind,
            material,
            fixed,
            inverse_mass,
            aero,
            colliders: Vec::new(),
            dragged: Vec::new(),
            self_contact,
            hierarchy,
            projection,
            holds: Holds::new(positions.len()),
            solver,
            positions,
            previous,
            steps: 0,
            time: 0.0,
            diverged: None,
            last_passes: 0,
        })
    }

    /// The same simulation with these colliders (see [`Self::set_colliders`]).
    pub fn with_colliders(mut self, colliders: Vec<Collider>) -> Self {
        self.colliders = colliders;
        self
    }

    /// Back to the mesh's initial state and time 0, keeping parameters,
    /// solver and colliders (as they are now: see [`Self::set_colliders`]).
    /// The solver's layout is kept and its particles written back, so a
    /// reset costs writes, not a new layout (disc-183, 101 017 particles:
    /// see *Reset* in docs/performance.md); the steps after it give the
    /// bits a new simulation's would.
    pub fn reset(&mut self) {
        // The solver moves into the new state; an empty one holds its place.
        let empty = Box::new(ReferenceSolver::new(&[], &[], &[], &[], None));
        let solver = std::mem::replace(&mut self.solver, empty as Box<dyn Solver>);
        let mut reused = Some((solver, self.aero.take()));
        match Self::build(self.mesh.clone(), self.params.clone(), self.kind, &mut reused) {
            Ok(fresh) => {
                let colliders = std::mem::take(&mut self.colliders);
                *self = fresh.with_colliders(colliders);
            }
            // Parameters were validated when set, so this cannot fail; were
            // it to (before `reused` is taken), the simulation stays as it
            // was, and the log says why.
            Err(err) => {
                log::error!("reset failed, the simulation is left as it was: {err}");
                if let Some((solver, aero)) = reused.take() {
                    self.solver = solver;
                    self.aero = aero;
                }
            }
        }
    }

    /// The mesh being simulated.
    pub fn mesh(&self) -> &Arc<ClothMesh> {
        &self.mesh
    }
    /// The current parameters.
    pub fn params(&self) -> &SolverParams {
        &self.params
    }
    /// Changes the parameters; they apply from the next step on. A new
    /// density rewrites every free particle's weight (no rebuild).
    pub fn set_params(&mut self, params: SolverParams) -> Result<(), SimError> {
        params.validate()?;
        units::check_surface(&params, &self.mesh)?;
        let material = Derived::new(&self.mesh, &params)?;
        let coarse_toggled = (params.coarse_passes > 0) != self.hierarchy.is_some();
        let coarse = if coarse_toggled { hierarchy(&self.mesh, &params)? } else { None };
        let aero = if params.wind.air().is_some() == self.aero.is_some() && material.mass == self.material.mass {
            self.aero.take()
        } else {
            aerodynamics(&self.mesh, &params, &material, self.solver.as_ref())
        };
        self.aero = aero;
        if material.weight != self.material.weight {
            for i in 0..material.weight.len() {
                if !self.fixed[i] {
                    let w = self.free_weight(&material, i);
                    self.inverse_mass[i] = w;
                    self.solver.set_inverse_mass(i, w);
                }
            }
        }
        if params.inextensible != self.projection.is_some() {
            self.projection = if params.inextensible { Some(FastProjection::new(&self.mesh)?) } else { None };
        }
        if coarse_toggled {
            self.hierarchy = coarse;
        }
        self.material = material;
        let tethers_toggled = params.tether_slack.is_some() != self.params.tether_slack.is_some();
        if params.self_collision != self.self_contact.is_some() {
            self.self_contact = params.self_collision.then(|| SelfContact::new(self.mesh.positions()));
        }
        self.params = params;
        if tethers_toggled {
            self.refresh_tethers();
        }
        Ok(())
    }
    /// The solver in use.
    pub fn solver(&self) -> SolverKind {
        self.kind
    }
    /// Switches solver, carrying the current state over.
    pub fn set_solver(&mut self, kind: SolverKind) {
        if kind != self.kind {
            self.kind = kind;
            self.rebuild_solver();
        }
    }
    /// Steps taken since the start.
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// Simulated time since the start, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Current positions x_i, scene order, metres.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }
    /// Positions one step ago x_{i−1}, scene order, metres.
    pub fn previous_positions(&self) -> &[Vec3] {
        &self.previous
    }
    /// Which particles are fixed now.
    pub fn fixed(&self) -> &[bool] {
        &self.fixed
    }
    /// Each particle's inverse mass relative to m̄ ([`Self::mean_mass`]):
    /// m̄/m_i when free (1 for a cloth of equal masses), 0 fixed.
    pub fn inverse_masses(&self) -> &[f32] {
        &self.inverse_mass
    }
    /// Every particle's mass m_i, kg: `mass` each, or σ times its area.
    pub fn masses(&self) -> &[f32] {
        &self.material.mass
    }
    /// m̄: the mean particle mass, kg (the m of equation 1).
    pub fn mean_mass(&self) -> f32 {
        self.material.mean
    }
    /// The compliances in use, m/N, structural and bend: the parameters'
    /// own, or those derived from `stretch_stiffness` and `bend_stiffness`.
    pub fn compliances(&self) -> (f32, f32) {
        (self.material.stretch_compliance, self.material.bend_compliance)
    }
    /// Every bar of the mesh (the solvers visit each; one between two fixed
    /// particles moves nothing).
    pub fn bars(&self) -> &[Bar] {
        self.mesh.bars()
    }
    /// How many bars can move now: those with at least one free end.
    pub fn movable_bar_count(&self) -> usize {
        self.mesh.bars().iter().filter(|b| !(self.fixed[b.a as usize] && self.fixed[b.b as usize])).count()
    }
    /// Bar projections one step performs: bars × relaxations × substeps.
    pub fn projections_per_step(&self) -> u64 {
        self.mesh.bars().len() as u64 * u64::from(self.params.relaxations) * u64::from(self.params.substeps)
    }
    /// The colliders.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }
    /// Replaces the colliders; they act from the next step on.
    pub fn set_colliders(&mut self, colliders: Vec<Collider>) {
        self.colliders = colliders;
        self.dragged.clear();
    }
    /// Where every collider is now (a collider moved by hand is where it was
    /// put).
    pub fn collider_poses(&self) -> Vec<Pose> {
        (0..self.colliders.len()).map(|k| self.collider_pose(k)).collect()
    }
    fn collider_pose(&self, k: usize) -> Pose {
        match self.dragged.iter().find(|d| d.0 == k) {
            Some(&(_, _, to)) => to,
            None => self.colliders[k].pose_at(self.time),
        }
    }
    /// Moves collider `index` by hand to `pose`. Over the next step it
    /// travels there from where it is (so friction and contact see the
    /// motion), then stays (its own motion, if any, ends).
    pub fn move_collider(&mut self, index: usize, pose: Pose) -> Result<(), SimError> {
        if index >= self.colliders.len() {
            return Err(SimError::Param(ParamError::new("collider", index, "the index of an existing collider")));
        }
        if !(pose.translation.is_finite() && pose.rotation.is_finite()) {
            return Err(SimError::Param(ParamError::new("collider pose", pose.translation, "finite coordinates")));
        }
        match self.dragged.iter_mut().find(|d| d.0 == index) {
            Some(d) => d.2 = pose,
            None => {
                let from = self.collider_pose(index);
                self.dragged.push((index, from, pose));
            }
        }
        Ok(())
    }
    /// Relaxation passes the last substep made: `relaxations`, or fewer when
    /// the tolerance ended it early.
    pub fn last_passes(&self) -> u32 {
        self.last_passes
    }
    /// How the solver in use works, in a few words (layout, SIMD, threads).
    pub fn solver_description(&self) -> String {
        self.solver.describe()
    }
    /// The error that stopped the simulation, if it blew up.
    pub fn diverged(&self) -> Option<&SimError> {
        self.diverged.as_ref()
    }

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
    /// solver's relaxation uses the pool ([`Solver::uses_pool`]), such a call
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
    /// `max_acceleration` m/s² (see [`super::hold`]); holding it again
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
    fn free_weight(&self, material: &Derived, i: usize) -> f32 {
        let held = self.holds.list.iter().any(|h| h.particle == i);
        material.weight[i] * if held { HAND_WEIGHT } else { 1.0 }
    }

    /// The particles held now.
    pub fn holds(&self) -> &[Hold] {
        &self.holds.list
    }

    /// The grid's coarse levels the coarse phase works on (0 while
    /// `coarse_passes` is 0).
    pub fn coarse_levels(&self) -> usize {
        self.hierarchy.as_ref().map_or(0, Hierarchy::level_count)
    }

    /// Searches for self-collision pairs and self-collide substeps so far,
    /// `(searches, substeps)`: fewer searches than substeps where the pair
    /// list was kept (`None` while self-collision is off).
    pub fn self_collision_searches(&self) -> Option<(u64, u64)> {
        self.self_contact.as_ref().map(SelfContact::searches)
    }

    /// What the inextensible projection did in the last substep (`None`
    /// while the cloth is not inextensible).
    pub fn last_projection(&self) -> Option<ProjectionReport> {
        self.projection.as_ref().map(FastProjection::last_report)
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

    /// Replaces the state: current positions x_i and previous positions
    /// x_{i−1} (equal arrays mean every particle is at rest). Counts as a
    /// started simulation: the next step uses equation 1, not the Euler start.
    pub fn set_state(&mut self, positions: &[Vec3], previous: &[Vec3]) -> Result<(), SimError> {
        let n = self.positions.len();
        for (what, list) in [("positions", positions), ("previous positions", previous)] {
            if list.len() != n {
                return Err(SimError::Param(ParamError::new(what, list.len(), "one entry per particle")));
            }
            if let Some(p) = list.iter().find(|p| !p.is_finite()) {
                return Err(SimError::Param(ParamError::new(what, p, "finite coordinates")));
            }
        }
        self.positions.copy_from_slice(positions);
        self.previous.copy_from_slice(previous);
        self.steps = self.steps.max(1);
        self.diverged = None;
        for i in 0..n {
            self.solver.set_particle(i, positions[i], previous[i]);
        }
        Ok(())
    }

    /// Sets the clock: steps taken and simulated seconds (the wind and moving
    /// colliders follow it). With [`Simulation::set_state`], puts the
    /// simulation back in a recorded state; `steps = 0` makes the next step
    /// the Euler start again. A negative or non-finite time is refused.
    pub fn set_clock(&mut self, steps: u64, time: f64) -> Result<(), SimError> {
        if !(time.is_finite() && time >= 0.0) {
            return Err(SimError::Param(ParamError::new("time", time, "a finite time ≥ 0 s")));
        }
        self.steps = steps;
        self.time = time;
        Ok(())
    }

    /// Max and RMS relative strain of the relaxed bars.
    pub fn strain(&self) -> Strain {
        metrics::strain(&self.positions, self.mesh.bars(), &self.fixed)
    }
    /// Max and RMS relative strain of the edges alone
    /// ([`ClothMesh::is_edge`]: a grid's horizontal and vertical bars), the
    /// stretch of the cloth along its threads.
    pub fn edge_strain(&self) -> Strain {
        metrics::strain(&self.positions, &self.edges, &self.fixed)
    }
    /// Kinetic energy of the free particles, joules, from the velocity of the
    /// last substep, (x − x_prev)/(h/n).
    pub fn kinetic_energy(&self) -> f64 {
        metrics::kinetic_energy(
            &self.positions,
            &self.previous,
            &self.fixed,
            &self.material.mass,
            self.params.substep_dt(),
        )
    }
    /// Gravitational potential energy of the free particles, joules: −f_g·x
    /// for the seed's force, −m_i g·x for an acceleration.
    pub fn potential_energy(&self) -> f64 {
        let g = self.params.gravity_acceleration.unwrap_or(self.params.gravity / self.material.mean);
        metrics::potential_energy(&self.positions, &self.fixed, &self.material.mass, g)
    }

    fn check_index(&self, index: usize) -> Result<(), SimError> {
        if index < self.positions.len() {
            Ok(())
        } else {
            Err(SimError::NoSuchParticle { index, count: self.positions.len() })
        }
    }

    fn rebuild_solver(&mut self) {
        let state = (&self.positions[..], &self.previous[..]);
        let tethers = self.tethers();
        self.solver = build_solver(self.kind, &self.mesh, state, &self.inverse_mass, tethers);
        // The self-collide phase's kept pairs are numbered in the old
        // solver's row order (each solver gives its own): search anew.
        if let Some(phase) = &mut self.self_contact {
            *phase = SelfContact::new(self.mesh.positions());
        }
        // The air phase reads the new solver's lanes, or rows.
        self.aero = aerodynamics(&self.mesh, &self.params, &self.material, self.solver.as_ref());
    }

    fn tethers(&self) -> Option<Tethers> {
        self.params.tether_slack.map(|_| Tethers::new(self.positions.len(), self.mesh.bars(), &self.fixed))
    }

    fn refresh_tethers(&mut self) {
        let tethers = self.tethers();
        self.solver.set_tethers(tethers);
    }
}

/// A held particle's weight relative to its own: the hand is 50 times
/// heavier, so the bars and the projection move the cloth toward the hand
/// rather than the hand back toward the cloth ([`super::hold`]).
const HAND_WEIGHT: f32 = 0.02;

/// What the parameters and the mesh make of masses and stiffness.
#[derive(Clone, Debug, PartialEq)]
struct Derived {
    /// m_i, kg.
    mass: Vec<f32>,
    /// m̄, kg.
    mean: f32,
    /// m̄ / m_i: the weight of each particle while free.
    weight: Vec<f32>,
    /// α of structural, bend and shear bars, m/N.
    stretch_compliance: f32,
    bend_compliance: f32,
    shear_compliance: f32,
}

impl Derived {
    fn new(mesh: &ClothMesh, p: &SolverParams) -> Result<Self, ParamError> {
        let n = mesh.particle_count();
        let (mass, mean, weight) = match p.density {
            None => (vec![p.mass; n], p.mass, vec![1.0; n]),
            Some(sigma) => {
                let mass = units::particle_masses(mesh, sigma)?;
                let mean = (mass.iter().map(|&m| f64::from(m)).sum::<f64>() / n.max(1) as f64) as f32;
                let weight = mass.iter().map(|&m| mean / m).collect();
                (mass, mean, weight)
            }
        };
        let stretch_compliance = match p.stretch_stiffness {
            Some(k) => units::stretch_compliance(mesh, k)?.min(super::params::MAX_COMPLIANCE),
            None => p.stretch_compliance,
        };
        let bend_compliance = match p.bend_stiffness {
            Some(b) => units::bend_compliance(mesh, b)?.min(super::params::MAX_COMPLIANCE),
            None => p.bend_compliance,
        };
        let shear_compliance = p.shear_compliance.unwrap_or(stretch_compliance);
        Ok(Self { mass, mean, weight, stretch_compliance, bend_compliance, shear_compliance })
    }
}

/// The coarse phase when `p` asks for coarse passes; an error on a mesh
/// that is not a grid.
fn hierarchy(mesh: &ClothMesh, p: &SolverParams) -> Result<Option<Hierarchy>, SimError> {
    if p.coarse_passes == 0 {
        return Ok(None);
    }
    Hierarchy::new(mesh).map(Some).ok_or(SimError::CoarseNeedsGrid { passes: p.coarse_passes })
}

/// The air phase, when the wind is "air" (the mesh has triangles:
/// [`units::check_surface`]), reading `solver`'s lanes where it has them.
fn aerodynamics(mesh: &ClothMesh, p: &SolverParams, m: &Derived, solver: &dyn Solver) -> Option<Aerodynamics> {
    p.wind.air().map(|_| Aerodynamics::new(mesh, &m.mass, solver.lanes().map(|lanes| lanes.places()).as_ref()))
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

/// The solver of this kind for this state.
fn build_solver(
    kind: SolverKind,
    mesh: &ClothMesh,
    state: (&[Vec3], &[Vec3]),
    inverse_mass: &[f32],
    tethers: Option<Tethers>,
) -> Box<dyn Solver> {
    let (positions, previous) = state;
    match kind {
        SolverKind::Reference => {
            Box::new(ReferenceSolver::new(positions, previous, inverse_mass, mesh.bars(), tethers))
        }
        SolverKind::Fast => fast::new(mesh, positions, previous, inverse_mass, mesh.bars(), tethers),
    }
}
