//! Criterion benchmarks of one solver step: the seed's Table 1 (relaxation
//! counts on its 20 × 30 cloth) and larger cloths, reference beside fast in
//! the same run so their ratio holds however busy the machine is.
//!
//! `cargo bench --bench solver`; throughput is in bar projections
//! (bars × relaxations per step).

mod common;

use std::time::Duration;

use criterion::{Bencher, BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use drape::sim::{Collider, Grid, GridPlane, Pins, Pose, Shape, Simulation, SolverKind, SolverParams, Wind};
use glam::Vec3;

/// A simulation warmed up for 20 steps, so the cloth is moving as it will.
fn warmed(mesh: drape::sim::ClothMesh, params: SolverParams, kind: SolverKind) -> Simulation {
    let mut sim = Simulation::with_solver(mesh, params, kind).expect("valid benchmark scene");
    sim.advance(20).expect("the benchmark scene does not blow up");
    sim
}

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
    let ground = |y: f32| {
        Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose { translation: Vec3::Y * y, ..Pose::default() })
    };

    let scene = drape::scene::load("seed").expect("bundled scene");
    let far =
        warmed((*scene.mesh).clone(), scene.params.clone(), SolverKind::Fast).with_colliders(vec![ground(-100.0)]);
    for (name, colliders) in [("seed-far-ground/without", vec![]), ("seed-far-ground/with", vec![ground(-100.0)])] {
        let mut sim = far.clone();
        sim.set_colliders(colliders);
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }

    let n = 256u32;
    let half = 0.5 * 0.02 * (n - 1) as f32;
    let mesh = Grid {
        columns: n,
        rows: n,
        spacing: 0.02,
        plane: GridPlane::Horizontal,
        origin: Some(Vec3::new(-half, 1.7, -half)),
        pins: Pins::None,
        ..Grid::default()
    }
    .build()
    .expect("valid grid");
    let params = SolverParams {
        relaxations: 20,
        dt: 0.01,
        mass: 0.001,
        gravity: Vec3::new(0.0, -0.0098, 0.0),
        ..SolverParams::default()
    };
    let sphere =
        Collider::fixed(Shape::Sphere { radius: 0.75 }, Pose { translation: Vec3::Y * 0.75, ..Pose::default() });
    let mut draped =
        Simulation::new(mesh, params.clone()).expect("valid scene").with_colliders(vec![ground(0.0), sphere]);
    // 1.5 s: the cloth has landed on the ball and its hem on the ground.
    draped.advance(150).expect("no blow-up");
    let disc = draped_disc(params);
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

