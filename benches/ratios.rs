//! Issue 14's ratios measured in one process, window by window.
//!
//! `cargo bench --no-default-features --bench ratios [-- FILTER…] [--rounds N] [--window-ms M] [--levels avx512,avx2,portable]`
//!
//! Criterion (`benches/solver.rs`) times each benchmark on its own, a
//! minute or more apart; on a shared host whose load comes and goes (host
//! D's one-thread step has read anything from 17 to 38 ms within an hour)
//! the ratio of two such times moves with the load as much as with the
//! code. Here every run of a comparison (the reference solver, the fast
//! one at each kernel level, a phase on and off) takes a window of steps
//! in turn, round after round, the order rotated every round: whatever the
//! host does falls on all of them, and each ratio is taken within one
//! round. The kernel level is switched between windows with
//! [`drape::sim::fast::simd::force`] (AVX2 and AVX-512 compute the same
//! bits), and the AVX-512 level's vector width with
//! [`drape::sim::fast::simd::force_width`] (the seed's scene, 256 × 256 and
//! each phase's comparison also run AVX-512 at the width this CPU does not
//! take by default).
//!
//! Each run steps its own simulation on from window to window, from a
//! warmed-up state shared by the runs of a comparison (as criterion steps
//! one simulation on from sample to sample). A window is as many steps as
//! fill `--window-ms` (default 100 ms), at least one; a first round, not
//! counted, sizes the windows and warms the caches.
//!
//! Printed for each comparison: the median time a step of each run and
//! the range over rounds; each ratio as the median over rounds (with its
//! range) against the target; on one thread, ns a bar projection,
//! counted over every bar and over the bars projected (those with an end
//! that is not fixed: a bar between two fixed ends is skipped by the fast
//! solver's coloured path); and, where Linux's `/proc/stat` can be read,
//! the steal time over the comparison (the hypervisor running something
//! else while a vCPU of ours was ready to run), so that a guest's slow
//! minutes can be told from the host taking its vCPUs away.
//!
//! Beside the medians, for each speed-up over the reference: the ratio of
//! the reference's quickest window to the run's quickest, and ns a
//! projection in the run's quickest window. A shared host's load only adds
//! time, and on some hosts it comes in spells that slow the fast kernels
//! far more than the reference (on host F, an Emerald Rapids Xeon, the
//! seed's fast step reads 67–72 or 117–126 µs within one process while the
//! reference's moves by 15 %), so the quickest windows say what the code
//! does on a quiet machine. Targets are judged on the medians.
//!
//! FILTER keeps the comparisons whose name contains it (`seed`, `256`,
//! `tablecloth`, `disc-183`, `contact`, `self-collision`, `air`).

mod scenes;

use std::time::{Duration, Instant};

use drape::sim::fast::simd::{self, SimdLevel, VectorWidth};
use drape::sim::{Simulation, SolverKind, SolverParams};
use scenes::{
    blowing, disc_params, draped_256, draped_disc, folded_256, hanging_in_air, hanging_params, hanging_square,
    lying_params, ring_disc, warmed,
};

/// Where a run's steps execute.
#[derive(Clone, Copy, PartialEq)]
enum Threads {
    /// A one-thread pool.
    One,
    /// The global pool (every core).
    All,
}

/// One run of a comparison: its simulation, the kernel level it steps at
/// (`None` for the reference solver, which has no lanes), where its steps
/// execute, and the run its ratio is taken against.
struct Run {
    label: String,
    sim: Simulation,
    level: Option<SimdLevel>,
    /// The AVX-512 level's vector width ([`simd::width`]).
    width: VectorWidth,
    threads: Threads,
    /// The run this one's ratio is against (its own index for a base).
    base: usize,
    /// Steps a window (sized before the rounds).
    steps: u32,
    /// Seconds a step, one value a round.
    per_step: Vec<f64>,
}

/// What a ratio is held to.
#[derive(Clone, Copy)]
enum Target {
    /// base / run at least this (a speed-up over the reference).
    AtLeast(f64),
    /// run / base at most this (the cost of a phase).
    AtMost(f64),
}

/// The target a run's ratio is held to (None: none, or the base).
type TargetOf = Box<dyn Fn(&Run) -> Option<Target>>;

/// Runs timed together.
struct Comparison {
    runs: Vec<Run>,
    target: TargetOf,
}

