//! Criterion benchmarks of one solver step: the seed's Table 1 (relaxation
//! counts on its 20 × 30 cloth) and larger cloths, reference beside fast in
//! the same run so their ratio holds however busy the machine is.
//!
//! `cargo bench --bench solver`; throughput is in bar projections
//! (bars × relaxations per step).

mod common;
mod scenes;

use std::time::Duration;

use criterion::{Bencher, BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use drape::sim::{Grid, Simulation, SolverKind, SolverParams};
use glam::Vec3;
use scenes::{
    blowing, disc_params, draped_256, draped_disc, folded_256, ground, hanging_in_air, hanging_params, hanging_square,
    lying_params, ring_disc, shuffled_sheet, triangle_sheet, warmed, wavy_sheet,
};

/// Times `sim`'s step, inside `pool` when one is given (the one-thread
/// runs). The pool is entered once and every step timed inside it:
/// entering it for each step hands the step to the pool's sleeping thread
/// and back, which cost 30–50 µs a step on host D (a tablecloth step is
/// about 340 µs), a cost of the benchmark, not of the solver.
fn time_steps(b: &mut Bencher, sim: &mut Simulation, pool: Option<&rayon::ThreadPool>) {
    match pool {
        Some(pool) => pool.install(|| b.iter(|| sim.step().expect("no blow-up"))),
        None => b.iter(|| sim.step().expect("no blow-up")),
    }
}

/// The seed's Table 1: its scene (20 × 30, δ = 0.02, h = 0.05 s, m = 0.2 kg,
/// seed wind) at 5, 10, 20, 30 and 40 relaxations.
fn relaxations(c: &mut Criterion) {
    let scene = drape::scene::load("seed").expect("bundled scene");
    let mut group = c.benchmark_group("relaxations");
    group.measurement_time(Duration::from_secs(3));
    for k in [5u32, 10, 20, 30, 40] {
        for kind in SolverKind::ALL {
            let params = SolverParams { relaxations: k, ..scene.params.clone() };
            let mut sim = warmed((*scene.mesh).clone(), params, kind);
            group.throughput(Throughput::Elements(sim.projections_per_step()));
            group.bench_function(BenchmarkId::new(kind.name(), k), |b| b.iter(|| sim.step().expect("no blow-up")));
        }
    }
    group.finish();
}

/// Square cloths of n × n at 20 relaxations, hung by the top row in a light
/// seed wind with physical gravity (9.8 m/s²): the fast solver on one thread
/// and on all threads, and the reference.
fn scale(c: &mut Criterion) {
    let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    let mut group = c.benchmark_group("scale");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(5));
    for n in [64u32, 256, 512] {
        let (mesh, params) = (hanging_square(n), hanging_params());
        let runs: [(&str, SolverKind, Option<&rayon::ThreadPool>); 3] = [
            ("reference", SolverKind::Reference, None),
            ("fast-1-thread", SolverKind::Fast, Some(&single)),
            ("fast-all-threads", SolverKind::Fast, None),
        ];
        for (name, kind, pool) in runs {
            let mut sim = warmed(mesh.clone(), params.clone(), kind);
            group.throughput(Throughput::Elements(sim.projections_per_step()));
            group.bench_function(BenchmarkId::new(name, n), |b| time_steps(b, &mut sim, pool));
        }
    }
    group.finish();
}

/// The cost of contact as a ratio to the same step without it, fast solver,
/// all threads: the seed's scene above a ground 100 m below that it never
/// reaches (the broad phase's cost alone), and a 256 × 256 cloth of 2 cm
/// (5.1 m) at 20 relaxations draped over a 1.5 m sphere and lying on the
/// ground; and disc-183 (101 017 particles, no grid: the coloured path),
/// its pinned middle third over a 1 m ball, its hem lying on the ground 2 m
/// below. "without" is the same state with the colliders removed.
fn contact(c: &mut Criterion) {
    let mut group = c.benchmark_group("contact");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(4));
    let scene = drape::scene::load("seed").expect("bundled scene");
    let far =
        warmed((*scene.mesh).clone(), scene.params.clone(), SolverKind::Fast).with_colliders(vec![ground(-100.0)]);
    for (name, colliders) in [("seed-far-ground/without", vec![]), ("seed-far-ground/with", vec![ground(-100.0)])] {
        let mut sim = far.clone();
        sim.set_colliders(colliders);
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }
    let (draped, disc) = (draped_256(), draped_disc(lying_params()));
    let cases = [("256-draped", &draped), ("disc-183-draped", &disc)];
    for ((scene, draped), with) in cases.into_iter().flat_map(|c| [(c, false), (c, true)]) {
        let mut sim = draped.clone();
        if !with {
            sim.set_colliders(vec![]);
        }
        let name = format!("{scene}/{}", if with { "with" } else { "without" });
        group.throughput(Throughput::Elements(sim.projections_per_step()));
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }
    group.finish();
}

