//! Solver parameters: the seed's h, δ, m, the relaxation count, and the forces.
//!
//! Every field documents its unit, its allowed range and its default. The
//! ranges are checked by [`SolverParams::validate`], which every way of
//! building or changing a simulation goes through: a scene file, the CLI,
//! the viewer's panel and library users.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::wind::Wind;

/// Largest accepted number of relaxation passes per step.
pub const MAX_RELAXATIONS: u32 = 100_000;
/// Largest accepted time step h, in seconds.
pub const MAX_DT: f32 = 1.0;
/// Smallest time step h, seconds (1 µs): XPBD's α·m/h² and the solver's
/// h² stay well inside f32's range (h² ≥ 1e-12, and ≥ 1e-18 per substep).
pub const MIN_DT: f32 = 1e-6;
/// Farthest the seed's gravity force may move a particle in one step, h²/m·|f_g|,
/// metres (the largest coordinate a mesh may have).
pub const MAX_STEP_DISPLACEMENT: f32 = 1e6;
/// Smallest accepted particle mass m, in kilograms.
pub const MIN_MASS: f32 = 1e-9;
/// Largest accepted particle mass m, in kilograms.
pub const MAX_MASS: f32 = 1e9;
/// Largest accepted magnitude of any force component, in newtons.
pub const MAX_FORCE: f32 = 1e9;
/// Largest accepted number of substeps per step.
pub const MAX_SUBSTEPS: u32 = 1000;
/// Largest accepted compliance, m/N.
pub const MAX_COMPLIANCE: f32 = 1.0;
/// Largest accepted contact thickness, metres.
pub const MAX_THICKNESS: f32 = 10.0;
/// Largest accepted friction coefficient.
pub const MAX_FRICTION: f32 = 100.0;
/// Accepted area densities σ, kg/m² (a soap film is 1e-6, a steel sheet 1e4).
pub const DENSITY_RANGE: std::ops::RangeInclusive<f32> = 1e-6..=1e4;
/// Largest accepted magnitude of any component of g, m/s².
pub const MAX_ACCELERATION: f32 = 1e4;
/// Accepted stretch stiffness, N/m.
pub const STRETCH_STIFFNESS_RANGE: std::ops::RangeInclusive<f32> = 1e-3..=1e9;
/// Accepted bend stiffness, N·m.
pub const BEND_STIFFNESS_RANGE: std::ops::RangeInclusive<f32> = 1e-12..=1e3;