fn main() {
    let options = match Options::parse(std::env::args().skip(1)) {
        Ok(options) => options,
        Err(e) => {
            eprintln!("ratios: {e}");
            std::process::exit(2);
        }
    };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    let asked = options.levels.clone().unwrap_or_else(|| vec![SimdLevel::Avx512, SimdLevel::Avx2]);
    for &level in asked.iter().filter(|&&l| l > SimdLevel::best_available()) {
        println!("# {} left out: this CPU's best level is {}", level.label(), SimdLevel::best_available().label());
    }
    let levels: Vec<SimdLevel> = asked.into_iter().filter(|&l| l <= SimdLevel::best_available()).collect();
    let levels = if levels.is_empty() { vec![SimdLevel::Portable] } else { levels };
    let before = simd::level();
    let before_width = default_width();
    println!(
        "# Ratios in one process on {} (best level {}): {} rounds, windows of {} ms; levels {}; {} threads in the global pool",
        cpu_name(),
        SimdLevel::best_available().label(),
        options.rounds,
        options.window.as_millis(),
        levels.iter().map(|l| l.label()).collect::<Vec<_>>().join(", "),
        rayon::current_num_threads()
    );
    for (name, build) in comparisons() {
        if !options.keeps(name) {
            continue;
        }
        let mut comparison = build(&levels);
        let before = cpu_ticks();
        measure(&mut comparison, &options, &one);
        report(name, &comparison);
        if let (Some(before), Some(after)) = (before, cpu_ticks()) {
            report_steal(before, after);
        }
    }
    simd::force(before);
    simd::force_width(before_width);
}

/// The width the runs take unless they ask for another: the process's
/// (`DRAPE_SIMD_WIDTH`, else the CPU's default), read once, before any is
/// forced (`main` reads it first).
fn default_width() -> VectorWidth {
    static DEFAULT: std::sync::OnceLock<VectorWidth> = std::sync::OnceLock::new();
    *DEFAULT.get_or_init(simd::width)
}

/// The AVX-512 level's other width than the default, for the grid's
/// comparison (the width changes only the kernels the compiler vectorises:
/// the grid's sweeps and the collide phases).
fn other_width() -> VectorWidth {
    match default_width() {
        VectorWidth::Bits256 => VectorWidth::Bits512,
        VectorWidth::Bits512 => VectorWidth::Bits256,
    }
}

/// Builds a comparison's runs for the kernel levels given.
type Build = fn(&[SimdLevel]) -> Comparison;

/// The comparisons, by name, each built only when its name is kept.
fn comparisons() -> Vec<(&'static str, Build)> {
    vec![
        ("seed, 20 relaxations, 1 thread", seed),
        ("256 x 256, 20 relaxations, all threads", square_256),
        ("tablecloth, 20 relaxations, 1 thread", tablecloth),
        ("disc-183, 20 relaxations, all threads and 1 thread", disc_183),
        ("contact, 256 x 256 draped, all threads", contact_256),
        ("contact, disc-183 draped, all threads", contact_disc),
        ("self-collision, 256 x 256 folded, all threads", self_256),
        ("self-collision, disc-183 draped, all threads", self_disc),
        ("air, 256 x 256 hanging, all threads", air_256),
    ]
}

/// The reference solver and the fast one at each level, on `threads`
/// (and, with `also_one`, on one thread too), from the same scene.
fn speedups(
    mesh: drape::sim::ClothMesh,
    params: SolverParams,
    levels: &[SimdLevel],
    threads: Threads,
    also_one: bool,
    target: impl Fn(&Run) -> Option<Target> + 'static,
) -> Comparison {
    let mut runs =
        vec![run("reference", warmed(mesh.clone(), params.clone(), SolverKind::Reference), None, threads, 0)];
    let fast = warmed(mesh, params, SolverKind::Fast);
    let mut places = vec![threads];
    if also_one && threads == Threads::All {
        places.push(Threads::One);
    }
    for &place in &places {
        for &level in levels {
            runs.push(run("fast", fast.clone(), Some(level), place, 0));
        }
    }
    Comparison { runs, target: Box::new(target) }
}

/// A phase's cost: the same state with the phase off (`without`, the base)
/// and on (`with`), at each level; the step with it at most `most` times
/// the step without.
fn phase(without: Simulation, with: Simulation, levels: &[SimdLevel], most: f64) -> Comparison {
    let mut runs = Vec::new();
    for &level in levels {
        let base = runs.len();
        runs.push(run("without", without.clone(), Some(level), Threads::All, base));
        runs.push(run("with", with.clone(), Some(level), Threads::All, base));
    }
    // And AVX-512 at its other vector width: the width changes the compiled
    // kernels a phase runs beside (the grid's sweeps) or in (the coloured
    // path's collide phase), and which width costs less differs between
    // CPUs.
    if levels.contains(&SimdLevel::Avx512) {
        let base = runs.len();
        for (label, sim) in [("without", without), ("with", with)] {
            let mut other = run(label, sim, Some(SimdLevel::Avx512), Threads::All, base);
            other.width = other_width();
            runs.push(other);
        }
    }
    Comparison { runs, target: Box::new(move |r| (r.label == "with").then_some(Target::AtMost(most))) }
}

