//! `drape run`: advance a scene without a window and report what happened.
//!
//! The CLI adds the progress bar and argument parsing; everything else is here
//! so that tests can run it in-process.

use std::io::Write;
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::export::ExportError;
use crate::sim::{SimError, Simulation, Strain};

/// The figures `drape run` prints and writes to `--out`.
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    /// Particles in the mesh.
    pub particles: usize,
    /// Bars the solver relaxes (bars between two fixed particles excluded).
    pub bars: usize,
    /// Steps taken by this run.
    pub steps: u64,
    /// The cloth's mass, kg: Σ m_i.
    pub total_mass: f64,
    /// Relaxation passes per substep.
    pub relaxations: u32,
    /// Substeps per step.
    pub substeps: u32,
    /// Passes per coarse level and the grid's coarse levels (0 and 0: off).
    pub coarse: (u32, usize),
    /// The solver used.
    pub solver: &'static str,
    /// The fast solver's SIMD level (`DRAPE_SIMD`, [`crate::sim::fast::simd`]),
    /// and why it differs from the one asked for, if it does.
    pub simd: String,
    /// How the solver lays the cloth out (lanes, colours, blocks, threads):
    /// [`crate::sim::Simulation::solver_description`].
    pub layout: String,
    /// Wall-clock seconds per step, stepping only (output excluded).
    pub seconds_per_step: f64,
    /// Bar projections per wall-clock second.
    pub projections_per_second: f64,
    /// Simulated seconds at the end.
    pub time: f64,
    /// Strain at the end.
    pub strain: Strain,
    /// Strain of the edges alone at the end (a grid's horizontal and
    /// vertical bars: the cloth's stretch along its threads).
    pub edge_strain: Strain,
    /// The edges' max strain over the run's steps: its mean over the steps
    /// (typical) and its largest (worst).
    pub edge_strain_over_run: (f64, f32),
    /// With inextensible edges: the Newton iterations per step, mean over
    /// the run (of each step's last substep).
    pub newton: Option<f64>,
    /// With self-collision: the searches for pairs in this run and the
    /// substeps, `(searches, substeps)`: fewer searches where the pairs were
    /// kept between substeps ([`crate::sim::self_contact`]).
    pub self_collision: Option<(u64, u64)>,
    /// With self-collision: its top speed and the particles it held there
    /// ([`crate::sim::Simulation::self_collision_top_speed`]).
    pub top_speed: Option<TopSpeed>,
    /// Kinetic energy of the free particles at the end, joules.
    pub kinetic_energy: f64,
    /// What is absurd about the end state, if anything ([`crate::sim::health`]).
    pub warning: Option<String>,
}

/// The self-collide phase's top speed over a run: where many particles
/// are held to it, the cloth moves slower than it would.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TopSpeed {
    /// [`crate::sim::self_contact::TOP_SPEED_SHARE`] · r / (h/n) (r/4 a
    /// substep), m/s.
    pub speed: f32,
    /// Share of the particles held to it in the last substep, 0..=1.
    pub held_last: f64,
    /// Share of particle-substeps held to it over the run, 0..=1.
    pub held_run: f64,
}