/// How the solver spends its work on one step, and the forces it applies.
///
/// The defaults are the seed's values (its section 3): δ = 0.02, h = 0.05 s,
/// m = 0.2 kg, 20 relaxations, gravity (0, −9.8, 0) N and no wind.
///
/// ```
/// use drape::sim::SolverParams;
/// let params = SolverParams { relaxations: 40, ..SolverParams::default() };
/// assert!(params.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SolverParams {
    /// Relaxation passes per step: how many times every bar is projected
    /// back to its rest length after integration (the seed's Figure 3).
    ///
    /// Range `0..=100_000`, default 20. More passes give stiffer, less
    /// stretchy cloth at a cost linear in the count (the seed's Table 1);
    /// 0 leaves the particles unconstrained.
    pub relaxations: u32,
    /// δ in the seed's equation 1: the share of last step's displacement
    /// that is removed every step. Dimensionless.
    ///
    /// Range `0 <= δ < 1`, default 0.02. 0 is undamped; values near 1 stop
    /// every particle almost at once.
    pub damping: f32,
    /// h in the seed's equations 1 and 2: the time step, in seconds.
    ///
    /// Range `1e-6 <= h <= 1`, default 0.05 (the seed's 20 steps per simulated
    /// second). A particle falls h²·|f|/m further per step, so large steps
    /// need more relaxations to hold the cloth together.
    pub dt: f32,
    /// m in the seed's equation 1: the mass of every particle, in kilograms.
    ///
    /// Range `1e-9 ..= 1e9`, default 0.2. Forces are divided by it, so with
    /// the seed's force-valued gravity a lighter cloth falls faster.
    pub mass: f32,
    /// f_g in the seed's equation 3: gravity, a force in newtons applied to
    /// every free particle (not an acceleration: the acceleration is f_g/m).
    ///
    /// Any finite vector with components within ±1e9, default (0, −9.8, 0).
    pub gravity: Vec3,
    /// f_w in the seed's equation 4: the wind, a force applied to every free
    /// particle. Default [`Wind::None`].
    pub wind: Wind,
    /// Early end of relaxation: when every bar is within this relative strain
    /// `|len − rest| / rest` before its projection in a pass, the step stops
    /// relaxing after that pass. Dimensionless, range `0 <= tolerance < 1`,
    /// default 0 (off: always `relaxations` passes, as the seed does, so runs
    /// stay reproducible pass for pass).
    pub tolerance: f32,
    /// n: substeps per step. Each step of h becomes n steps of h/n, each
    /// integrating and then relaxing `relaxations` times (Macklin et al.
    /// 2019, *Small Steps*), so a step costs n × relaxations passes. Stretch
    /// falls as 1/n² with substeps but only as 1/passes with passes.
    /// δ keeps its meaning per step of h: each substep removes
    /// δ_n = 1 − (1 − δ)^(1/n) of the motion, so n substeps damp as one step.
    /// The wind is sampled once per step, at its start, for all its
    /// substeps. Range `1..=1000`, default 1 (the seed's way).
    ///
    /// Give each substep at least two passes on the seed's grid: with both
    /// diagonals its cells are over-constrained, a single Gauss–Seidel pass
    /// leaves a residual that changes from substep to substep, and its
    /// velocity (residual / (h/n)) grows as substeps shrink — measured, the
    /// hanging seed cloth never comes to rest at 20 × 1 and shivers
    /// harder at 80 × 1, while 20 × 2 settles with 0.3 % strain.
    pub substeps: u32,
    /// α for structural bars: compliance, the inverse of stiffness, in m/N
    /// (XPBD, Macklin et al. 2016). A bar stretched by ε metres pulls with
    /// ε/α newtons, whatever the number of passes or substeps, so stiffness is
    /// a material property. Range `0 ..= 1`, default 0 (rigid bars, the seed's).
    pub stretch_compliance: f32,
    /// α for bend bars, m/N, as `stretch_compliance`. Soft bend bars (1e-4 to
    /// 1e-2) let cloth fold without making it stretchy. Default 0.
    pub bend_compliance: f32,
    /// α for shear bars (a grid's diagonals), m/N, as `stretch_compliance`.
    /// Woven cloth gives in shear long before it stretches: soft diagonals
    /// (1e-3 to 1e-1 on the seed's scales) let a cloth shear flat where
    /// rigid ones make it buckle into diagonal pleats. Range `0 ..= 1`;
    /// default unset: the diagonals take `stretch_compliance` (the seed's
    /// grid, where they are structural bars like the others).
    pub shear_compliance: Option<f32>,
    /// ω: over-relaxation of every projection, which moves the bar's ends ω
    /// times the way to its rest length. Range `1 <= ω < 2`, default 1 (plain
    /// projection). Values up to about 1.5 converge in fewer passes on cloth;
    /// near 2 the passes oscillate, so 1.2–1.5 is the safe choice. On a cloth
    /// stretched many times its rest size (one pass, huge steps, no damping)
    /// ω > 1 diverges: the stability tests found a case at ω = 1.41.
    pub over_relaxation: f32,
    /// Long-range attachments (Kim et al. 2012): every free particle stays
    /// within its rest path length (along bars, ×(1 + slack)) of the nearest
    /// fixed particle, so a hanging cloth cannot stretch down its length
    /// however few passes run. `None` (default) is off; the slack ranges
    /// `0 ..= 1`.
    pub tether_slack: Option<f32>,
    /// How the first step starts: the seed's Euler step (equation 2, default)
    /// or a second-order one.
    pub start: Start,
    /// r: the distance every particle keeps from every collider surface, in
    /// metres ([`super::contact`]). Range `0 ..= 10`, default 0.01. Unused
    /// without colliders.
    pub thickness: f32,
    /// μ: Coulomb's friction coefficient between cloth and colliders that
    /// give none of their own. Dimensionless, range `0 ..= 100`, default 0.3
    /// (cotton on wood is about 0.3–0.5; 0 is ice).
    pub friction: f32,
    /// Keep the cloth from passing through itself ([`super::self_contact`]):
    /// particles not near each other in the rest shape stay `thickness`
    /// apart, with friction between layers, and move at most thickness/4 per
    /// substep. Default false (a scene that does not ask for it pays nothing).
    pub self_collision: bool,
    /// σ: the cloth's area density, kg/m². When given, each particle's mass
    /// is σ times a third of the area of the triangles around it
    /// ([`super::units`]), so a cloth weighs σ × its area at any resolution,
    /// and `mass` is not used. Needs a mesh with triangles. Range
    /// `1e-6 ..= 1e4`, default `None` (every particle weighs `mass`, the
    /// seed's way).
    pub density: Option<f32>,
    /// g: gravity as an acceleration, m/s², the same for every particle
    /// whatever its mass. When given, `gravity` (a force) is not used.
    /// Components within ±1e4, default `None` (the seed's force).
    pub gravity_acceleration: Option<Vec3>,
    /// k_s: stretch stiffness, N/m (force per unit width per unit strain;
    /// Young's modulus times thickness). When given, it sets the structural
    /// bars' compliance from the mesh ([`super::units`]) in place of
    /// `stretch_compliance`. Needs a mesh with triangles. Range
    /// `1e-3 ..= 1e9`, default `None`.
    pub stretch_stiffness: Option<f32>,
    /// B: bend stiffness (flexural rigidity), N·m. When given, it sets the
    /// bend bars' compliance from the mesh ([`super::units`]) in place of
    /// `bend_compliance`. Needs a mesh with triangles. Range `1e-12 ..= 1e3`,
    /// default `None`.
    pub bend_stiffness: Option<f32>,
    /// Inextensible edges ([`super::inextensible`]): after the relaxation
    /// passes, every substep puts all the edges (a grid's horizontal and
    /// vertical bars, a triangle mesh's edges) back to their rest lengths
    /// at once with a global Newton solve (Goldenthal et al. 2007), so the
    /// cloth stretches as little as `newton_tolerance` allows whatever the
    /// number of passes. The passes still hold the diagonals and bend bars.
    /// Default false (the seed's relaxation alone).
    pub inextensible: bool,
    /// With `inextensible`: the most Newton iterations per substep. Range
    /// `1 ..= 100`, default 3; each costs one sparse Cholesky factorisation
    /// and solve (about 0.5 ms for the seed's 1 150 edges).
    pub newton_iterations: u32,
    /// With `inextensible`: the iterations stop once every edge is within
    /// this relative strain of its rest length. Dimensionless, range
    /// `0 < newton_tolerance < 1`, default 0.008 (0.8 %: the seed's scene
    /// then stretches 0.26 % typically, 0.8 % at worst).
    pub newton_tolerance: f32,
    /// With `inextensible`: Gauss–Seidel passes over the edges alone (over-
    /// relaxed, ω = 1.8) before the first Newton iteration and after each.
    /// A Newton step is exact for the linearised constraints; where the
    /// cloth is curved and moving fast (the seed's wind moves its free edge
    /// further than a bar's length per step) it overshoots locally, and
    /// these cheap passes remove that local error so the next iteration
    /// starts close (often none is then needed). At most this many: they
    /// stop, in batches of 8, once every edge is within `newton_tolerance`.
    /// Range `0 ..= 1000`, default 48.
    pub newton_smoothing: u32,
    /// Passes over each coarser grid of a grid mesh after the relaxation
    /// ([`super::hierarchy`], hierarchical position-based dynamics): the
    /// grid coarsened 2, 4, 8, … times, each level's bars pulling only when
    /// stretched, coarsest first, the correction interpolated down to the
    /// particles. It removes the smooth stretch that the seed's passes
    /// carry one bar a pass. On the 256 × 256 cloth (host D) a coarse pass
    /// over every level costs about one fine pass (0.28 ms: scalar, on one
    /// thread), plus 0.7 ms a substep to read the positions out and push
    /// the correction back. Pair it with soft diagonals
    /// (`shear_compliance`), which otherwise hold the edges' stretch
    /// locally. Grid meshes only. Range `0 ..= 100`, default 0 (off, the
    /// seed's relaxation alone).
    pub coarse_passes: u32,
}