/// The cost of moving air as a ratio to the same step without it: a
/// 256 × 256 cloth of 2 cm hanging from its top row, 20 relaxations, mass
/// per area (σ = 0.13 kg/m², g), fast solver, all threads. "still" has no
/// wind; "air" blows at 8 m/s with 30 % gusts (noise per particle, drag and
/// lift per triangle, gathered per particle). "mass-per-particle" is the
/// seed's equal masses at the same weight, for the cost of unequal masses.
fn air(c: &mut Criterion) {
    let mut group = c.benchmark_group("air");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(4));
    let mesh = Grid { columns: 256, rows: 256, spacing: 0.02, ..Grid::default() }.build().expect("valid grid");
    let seed_way = SolverParams {
        relaxations: 20,
        dt: 0.01,
        mass: 0.13 * 0.02 * 0.02,
        gravity: Vec3::new(0.0, -9.81 * 0.13 * 0.02 * 0.02, 0.0),
        ..SolverParams::default()
    };
    let cases = [
        ("256-hanging/mass-per-particle", warmed(mesh, seed_way, SolverKind::Fast)),
        ("256-hanging/still", hanging_in_air(None)),
        ("256-hanging/air", hanging_in_air(Some(blowing()))),
    ];
    for (name, mut sim) in cases {
        group.throughput(Throughput::Elements(sim.projections_per_step()));
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }
    group.finish();
}

/// The cost of self-collision as a ratio to the same step without it: a
/// 256 × 256 cloth of 2 cm lying folded in two on the ground (r = 1.5 cm,
/// 20 relaxations, all threads), the `pile` scene after it has piled up,
/// and disc-183 draped over a ball onto the ground (r = 1 cm; no grid).
fn self_collision(c: &mut Criterion) {
    let mut group = c.benchmark_group("self-collision");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(4));
    for on in [false, true] {
        let mut sim = folded_256(on);
        let name = if on { "256-folded/with" } else { "256-folded/without" };
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }
    let scene = drape::scene::load("pile").expect("bundled scene");
    let mut piled = scene.simulation().expect("valid scene");
    piled.advance(200).expect("no blow-up");
    for on in [false, true] {
        let mut sim = piled.clone();
        sim.set_params(SolverParams { self_collision: on, ..scene.params.clone() }).expect("valid parameters");
        let name = if on { "pile/with" } else { "pile/without" };
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }
    let disc = draped_disc(disc_params(true));
    for on in [false, true] {
        let mut sim = disc.clone();
        sim.set_params(disc_params(on)).expect("valid parameters");
        let name = if on { "disc-183-draped/with" } else { "disc-183-draped/without" };
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }
    group.finish();
}

/// Meshes that are not grids (OBJ files, triangle meshes) take the coloured
/// path: the bundled tablecloth (1 801 vertices) and a disc of the same
/// build with 101 017 ([`ring_disc`]). Triangulated sheets are grids the
/// fast solver finds (in their numbering, or in their triangles) and runs
/// on the grid's lanes: one of 42 × 42 (the tablecloth's size) and three
/// of 320 × 320 (102 400 vertices: in row order, shuffled, and with a wavy
/// rest shape). 20 relaxations, light seed wind, reference beside fast on
/// one thread and on all threads.
fn meshes(c: &mut Criterion) {
    let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    let mut group = c.benchmark_group("mesh");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(4));
    let tablecloth = drape::scene::load("tablecloth").expect("bundled scene");
    let sheet = triangle_sheet(320, 0.02);
    let sheet_params = hanging_params();
    let cases = [
        ("tablecloth", (*tablecloth.mesh).clone(), SolverParams { relaxations: 20, ..tablecloth.params.clone() }),
        ("sheet-42", triangle_sheet(42, 0.05), sheet_params.clone()),
        ("sheet-320", sheet, sheet_params.clone()),
        ("sheet-320-shuffled", shuffled_sheet(320, 0.02), sheet_params.clone()),
        ("sheet-320-wavy", wavy_sheet(320, 0.02), sheet_params.clone()),
        ("disc-183", ring_disc(183, 0.02), sheet_params),
    ];
    for (mesh_name, mesh, params) in cases {
        let runs: [(&str, SolverKind, Option<&rayon::ThreadPool>); 3] = [
            ("reference", SolverKind::Reference, None),
            ("fast-1-thread", SolverKind::Fast, Some(&single)),
            ("fast-all-threads", SolverKind::Fast, None),
        ];
        for (name, kind, pool) in runs {
            let mut sim = warmed(mesh.clone(), params.clone(), kind);
            group.throughput(Throughput::Elements(sim.projections_per_step()));
            group.bench_function(BenchmarkId::new(name, mesh_name), |b| time_steps(b, &mut sim, pool));
        }
    }
    group.finish();
}

