//! Run time against error: `cargo bench --bench accuracy`.
//!
//! Sweeps ways of spending the solver's work (methods) × amounts of work
//! (sweeps over the bars per step) on three scenes, and measures for each the
//! wall time per simulated second (fast solver) and the error it leaves:
//!
//! - `seed`: the seed's cloth in its wind. Over 10 s after 2 s of warm-up:
//!   the typical max strain (each step's max strain, averaged over the
//!   steps), the worst step's max strain, and the mean RMS strain; dynamic
//!   error after 0.5 s against a converged run (200 substeps × 40 passes), as
//!   RMS distance over the cloth's diagonal.
//! - `seed-calm`: the same cloth without wind, hanging under its own weight:
//!   the stretch it settles at (the field's usual measure).
//! - `chain`: the hanging chain settled for 10 s; static error against the
//!   exact discrete catenary, as the largest node distance over the chain's
//!   length.
//! - `large`: the 256 × 256 cloth; max and mean RMS strain over 0.3 s after
//!   0.1 s (threads on).
//!
//! Then the seed's scene over a grid of step sizes × wind strengths, to map
//! where each method stays stable.
//!
//! Writes `target/accuracy/accuracy.csv`, `stability.csv` and
//! `accuracy.png` (log–log charts with the Pareto front), and prints the
//! README's tables (also in `report.md`). Takes about half a minute on 2
//! cores. `cargo bench --bench
//! accuracy -- --quick` runs a reduced sweep (for CI smoke tests).

mod common;

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use drape::sim::exact::discrete_catenary;
use drape::sim::metrics::{max_distance_error, rms_distance_error};
use drape::sim::{ClothMesh, SolverKind, SolverParams, StrainHistory, Wind};
use glam::{DVec2, Vec3};
use plotters::prelude::*;

/// A way of spending `budget` sweeps over the bars per step.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Method {
    /// The seed's: one step, `budget` passes.
    Passes,
    /// `budget` substeps of one pass each.
    Substeps,
    /// `budget / 2` substeps of two passes.
    SubstepsTwoPasses,
    /// `budget` passes over-relaxed by ω = 1.3.
    OverRelaxed,
    /// `budget` passes and tethers.
    Tethers,
    /// `budget / 2` substeps of two passes, and tethers.
    SubstepsTethers,
}

impl Method {
    const ALL: [Method; 6] = [
        Method::Passes,
        Method::Substeps,
        Method::SubstepsTwoPasses,
        Method::OverRelaxed,
        Method::Tethers,
        Method::SubstepsTethers,
    ];

    fn name(self) -> &'static str {
        match self {
            Method::Passes => "passes (the seed's)",
            Method::Substeps => "substeps × 1 pass",
            Method::SubstepsTwoPasses => "substeps × 2 passes",
            Method::OverRelaxed => "passes, ω = 1.3",
            Method::Tethers => "passes + tethers",
            Method::SubstepsTethers => "substeps × 2 + tethers",
        }
    }

    fn params(self, base: &SolverParams, budget: u32) -> SolverParams {
        let p = SolverParams { substeps: 1, relaxations: budget, ..base.clone() };
        let halves = SolverParams { substeps: (budget / 2).max(1), relaxations: 2, ..p.clone() };
        match self {
            Method::Passes => p,
            Method::Substeps => SolverParams { substeps: budget, relaxations: 1, ..p },
            Method::SubstepsTwoPasses => halves,
            Method::OverRelaxed => SolverParams { over_relaxation: 1.3, ..p },
            Method::Tethers => SolverParams { tether_slack: Some(0.0), ..p },
            Method::SubstepsTethers => SolverParams { tether_slack: Some(0.0), ..halves },
        }
    }

    fn colour(self) -> RGBColor {
        match self {
            Method::Passes => RGBColor(214, 39, 40),
            Method::Substeps => RGBColor(31, 119, 180),
            Method::SubstepsTwoPasses => RGBColor(23, 190, 207),
            Method::OverRelaxed => RGBColor(255, 127, 14),
            Method::Tethers => RGBColor(148, 103, 189),
            Method::SubstepsTethers => RGBColor(44, 160, 44),
        }
    }
}
/// Reads one error measure off a row.
type Metric = fn(&Row) -> f64;

/// One chart panel: scene, title, measure.
type Panel = (&'static str, &'static str, Metric);