/// The phase targets: a step with contact, self-collision or
/// moving air at most this many times the step without.
const CONTACT_MOST: f64 = 1.25;
const SELF_MOST: f64 = 1.5;
const AIR_MOST: f64 = 1.2;

fn run(label: &str, sim: Simulation, level: Option<SimdLevel>, threads: Threads, base: usize) -> Run {
    let width = default_width();
    Run { label: label.to_string(), sim, level, width, threads, base, steps: 0, per_step: Vec::new() }
}

fn seed(levels: &[SimdLevel]) -> Comparison {
    let scene = drape::scene::load("seed").expect("bundled scene");
    let params = SolverParams { relaxations: 20, ..scene.params.clone() };
    // ≥ 10× at AVX2 (an AVX2-only host), ≥ 16× where AVX-512 exists.
    let comparison = speedups((*scene.mesh).clone(), params, levels, Threads::One, false, |r| match r.level {
        Some(SimdLevel::Avx512) => Some(Target::AtLeast(16.0)),
        Some(_) => Some(Target::AtLeast(10.0)),
        None => None,
    });
    with_other_width(comparison, levels, Threads::One)
}

/// `comparison` with one more run: the fast solver (its run 1) at AVX-512
/// at the vector width this CPU does not take by default, to show which
/// width is the quicker here (the grid's sweeps are compiled kernels).
fn with_other_width(mut comparison: Comparison, levels: &[SimdLevel], threads: Threads) -> Comparison {
    if levels.contains(&SimdLevel::Avx512) {
        let fast = comparison.runs[1].sim.clone();
        let mut other = run("fast", fast, Some(SimdLevel::Avx512), threads, 0);
        other.width = other_width();
        comparison.runs.push(other);
    }
    comparison
}

fn square_256(levels: &[SimdLevel]) -> Comparison {
    // ≥ 20× on both cores (the issue asks it of an AVX2-only host).
    let comparison = speedups(hanging_square(256), hanging_params(), levels, Threads::All, false, |r| {
        r.level.map(|_| Target::AtLeast(20.0))
    });
    with_other_width(comparison, levels, Threads::All)
}

fn tablecloth(levels: &[SimdLevel]) -> Comparison {
    let scene = drape::scene::load("tablecloth").expect("bundled scene");
    let params = SolverParams { relaxations: 20, ..scene.params.clone() };
    // ≥ 8× on one thread.
    speedups((*scene.mesh).clone(), params, levels, Threads::One, false, |r| r.level.map(|_| Target::AtLeast(8.0)))
}

fn disc_183(levels: &[SimdLevel]) -> Comparison {
    // ≥ 15× on both cores; on one thread the target is ≤ 1.5 ns a
    // projection (printed beside it), not a ratio.
    speedups(ring_disc(183, 0.02), hanging_params(), levels, Threads::All, true, |r| {
        (r.level.is_some() && r.threads == Threads::All).then_some(Target::AtLeast(15.0))
    })
}

fn contact_256(levels: &[SimdLevel]) -> Comparison {
    let with = draped_256();
    let mut without = with.clone();
    without.set_colliders(vec![]);
    phase(without, with, levels, CONTACT_MOST)
}

fn contact_disc(levels: &[SimdLevel]) -> Comparison {
    let with = draped_disc(lying_params());
    let mut without = with.clone();
    without.set_colliders(vec![]);
    phase(without, with, levels, CONTACT_MOST)
}

fn self_256(levels: &[SimdLevel]) -> Comparison {
    phase(folded_256(false), folded_256(true), levels, SELF_MOST)
}

fn self_disc(levels: &[SimdLevel]) -> Comparison {
    let with = draped_disc(disc_params(true));
    let mut without = with.clone();
    without.set_params(disc_params(false)).expect("valid parameters");
    phase(without, with, levels, SELF_MOST)
}

fn air_256(levels: &[SimdLevel]) -> Comparison {
    phase(hanging_in_air(None), hanging_in_air(Some(blowing())), levels, AIR_MOST)
}