/// Pinning and unpinning one particle of the 256 × 256 cloth: a write of
/// its weight (goal: under 1 ms; it was a 0.13 s rebuild).
fn pin(c: &mut Criterion) {
    let mesh = Grid { columns: 256, rows: 256, spacing: 0.02, ..Grid::default() }.build().expect("valid grid");
    let mut sim = Simulation::new(mesh, SolverParams::default()).expect("valid scene");
    let mut group = c.benchmark_group("pin");
    group.bench_function("256-pin-and-unpin", |b| {
        b.iter(|| {
            sim.set_fixed(40_000, true).expect("index exists");
            sim.set_fixed(40_000, false).expect("index exists");
        })
    });
    group.finish();
}

/// The cost of the coarse phase as a ratio to the same step without it:
/// the bundled `large-inextensible` scene (256 × 256 in the seed's wind at
/// 1/1000, 8 passes, soft diagonals) with its 2 coarse passes a level and
/// with none, fast solver, all threads.
fn coarse(c: &mut Criterion) {
    let mut group = c.benchmark_group("coarse");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(4));
    let scene = drape::scene::load("large-inextensible").expect("bundled scene");
    for (name, passes) in [("256-hanging/without", 0), ("256-hanging/with", scene.params.coarse_passes)] {
        let params = SolverParams { coarse_passes: passes, ..scene.params.clone() };
        let mut sim = warmed((*scene.mesh).clone(), params, SolverKind::Fast);
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }
    group.finish();
}

/// Criterion with its HTML charts, which need a font registered first.
fn config() -> Criterion {
    if let Err(e) = common::register_chart_font() {
        eprintln!("{e}; criterion's charts may fail");
    }
    Criterion::default()
}

/// Setup: the bundled 256 × 256 scene parsed, its mesh built and checked,
/// and a fast simulation made from it (what the viewer does on a scene
/// switch). Target: under 50 ms. Beside it, a reset of that simulation
/// (the layout kept, its particles written back), and the same two for
/// disc-183 (101 017 particles on the coloured path, the mesh built once).
fn setup(c: &mut Criterion) {
    let mut group = c.benchmark_group("setup");
    group.sample_size(20);
    group.bench_function("large-256", |b| {
        b.iter(|| drape::scene::load("large").expect("bundled scene").simulation().expect("valid scene"))
    });
    let mut large = drape::scene::load("large").expect("bundled scene").simulation().expect("valid scene");
    large.advance(2).expect("no blow-up");
    group.bench_function("reset-large-256", |b| b.iter(|| large.reset()));
    let disc = std::sync::Arc::new(ring_disc(183, 0.02));
    let params = SolverParams { relaxations: 20, dt: 0.01, mass: 0.001, ..SolverParams::default() };
    group.bench_function("disc-183", |b| {
        b.iter(|| Simulation::with_solver(disc.clone(), params.clone(), SolverKind::Fast).expect("valid scene"))
    });
    let mut sim = Simulation::with_solver(disc.clone(), params.clone(), SolverKind::Fast).expect("valid scene");
    sim.advance(2).expect("no blow-up");
    group.bench_function("reset-disc-183", |b| b.iter(|| sim.reset()));
    group.finish();
}

criterion_group! {
    name = benches;
    config = config();
    targets = relaxations, scale, meshes, contact, self_collision, pin, air, coarse, setup
}
criterion_main!(benches);