impl std::fmt::Display for RunSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "particles            {}", self.particles)?;
        writeln!(f, "bars                 {}", self.bars)?;
        writeln!(f, "mass                 {:.4} kg", self.total_mass)?;
        writeln!(f, "steps                {} ({:.3} s simulated)", self.steps, self.time)?;
        if self.substeps > 1 {
            writeln!(
                f,
                "relaxations          {} per substep × {} substeps ({} solver)",
                self.relaxations, self.substeps, self.solver
            )?;
        } else {
            writeln!(f, "relaxations          {} ({} solver)", self.relaxations, self.solver)?;
        }
        if self.coarse.0 > 0 {
            writeln!(f, "coarse passes        {} per level × {} levels of the grid", self.coarse.0, self.coarse.1)?;
        }
        writeln!(f, "SIMD level           {}", self.simd)?;
        writeln!(f, "solver layout        {}", self.layout)?;
        writeln!(f, "wall time per step   {}", format_duration(self.seconds_per_step))?;
        writeln!(f, "bar projections/s    {:.3e}", self.projections_per_second)?;
        writeln!(f, "max strain           {:.4e}", self.strain.max)?;
        writeln!(f, "RMS strain           {:.4e}", self.strain.rms)?;
        writeln!(f, "edge max strain      {:.4e}", self.edge_strain.max)?;
        writeln!(
            f,
            "edge max strain, run {:.4e} typical, {:.4e} worst",
            self.edge_strain_over_run.0, self.edge_strain_over_run.1
        )?;
        if let Some(iterations) = self.newton {
            writeln!(f, "newton iterations    {iterations:.2} per step, mean (inextensible)")?;
        }
        if let Some((searches, substeps)) = self.self_collision {
            writeln!(f, "self-collision       {searches} searches in {substeps} substeps (pairs kept between)")?;
        }
        if let Some(top) = self.top_speed {
            writeln!(
                f,
                "top speed            {:.3} m/s (self-collision, r/4 a substep): {:.1} % of the particles held to it \
                 in the last substep, {:.1} % over the run{}",
                top.speed,
                100.0 * top.held_last,
                100.0 * top.held_run,
                if top.held_run > 0.01 { "; more substeps raise it" } else { "" }
            )?;
        }
        write!(f, "kinetic energy       {:.4e} J", self.kinetic_energy)?;
        if let Some(warning) = &self.warning {
            write!(f, "\nwarning: {warning}")?;
        }
        Ok(())
    }
}

/// Seconds as `12.3 µs`, `4.56 ms` or `1.23 s`.
pub fn format_duration(seconds: f64) -> String {
    if seconds < 1e-3 {
        format!("{:.2} µs", seconds * 1e6)
    } else if seconds < 1.0 {
        format!("{:.3} ms", seconds * 1e3)
    } else {
        format!("{seconds:.3} s")
    }
}

/// What can stop a run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The simulation blew up.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The trace could not be written (the I/O error in the message only,
    /// not also as its source, so that a chain printed whole says it once).
    #[error("cannot write the trace: {0}")]
    Trace(std::io::Error),
    /// The export could not be written.
    #[error(transparent)]
    Export(#[from] ExportError),
}

/// Where a run sends its frames, and how often.
pub struct FrameOutput<'a> {
    /// Called with the simulation at step 0, after every `every`-th step,
    /// and after the last step if that is not a multiple of `every` (so the
    /// last frame is always the run's end state).
    pub write: &'a mut dyn FnMut(&Simulation) -> Result<(), RunError>,
    /// Steps between frames, ≥ 1.
    pub every: u64,
}

/// The number of frames a run of `steps` steps gives with one every
/// `every` steps: step 0, each multiple of `every`, and the last step.
pub fn frame_count(steps: u64, every: u64) -> u64 {
    let every = every.max(1);
    1 + steps / every + u64::from(!steps.is_multiple_of(every))
}