/// One measured configuration.
#[derive(Clone, Debug)]
struct Row {
    scene: &'static str,
    method: Method,
    budget: u32,
    /// Wall seconds per simulated second.
    cost: f64,
    /// Mean over the steps of each step's max strain.
    max_strain: f64,
    /// The worst step's max strain.
    worst_max_strain: f64,
    rms_strain: f64,
    /// Dynamic error (seed) or static error (chain).
    error: Option<f64>,
}

impl Row {
    fn new(
        scene: &'static str,
        method: Method,
        budget: u32,
        cost: f64,
        strain: &StrainHistory,
        error: Option<f64>,
    ) -> Self {
        Row {
            scene,
            method,
            budget,
            cost,
            max_strain: strain.mean_max(),
            worst_max_strain: f64::from(strain.worst_max),
            rms_strain: strain.mean_rms(),
            error,
        }
    }
}

fn simulation(mesh: &ClothMesh, params: SolverParams) -> drape::sim::Simulation {
    drape::sim::Simulation::with_solver(mesh.clone(), params, SolverKind::Fast).expect("valid benchmark parameters")
}

/// Steps `warmup` steps, then `steps` more while recording strain. Returns the
/// wall time of the stepping (best of `repeats` runs) per simulated second,
/// and the strain of the last run; a run that blows up records infinite
/// strain.
fn strain_run(mesh: &ClothMesh, params: &SolverParams, warmup: u64, steps: u64, repeats: u32) -> (f64, StrainHistory) {
    let mut best = f64::INFINITY;
    let mut history = StrainHistory::default();
    for _ in 0..repeats {
        let mut sim = simulation(mesh, params.clone());
        history = StrainHistory::default();
        let mut wall = 0.0;
        for k in 0..warmup + steps {
            let start = Instant::now();
            let stepped = sim.step();
            wall += start.elapsed().as_secs_f64();
            if stepped.is_err() {
                history.record(drape::sim::Strain { max: f32::INFINITY, rms: f32::INFINITY });
                return (wall / ((k + 1) as f64 * f64::from(params.dt)), history);
            }
            if k >= warmup {
                history.record(sim.strain());
            }
        }
        best = best.min(wall / ((warmup + steps) as f64 * f64::from(params.dt)));
    }
    (best, history)
}

/// Positions after `steps` steps (NaN everywhere if the run blew up).
fn positions_after(mesh: &ClothMesh, params: &SolverParams, steps: u64) -> Vec<Vec3> {
    let mut sim = simulation(mesh, params.clone());
    match sim.advance(steps) {
        Ok(()) => sim.positions().to_vec(),
        Err(_) => vec![Vec3::NAN; mesh.particle_count()],
    }
}

