//! The `drape` command line: the viewer by default, and headless commands.

use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use drape::headless;
use drape::scene;
use drape::sim::SolverKind;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// drape: cloth as particles and bars, Verlet integration and relaxation.
///
/// With no command, opens the viewer on a scene (the seed's by default).
#[derive(Parser, Debug)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Scene for the viewer: a bundled name (see `drape scenes`) or a TOML file.
    #[arg(long, default_value = "seed")]
    scene: String,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scene headless and report strain, energy and speed.
    // Negative numbers are values, so `--mass -1` reaches the parameters'
    // check and says what is allowed instead of clap's "unexpected argument".
    #[command(allow_negative_numbers = true)]
    Run(Box<RunArgs>),
    /// List the bundled scenes.
    Scenes,
    /// Run a scene headless and write one rendered frame as a PNG (needs no
    /// display: a software rasteriser will do).
    #[cfg(feature = "viewer")]
    #[command(allow_negative_numbers = true)]
    Render(Box<RenderArgs>),
    /// List the graphics adapters wgpu can see and which one drape uses.
    #[cfg(feature = "viewer")]
    Adapters,
}

/// Overrides of the scene's `[solver]` values.
#[derive(Args, Debug, Default)]
struct SolverOverrides {
    /// Relaxation passes per step (0–100000).
    #[arg(long, value_parser = parse_count::<u32>)]
    relaxations: Option<u32>,
    /// Time step h in seconds (1e-6 ≤ h ≤ 1).
    #[arg(long)]
    dt: Option<f32>,
    /// Damping δ (0 ≤ δ < 1).
    #[arg(long)]
    damping: Option<f32>,
    /// Particle mass m in kilograms.
    #[arg(long)]
    mass: Option<f32>,
    /// Solver: fast or reference.
    #[arg(long, value_parser = parse_solver)]
    solver: Option<SolverKind>,
    /// Substeps per step (1–1000); give each at least 2 relaxations.
    #[arg(long, value_parser = parse_count::<u32>)]
    substeps: Option<u32>,
    /// XPBD compliance of structural bars, m/N (0 = rigid).
    #[arg(long)]
    stretch_compliance: Option<f32>,
    /// XPBD compliance of bend bars, m/N (0 = rigid).
    #[arg(long)]
    bend_compliance: Option<f32>,
    /// XPBD compliance of shear bars, a grid's diagonals, m/N (0 = rigid; default: the stretch compliance)
    #[arg(long)]
    shear_compliance: Option<f32>,
    /// Over-relaxation ω of each projection (1 ≤ ω < 2).
    #[arg(long)]
    over_relaxation: Option<f32>,
    /// Turn tethers on with this slack (0–1).
    #[arg(long)]
    tether_slack: Option<f32>,
    /// Stop relaxing once every bar is within this relative strain (0 = off).
    #[arg(long)]
    tolerance: Option<f32>,
    /// First step: euler (the seed's equation 2) or second-order.
    #[arg(long, value_parser = parse_start)]
    start: Option<drape::sim::Start>,
    /// Metres every particle keeps from collider surfaces (0–10).
    #[arg(long)]
    thickness: Option<f32>,
    /// Coulomb friction of colliders that give none of their own (0–100).
    #[arg(long)]
    friction: Option<f32>,
    /// Turn self-collision on (the cloth kept `thickness` from itself).
    #[arg(long)]
    self_collision: bool,
    /// Inextensible edges: a global Newton projection after the passes
    /// puts every edge back to its rest length each substep.
    #[arg(long)]
    inextensible: bool,
    /// With --inextensible: the most Newton iterations per substep (1–100).
    #[arg(long, value_parser = parse_count::<u32>)]
    newton_iterations: Option<u32>,
    /// With --inextensible: the edge strain that ends the iterations (0–1).
    #[arg(long)]
    newton_tolerance: Option<f32>,
    /// With --inextensible: Gauss–Seidel passes over the edges after each
    /// Newton iteration (0–1000).
    #[arg(long, value_parser = parse_count::<u32>)]
    newton_smoothing: Option<u32>,
    /// Passes over each coarser level of a grid (the grid taken 2, 4, 8, …
    /// particles apart) after the relaxation: removes the smooth stretch
    /// of a large cloth (0–100; 0 is off; grid meshes only).
    #[arg(long, value_parser = parse_count::<u32>)]
    coarse_passes: Option<u32>,
    /// A fabric preset: cotton, silk, denim, leather, jersey or rubber
    /// (density, stiffness, friction, thickness; gravity kept as an
    /// acceleration). Applied before the other flags.
    #[arg(long, value_parser = parse_material)]
    material: Option<drape::sim::Material>,
}

