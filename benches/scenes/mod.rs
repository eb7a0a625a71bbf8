//! The scenes both timing benchmarks build (`solver.rs` with criterion,
//! `ratios.rs` window by window in one process), so that the two time the
//! same cloths.

// Each benchmark uses some of these.
#![allow(dead_code)]

use drape::sim::{Collider, Grid, GridPlane, Pins, Pose, Shape, Simulation, SolverKind, SolverParams, Wind};
use glam::Vec3;

/// A simulation warmed up for 20 steps, so the cloth is moving as it will.
pub fn warmed(mesh: drape::sim::ClothMesh, params: SolverParams, kind: SolverKind) -> Simulation {
    let mut sim = Simulation::with_solver(mesh, params, kind).expect("valid benchmark scene");
    sim.advance(20).expect("the benchmark scene does not blow up");
    sim
}

/// disc-183 ([`ring_disc`]: 101 017 particles, no grid, the coloured
/// path) under `params`, its pinned middle third over a 1 m ball, after
/// 1.5 s: its hem has reached the ground 2 m below and lies on it.
pub fn draped_disc(params: SolverParams) -> Simulation {
    let floor =
        Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose { translation: Vec3::Y * -2.0, ..Pose::default() });
    let ball = Collider::fixed(Shape::Sphere { radius: 1.0 }, Pose { translation: Vec3::Y * -1.05, ..Pose::default() });
    let mut disc = Simulation::with_solver(ring_disc(183, 0.02), params, SolverKind::Fast)
        .expect("valid scene")
        .with_colliders(vec![floor, ball]);
    disc.advance(150).expect("no blow-up");
    disc
}

/// A triangulated n × n sheet (two triangles a cell, alternating
/// diagonals) in the x–y plane, `spacing` apart, hung by its top row: a
/// triangle mesh, so it takes the coloured path, not the grid's lanes.
pub fn triangle_sheet(n: u32, spacing: f32) -> drape::sim::ClothMesh {
    numbered_sheet(n, spacing, |i| i, |_, _| 0.0)
}

/// [`triangle_sheet`] whose rest shape is a wave 0.3 m high (z = 0.3 sin 2x
/// cos 1.5y), as a sheet modelled draped over something would be: every
/// bar has its own rest length.
pub fn wavy_sheet(n: u32, spacing: f32) -> drape::sim::ClothMesh {
    numbered_sheet(n, spacing, |i| i, |x, y| 0.3 * (2.0 * x).sin() * (1.5 * y).cos())
}

/// [`triangle_sheet`] with its particles numbered in a shuffled order (a
/// fixed permutation), as a mesh built by code or subdivided can leave them.
pub fn shuffled_sheet(n: u32, spacing: f32) -> drape::sim::ClothMesh {
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
pub fn numbered_sheet(
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
pub fn ring_disc(rings: u32, spacing: f32) -> drape::sim::ClothMesh {
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

/// The hanging cloths' settings (`scale`, `mesh`): 20 relaxations,
/// h = 0.01 s, m = 1 g, gravity as a force (9.8 m/s² on 1 g) and the
/// seed's wind at 1/1000.
pub fn hanging_params() -> SolverParams {
    SolverParams {
        relaxations: 20,
        dt: 0.01,
        mass: 0.001,
        gravity: Vec3::new(0.0, -0.0098, 0.0),
        wind: Wind::Seed { scale: 0.001 },
        ..SolverParams::default()
    }
}

/// An n × n grid of 2 cm hung by its top row (`scale`).
pub fn hanging_square(n: u32) -> drape::sim::ClothMesh {
    Grid { columns: n, rows: n, spacing: 0.02, pins: Pins::TopRow, ..Grid::default() }.build().expect("valid grid")
}

/// An n × n grid of 2 cm lying flat (x–z) and free, its centre `height`
/// above the origin.
fn lying_square(n: u32, height: f32) -> drape::sim::ClothMesh {
    let half = 0.5 * 0.02 * (n - 1) as f32;
    Grid {
        columns: n,
        rows: n,
        spacing: 0.02,
        plane: GridPlane::Horizontal,
        origin: Some(Vec3::new(-half, height, -half)),
        pins: Pins::None,
        ..Grid::default()
    }
    .build()
    .expect("valid grid")
}

/// The lying cloths' settings (contact, self-collision): as
/// [`hanging_params`] without wind.
pub fn lying_params() -> SolverParams {
    SolverParams { wind: Wind::None, ..hanging_params() }
}

/// A fixed plane of normal +y at height `y` (m).
pub fn ground(y: f32) -> Collider {
    Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose { translation: Vec3::Y * y, ..Pose::default() })
}

/// A 256 × 256 cloth of 2 cm (5.1 m) at 20 relaxations dropped from 1.7 m
/// onto a 1.5 m sphere on the ground, after 1.5 s: it lies on the ball and
/// its hem on the ground.
pub fn draped_256() -> Simulation {
    let sphere =
        Collider::fixed(Shape::Sphere { radius: 0.75 }, Pose { translation: Vec3::Y * 0.75, ..Pose::default() });
    let mut draped = Simulation::new(lying_square(256, 1.7), lying_params())
        .expect("valid scene")
        .with_colliders(vec![ground(0.0), sphere]);
    draped.advance(150).expect("no blow-up");
    draped
}

/// A 256 × 256 cloth of 2 cm lying folded in two on the ground (the right
/// half laid over the left, 1.5 cm higher; thickness 1.5 cm), 5 steps after
/// it was laid, with self-collision `on` or off.
pub fn folded_256(on: bool) -> Simulation {
    let mesh = lying_square(256, 0.015);
    let folded: Vec<Vec3> =
        mesh.positions().iter().map(|p| if p.x > 0.0 { Vec3::new(-p.x, p.y + 0.015, p.z) } else { *p }).collect();
    let params = SolverParams { thickness: 0.015, self_collision: on, ..lying_params() };
    let mut sim = Simulation::new(mesh, params).expect("valid scene").with_colliders(vec![ground(0.0)]);
    sim.set_state(&folded, &folded).expect("finite state");
    sim.advance(5).expect("no blow-up");
    sim
}

/// The settings of disc-183 draped with self-collision: [`lying_params`]
/// with a thickness of 1 cm.
pub fn disc_params(self_collision: bool) -> SolverParams {
    SolverParams { thickness: 0.01, self_collision, ..lying_params() }
}

/// A 256 × 256 cloth of 2 cm hanging from its top row in physical units
/// (σ = 0.13 kg/m², g = 9.81 m/s²), 20 relaxations: still (`air` None) or
/// in moving air. Warmed up 20 steps.
pub fn hanging_in_air(air: Option<drape::sim::Air>) -> Simulation {
    let mesh = Grid { columns: 256, rows: 256, spacing: 0.02, ..Grid::default() }.build().expect("valid grid");
    let params = SolverParams {
        relaxations: 20,
        dt: 0.01,
        density: Some(0.13),
        gravity_acceleration: Some(Vec3::new(0.0, -9.81, 0.0)),
        wind: air.map_or(Wind::None, Wind::Air),
        ..SolverParams::default()
    };
    warmed(mesh, params, SolverKind::Fast)
}

/// The air [`hanging_in_air`] is benchmarked in: 8 m/s with 30 % gusts.
pub fn blowing() -> drape::sim::Air {
    drape::sim::Air { velocity: Vec3::new(8.0, 0.0, 0.0), gusts: 0.3, ..Default::default() }
}