/// Largest accepted number of Newton iterations per substep.
pub const MAX_NEWTON_ITERATIONS: u32 = 100;

/// Largest accepted number of passes per coarse level.
pub const MAX_COARSE_PASSES: u32 = 100;

/// The first step of the simulation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Start {
    /// Equation 2: x₁ = x₀ + h v₀, the force ignored. A particle in free fall
    /// then lags the exact parabola by a·h·t/2 for ever after.
    #[default]
    Euler,
    /// x₁ = x₀ + h v₀ + ½ h² f/m: with equation 1 afterwards, exact for a
    /// constant force.
    SecondOrder,
}

impl Default for SolverParams {
    fn default() -> Self {
        Self {
            relaxations: 20,
            damping: 0.02,
            dt: 0.05,
            mass: 0.2,
            gravity: Vec3::new(0.0, -9.8, 0.0),
            wind: Wind::None,
            tolerance: 0.0,
            substeps: 1,
            stretch_compliance: 0.0,
            bend_compliance: 0.0,
            shear_compliance: None,
            over_relaxation: 1.0,
            tether_slack: None,
            start: Start::Euler,
            thickness: 0.01,
            friction: 0.3,
            self_collision: false,
            density: None,
            gravity_acceleration: None,
            stretch_stiffness: None,
            bend_stiffness: None,
            inextensible: false,
            newton_iterations: 3,
            newton_tolerance: 8e-3,
            newton_smoothing: 48,
            coarse_passes: 0,
        }
    }
}