impl SolverOverrides {
    /// The scene's parameters with these overrides applied.
    fn apply(&self, mut params: drape::sim::SolverParams) -> drape::sim::SolverParams {
        if let Some(material) = self.material {
            material.select(&mut params);
        }
        if self.mass.is_some() {
            // A mass per particle replaces a mass per area.
            params.density = None;
        }
        params.relaxations = self.relaxations.unwrap_or(params.relaxations);
        params.dt = self.dt.unwrap_or(params.dt);
        params.damping = self.damping.unwrap_or(params.damping);
        params.mass = self.mass.unwrap_or(params.mass);
        params.substeps = self.substeps.unwrap_or(params.substeps);
        params.stretch_compliance = self.stretch_compliance.unwrap_or(params.stretch_compliance);
        params.bend_compliance = self.bend_compliance.unwrap_or(params.bend_compliance);
        params.shear_compliance = self.shear_compliance.or(params.shear_compliance);
        params.over_relaxation = self.over_relaxation.unwrap_or(params.over_relaxation);
        params.tether_slack = self.tether_slack.or(params.tether_slack);
        params.tolerance = self.tolerance.unwrap_or(params.tolerance);
        params.start = self.start.unwrap_or(params.start);
        params.thickness = self.thickness.unwrap_or(params.thickness);
        params.friction = self.friction.unwrap_or(params.friction);
        params.self_collision |= self.self_collision;
        params.inextensible |= self.inextensible;
        params.newton_iterations = self.newton_iterations.unwrap_or(params.newton_iterations);
        params.newton_tolerance = self.newton_tolerance.unwrap_or(params.newton_tolerance);
        params.newton_smoothing = self.newton_smoothing.unwrap_or(params.newton_smoothing);
        params.coarse_passes = self.coarse_passes.unwrap_or(params.coarse_passes);
        params
    }
}

fn parse_material(s: &str) -> Result<drape::sim::Material, String> {
    drape::sim::Material::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = drape::sim::Material::ALL.iter().map(|m| m.name()).collect();
        format!("unknown material '{s}'; choose one of {}", names.join(", "))
    })
}

fn parse_start(s: &str) -> Result<drape::sim::Start, String> {
    match s {
        "euler" => Ok(drape::sim::Start::Euler),
        "second-order" => Ok(drape::sim::Start::SecondOrder),
        _ => Err(format!("unknown start '{s}'; choose euler or second-order")),
    }
}

#[derive(Args, Debug)]
struct RunArgs {
    /// A bundled scene name (see `drape scenes`) or a scene TOML file.
    #[arg(long, default_value = "seed")]
    scene: String,
    /// Steps to take.
    #[arg(long, default_value_t = 1000, value_parser = parse_count::<u64>)]
    steps: u64,
    #[command(flatten)]
    overrides: SolverOverrides,
    /// Write the final positions, time and figures as JSON.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write a CSV trace: step, time, particle, x, y, z.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Export the motion: PATH ending in .glb writes one animated glTF file
    /// (morph targets keyed in time); PATH containing {frame} writes one
    /// OBJ per frame (e.g. out/cloth_{frame}.obj).
    #[arg(long, value_name = "PATH")]
    export: Option<PathBuf>,
    /// Trace and export every K-th step (and always the first and last).
    #[arg(long, default_value_t = 1, value_parser = parse_every)]
    every: u64,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

/// Which layers `drape render` draws.
#[cfg(feature = "viewer")]
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum RenderView {
    /// The lit surface (bars for a mesh without triangles).
    Surface,
    /// The bars coloured by strain, and the particles.
    Bars,
}

#[cfg(feature = "viewer")]
#[derive(Args, Debug)]
struct RenderArgs {
    /// A bundled scene name (see `drape scenes`) or a scene TOML file.
    #[arg(long, default_value = "seed")]
    scene: String,
    /// Steps to take before rendering.
    #[arg(long, default_value_t = 100, value_parser = parse_count::<u64>)]
    steps: u64,
    #[command(flatten)]
    overrides: SolverOverrides,
    /// The PNG to write; with --frames, a path containing {frame}
    /// (e.g. frames/{frame}.png), replaced by the zero-padded frame number.
    #[arg(long, default_value = "frame.png")]
    out: PathBuf,
    /// Write a sequence of N PNGs instead of one: the first after --steps
    /// steps, then one every --every steps, the camera fixed.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    frames: Option<u64>,
    /// With --frames: steps between frames.
    #[arg(long, default_value_t = 1, requires = "frames", value_parser = parse_every)]
    every: u64,
    /// Image size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "800x600", value_parser = parse_size)]
    size: (u32, u32),
    /// What to draw.
    #[arg(long, value_enum, default_value_t = RenderView::Surface)]
    view: RenderView,
    /// Camera as YAW,PITCH[,DISTANCE]: degrees about the vertical (0 looks
    /// along −z), degrees of elevation, metres from the cloth's centre.
    /// Default: the scene's own view.
    #[arg(long, value_parser = parse_camera, allow_hyphen_values = true)]
    camera: Option<(f32, f32, Option<f32>)>,
}

#[cfg(feature = "viewer")]
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT, e.g. 800x600"))?;
    let dim = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (1..=16384).contains(&n) => Ok(n),
        _ => Err(format!("'{v}' is not a size from 1 to 16384 pixels")),
    };
    Ok((dim(w)?, dim(h)?))
}

