//! Contact and friction against exact answers: no particle inside any
//! collider, Coulomb's friction angle and sliding acceleration, a cloth
//! carried by a moving box, no tunnelling at 30 m/s, resting contact that
//! comes to rest, and both solvers agreeing.

use std::sync::Arc;

use drape::sim::{
    Collider, Grid, GridPlane, MeshShape, Motion, Pins, Pose, Shape, Simulation, SolverKind, SolverParams,
};
use glam::{Quat, Vec3};

const G: f32 = 9.8;

/// Particle mass 0.01 kg, gravity as the force m·g, no wind.
fn params(dt: f32) -> SolverParams {
    SolverParams { dt, mass: 0.01, gravity: Vec3::new(0.0, -G * 0.01, 0.0), ..SolverParams::default() }
}

/// A horizontal n × n sheet of `spacing`, centred over (x, z) = (0, 0) at height y.
fn sheet(n: u32, spacing: f32, y: f32) -> Grid {
    let half = 0.5 * spacing * (n - 1) as f32;
    Grid {
        columns: n,
        rows: n,
        spacing,
        plane: GridPlane::Horizontal,
        origin: Some(Vec3::new(-half, y, -half)),
        pins: Pins::None,
        ..Grid::default()
    }
}

fn at(translation: Vec3) -> Pose {
    Pose { translation, ..Pose::default() }
}

/// A closed axis-aligned box mesh of half size `e`, faces wound outwards.
fn box_mesh(e: Vec3) -> MeshShape {
    let v: Vec<Vec3> =
        (0..8).map(|k| Vec3::new([-e.x, e.x][k & 1], [-e.y, e.y][(k >> 1) & 1], [-e.z, e.z][(k >> 2) & 1])).collect();
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let t = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    MeshShape::new(v, t).unwrap()
}

/// The smallest φ − r over particles and colliders (negative: inside the
/// thickness), at the simulation's current time.
fn worst_clearance(sim: &Simulation) -> f32 {
    let r = sim.params().thickness;
    let poses = sim.collider_poses();
    let mut worst = f32::INFINITY;
    for (c, pose) in sim.colliders().iter().zip(&poses) {
        for &x in sim.positions() {
            if let Some(p) = c.shape.proximity(pose.inverse_apply(x)) {
                worst = worst.min(p.distance - r);
            }
        }
    }
    worst
}

#[test]
fn no_particle_ends_a_step_inside_any_collider_in_either_solver() {
    // A 15 × 15 sheet of 0.04 m (0.56 m across) dropped from 0.5 m onto each
    // shape, centred 0.2 m above the ground. After every step every particle
    // is at least the thickness (0.01 m) from every surface, less 1 % of it
    // plus f32 rounding of coordinates near 1 m (1e-6).
    let e = Vec3::new(0.15, 0.1, 0.15);
    let shapes: Vec<(&str, Shape, Quat)> = vec![
        ("sphere", Shape::Sphere { radius: 0.15 }, Quat::IDENTITY),
        ("capsule", Shape::Capsule { half_axis: Vec3::new(0.2, 0.0, 0.0), radius: 0.08 }, Quat::from_rotation_y(0.4)),
        ("box", Shape::Box { half_extents: e }, Quat::from_rotation_y(0.5)),
        ("mesh", Shape::Mesh(Arc::new(box_mesh(e))), Quat::from_rotation_y(-0.3)),
    ];
    for (name, shape, rotation) in shapes {
        for kind in SolverKind::ALL {
            let mesh = sheet(15, 0.04, 0.5).build().unwrap();
            let p = SolverParams { substeps: 2, relaxations: 10, ..params(1.0 / 60.0) };
            let colliders = vec![
                Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose::default()),
                Collider::fixed(shape.clone(), Pose { rotation, translation: Vec3::new(0.0, 0.2, 0.0) }),
            ];
            let mut sim = Simulation::with_solver(mesh, p, kind).unwrap().with_colliders(colliders);
            let mut lowest_centre = f32::INFINITY;
            for step in 0..120 {
                sim.step().unwrap();
                let clearance = worst_clearance(&sim);
                assert!(clearance >= -(0.01 * 0.01 + 1e-6), "{name}, {kind:?}, step {step}: {clearance} m inside");
                lowest_centre = lowest_centre.min(sim.positions()[7 * 15 + 7].y);
            }
            // It did fall onto the shape: the centre particle rests on top
            // (the shape's top is at most 0.2 + 0.15 + r above the ground),
            // far below where it started.
            assert!(lowest_centre < 0.37, "{name}, {kind:?}: the sheet never reached the shape ({lowest_centre})");
        }
    }
}