/// A parameter outside its allowed range.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{name} = {value} is not allowed: {allowed}")]
pub struct ParamError {
    /// The parameter's name, as in a scene file's `[solver]` or `[wind]` table.
    pub name: &'static str,
    /// The rejected value, formatted.
    pub value: String,
    /// What the parameter accepts.
    pub allowed: &'static str,
}

impl ParamError {
    pub(crate) fn new(name: &'static str, value: impl std::fmt::Display, allowed: &'static str) -> Self {
        Self { name, value: value.to_string(), allowed }
    }
}

/// Checks a force-like vector: finite, each component within ±[`MAX_FORCE`].
pub(crate) fn check_force(name: &'static str, v: Vec3) -> Result<(), ParamError> {
    if v.is_finite() && v.abs().max_element() <= MAX_FORCE {
        Ok(())
    } else {
        Err(ParamError::new(name, format!("[{}, {}, {}]", v.x, v.y, v.z), "finite components within ±1e9 N"))
    }
}

/// Checks a friction coefficient: 0 ≤ μ ≤ [`MAX_FRICTION`].
pub(crate) fn check_friction(name: &'static str, mu: f32) -> Result<(), ParamError> {
    if (0.0..=MAX_FRICTION).contains(&mu) {
        Ok(())
    } else {
        Err(ParamError::new(name, mu, "a coefficient, 0 <= friction <= 100"))
    }
}