fn diagonal(mesh: &ClothMesh) -> f64 {
    let (lo, hi) = mesh.bounds();
    f64::from(lo.distance(hi))
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let out = PathBuf::from(std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into())).join("accuracy");
    std::fs::create_dir_all(&out).expect("create target/accuracy");
    let budgets: &[u32] = if quick { &[6, 20] } else { &[4, 6, 8, 10, 14, 20, 28, 40, 80, 160] };
    let repeats = if quick { 1 } else { 3 };
    let mut rows = Vec::new();
    let mut report = String::new();

    // The seed's scene.
    let seed = drape::scene::load("seed").expect("bundled scene");
    let seed_steps = |seconds: f64| (seconds / f64::from(seed.params.dt)).round() as u64;
    let horizon = seed_steps(0.5);
    let converged = SolverParams { substeps: 200, relaxations: 40, ..seed.params.clone() };
    let reference = positions_after(&seed.mesh, &converged, horizon);
    let finer = positions_after(&seed.mesh, &SolverParams { substeps: 400, ..converged.clone() }, horizon);
    let size = diagonal(&seed.mesh);
    let floor = rms_distance_error(&reference, &finer, size);
    writeln!(report, "seed: dynamic error of the converged run against one with twice the substeps: {floor:.2e}")
        .unwrap();
    for method in Method::ALL {
        for &budget in budgets {
            let params = method.params(&seed.params, budget);
            let (cost, strain) = strain_run(&seed.mesh, &params, seed_steps(2.0), seed_steps(10.0), repeats);
            let error = rms_distance_error(&positions_after(&seed.mesh, &params, horizon), &reference, size);
            rows.push(Row::new("seed", method, budget, cost, &strain, Some(error)));
            eprintln!("seed  {:24} {budget:4}: {:.3e} s/s, max strain {:.3e}", method.name(), cost, strain.worst_max);
        }
    }

    // The seed's cloth without its wind: stretch under its own weight, the
    // measure of the field (Müller 2008, Fig. 3).
    let calm = SolverParams { wind: Wind::None, ..seed.params.clone() };
    for method in Method::ALL {
        for &budget in budgets {
            let params = method.params(&calm, budget);
            let (cost, strain) = strain_run(&seed.mesh, &params, seed_steps(2.0), seed_steps(10.0), repeats);
            rows.push(Row::new("seed-calm", method, budget, cost, &strain, None));
        }
    }

    // The chain, settled, against the exact discrete catenary.
    let chain = drape::scene::load("chain").expect("bundled scene");
    let first = chain.mesh.positions()[0];
    let last = chain.mesh.positions()[chain.mesh.particle_count() - 1];
    let links = chain.mesh.bars().len();
    let link = f64::from(chain.mesh.bars()[0].rest_length);
    let exact = discrete_catenary(
        links,
        link,
        DVec2::new(f64::from(first.x), f64::from(first.y)),
        DVec2::new(f64::from(last.x), f64::from(last.y)),
    )
    .expect("the chain spans its ends");
    let chain_steps = (10.0 / f64::from(chain.params.dt)).round() as u64;
    for method in Method::ALL {
        for &budget in budgets {
            let params = method.params(&chain.params, budget);
            let (cost, strain) = strain_run(&chain.mesh, &params, chain_steps - 1, 1, repeats);
            let settled = positions_after(&chain.mesh, &params, chain_steps);
            let error = max_distance_error(&settled, &exact, links as f64 * link);
            rows.push(Row::new("chain", method, budget, cost, &strain, Some(error)));
        }
    }

    // The large cloth.
    let large = drape::scene::load("large").expect("bundled scene");
    let large_budgets: &[u32] = if quick { &[6] } else { &[6, 10, 20, 40, 80] };
    let large_steps = |seconds: f64| (seconds / f64::from(large.params.dt)).round() as u64;
    for method in Method::ALL {
        for &budget in large_budgets {
            let params = method.params(&large.params, budget);
            let (cost, strain) = strain_run(&large.mesh, &params, large_steps(0.1), large_steps(0.3), 1);
            rows.push(Row::new("large", method, budget, cost, &strain, None));
            eprintln!("large {:24} {budget:4}: {:.3e} s/s, max strain {:.3e}", method.name(), cost, strain.worst_max);
        }
    }

    write_csv(&out.join("accuracy.csv"), &rows);
    report.push_str(&targets(&rows));
    report.push_str(&cheapest_table(
        &rows,
        "seed",
        "typical max strain",
        |r| r.max_strain,
        &[0.5, 0.3, 0.1, 0.03, 0.01],
    ));
    report.push_str(&cheapest_table(&rows, "seed", "mean RMS strain", |r| r.rms_strain, &[0.03, 0.01, 0.003, 0.001]));
    report.push_str(&cheapest_table(
        &rows,
        "seed-calm",
        "typical max strain",
        |r| r.max_strain,
        &[0.1, 0.03, 0.01, 0.003],
    ));
    report.push_str(&cheapest_table(
        &rows,
        "seed",
        "dynamic error",
        |r| r.error.unwrap_or(f64::NAN),
        &[0.03, 0.01, 0.003, 0.001],
    ));
    report.push_str(&cheapest_table(
        &rows,
        "chain",
        "catenary error",
        |r| r.error.unwrap_or(f64::NAN),
        &[1e-2, 3e-3, 1e-3, 3e-4],
    ));
    report.push_str(&cheapest_table(
        &rows,
        "large",
        "typical max strain",
        |r| r.max_strain,
        &[1.0, 0.3, 0.1, 0.03, 0.01],
    ));
    let panels: [Panel; 4] = [
        ("seed", "seed's cloth: typical max strain", |r| r.max_strain),
        ("seed", "seed's cloth: dynamic error (0.5 s)", |r| r.error.unwrap_or(f64::NAN)),
        ("chain", "chain: catenary error", |r| r.error.unwrap_or(f64::NAN)),
        ("large", "256 × 256 cloth: typical max strain", |r| r.max_strain),
    ];
    if let Err(e) = chart(&out.join("accuracy.png"), &rows, &panels) {
        eprintln!("could not draw the chart: {e}");
    }

    report.push_str(&stability(&seed, quick, &out.join("stability.csv")));
    report.push_str(&inextensible(quick));
    println!("{report}");
    std::fs::write(out.join("report.md"), &report).expect("write the report");
    eprintln!("wrote {}", out.display());
}