#[cfg(feature = "viewer")]
fn parse_camera(s: &str) -> Result<(f32, f32, Option<f32>), String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let number = |v: &str| v.parse::<f32>().ok().filter(|x| x.is_finite());
    let bad = || format!("'{s}' is not YAW,PITCH or YAW,PITCH,DISTANCE (degrees, degrees, metres)");
    match parts.as_slice() {
        [y, p] => Ok((number(y).ok_or_else(bad)?, number(p).ok_or_else(bad)?, None)),
        [y, p, d] => {
            let d = number(d).filter(|d| *d > 0.0).ok_or_else(bad)?;
            Ok((number(y).ok_or_else(bad)?, number(p).ok_or_else(bad)?, Some(d)))
        }
        _ => Err(bad()),
    }
}

/// `--every`: a whole number of steps, 1 or more (clap's own range check
/// would print the range's end, 18446744073709551615).
fn parse_every(s: &str) -> Result<u64, String> {
    match s.parse::<u64>() {
        Ok(0) => Err("0 steps is not allowed: give 1 (every step) or more".into()),
        Ok(k) => Ok(k),
        Err(_) => Err(format!("'{s}' is not a whole number of steps: give 1 (every step) or more")),
    }
}

/// A count (passes, substeps, steps): clap's own parser would answer `-3`
/// with the type's range, 0..=4294967295, which is not the flag's; the
/// flag's range is in its help and the parameters' check says it for a
/// number out of it.
fn parse_count<T: std::str::FromStr>(s: &str) -> Result<T, String> {
    s.parse().map_err(|_| format!("'{s}' is not a whole number (0, 1, 2, …); the flag's range is in --help"))
}

fn parse_solver(s: &str) -> Result<SolverKind, String> {
    SolverKind::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| {
        let names: Vec<_> = SolverKind::ALL.iter().map(|k| k.name()).collect();
        format!("unknown solver '{s}'; choose one of: {}", names.join(", "))
    })
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Run(args)) => run(*args),
        Some(Command::Scenes) => {
            list_scenes();
            Ok(())
        }
        #[cfg(feature = "viewer")]
        Some(Command::Render(args)) => render(*args),
        #[cfg(feature = "viewer")]
        Some(Command::Adapters) => {
            print!("{}", drape::render::gpu::adapters_report());
            Ok(())
        }
        None => viewer(&cli.scene),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn list_scenes() {
    let width = scene::BUNDLED.iter().map(|b| b.name.len()).max().unwrap_or(0);
    for b in scene::BUNDLED {
        match scene::load(b.name) {
            Ok(s) => println!("{:<width$}  {}", b.name, s.description),
            Err(e) => println!("{:<width$}  (broken: {e})", b.name),
        }
    }
}

fn load_scene(name: &str, overrides: &SolverOverrides) -> anyhow::Result<(scene::Scene, drape::sim::Simulation)> {
    let scene = scene::load(name)?;
    let params = overrides.apply(scene.params.clone());
    params.validate().context("invalid command-line override")?;
    let solver = overrides.solver.unwrap_or(scene.solver);
    let sim = drape::sim::Simulation::with_solver(scene.mesh.clone(), params, solver)?
        .with_colliders(scene.colliders.clone());
    Ok((scene, sim))
}