/// A 4 × 4 sheet lying on a slope of `degrees` about z (rising towards −x),
/// thickness above it; returns the simulation.
fn on_slope(degrees: f32, mu: f32, kind: SolverKind) -> (Simulation, Vec3) {
    let theta = degrees.to_radians();
    let rotation = Quat::from_rotation_z(theta);
    let normal = rotation * Vec3::Y;
    let r = 0.01;
    let grid = sheet(4, 0.05, 0.0).build().unwrap();
    let positions: Vec<Vec3> = grid.positions().iter().map(|&p| rotation * p + normal * r).collect();
    let mesh = drape::sim::ClothMesh::new(drape::sim::MeshParts {
        positions,
        bars: grid.bars().iter().map(|b| (b.a, b.b, b.kind)).collect(),
        ..Default::default()
    })
    .unwrap();
    let p = SolverParams { damping: 0.0, thickness: r, friction: mu, ..params(0.01) };
    let ground = Collider::fixed(Shape::Plane { normal }, Pose::default());
    let downhill = rotation * Vec3::NEG_X;
    // The slope falls along −x rotated: for a rotation about +z by θ the
    // plane's downhill direction is (−cos θ, −sin θ, 0).
    (Simulation::with_solver(mesh, p, kind).unwrap().with_colliders(vec![ground]), downhill)
}

fn mean(points: &[Vec3]) -> Vec3 {
    points.iter().sum::<Vec3>() / points.len() as f32
}

#[test]
fn cloth_sticks_below_the_friction_angle() {
    // μ = 0.5: the friction angle is atan 0.5 = 26.6°. At 15° the pull along
    // the slope, g sin 15° = 2.54 m/s², is below μ g cos 15° = 4.73 m/s²:
    // the sheet must not move at all (static friction removes all of it).
    for kind in SolverKind::ALL {
        let (mut sim, _) = on_slope(15.0, 0.5, kind);
        let start = mean(sim.positions());
        sim.advance(200).unwrap();
        let moved = mean(sim.positions()).distance(start);
        assert!(moved < 1e-5, "{kind:?}: slid {moved} m on a 15° slope with μ = 0.5");
        assert!(worst_clearance(&sim) > -1e-6);
    }
}

#[test]
fn cloth_slides_above_the_friction_angle_at_coulombs_acceleration() {
    // 40°, μ = 0.5, δ = 0: a = g (sin 40° − μ cos 40°) = 9.8 (0.6428 − 0.3830)
    // = 2.546 m/s². Starting from rest with the Euler start, Verlet gives
    // s_k = a h² k(k − 1)/2 after k steps: 100 steps of 0.01 s → 0.495 a =
    // 1.260 m. Tolerance 2 %, for the first step (a contact that starts at
    // the thickness exactly) and f32 rounding. Without friction it would
    // slide g sin 40° · 0.495 = 3.12 m, which the same check rejects.
    let a = G * (40f32.to_radians().sin() - 0.5 * 40f32.to_radians().cos());
    let expected = a * 0.01 * 0.01 * 100.0 * 99.0 / 2.0;
    for (mu, want) in [(0.5, expected), (0.0, G * 40f32.to_radians().sin() * 0.495)] {
        for kind in SolverKind::ALL {
            let (mut sim, downhill) = on_slope(40.0, mu, kind);
            let start = mean(sim.positions());
            sim.advance(100).unwrap();
            let slid = (mean(sim.positions()) - start).dot(downhill);
            assert!((slid - want).abs() < 0.02 * want, "{kind:?}, μ {mu}: slid {slid} m, expected {want} m");
        }
    }
}