fn write_csv(path: &std::path::Path, rows: &[Row]) {
    let mut csv = String::from(
        "scene,method,budget,wall_seconds_per_simulated_second,mean_max_strain,worst_max_strain,mean_rms_strain,error\n",
    );
    for r in rows {
        let error = r.error.map(|e| format!("{e:.6e}")).unwrap_or_default();
        writeln!(
            csv,
            "{},{},{},{:.6e},{:.6e},{:.6e},{:.6e},{error}",
            r.scene,
            r.method.name(),
            r.budget,
            r.cost,
            r.max_strain,
            r.worst_max_strain,
            r.rms_strain
        )
        .unwrap();
    }
    std::fs::write(path, csv).expect("write accuracy.csv");
}

/// The points of `(cost, error)` no other point beats on both, by cost.
fn pareto(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in sorted {
        if front.last().is_none_or(|last| p.1 < last.1) {
            front.push(p);
        }
    }
    front
}

/// The issue's two targets on the seed's scene, for both readings of "max
/// strain": the typical step's (mean over steps of the per-step max) and the
/// worst step's.
fn targets(rows: &[Row]) -> String {
    let seed: Vec<&Row> = rows.iter().filter(|r| r.scene == "seed").collect();
    let find = |budget| seed.iter().find(|r| r.method == Method::Passes && r.budget == budget).copied();
    let mut s = String::from("\n### Targets on the seed's scene\n\n");
    let (Some(p40), Some(p20)) = (find(40), find(20)) else {
        return s;
    };
    let readings: [(&str, Metric); 2] =
        [("typical max strain", |r| r.max_strain), ("worst max strain", |r| r.worst_max_strain)];
    for (what, metric) in readings {
        let cheapest =
            |limit: f64| seed.iter().filter(|r| metric(r) <= limit).min_by(|a, b| a.cost.total_cmp(&b.cost)).copied();
        match cheapest(metric(p40)) {
            Some(best) => writeln!(
                s,
                "- {what} of 40 passes ({:.3}) is reached by {} × {} ({:.3}) for {:.3e} s/s, {:.2} of the {:.3e} s/s of 40 passes (target ≤ 0.20): {}.",
                metric(p40),
                best.method.name(),
                best.budget,
                metric(best),
                best.cost,
                best.cost / p40.cost,
                p40.cost,
                if best.cost <= p40.cost / 5.0 { "met" } else { "missed" }
            )
            .unwrap(),
            None => writeln!(s, "- Nothing reaches the {what} of 40 passes.").unwrap(),
        }
        match cheapest(0.01) {
            Some(best) => writeln!(
                s,
                "- {what} ≤ 1 %: cheapest is {} × {} ({:.4}) at {:.3e} s/s, {:.2} of the {:.3e} s/s of 20 passes (target ≤ 1): {}.",
                best.method.name(),
                best.budget,
                metric(best),
                best.cost,
                best.cost / p20.cost,
                p20.cost,
                if best.cost <= p20.cost { "met" } else { "missed" }
            )
            .unwrap(),
            None => writeln!(s, "- No configuration keeps the {what} at or below 1 %.").unwrap(),
        }
    }
    let calm: Vec<&Row> = rows.iter().filter(|r| r.scene == "seed-calm").collect();
    let calm20 = calm.iter().find(|r| r.method == Method::Passes && r.budget == 20);
    let calm_best = calm.iter().filter(|r| r.max_strain <= 0.01).min_by(|a, b| a.cost.total_cmp(&b.cost));
    if let (Some(p20), Some(best)) = (calm20, calm_best) {
        writeln!(
            s,
            "- Without the wind (the cloth hanging under its own weight), max strain ≤ 1 %: cheapest is {} × {} ({:.4}) at {:.3e} s/s, {:.2} of the {:.3e} s/s of 20 passes (which leave {:.3}).",
            best.method.name(),
            best.budget,
            best.max_strain,
            best.cost,
            best.cost / p20.cost,
            p20.cost,
            p20.max_strain
        )
        .unwrap();
    }
    s
}