fn run(args: RunArgs) -> anyhow::Result<()> {
    let (scene, mut sim) = load_scene(&args.scene, &args.overrides)?;
    let mut trace = match &args.trace {
        Some(path) => {
            let mut w = BufWriter::new(
                File::create(path).with_context(|| format!("cannot create trace file {}", path.display()))?,
            );
            writeln!(w, "{}", headless::TRACE_HEADER).context("cannot write the trace")?;
            Some(w)
        }
        None => None,
    };
    // Checked before the run: a path that names no format, or glTF of a
    // mesh without triangles, fails at once.
    let frames = headless::frame_count(args.steps, args.every);
    let mut exporter = match &args.export {
        Some(path) => {
            Some(drape::export::Exporter::new(path, sim.mesh().clone(), usize::try_from(frames).unwrap_or(usize::MAX))?)
        }
        None => None,
    };
    let mut write_frame = |sim: &drape::sim::Simulation| -> Result<(), headless::RunError> {
        if let Some(w) = trace.as_mut() {
            headless::write_trace_rows(w, sim).map_err(headless::RunError::Trace)?;
        }
        if let Some(e) = exporter.as_mut() {
            e.frame(sim)?;
        }
        Ok(())
    };
    // The bar appears on a terminal once a run has taken a second; never
    // when stderr is redirected or with --quiet.
    let bar = ProgressBar::with_draw_target(Some(args.steps), ProgressDrawTarget::hidden());
    bar.set_style(ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} steps, eta {eta}",
    )?);
    let show_bar = !args.quiet && std::io::stderr().is_terminal();
    let started = std::time::Instant::now();
    let mut shown = false;
    let progress = |done| {
        if show_bar && !shown && started.elapsed().as_secs_f64() > 1.0 {
            bar.set_draw_target(ProgressDrawTarget::stderr());
            bar.enable_steady_tick(std::time::Duration::from_millis(200));
            shown = true;
        }
        bar.set_position(done);
    };
    let output = (args.trace.is_some() || args.export.is_some())
        .then_some(headless::FrameOutput { write: &mut write_frame, every: args.every });
    let summary =
        headless::run(&mut sim, args.steps, output, progress).with_context(|| format!("running {}", scene.source))?;
    bar.finish_and_clear();
    if let Some(mut w) = trace {
        w.flush().context("cannot write the trace")?;
    }
    let exported = exporter.map(drape::export::Exporter::finish).transpose()?;
    println!("{}: {}", scene.name, scene.source);
    println!("{summary}");
    if let Some(path) = &args.out {
        let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        headless::write_state_json(BufWriter::new(file), &scene.name, &sim, &summary)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if let Some(report) = exported {
        if report.files == 1 {
            println!("exported {} frames → {}", report.frames, report.first.display());
        } else {
            println!(
                "exported {} frames → {} files, the first {}",
                report.frames,
                report.files,
                report.first.display()
            );
        }
    }
    Ok(())
}

#[cfg(feature = "viewer")]
fn render(args: RenderArgs) -> anyhow::Result<()> {
    use drape::render::{self, AdapterPreference, Gpu, OffscreenTarget, Renderer, ViewOptions};

    let (scene, mut sim) = load_scene(&args.scene, &args.overrides)?;
    sim.advance(args.steps).with_context(|| format!("running {}", scene.source))?;
    let gpu = Gpu::headless(AdapterPreference::Hardware)?;
    log::info!("rendering on {}", gpu.adapter_summary());
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT);
    let options = match args.view {
        RenderView::Surface => ViewOptions::for_mesh(&scene.mesh),
        RenderView::Bars => ViewOptions::bars_view().adapted_to(&scene.mesh),
    };
    let mut hint = scene.camera;
    if let Some((yaw, pitch, distance)) = args.camera {
        hint.yaw_degrees = yaw;
        hint.pitch_degrees = pitch;
        hint.distance = distance.or(hint.distance);
    }
    let (width, height) = args.size;
    let camera = render::start_camera(&hint, &sim, width as f32 / height as f32);
    let Some(frames) = args.frames else {
        let image = drape::app::snapshot(&gpu, &mut renderer, &sim, &camera, &options, args.size)?;
        render::write_png(&args.out, &image).with_context(|| format!("cannot write {}", args.out.display()))?;
        println!(
            "{}: {} steps ({:.3} s simulated), {}x{} → {}",
            scene.name,
            sim.steps(),
            sim.time(),
            width,
            height,
            args.out.display()
        );
        return Ok(());
    };
    let pattern = args.out.to_string_lossy().into_owned();
    anyhow::ensure!(
        pattern.contains(drape::export::FRAME_PLACEHOLDER),
        "--frames writes one PNG per frame, so --out must contain {{frame}} (e.g. frames/{{frame}}.png), not '{pattern}'"
    );
    let digits = drape::export::frame_digits(usize::try_from(frames).unwrap_or(usize::MAX));
    for k in 0..frames {
        if k > 0 {
            sim.advance(args.every).with_context(|| format!("running {}", scene.source))?;
        }
        let image = drape::app::snapshot(&gpu, &mut renderer, &sim, &camera, &options, args.size)?;
        let path = drape::export::frame_path(&pattern, k as usize, digits);
        drape::export::create_parent(&path)?;
        render::write_png(&path, &image).with_context(|| format!("cannot write {}", path.display()))?;
    }
    println!(
        "{}: {frames} frames {} steps apart, to {} s simulated, {}x{} → {}",
        scene.name,
        args.every,
        sim.time(),
        width,
        height,
        drape::export::frame_path(&pattern, 0, digits).display()
    );
    Ok(())
}