/// disc-183 ([`ring_disc`]: 101 017 particles, no grid, the coloured
/// path) under `params`, its pinned middle third over a 1 m ball, after
/// 1.5 s: its hem has reached the ground 2 m below and lies on it.
fn draped_disc(params: SolverParams) -> Simulation {
    let floor =
        Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose { translation: Vec3::Y * -2.0, ..Pose::default() });
    let ball = Collider::fixed(Shape::Sphere { radius: 1.0 }, Pose { translation: Vec3::Y * -1.05, ..Pose::default() });
    let mut disc = Simulation::with_solver(ring_disc(183, 0.02), params, SolverKind::Fast)
        .expect("valid scene")
        .with_colliders(vec![floor, ball]);
    disc.advance(150).expect("no blow-up");
    disc
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
    let n = 256u32;
    let mesh = Grid { columns: n, rows: n, spacing: 0.02, ..Grid::default() }.build().expect("valid grid");
    let physical = SolverParams {
        relaxations: 20,
        dt: 0.01,
        density: Some(0.13),
        gravity_acceleration: Some(Vec3::new(0.0, -9.81, 0.0)),
        ..SolverParams::default()
    };
    let seed_way = SolverParams {
        relaxations: 20,
        dt: 0.01,
        mass: 0.13 * 0.02 * 0.02,
        gravity: Vec3::new(0.0, -9.81 * 0.13 * 0.02 * 0.02, 0.0),
        ..SolverParams::default()
    };
    let blowing = drape::sim::Air { velocity: Vec3::new(8.0, 0.0, 0.0), gusts: 0.3, ..Default::default() };
    let cases = [
        ("256-hanging/mass-per-particle", seed_way),
        ("256-hanging/still", physical.clone()),
        ("256-hanging/air", SolverParams { wind: Wind::Air(blowing), ..physical }),
    ];
    for (name, params) in cases {
        let mut sim = warmed(mesh.clone(), params, SolverKind::Fast);
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
    let n = 256u32;
    let half = 0.5 * 0.02 * (n - 1) as f32;
    let mesh = Grid {
        columns: n,
        rows: n,
        spacing: 0.02,
        plane: GridPlane::Horizontal,
        origin: Some(Vec3::new(-half, 0.015, -half)),
        pins: Pins::None,
        ..Grid::default()
    }
    .build()
    .expect("valid grid");
    // Folded along x = 0: the right half laid over the left, 1.5 cm higher.
    let folded: Vec<Vec3> =
        mesh.positions().iter().map(|p| if p.x > 0.0 { Vec3::new(-p.x, p.y + 0.015, p.z) } else { *p }).collect();
    let params = SolverParams {
        relaxations: 20,
        dt: 0.01,
        mass: 0.001,
        gravity: Vec3::new(0.0, -0.0098, 0.0),
        thickness: 0.015,
        ..SolverParams::default()
    };
    let ground = Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose::default());
    for on in [false, true] {
        let mut sim = Simulation::new(mesh.clone(), SolverParams { self_collision: on, ..params.clone() })
            .expect("valid scene")
            .with_colliders(vec![ground.clone()]);
        sim.set_state(&folded, &folded).expect("finite state");
        sim.advance(5).expect("no blow-up");
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
    let disc_params = SolverParams { thickness: 0.01, ..params };
    let disc = draped_disc(SolverParams { self_collision: true, ..disc_params.clone() });
    for on in [false, true] {
        let mut sim = disc.clone();
        sim.set_params(SolverParams { self_collision: on, ..disc_params.clone() }).expect("valid parameters");
        let name = if on { "disc-183-draped/with" } else { "disc-183-draped/without" };
        group.bench_function(name, |b| b.iter(|| sim.step().expect("no blow-up")));
    }
    group.finish();
}

/// A triangulated n × n sheet (two triangles a cell, alternating
/// diagonals) in the x–y plane, `spacing` apart, hung by its top row: a
/// triangle mesh, so it takes the coloured path, not the grid's lanes.
fn triangle_sheet(n: u32, spacing: f32) -> drape::sim::ClothMesh {
    numbered_sheet(n, spacing, |i| i, |_, _| 0.0)
}

/// [`triangle_sheet`] whose rest shape is a wave 0.3 m high (z = 0.3 sin 2x
/// cos 1.5y), as a sheet modelled draped over something would be: every
/// bar has its own rest length.
fn wavy_sheet(n: u32, spacing: f32) -> drape::sim::ClothMesh {
    numbered_sheet(n, spacing, |i| i, |x, y| 0.3 * (2.0 * x).sin() * (1.5 * y).cos())
}

/// [`triangle_sheet`] with its particles numbered in a shuffled order (a
/// fixed permutation), as a mesh built by code or subdivided can leave them.
fn shuffled_sheet(n: u32, spacing: f32) -> drape::sim::ClothMesh {
    let mut new_index: Vec<u32> = (0..n * n).collect();
    let mut state = 12345u64;
    for i in (1..new_index.len()).rev() {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        new_index.swap(i, (state >> 33) as usize % (i + 1));
    }
    numbered_sheet(n, spacing, |i| new_index[i as usize], |_, _| 0.0)
}