/// For each error level: the cheapest configuration reaching it, and the
/// cost of the seed's way (passes) to reach it.
fn cheapest_table(rows: &[Row], scene: &str, what: &str, metric: Metric, levels: &[f64]) -> String {
    let scene_rows: Vec<&Row> = rows.iter().filter(|r| r.scene == scene).collect();
    let mut s = format!(
        "\n### {scene}: {what}\n\n| {what} ≤ | cheapest way | wall s per simulated s | the seed's way (passes) | its cost | ratio |\n|---|---|---|---|---|---|\n"
    );
    for &level in levels {
        let reach = |r: &&&Row| metric(r) <= level;
        let best = scene_rows.iter().filter(reach).min_by(|a, b| a.cost.total_cmp(&b.cost));
        let passes = scene_rows
            .iter()
            .filter(|r| r.method == Method::Passes)
            .filter(reach)
            .min_by(|a, b| a.cost.total_cmp(&b.cost));
        let cell = |r: Option<&&Row>| match r {
            Some(r) => (format!("{} × {}", r.method.name(), r.budget), format!("{:.3e}", r.cost)),
            None => ("not reached".to_string(), "–".to_string()),
        };
        let (best_name, best_cost) = cell(best);
        let (passes_name, passes_cost) = cell(passes);
        let ratio = match (best, passes) {
            (Some(b), Some(p)) => format!("{:.2}", b.cost / p.cost),
            _ => "–".to_string(),
        };
        writeln!(s, "| {level} | {best_name} | {best_cost} | {passes_name} | {passes_cost} | {ratio} |").unwrap();
    }
    s
}

fn chart(path: &std::path::Path, rows: &[Row], panels: &[Panel]) -> Result<(), Box<dyn std::error::Error>> {
    common::register_chart_font()?;
    let (width, height) = (1600u32, 1200u32);
    let mut pixels = vec![0u8; (width * height * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (width, height)).into_drawing_area();
        root.fill(&WHITE)?;
        for (area, &(scene, title, metric)) in root.split_evenly((2, 2)).iter().zip(panels) {
            // Blown-up runs (infinite or absurd error) are left off the chart.
            let points: Vec<(Method, f64, f64)> = rows
                .iter()
                .filter(|r| r.scene == scene)
                .map(|r| (r.method, r.cost, metric(r)))
                .filter(|p| p.1.is_finite() && p.2.is_finite() && p.1 > 0.0 && p.2 > 0.0 && p.2 < 100.0)
                .collect();
            if points.is_empty() {
                continue;
            }
            let (x0, x1) = points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
            let (y0, y1) = points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.2), b.max(p.2)));
            let mut chart = ChartBuilder::on(area)
                .caption(title, ("sans-serif", 26))
                .margin(16)
                .x_label_area_size(50)
                .y_label_area_size(80)
                .build_cartesian_2d((x0 / 1.5..x1 * 1.5).log_scale(), (y0 / 2.0..y1 * 2.0).log_scale())?;
            chart
                .configure_mesh()
                .light_line_style(WHITE)
                .bold_line_style(RGBColor(225, 225, 225))
                .x_desc("wall seconds per simulated second (fast solver)")
                .y_desc(title.split(": ").nth(1).unwrap_or(title))
                .label_style(("sans-serif", 16))
                .axis_desc_style(("sans-serif", 18))
                .x_label_formatter(&|x| format!("{x:.0e}"))
                .y_label_formatter(&|y| format!("{y:.0e}"))
                .draw()?;
            for method in Method::ALL {
                let series: Vec<(f64, f64)> = points.iter().filter(|p| p.0 == method).map(|p| (p.1, p.2)).collect();
                let colour = method.colour();
                chart
                    .draw_series(LineSeries::new(series.clone(), colour.stroke_width(2)))?
                    .label(method.name())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3)));
                chart.draw_series(series.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
            }
            let front = pareto(&points.iter().map(|p| (p.1, p.2)).collect::<Vec<_>>());
            chart
                .draw_series(LineSeries::new(front.clone(), BLACK.stroke_width(1)))?
                .label("Pareto front")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], BLACK.stroke_width(1)));
            chart.draw_series(front.iter().map(|&p| Circle::new(p, 8, BLACK.stroke_width(1))))?;
            chart
                .configure_series_labels()
                .label_font(("sans-serif", 15))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()?;
        }
        root.present()?;
    }
    let image = image::RgbImage::from_raw(width, height, pixels).ok_or("chart buffer of the wrong size")?;
    image.save(path)?;
    Ok(())
}