/// Advances `sim` by `steps` steps.
///
/// With `output`, hands it the frames [`FrameOutput`] describes (a trace, an
/// export). `progress` is called with the number of steps done so far,
/// about a hundred times over the run.
pub fn run(
    sim: &mut Simulation,
    steps: u64,
    mut output: Option<FrameOutput<'_>>,
    mut progress: impl FnMut(u64),
) -> Result<RunSummary, RunError> {
    let chunk = match &output {
        Some(o) => o.every.max(1),
        None => (steps / 100).max(1),
    };
    if let Some(o) = output.as_mut() {
        (o.write)(sim)?;
    }
    let mut stepping = Duration::ZERO;
    let mut done = 0;
    let mut history = crate::sim::StrainHistory::default();
    let mut newton = 0u64;
    let searches_before = sim.self_collision_searches();
    let held_before = sim.self_collision_top_speed().map(|(_, (_, total))| total);
    while done < steps {
        let n = chunk.min(steps - done);
        for _ in 0..n {
            let start = Instant::now();
            sim.advance(1)?;
            stepping += start.elapsed();
            history.record(sim.edge_strain());
            newton += sim.last_projection().map_or(0, |r| u64::from(r.iterations));
        }
        done += n;
        if let Some(o) = output.as_mut() {
            // A frame on each multiple of `every`, and at the end.
            (o.write)(sim)?;
        }
        progress(done);
    }
    let seconds = stepping.as_secs_f64();
    let projections = sim.projections_per_step() as f64 * steps as f64;
    Ok(RunSummary {
        particles: sim.positions().len(),
        bars: sim.movable_bar_count(),
        total_mass: sim.masses().iter().map(|&m| f64::from(m)).sum(),
        steps,
        relaxations: sim.params().relaxations,
        substeps: sim.params().substeps,
        coarse: (sim.params().coarse_passes, sim.coarse_levels()),
        solver: sim.solver().name(),
        simd: crate::sim::fast::simd::describe(),
        layout: sim.solver_description(),
        seconds_per_step: if steps > 0 { seconds / steps as f64 } else { 0.0 },
        projections_per_second: if seconds > 0.0 { projections / seconds } else { 0.0 },
        time: sim.time(),
        strain: sim.strain(),
        edge_strain: sim.edge_strain(),
        edge_strain_over_run: (history.mean_max(), history.worst_max),
        newton: sim.last_projection().map(|_| newton as f64 / steps.max(1) as f64),
        self_collision: sim.self_collision_searches().map(|(searches, substeps)| {
            let (s0, n0) = searches_before.unwrap_or((0, 0));
            (searches.saturating_sub(s0), substeps.saturating_sub(n0))
        }),
        top_speed: sim.self_collision_top_speed().map(|(speed, (held, total))| {
            let n = sim.positions().len().max(1) as f64;
            let substeps = sim.self_collision_searches().map_or(0, |(_, s)| s);
            let substeps = substeps.saturating_sub(searches_before.map_or(0, |(_, s)| s));
            let held_run = total.saturating_sub(held_before.unwrap_or(0));
            TopSpeed {
                speed,
                held_last: held as f64 / n,
                held_run: if substeps > 0 { held_run as f64 / (substeps as f64 * n) } else { 0.0 },
            }
        }),
        kinetic_energy: sim.kinetic_energy(),
        warning: crate::sim::health::check(sim, sim.edge_strain().max).map(|a| a.to_string()),
    })
}

/// The CSV header of a trace.
pub const TRACE_HEADER: &str = "step,time,particle,x,y,z";

/// One CSV row per particle: `step,time,particle,x,y,z`.
pub fn write_trace_rows(w: &mut dyn Write, sim: &Simulation) -> std::io::Result<()> {
    let (step, time) = (sim.steps(), sim.time());
    for (i, p) in sim.positions().iter().enumerate() {
        writeln!(w, "{step},{time},{i},{},{},{}", p.x, p.y, p.z)?;
    }
    Ok(())
}

/// The JSON that `drape run --out` writes.
#[derive(Serialize)]
pub struct StateFile<'a> {
    /// The scene's name.
    pub scene: &'a str,
    /// Simulated seconds.
    pub time: f64,
    /// Steps since the start.
    pub steps: u64,
    /// One `[x, y, z]` per particle, in scene order, metres.
    pub positions: Vec<[f32; 3]>,
    /// The run's figures.
    pub metrics: &'a RunSummary,
}

/// Writes the state and summary as JSON.
pub fn write_state_json(w: impl Write, scene: &str, sim: &Simulation, summary: &RunSummary) -> std::io::Result<()> {
    let state = StateFile {
        scene,
        time: sim.time(),
        steps: sim.steps(),
        positions: sim.positions().iter().map(|p| p.to_array()).collect(),
        metrics: summary,
    };
    serde_json::to_writer_pretty(w, &state).map_err(std::io::Error::other)
}