#[cfg(feature = "viewer")]
fn viewer(scene_name: &str) -> anyhow::Result<()> {
    let scene = scene::load(scene_name)?;
    drape::app::run(scene)?;
    Ok(())
}

#[cfg(not(feature = "viewer"))]
fn viewer(_scene_name: &str) -> anyhow::Result<()> {
    anyhow::bail!(
        "this drape was built without the `viewer` feature, so it has no window; \
         `drape run` works, or rebuild with default features"
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn run_arguments_parse() {
        let cli =
            Cli::try_parse_from(["drape", "run", "--scene", "flag", "--steps", "5", "--relaxations", "3"]).unwrap();
        let Some(Command::Run(args)) = cli.command else { panic!("not a run command") };
        assert_eq!((args.scene.as_str(), args.steps, args.overrides.relaxations), ("flag", 5, Some(3)));
        let every = Cli::try_parse_from(["drape", "run", "--every", "0"]).map(|_| ()).unwrap_err().to_string();
        assert!(every.contains("give 1 (every step) or more") && !every.contains("18446744073709551615"), "{every}");
        let Some(Command::Run(args)) = Cli::try_parse_from(["drape", "run", "--every", "7"]).unwrap().command else {
            panic!("not a run command")
        };
        assert_eq!(args.every, 7);
        assert!(Cli::try_parse_from(["drape", "run", "--solver", "magic"]).is_err());
    }

    /// A negative value is a value: clap's default reads `-1` as an unknown
    /// flag ("unexpected argument '-1' found"), which names neither the
    /// parameter nor what it allows. Parsed, the parameters' own check says
    /// both.
    #[test]
    fn a_negative_value_reaches_the_parameters_check() {
        for (flag, value, allowed) in [("--mass", -1.0, "1e-9 <= mass"), ("--damping", -0.5, "0 <= damping < 1")] {
            let text = value.to_string();
            let cli = Cli::try_parse_from(["drape", "run", flag, text.as_str()]).unwrap();
            let Some(Command::Run(args)) = cli.command else { panic!("not a run command") };
            assert_eq!(args.overrides.mass.or(args.overrides.damping), Some(value));
            let error = format!("{:#}", load_scene("seed", &args.overrides).map(|_| ()).unwrap_err());
            assert!(error.contains("invalid command-line override") && error.contains(allowed), "{error}");
        }
        // An unsigned count still says it wants a number it can take.
        let relaxations =
            Cli::try_parse_from(["drape", "run", "--relaxations", "-3"]).map(|_| ()).unwrap_err().to_string();
        assert!(
            relaxations.contains("--relaxations")
                && relaxations.contains("'-3' is not a whole number")
                && !relaxations.contains("4294967295"),
            "{relaxations}"
        );
        // In range for the type but not the parameter: the check names the range.
        let cli = Cli::try_parse_from(["drape", "run", "--substeps", "0"]).unwrap();
        let Some(Command::Run(args)) = cli.command else { panic!("not a run command") };
        let error = format!("{:#}", load_scene("seed", &args.overrides).map(|_| ()).unwrap_err());
        assert!(error.contains("substeps = 0 is not allowed"), "{error}");
    }
}