#[test]
fn cloth_on_a_moving_box_is_carried_along_by_friction() {
    // A 5 × 5 sheet resting on a box whose top is at y = 0 moves with it at
    // 0.2 m/s along x. Friction accelerates it at μ g = 4.9 m/s² until it
    // matches the box (after 0.04 s, having slipped 0.2²/(2 · 4.9) = 4 mm),
    // so after 2 s it has moved 0.4 − 0.004 m. Without friction it stays.
    for (mu, want) in [(0.5f32, 0.396f32), (0.0, 0.0)] {
        let mesh = sheet(5, 0.05, 0.01).build().unwrap();
        let p = SolverParams { friction: mu, ..params(0.01) };
        let mut table =
            Collider::fixed(Shape::Box { half_extents: Vec3::new(1.0, 0.1, 1.0) }, at(Vec3::new(0.0, -0.1, 0.0)));
        table.motion = Motion::Moving { velocity: Vec3::new(0.2, 0.0, 0.0), angular_velocity: Vec3::ZERO };
        let mut sim = Simulation::new(mesh, p).unwrap().with_colliders(vec![table]);
        sim.advance(200).unwrap();
        let c = mean(sim.positions());
        assert!((c.x - want).abs() < 0.006, "μ {mu}: moved {} m along x, expected {want}", c.x);
        assert!((c.y - 0.01).abs() < 1e-4, "μ {mu}: height {} (should rest on the top at the thickness)", c.y);
    }
}

#[test]
fn a_fast_patch_stops_on_the_near_side_of_a_sphere() {
    // A 3 × 3 patch (4 cm) thrown at 30 m/s along +x at a sphere of radius
    // 0.15 m centred at the origin, h = 1/60 s, no gravity: 0.5 m per step,
    // more than the sphere's 0.3 m diameter. It starts at x = −0.75, so the
    // positions it would visit, −0.25 and +0.25, both lie outside the
    // sphere: a check of end positions alone would let it through.
    for kind in SolverKind::ALL {
        let n = 3;
        let grid = Grid {
            columns: n,
            rows: n,
            spacing: 0.02,
            plane: GridPlane::Vertical,
            origin: Some(Vec3::new(-0.75, 0.02, -0.02)),
            pins: Pins::None,
            ..Grid::default()
        };
        let base = grid.build().unwrap();
        let mesh = drape::sim::ClothMesh::new(drape::sim::MeshParts {
            positions: base.positions().to_vec(),
            velocities: vec![Vec3::new(30.0, 0.0, 0.0); 9],
            bars: base.bars().iter().map(|b| (b.a, b.b, b.kind)).collect(),
            ..Default::default()
        })
        .unwrap();
        let sphere = Shape::Sphere { radius: 0.15 };
        for x in [-0.25f32, 0.25] {
            assert!(sphere.proximity(Vec3::new(x, 0.0, 0.0)).unwrap().distance > 0.09);
        }
        let p = SolverParams { gravity: Vec3::ZERO, damping: 0.0, ..params(1.0 / 60.0) };
        let free = Simulation::with_solver(mesh.clone(), p.clone(), kind).unwrap();
        let mut sim = free.clone().with_colliders(vec![Collider::fixed(sphere, Pose::default())]);
        let mut free = free;
        sim.advance(10).unwrap();
        free.advance(10).unwrap();
        assert!(free.positions().iter().all(|q| q.x > 1.0), "{kind:?}: without the sphere it flies past");
        for q in sim.positions() {
            assert!(q.x < 0.0 && q.length() >= 0.15 + 0.01 - 1e-4, "{kind:?}: particle at {q} got past the sphere");
        }
    }
}

#[test]
fn resting_contact_comes_to_rest() {
    // A 11 × 11 sheet dropped from 0.1 m onto the ground, and one draped over
    // a sphere, at several relaxation counts. δ = 0.02 per 10 ms step takes
    // 87 % of the motion away each second, so from the landing's ~1e-3 J the
    // kinetic energy falls about tenfold a second (measured: 5e-8 J at 4 s,
    // 4e-11 J at 7 s over the sphere with 4 relaxations). After 8 s it must
    // be below 1e-10 J (121 particles of 0.01 kg: RMS speed under 13 µm/s),
    // and over the last second no particle may creep more than 10 µm: no
    // buzz, no slow slide.
    for (name, sphere) in [("ground", false), ("sphere", true)] {
        for relaxations in [4, 20, 60] {
            for kind in SolverKind::ALL {
                let mesh = sheet(11, 0.05, if sphere { 0.4 } else { 0.1 }).build().unwrap();
                let p = SolverParams { relaxations, ..params(0.01) };
                let mut colliders = vec![Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose::default())];
                if sphere {
                    colliders.push(Collider::fixed(Shape::Sphere { radius: 0.2 }, at(Vec3::new(0.0, 0.15, 0.0))));
                }
                let mut sim = Simulation::with_solver(mesh, p, kind).unwrap().with_colliders(colliders);
                sim.advance(700).unwrap();
                let before = sim.positions().to_vec();
                sim.advance(100).unwrap();
                let e = sim.kinetic_energy();
                let what = format!("{name}, {relaxations} relaxations, {kind:?}");
                assert!(e < 1e-10, "{what}: kinetic energy {e} J after 8 s");
                let creep = before.iter().zip(sim.positions()).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
                assert!(creep < 1e-5, "{what}: a particle moved {creep} m in the last second");
            }
        }
    }
}