/// Times `steps` steps of the run's simulation, at its level and on its
/// threads: seconds a step.
fn window(run: &mut Run, steps: u32, one: &rayon::ThreadPool) -> f64 {
    if let Some(level) = run.level {
        simd::force(level);
        simd::force_width(run.width);
    }
    let sim = &mut run.sim;
    let mut timed = || {
        let t = Instant::now();
        for _ in 0..steps {
            sim.step().expect("the benchmark scene does not blow up");
        }
        t.elapsed().as_secs_f64() / f64::from(steps)
    };
    match run.threads {
        Threads::One => one.install(timed),
        Threads::All => timed(),
    }
}

/// Every round, every run one window, starting one run further along each
/// round. Before, one step of each run sizes its window, and a round not
/// counted warms up.
fn measure(comparison: &mut Comparison, options: &Options, one: &rayon::ThreadPool) {
    for run in &mut comparison.runs {
        let step = window(run, 1, one);
        run.steps = ((options.window.as_secs_f64() / step.max(1e-9)).round() as u32).max(1);
        window(run, run.steps, one);
    }
    let n = comparison.runs.len();
    for round in 0..options.rounds {
        for k in 0..n {
            let run = &mut comparison.runs[(round + k) % n];
            let steps = run.steps;
            let t = window(run, steps, one);
            run.per_step.push(t);
        }
    }
}

/// The median of `values` (the mean of the middle two for an even count).
fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let m = sorted.len() / 2;
    if sorted.len().is_multiple_of(2) { 0.5 * (sorted[m - 1] + sorted[m]) } else { sorted[m] }
}

/// A run's quickest window: seconds a step.
fn quickest_window(run: &Run) -> f64 {
    range(&run.per_step).0
}

fn range(values: &[f64]) -> (f64, f64) {
    values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
}

fn report(name: &str, comparison: &Comparison) {
    println!("\n## {name}\n");
    println!(
        "| run | ms a step, median (range) | ratio, median (range) | target | quickest windows' ratio | ns a projection, every bar / projected: median (quickest window) |"
    );
    println!("|---|---|---|---|---|---|");
    for (index, run) in comparison.runs.iter().enumerate() {
        let base = &comparison.runs[run.base];
        let ms: Vec<f64> = run.per_step.iter().map(|t| t * 1e3).collect();
        let (lo, hi) = range(&ms);
        let name = match (run.level, run.threads) {
            (None, _) => run.label.clone(),
            (Some(level), threads) => {
                let width =
                    if level == SimdLevel::Avx512 { format!(" ({}-bit)", run.width.name()) } else { String::new() };
                let place = if threads == Threads::One { ", 1 thread" } else { "" };
                format!("{} {}{width}{place}", run.label, level.label())
            }
        };
        let target = (comparison.target)(run);
        let cost = matches!(target, Some(Target::AtMost(_)));
        // Within each round: base over run for a speed-up, run over base
        // for a cost.
        let ratios: Vec<f64> =
            run.per_step.iter().zip(&base.per_step).map(|(t, b)| if cost { t / b } else { b / t }).collect();
        let (ratio, verdict, quickest) = if run.base == index || ratios.is_empty() {
            ("base".to_string(), String::new(), String::new())
        } else {
            let (rlo, rhi) = range(&ratios);
            let r = median(&ratios);
            // The targets are held at the AVX levels; the portable
            // level (a CPU without AVX2) is measured beside them.
            let verdict = match target {
                _ if run.level == Some(SimdLevel::Portable) && target.is_some() => "not held at this level".to_string(),
                Some(Target::AtLeast(t)) => format!("≥ {t}×: {}", if r >= t { "met" } else { "missed" }),
                Some(Target::AtMost(t)) => format!("≤ {t}×: {}", if r <= t { "met" } else { "missed" }),
                None => String::new(),
            };
            // A phase's cost to three decimals, so that a median just over
            // its target does not print as the target itself.
            let digits = if cost { 3 } else { 2 };
            // Each run's quickest window against its base's: what the code
            // does when the host leaves it alone (load only adds time), for
            // reading a noisy host's medians; the verdict stays the median's.
            // Speed-ups only: a phase's two runs both step the fast kernels,
            // which the host's spells slow alike, and the ratio of two
            // single windows is noisier than the median of the rounds'.
            let best =
                if cost { String::new() } else { format!("{:.2}×", quickest_window(base) / quickest_window(run)) };
            (format!("{r:.digits$}× ({rlo:.digits$}–{rhi:.digits$})"), verdict, best)
        };
        let ns = if run.threads == Threads::One && run.level.is_some() {
            let (t, best) = (median(&run.per_step) * 1e9, quickest_window(run) * 1e9);
            let (every, moving) = (run.sim.projections_per_step() as f64, projected(&run.sim) as f64);
            format!("{:.2} / {:.2} ({:.2} / {:.2})", t / every, t / moving, best / every, best / moving)
        } else {
            String::new()
        };
        println!("| {name} | {:.3} ({lo:.3}–{hi:.3}) | {ratio} | {verdict} | {quickest} | {ns} |", median(&ms));
    }
}