/// An n × n triangulated sheet hung by its top row; particle (c, r) gets
/// the index `number(r·n + c)` (a permutation), and sits at z = `height(x,
/// y)`.
fn numbered_sheet(
    n: u32,
    spacing: f32,
    number: impl Fn(u32) -> u32,
    height: impl Fn(f32, f32) -> f32,
) -> drape::sim::ClothMesh {
    let index = |c: u32, r: u32| number(r * n + c);
    let mut positions = vec![Vec3::ZERO; (n * n) as usize];
    for r in 0..n {
        for c in 0..n {
            let (x, y) = (c as f32 * spacing, -(r as f32) * spacing);
            positions[index(c, r) as usize] = Vec3::new(x, y, height(x, y));
        }
    }
    let mut triangles = Vec::with_capacity(2 * (n as usize - 1).pow(2));
    for r in 0..n - 1 {
        for c in 0..n - 1 {
            let (a, b, d, e) = (index(c, r), index(c + 1, r), index(c, r + 1), index(c + 1, r + 1));
            if (r + c) % 2 == 0 {
                triangles.extend([[a, d, e], [a, e, b]]);
            } else {
                triangles.extend([[a, d, b], [b, d, e]]);
            }
        }
    }
    let pinned: Vec<u64> = (0..n).map(|c| u64::from(index(c, 0))).collect();
    drape::sim::ClothMesh::from_triangles(positions, triangles, &pinned, None).expect("valid sheet")
}

/// A round cloth like the bundled tablecloth, larger: a centre particle and
/// `rings` rings of 6k particles (k = 1, 2, …), `spacing` apart, each ring
/// joined to the one inside it by a zipper of triangles (the next triangle
/// takes whichever ring's next particle comes first by angle); the centre
/// and the inner third of the rings pinned as a table top. 183 rings:
/// 101 017 particles. No grid in any numbering, so the coloured path runs
/// it.
fn ring_disc(rings: u32, spacing: f32) -> drape::sim::ClothMesh {
    let first = |k: u32| if k == 0 { 0 } else { 1 + 3 * k * (k - 1) };
    let count = |k: u32| if k == 0 { 1 } else { 6 * k };
    let angle = |k: u32, j: u32| std::f32::consts::TAU * j as f32 / count(k) as f32;
    let mut positions = Vec::new();
    for k in 0..=rings {
        for j in 0..count(k) {
            let (s, c) = angle(k, j).sin_cos();
            positions.push(Vec3::new(c * k as f32 * spacing, 0.0, s * k as f32 * spacing));
        }
    }
    let mut triangles = Vec::new();
    for k in 1..=rings {
        let (inner, outer) = (count(k - 1), count(k));
        let at = |ring: u32, j: u32, n: u32| first(ring) + j % n;
        let (mut i, mut o) = (0, 0);
        while i < inner || o < outer {
            // Angles of the next particle on each ring (a full turn at the end).
            let next_inner = if inner == 1 { f32::INFINITY } else { angle(k - 1, i + 1) };
            let next_outer = angle(k, o + 1);
            if o < outer && (i >= inner || next_outer <= next_inner) {
                triangles.push([at(k - 1, i, inner), at(k, o, outer), at(k, o + 1, outer)]);
                o += 1;
            } else {
                triangles.push([at(k - 1, i, inner), at(k, o, outer), at(k - 1, i + 1, inner)]);
                i += 1;
            }
            if inner == 1 && o == outer {
                break;
            }
        }
    }
    let pinned: Vec<u64> = (0..u64::from(first(rings / 3 + 1))).collect();
    drape::sim::ClothMesh::from_triangles(positions, triangles, &pinned, None).expect("valid disc")
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
    let sheet_params = SolverParams {
        relaxations: 20,
        dt: 0.01,
        mass: 0.001,
        gravity: glam::Vec3::new(0.0, -0.0098, 0.0),
        wind: Wind::Seed { scale: 0.001 },
        ..SolverParams::default()
    };
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
