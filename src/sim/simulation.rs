//! [`Simulation`]: a mesh, its parameters, a solver and the clock.

use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::fast::FastSolver;
use super::mesh::{Bar, ClothMesh};
use super::metrics::{self, Strain};
use super::params::{ParamError, SolverParams, Start};
use super::reference::ReferenceSolver;
use super::tether::Tethers;

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
    /// A particle index outside the mesh.
    #[error("particle {index} does not exist: the mesh has {count} particles")]
    NoSuchParticle {
        /// The index given.
        index: usize,
        /// The number of particles.
        count: usize,
    },
}

/// Everything one substep of h/n needs, derived from [`SolverParams`] by
/// [`Simulation`]; the solvers take it as it is.
#[derive(Clone, Copy, Debug)]
pub struct Substep<'a> {
    /// h/n, seconds.
    pub dt: f32,
    /// 1 − δ_n, the share of last substep's motion that is kept.
    pub keep: f32,
    /// (h/n)² f / m: what the force adds to a free particle's displacement.
    pub accel: Vec3,
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
    /// The tether slack when tethers are on.
    pub tether_slack: Option<f32>,
}

/// The solver's own state, whichever kind it is.
#[derive(Clone, Debug)]
enum Engine {
    Reference(ReferenceSolver),
    Fast(FastSolver),
}

impl Engine {
    fn new(
        kind: SolverKind,
        mesh: &ClothMesh,
        state: (&[Vec3], &[Vec3]),
        fixed: &[bool],
        bars: &[Bar],
        tethers: Option<Tethers>,
    ) -> Self {
        let (positions, previous) = state;
        match kind {
            SolverKind::Reference => Engine::Reference(ReferenceSolver::new(positions, previous, fixed, bars, tethers)),
            SolverKind::Fast => Engine::Fast(FastSolver::new(mesh, positions, previous, fixed, bars, tethers)),
        }
    }

    fn step(&mut self, substep: &Substep) -> u32 {
        match self {
            Engine::Reference(s) => s.step(substep),
            Engine::Fast(s) => s.step(substep),
        }
    }

    fn read(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        match self {
            Engine::Reference(s) => {
                positions.copy_from_slice(&s.positions);
                previous.copy_from_slice(&s.previous);
            }
            Engine::Fast(s) => s.read(positions, previous),
        }
    }

    fn first_non_finite(&self) -> Option<usize> {
        match self {
            Engine::Reference(s) => s.positions.iter().position(|p| !p.is_finite()),
            Engine::Fast(s) => s.first_non_finite(),
        }
    }

    fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        match self {
            Engine::Reference(s) => {
                s.positions[index] = position;
                s.previous[index] = previous;
            }
            Engine::Fast(s) => s.set_particle(index, position, previous),
        }
    }

    fn describe(&self) -> String {
        match self {
            Engine::Reference(_) => "creation order, scalar, one thread".to_string(),
            Engine::Fast(s) => s.describe(),
        }
    }
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
    params: SolverParams,
    kind: SolverKind,
    fixed: Vec<bool>,
    bars: Vec<Bar>,
    engine: Engine,
    positions: Vec<Vec3>,
    previous: Vec<Vec3>,
    steps: u64,
    time: f64,
    diverged: Option<SimError>,
    last_passes: u32,
}

