//! [`Simulation`]: a mesh, its parameters, a solver and the clock.

use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::aero::Aerodynamics;
use super::collider::{Collider, Pose};
use super::hierarchy::Hierarchy;
use super::hold::Holds;
use super::inextensible::{FastProjection, ProjectionError, ProjectionReport};
use super::mesh::{Bar, ClothMesh};
use super::metrics::{self, Strain};
use super::params::{ParamError, SolverParams};
use super::reference::ReferenceSolver;
use super::self_contact::SelfContact;
use super::step::Solver;
use super::tether::Tethers;
use super::units;

mod advance;
mod grips;
mod setup;

use setup::{Derived, aerodynamics, build_solver, hierarchy};

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

    /// The self-collide phase's top speed and whom it held: `(speed,
    /// (last, total))` with speed =
    /// [`TOP_SPEED_SHARE`](crate::sim::self_contact::TOP_SPEED_SHARE) · r /
    /// (h/n) in m/s (r/4 a substep; r the thickness, h/n the substep), last the particles whose motion it cut to that
    /// speed in the last substep and total those summed over every
    /// substep since the phase was made (with
    /// [`Self::self_collision_searches`]'s substeps, the share of a run
    /// held); `None` while self-collision is off. Where many are held the
    /// cloth falls or swings slower than it would; more substeps raise the
    /// speed.
    pub fn self_collision_top_speed(&self) -> Option<(f32, (usize, u64))> {
        let p = &self.params;
        let substep = p.dt / p.substeps.max(1) as f32;
        let speed = crate::sim::self_contact::TOP_SPEED_SHARE * p.thickness / substep;
        self.self_contact.as_ref().map(|phase| (speed, phase.held_to_top_speed()))
    }

    /// What the inextensible projection did in the last substep (`None`
    /// while the cloth is not inextensible).
    pub fn last_projection(&self) -> Option<ProjectionReport> {
        self.projection.as_ref().map(FastProjection::last_report)
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