impl SolverParams {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.relaxations > MAX_RELAXATIONS {
            return Err(ParamError::new("relaxations", self.relaxations, "an integer from 0 to 100000"));
        }
        // `!(a <= x && x < b)` also rejects NaN.
        if !(0.0..1.0).contains(&self.damping) {
            return Err(ParamError::new("damping", self.damping, "0 <= damping < 1"));
        }
        if !(self.dt >= MIN_DT && self.dt <= MAX_DT) {
            return Err(ParamError::new("dt", self.dt, "seconds, 1e-6 <= dt <= 1"));
        }
        if !(MIN_MASS..=MAX_MASS).contains(&self.mass) {
            return Err(ParamError::new("mass", self.mass, "kilograms, 1e-9 <= mass <= 1e9"));
        }
        check_force("gravity", self.gravity)?;
        // Derived: how far the seed's gravity force moves a particle of mass
        // m in one step, h²/m·|f_g| (finite, as each factor was checked).
        // Past 1e6 m, the largest coordinate a mesh may have, the first step
        // leaves f32's useful range. (With a density or g the masses and the
        // acceleration are checked by their own ranges.)
        let step = self.gravity.length() * self.dt * self.dt / self.mass;
        if self.gravity_acceleration.is_none() && self.density.is_none() && step > MAX_STEP_DISPLACEMENT {
            let value = format!("{step:e} m per step (h²/m·|f_g| with h = {}, m = {})", self.dt, self.mass);
            return Err(ParamError::new(
                "gravity",
                value,
                "at most 1e6 m per step; use a smaller dt, a larger mass or a weaker gravity",
            ));
        }
        if !(0.0..1.0).contains(&self.tolerance) {
            return Err(ParamError::new("tolerance", self.tolerance, "0 <= tolerance < 1 (0 turns it off)"));
        }
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(ParamError::new("substeps", self.substeps, "an integer from 1 to 1000"));
        }
        for (name, alpha) in [
            ("stretch_compliance", self.stretch_compliance),
            ("bend_compliance", self.bend_compliance),
            ("shear_compliance", self.shear_compliance.unwrap_or(0.0)),
        ] {
            if !(0.0..=MAX_COMPLIANCE).contains(&alpha) {
                return Err(ParamError::new(name, alpha, "m/N, 0 <= compliance <= 1 (0 is rigid)"));
            }
        }
        if !(1..=MAX_NEWTON_ITERATIONS).contains(&self.newton_iterations) {
            return Err(ParamError::new("newton_iterations", self.newton_iterations, "an integer from 1 to 100"));
        }
        if self.newton_smoothing > 1000 {
            return Err(ParamError::new("newton_smoothing", self.newton_smoothing, "an integer from 0 to 1000"));
        }
        if self.coarse_passes > MAX_COARSE_PASSES {
            return Err(ParamError::new("coarse_passes", self.coarse_passes, "an integer from 0 to 100"));
        }
        if !(self.newton_tolerance > 0.0 && self.newton_tolerance < 1.0) {
            return Err(ParamError::new("newton_tolerance", self.newton_tolerance, "0 < newton_tolerance < 1"));
        }
        if !(1.0..2.0).contains(&self.over_relaxation) {
            return Err(ParamError::new("over_relaxation", self.over_relaxation, "1 <= over_relaxation < 2"));
        }
        if let Some(slack) = self.tether_slack
            && !(0.0..=1.0).contains(&slack)
        {
            return Err(ParamError::new("tether_slack", slack, "0 <= tether_slack <= 1"));
        }
        if !(0.0..=MAX_THICKNESS).contains(&self.thickness) {
            return Err(ParamError::new("thickness", self.thickness, "metres, 0 <= thickness <= 10"));
        }
        check_friction("friction", self.friction)?;
        if let Some(sigma) = self.density
            && !DENSITY_RANGE.contains(&sigma)
        {
            return Err(ParamError::new("density", sigma, "kg/m², 1e-6 <= density <= 1e4"));
        }
        if let Some(g) = self.gravity_acceleration
            && !(g.is_finite() && g.abs().max_element() <= MAX_ACCELERATION)
        {
            let value = format!("[{}, {}, {}]", g.x, g.y, g.z);
            return Err(ParamError::new("g", value, "m/s², finite components within ±1e4"));
        }
        if let Some(k) = self.stretch_stiffness
            && !STRETCH_STIFFNESS_RANGE.contains(&k)
        {
            return Err(ParamError::new("stretch_stiffness", k, "N/m, 1e-3 <= stretch_stiffness <= 1e9"));
        }
        if let Some(b) = self.bend_stiffness
            && !BEND_STIFFNESS_RANGE.contains(&b)
        {
            return Err(ParamError::new("bend_stiffness", b, "N·m, 1e-12 <= bend_stiffness <= 1e3"));
        }
        self.wind.validate()
    }

    /// The displacement `h²/m · f` that a constant force `f` adds to a free
    /// particle in one step of equation 1.
    pub fn displacement_of(&self, force: Vec3) -> Vec3 {
        force * (self.dt * self.dt / self.mass)
    }

    /// The length of one substep, h/n, seconds.
    pub fn substep_dt(&self) -> f32 {
        self.dt / self.substeps as f32
    }

    /// δ_n = 1 − (1 − δ)^(1/n): the damping per substep that damps n substeps
    /// as much as δ damps one step of h.
    pub fn substep_damping(&self) -> f32 {
        if self.substeps == 1 { self.damping } else { 1.0 - (1.0 - self.damping).powf(1.0 / self.substeps as f32) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_seeds_values_and_valid() {
        let p = SolverParams::default();
        assert_eq!((p.relaxations, p.damping, p.dt, p.mass), (20, 0.02, 0.05, 0.2));
        assert_eq!(p.gravity, Vec3::new(0.0, -9.8, 0.0));
        assert_eq!(p.validate(), Ok(()));
    }

    #[test]
    fn each_out_of_range_value_names_its_parameter() {
        let base = SolverParams::default();
        let cases: Vec<(SolverParams, &str)> = vec![
            (SolverParams { relaxations: MAX_RELAXATIONS + 1, ..base.clone() }, "relaxations"),
            (SolverParams { damping: 1.0, ..base.clone() }, "damping"),
            (SolverParams { damping: -0.1, ..base.clone() }, "damping"),
            (SolverParams { damping: f32::NAN, ..base.clone() }, "damping"),
            (SolverParams { dt: 0.0, ..base.clone() }, "dt"),
            (SolverParams { dt: -1.0, ..base.clone() }, "dt"),
            (SolverParams { dt: f32::INFINITY, ..base.clone() }, "dt"),
            (SolverParams { dt: 1.5, ..base.clone() }, "dt"),
            // h = 1e-30 s would make α·m/h² overflow f32 (the issue's case).
            (SolverParams { dt: 1e-30, ..base.clone() }, "dt"),
            (SolverParams { dt: 0.99e-6, ..base.clone() }, "dt"),
            // 1e9 N on 1e-9 kg for h = 1 s: 1e18 m in the first step.
            (SolverParams { dt: 1.0, mass: 1e-9, gravity: Vec3::new(0.0, -1e9, 0.0), ..base.clone() }, "gravity"),
            (SolverParams { mass: 0.0, ..base.clone() }, "mass"),
            (SolverParams { mass: f32::NAN, ..base.clone() }, "mass"),
            (SolverParams { gravity: Vec3::new(0.0, f32::NAN, 0.0), ..base.clone() }, "gravity"),
            (SolverParams { wind: Wind::Seed { scale: f32::INFINITY }, ..base.clone() }, "wind.scale"),
            (SolverParams { tolerance: -1e-3, ..base.clone() }, "tolerance"),
            (SolverParams { substeps: 0, ..base.clone() }, "substeps"),
            (SolverParams { stretch_compliance: -1.0, ..base.clone() }, "stretch_compliance"),
            (SolverParams { bend_compliance: f32::NAN, ..base.clone() }, "bend_compliance"),
            (SolverParams { shear_compliance: Some(2.0), ..base.clone() }, "shear_compliance"),
            (SolverParams { over_relaxation: 2.0, ..base.clone() }, "over_relaxation"),
            (SolverParams { tether_slack: Some(-0.5), ..base.clone() }, "tether_slack"),
            (SolverParams { thickness: -0.01, ..base.clone() }, "thickness"),
            (SolverParams { friction: f32::NAN, ..base.clone() }, "friction"),
            (SolverParams { friction: -0.1, ..base.clone() }, "friction"),
            (SolverParams { density: Some(-0.2), ..base.clone() }, "density"),
            (SolverParams { density: Some(f32::NAN), ..base.clone() }, "density"),
            (SolverParams { gravity_acceleration: Some(Vec3::new(0.0, 1e5, 0.0)), ..base.clone() }, "g"),
            (SolverParams { stretch_stiffness: Some(0.0), ..base.clone() }, "stretch_stiffness"),
            (SolverParams { bend_stiffness: Some(f32::INFINITY), ..base.clone() }, "bend_stiffness"),
            (SolverParams { newton_iterations: 0, ..base.clone() }, "newton_iterations"),
            (SolverParams { newton_tolerance: 0.0, ..base.clone() }, "newton_tolerance"),
            (SolverParams { newton_smoothing: 1001, ..base.clone() }, "newton_smoothing"),
            (SolverParams { coarse_passes: 101, ..base.clone() }, "coarse_passes"),
            (SolverParams { newton_tolerance: f32::NAN, ..base.clone() }, "newton_tolerance"),
            (
                SolverParams {
                    wind: Wind::Air(crate::sim::wind::Air { gusts: -1.0, ..Default::default() }),
                    ..base.clone()
                },
                "wind.gusts",
            ),
        ];
        for (params, name) in cases {
            let err = params.validate().expect_err(name);
            assert_eq!(err.name, name, "{err}");
        }
    }

    #[test]
    fn displacement_is_h_squared_over_m_times_f() {
        let p = SolverParams::default();
        // 0.05² / 0.2 = 0.0125 m per newton.
        let d = p.displacement_of(Vec3::new(0.0, -9.8, 0.0));
        assert!((d.y - (-0.1225)).abs() < 1e-7, "{d}");
    }
}