/// The bars that can move: those not joining two fixed particles.
fn active_bars(mesh: &ClothMesh, fixed: &[bool]) -> Vec<Bar> {
    mesh.bars().iter().filter(|b| !(fixed[b.a as usize] && fixed[b.b as usize])).copied().collect()
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
        params.validate()?;
        let mesh = mesh.into();
        let fixed = mesh.fixed().to_vec();
        let bars = active_bars(&mesh, &fixed);
        let positions = mesh.positions().to_vec();
        let previous = positions.clone();
        let tethers = params.tether_slack.map(|_| Tethers::new(positions.len(), &bars, &fixed));
        let engine = Engine::new(kind, &mesh, (&positions, &previous), &fixed, &bars, tethers);
        Ok(Self {
            mesh,
            params,
            kind,
            fixed,
            bars,
            engine,
            positions,
            previous,
            steps: 0,
            time: 0.0,
            diverged: None,
            last_passes: 0,
        })
    }

    /// Back to the mesh's initial state and time 0, keeping parameters and solver.
    pub fn reset(&mut self) {
        let fresh = Self::with_solver(self.mesh.clone(), self.params.clone(), self.kind);
        // Parameters were validated when set, so rebuilding cannot fail.
        if let Ok(fresh) = fresh {
            *self = fresh;
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
    /// Changes the parameters; they apply from the next step on.
    pub fn set_params(&mut self, params: SolverParams) -> Result<(), ParamError> {
        params.validate()?;
        let tethers_toggled = params.tether_slack.is_some() != self.params.tether_slack.is_some();
        self.params = params;
        if tethers_toggled {
            self.rebuild_engine();
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
            self.rebuild_engine();
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
    /// The bars the solver relaxes (none joins two fixed particles).
    pub fn bars(&self) -> &[Bar] {
        &self.bars
    }
    /// Bar projections one step performs: bars × relaxations × substeps.
    pub fn projections_per_step(&self) -> u64 {
        self.bars.len() as u64 * u64::from(self.params.relaxations) * u64::from(self.params.substeps)
    }
    /// Relaxation passes the last substep made: `relaxations`, or fewer when
    /// the tolerance ended it early.
    pub fn last_passes(&self) -> u32 {
        self.last_passes
    }
    /// How the solver in use works, in a few words (layout, SIMD, threads).
    pub fn solver_description(&self) -> String {
        self.engine.describe()
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
    pub fn advance(&mut self, n: u64) -> Result<(), SimError> {
        if let Some(e) = &self.diverged {
            return Err(e.clone());
        }
        let p = &self.params;
        let dt = p.substep_dt();
        let beta = |alpha: f32| alpha * p.mass / (dt * dt);
        for _ in 0..n {
            // The wind is sampled once per step, at its start.
            let mut force = p.gravity;
            if !p.wind.is_none() {
                force += p.wind.force(self.time);
            }
            let accel = force * (dt * dt / p.mass);
            let mut substep = Substep {
                dt,
                keep: 1.0 - p.substep_damping(),
                accel,
                first: None,
                relaxations: p.relaxations,
                tolerance: p.tolerance,
                over_relaxation: p.over_relaxation,
                stretch_beta: beta(p.stretch_compliance),
                bend_beta: beta(p.bend_compliance),
                tether_slack: p.tether_slack,
            };
            for k in 0..p.substeps {
                substep.first = (self.steps == 0 && k == 0).then(|| {
                    let extra = match p.start {
                        Start::Euler => Vec3::ZERO,
                        Start::SecondOrder => 0.5 * accel,
                    };
                    (self.mesh.velocities(), extra)
                });
                self.last_passes = self.engine.step(&substep);
            }
            self.steps += 1;
            self.time += f64::from(p.dt);
            if let Some(particle) = self.engine.first_non_finite() {
                let e = SimError::Diverged { step: self.steps, particle };
                self.diverged = Some(e.clone());
                return Err(e);
            }
        }
        self.engine.read(&mut self.positions, &mut self.previous);
        Ok(())
    }

    /// Fixes or frees a particle. Bars between two fixed particles drop out of
    /// the relaxation and come back when one end is freed.
    ///
    /// A particle being fixed comes to rest (its previous position becomes
    /// its current one), so one freed later starts from rest rather than
    /// with the velocity it had when it was fixed; moving it while fixed
    /// ([`Self::move_particle`], a drag) gives it that move's velocity.
    pub fn set_fixed(&mut self, index: usize, fixed: bool) -> Result<(), SimError> {
        self.check_index(index)?;
        if self.fixed[index] != fixed {
            self.fixed[index] = fixed;
            if fixed {
                self.previous[index] = self.positions[index];
            }
            self.bars = active_bars(&self.mesh, &self.fixed);
            self.rebuild_engine();
        }
        Ok(())
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
        self.engine.set_particle(index, position, previous);
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
        self.rebuild_engine();
        Ok(())
    }

    /// Max and RMS relative strain of the relaxed bars.
    pub fn strain(&self) -> Strain {
        metrics::strain(&self.positions, &self.bars)
    }
    /// Kinetic energy of the free particles, joules, from the velocity of the
    /// last substep, (x − x_prev)/(h/n).
    pub fn kinetic_energy(&self) -> f64 {
        metrics::kinetic_energy(
            &self.positions,
            &self.previous,
            &self.fixed,
            self.params.mass,
            self.params.substep_dt(),
        )
    }
    /// Gravitational potential energy of the free particles, joules.
    pub fn potential_energy(&self) -> f64 {
        metrics::potential_energy(&self.positions, &self.fixed, self.params.gravity)
    }

    fn check_index(&self, index: usize) -> Result<(), SimError> {
        if index < self.positions.len() {
            Ok(())
        } else {
            Err(SimError::NoSuchParticle { index, count: self.positions.len() })
        }
    }

    fn rebuild_engine(&mut self) {
        let state = (&self.positions[..], &self.previous[..]);
        let tethers = self.params.tether_slack.map(|_| Tethers::new(self.positions.len(), &self.bars, &self.fixed));
        self.engine = Engine::new(self.kind, &self.mesh, state, &self.fixed, &self.bars, tethers);
    }
}
