//! Criterion benchmarks of one solver step: the seed's Table 1 (relaxation
//! counts on its 20 × 30 cloth) and larger cloths, reference beside fast in
//! the same run so their ratio holds however busy the machine is.
//!
//! `cargo bench --bench solver`; throughput is in bar projections
//! (bars × relaxations per step).

mod common;

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use drape::sim::{Grid, Pins, Simulation, SolverKind, SolverParams, Wind};

/// A simulation warmed up for 20 steps, so the cloth is moving as it will.
fn warmed(mesh: drape::sim::ClothMesh, params: SolverParams, kind: SolverKind) -> Simulation {
    let mut sim = Simulation::with_solver(mesh, params, kind).expect("valid benchmark scene");
    sim.advance(20).expect("the benchmark scene does not blow up");
    sim
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
        let mesh = Grid { columns: n, rows: n, spacing: 0.02, pins: Pins::TopRow, ..Grid::default() }
            .build()
            .expect("valid grid");
        let params = SolverParams {
            relaxations: 20,
            dt: 0.01,
            mass: 0.001,
            gravity: glam::Vec3::new(0.0, -0.0098, 0.0),
            wind: Wind::Seed { scale: 0.001 },
            ..SolverParams::default()
        };
        let runs: [(&str, SolverKind, Option<&rayon::ThreadPool>); 3] = [
            ("reference", SolverKind::Reference, None),
            ("fast-1-thread", SolverKind::Fast, Some(&single)),
            ("fast-all-threads", SolverKind::Fast, None),
        ];
        for (name, kind, pool) in runs {
            let mut sim = warmed(mesh.clone(), params.clone(), kind);
            group.throughput(Throughput::Elements(sim.projections_per_step()));
            group.bench_function(BenchmarkId::new(name, n), |b| match pool {
                Some(pool) => b.iter(|| pool.install(|| sim.step().expect("no blow-up"))),
                None => b.iter(|| sim.step().expect("no blow-up")),
            });
        }
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

criterion_group! {
    name = benches;
    config = config();
    targets = relaxations, scale
}
criterion_main!(benches);