/// The CPU's model name with its family and model numbers, as Linux
/// reports them (`/proc/cpuinfo`; a virtual machine's name may be as short
/// as "AMD EPYC", and the numbers tell its generation), else "this CPU".
fn cpu_name() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |key: &str| {
        let line = info.lines().find(|l| l.split(':').next().is_some_and(|k| k.trim() == key))?;
        Some(line.split_once(':')?.1.trim().to_string())
    };
    match (field("model name"), field("cpu family"), field("model")) {
        (Some(name), Some(family), Some(model)) => format!("{name} (family {family}, model {model})"),
        (Some(name), _, _) => name,
        _ => "this CPU".to_string(),
    }
}

/// The CPU time of every vCPU so far and the part of it stolen, in clock
/// ticks: the `cpu` line of `/proc/stat` (user, nice, system, idle,
/// iowait, irq, softirq, steal; guest time is already in user). `None`
/// where it cannot be read (not Linux).
fn cpu_ticks() -> Option<(u64, u64)> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    let line = stat.lines().find(|l| l.split_whitespace().next() == Some("cpu"))?;
    let fields: Vec<u64> = line.split_whitespace().skip(1).take(8).map(|f| f.parse().ok()).collect::<Option<_>>()?;
    Some((fields.iter().sum(), *fields.get(7)?))
}

/// Prints the steal time between two [`cpu_ticks`] readings, as a share
/// of all the vCPUs' time (idle included) over the comparison.
fn report_steal(before: (u64, u64), after: (u64, u64)) {
    let all = after.0.saturating_sub(before.0);
    let steal = after.1.saturating_sub(before.1);
    if all > 0 {
        println!(
            "\nSteal time over this comparison: {:.1} % of the vCPUs' time ({steal} of {all} ticks, /proc/stat).",
            100.0 * steal as f64 / all as f64
        );
    }
}

/// Bar projections a step over the bars with an end that is not fixed.
fn projected(sim: &Simulation) -> u64 {
    let fixed = sim.fixed();
    let moving = sim.mesh().bars().iter().filter(|b| !(fixed[b.a as usize] && fixed[b.b as usize])).count() as u64;
    let per_bar = sim.projections_per_step() / (sim.mesh().bars().len() as u64).max(1);
    moving * per_bar
}

/// The command line: filters, `--rounds N`, `--window-ms M`, `--levels
/// L,L…` (of `avx512`, `avx2`, `portable`; default `avx512,avx2`, those
/// the CPU has); cargo's own `--bench` is ignored.
struct Options {
    filters: Vec<String>,
    rounds: usize,
    window: Duration,
    levels: Option<Vec<SimdLevel>>,
}

impl Options {
    fn parse(mut args: impl Iterator<Item = String>) -> Result<Self, String> {
        let mut options = Options { filters: Vec::new(), rounds: 20, window: Duration::from_millis(100), levels: None };
        while let Some(arg) = args.next() {
            let mut value = |name: &str, low: u64, high: u64| -> Result<u64, String> {
                let text = args.next().ok_or(format!("{name} needs a value"))?;
                match text.parse::<u64>() {
                    Ok(v) if (low..=high).contains(&v) => Ok(v),
                    _ => Err(format!("{name} takes a whole number from {low} to {high}, not {text:?}")),
                }
            };
            match arg.as_str() {
                "--rounds" => options.rounds = value("--rounds", 1, 1000)? as usize,
                "--window-ms" => options.window = Duration::from_millis(value("--window-ms", 1, 60_000)?),
                "--levels" => {
                    let text = args.next().ok_or("--levels needs a value, e.g. avx2,portable")?;
                    let level = |name: &str| match name.trim() {
                        "avx512" => Ok(SimdLevel::Avx512),
                        "avx2" => Ok(SimdLevel::Avx2),
                        "portable" => Ok(SimdLevel::Portable),
                        other => Err(format!("--levels takes avx512, avx2 and portable, not {other:?}")),
                    };
                    options.levels = Some(text.split(',').map(level).collect::<Result<_, _>>()?);
                }
                "--bench" => {}
                flag if flag.starts_with("--") => return Err(format!("unknown option {flag}")),
                filter => options.filters.push(filter.to_string()),
            }
        }
        Ok(options)
    }

    fn keeps(&self, name: &str) -> bool {
        self.filters.is_empty() || self.filters.iter().any(|f| name.contains(f.as_str()))
    }
}