#[test]
fn both_solvers_agree_on_a_sheet_landing_flat() {
    // Landing flat, nothing folds, so the order of projections matters to
    // rounding only: the two solvers end within 0.1 mm of each other.
    let run = |kind| {
        let mesh = sheet(20, 0.05, 0.3).build().unwrap();
        let ground = Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose::default());
        let mut sim = Simulation::with_solver(mesh, params(0.01), kind).unwrap().with_colliders(vec![ground]);
        sim.advance(150).unwrap();
        sim.positions().to_vec()
    };
    let (a, b) = (run(SolverKind::Fast), run(SolverKind::Reference));
    let worst = a.iter().zip(&b).map(|(p, q)| p.distance(*q)).fold(0.0, f32::max);
    assert!(worst < 1e-4, "solvers differ by {worst} m");
    assert!(a.iter().all(|p| (p.y - 0.01).abs() < 1e-4), "the sheet lies on the ground at the thickness");
}

#[test]
fn pinning_is_a_write_and_changes_nothing_else() {
    // Pin and unpin a particle of a 64 × 64 lane layout: the state stays
    // bit for bit what it was, and a pinned particle holds still.
    let mesh = Grid { columns: 64, rows: 64, spacing: 0.02, ..Grid::default() }.build().unwrap();
    let mut sim = Simulation::new(mesh, params(0.01)).unwrap();
    sim.advance(5).unwrap();
    let before = sim.positions().to_vec();
    let i = 40 * 64 + 10;
    sim.set_fixed(i, true).unwrap();
    sim.set_fixed(i, false).unwrap();
    sim.set_fixed(i, true).unwrap();
    assert_eq!(sim.positions(), &before[..]);
    sim.advance(20).unwrap();
    assert_eq!(sim.positions()[i], before[i], "a pinned particle does not move");
    sim.set_fixed(i, false).unwrap();
    sim.advance(20).unwrap();
    assert!(sim.positions()[i].distance(before[i]) > 1e-3, "freed, it moves again");
}

#[test]
fn a_fast_patch_stops_on_the_near_side_of_an_open_mesh_wall() {
    // Meshes guarantee the same as the analytic shapes for particles: every
    // particle's path through a substep is cast against the triangles (the
    // BVH), so none crosses a triangle in one step. A 1 m square wall of two
    // triangles (open: two-sided) stands in the plane x = 0; a patch thrown
    // at it at 30 m/s with h = 1/60 s (0.5 m per step) from x = −0.75 would
    // jump from −0.25 to +0.25 without ever being within the thickness of it.
    let wall = MeshShape::new(
        vec![
            Vec3::new(0.0, -0.5, -0.5),
            Vec3::new(0.0, 0.5, -0.5),
            Vec3::new(0.0, 0.5, 0.5),
            Vec3::new(0.0, -0.5, 0.5),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
    .unwrap();
    assert!(!wall.closed());
    for kind in SolverKind::ALL {
        let base = Grid {
            columns: 3,
            rows: 3,
            spacing: 0.02,
            origin: Some(Vec3::new(-0.75, 0.02, -0.02)),
            pins: Pins::None,
            ..Grid::default()
        }
        .build()
        .unwrap();
        let mesh = drape::sim::ClothMesh::new(drape::sim::MeshParts {
            positions: base.positions().to_vec(),
            velocities: vec![Vec3::new(30.0, 0.0, 0.0); 9],
            bars: base.bars().iter().map(|b| (b.a, b.b, b.kind)).collect(),
            ..Default::default()
        })
        .unwrap();
        let p = SolverParams { gravity: Vec3::ZERO, damping: 0.0, ..params(1.0 / 60.0) };
        let collider = Collider::fixed(Shape::Mesh(Arc::new(wall.clone())), Pose::default());
        let mut sim = Simulation::with_solver(mesh, p, kind).unwrap().with_colliders(vec![collider]);
        sim.advance(10).unwrap();
        for q in sim.positions() {
            assert!(q.x <= -0.01 + 1e-5, "{kind:?}: particle at {q} got through the wall");
        }
    }
}