/// The seed's scene over step sizes × wind strengths: for each method at 20
/// sweeps per step, the worst max strain over 10 s. Returns a Markdown table.
fn stability(seed: &drape::scene::Scene, quick: bool, csv_path: &std::path::Path) -> String {
    let steps_h: &[f32] = if quick { &[0.05, 0.5] } else { &[0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0] };
    let winds: &[f32] = if quick { &[1.0] } else { &[0.0, 1.0, 10.0, 100.0] };
    let methods = [Method::Passes, Method::Substeps, Method::SubstepsTwoPasses, Method::OverRelaxed, Method::Tethers];
    let mut csv = String::from("method,dt,wind_scale,outcome,mean_max_strain,worst_max_strain\n");
    let mut s = String::from(
        "\n### Stability of the seed's scene at 20 sweeps per step\n\nTypical max strain over 10 s (at most 400 steps): \
         `ok` below 10 %, `stretchy` below 100 %, `torn` above; `NaN` if a position stopped being finite.\n\n| method | dt \\ wind scale |",
    );
    for w in winds {
        write!(s, " {w} |").unwrap();
    }
    s.push_str("\n|---|---|");
    s.push_str(&"---|".repeat(winds.len()));
    s.push('\n');
    for method in methods {
        for &dt in steps_h {
            write!(s, "| {} | {dt} |", method.name()).unwrap();
            for &scale in winds {
                let base = SolverParams { dt, wind: Wind::Seed { scale }, ..seed.params.clone() };
                let params = method.params(&base, 20);
                let steps = ((10.0 / dt).round() as u64).min(400);
                let mut sim = simulation(&seed.mesh, params);
                let mut history = StrainHistory::default();
                let mut blew_up = false;
                for _ in 0..steps {
                    if sim.step().is_err() {
                        blew_up = true;
                        break;
                    }
                    history.record(sim.strain());
                }
                let worst = history.mean_max();
                let outcome = if blew_up {
                    "NaN"
                } else if worst < 0.1 {
                    "ok"
                } else if worst < 1.0 {
                    "stretchy"
                } else {
                    "torn"
                };
                writeln!(csv, "{},{dt},{scale},{outcome},{worst:.4e},{:.4e}", method.name(), history.worst_max)
                    .unwrap();
                write!(s, " {outcome} ({worst:.2}) |").unwrap();
            }
            s.push('\n');
        }
    }
    std::fs::write(csv_path, csv).expect("write stability.csv");
    s
}

/// The inextensible edges against the seed's method, in one run: the
/// edges' max strain (typical and worst step) and the wall time per step,
/// on the seed's scene in its wind (100 s after 2 s of warm-up), without
/// wind, and on the 256 × 256 cloth (a few steps).
fn inextensible(quick: bool) -> String {
    let seed = drape::scene::load("seed").expect("bundled scene");
    let inext = drape::scene::load("seed-inextensible").expect("bundled scene");
    let inext_fast = drape::scene::load("seed-inextensible-fast").expect("bundled scene");
    let large = drape::scene::load("large").expect("bundled scene");
    let steps = |seconds: f64, dt: f32| (seconds / f64::from(dt)).round() as u64;
    let calm = |p: &SolverParams| SolverParams { wind: Wind::None, ..p.clone() };
    let large_inext = SolverParams { inextensible: true, relaxations: 4, ..large.params.clone() };
    let large_coarse = drape::scene::load("large-inextensible").expect("bundled scene");
    let large_soft = SolverParams { coarse_passes: 0, ..large_coarse.params.clone() };
    let (seconds, large_steps) = if quick { (5.0, 3) } else { (100.0, 10) };
    let cases: Vec<(&str, &ClothMesh, SolverParams, SolverKind, u64, u64)> = vec![
        (
            "seed, 20 passes, reference",
            &seed.mesh,
            seed.params.clone(),
            SolverKind::Reference,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "seed, 20 passes, fast",
            &seed.mesh,
            seed.params.clone(),
            SolverKind::Fast,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "seed-inextensible, fast",
            &inext.mesh,
            inext.params.clone(),
            SolverKind::Fast,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "seed-inextensible, reference",
            &inext.mesh,
            inext.params.clone(),
            SolverKind::Reference,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "seed-inextensible + 8 coarse passes, fast",
            &inext.mesh,
            SolverParams { coarse_passes: 8, ..inext.params.clone() },
            SolverKind::Fast,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            // Issue 13's "aim further": the edges within the targets (1 %
            // typical, 2 % worst) for twice the fast solver's 20 passes.
            "`seed-inextensible-fast` (8 coarse passes, tolerance 1.2 %, 96 passes), fast",
            &inext_fast.mesh,
            inext_fast.params.clone(),
            SolverKind::Fast,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "no wind, 20 passes, reference",
            &seed.mesh,
            calm(&seed.params),
            SolverKind::Reference,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "no wind, 20 passes, fast",
            &seed.mesh,
            calm(&seed.params),
            SolverKind::Fast,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "no wind, inextensible, fast",
            &inext.mesh,
            calm(&inext.params),
            SolverKind::Fast,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "no wind, `seed-inextensible-fast`",
            &inext_fast.mesh,
            calm(&inext_fast.params),
            SolverKind::Fast,
            40,
            steps(seconds, seed.params.dt),
        ),
        (
            "no wind, inextensible + 8 coarse passes, fast",
            &inext.mesh,
            SolverParams { coarse_passes: 8, ..calm(&inext.params) },
            SolverKind::Fast,
            40,
            steps(seconds, seed.params.dt),
        ),
        ("256 × 256, 20 passes, fast", &large.mesh, large.params.clone(), SolverKind::Fast, 10, large_steps),
        ("256 × 256, inextensible, fast", &large.mesh, large_inext, SolverKind::Fast, 10, large_steps),
        ("256 × 256, 8 passes, soft shear, fast", &large.mesh, large_soft, SolverKind::Fast, 10, large_steps),
        (
            "256 × 256, `large-inextensible` (8 passes, 2 coarse), fast",
            &large_coarse.mesh,
            large_coarse.params.clone(),
            SolverKind::Fast,
            10,
            large_steps,
        ),
        (
            "256 × 256, `large-inextensible`, 3 s",
            &large_coarse.mesh,
            large_coarse.params.clone(),
            SolverKind::Fast,
            10,
            if quick { large_steps } else { 300 },
        ),
    ];
    let mut out = String::from(
        "\n### Inextensible edges (edges' max strain; wall time per step: the seed's cloth on one thread, the 256 × 256 one threaded)\n\n\
         | case | typical max strain | worst step | wall time per step | ÷ seed's 20 passes, reference (256 × 256: ÷ its 20 passes, fast) |\n\
         |---|---:|---:|---:|---:|\n",
    );
    let (mut yardstick, mut large_yardstick) = (None, None);
    for (name, mesh, params, kind, warmup, measured) in cases {
        let mut sim = drape::sim::Simulation::with_solver(mesh.clone(), params, kind).expect("valid parameters");
        let mut history = StrainHistory::default();
        let mut wall = 0.0;
        for k in 0..warmup + measured {
            let start = Instant::now();
            let stepped = sim.step();
            wall += start.elapsed().as_secs_f64();
            if stepped.is_err() {
                history.record(drape::sim::Strain { max: f32::INFINITY, rms: f32::INFINITY });
                break;
            }
            if k >= warmup {
                history.record(sim.edge_strain());
            }
        }
        let per_step = wall / (warmup + measured) as f64;
        let base = if name.starts_with("256") {
            *large_yardstick.get_or_insert(per_step)
        } else {
            *yardstick.get_or_insert(per_step)
        };
        let ratio = format!("{:.2}", per_step / base);
        eprintln!(
            "inextensible {name}: {:.3e} typical, {:.3e} worst, {:.3} ms/step",
            history.mean_max(),
            history.worst_max,
            per_step * 1e3
        );
        writeln!(
            out,
            "| {name} | {:.2e} | {:.2e} | {:.3} ms | {ratio} |",
            history.mean_max(),
            history.worst_max,
            per_step * 1e3
        )
        .unwrap();
    }
    out
}
