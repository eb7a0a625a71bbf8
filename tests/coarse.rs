//! The coarse phase (`coarse_passes`, hierarchical passes on a grid's
//! coarser levels): the 256 × 256 cloth within a few percent of its edges'
//! length, and shown to need the phase; grids only; pins and unequal
//! masses; the same bits on any thread count.

use drape::sim::{Grid, Pins, SimError, Simulation, SolverKind, SolverParams, Wind};
use glam::Vec3;

mod strain;
use strain::edge_strain_run;

#[test]
fn the_large_cloth_keeps_its_edges_within_two_percent_and_needs_the_coarse_passes_for_it() {
    // The `large-inextensible` scene: the 256 × 256 cloth of `large` (its
    // wind, h, δ, m), 8 passes, 2 coarse passes a level, soft diagonals.
    // Steps 10–20 as the accuracy benchmark measures them: measured
    // 1.36 % typical, 1.56 % worst. The bound, 2 %, is the target
    // (5 %) with room, and far below the same settings without the coarse
    // phase (measured 10.0 % typical): the run is deterministic, so the
    // margin only has to cover compilers and CPUs (f32 rounding).
    let scene = drape::scene::load("large-inextensible").unwrap();
    let large = drape::scene::load("large").unwrap();
    let (p, l) = (&scene.params, &large.params);
    assert_eq!((p.dt, p.damping, p.mass, p.gravity, p.wind), (l.dt, l.damping, l.mass, l.gravity, l.wind));
    assert_eq!(scene.mesh.positions(), large.mesh.positions());
    let mut sim = Simulation::new(scene.mesh.clone(), scene.params.clone()).unwrap();
    let (typical, worst) = edge_strain_run(&mut sim, 10, 10);
    eprintln!("large-inextensible: typical {typical}, worst {worst}");
    assert!(typical <= 0.02 && worst <= 0.025, "typical {typical}, worst {worst}");
    let off = SolverParams { coarse_passes: 0, ..scene.params.clone() };
    let (typical_off, _) = edge_strain_run(&mut Simulation::new(scene.mesh.clone(), off).unwrap(), 10, 10);
    assert!(typical_off > 0.07, "without the coarse passes: typical {typical_off}");
}

/// A `size` × `size` hanging cloth of 2 cm in the seed's wind at 1/1000
/// (the `large` scene's settings), soft diagonals, with coarse passes.
fn hanging(size: u32, coarse_passes: u32) -> (drape::sim::ClothMesh, SolverParams) {
    let mesh =
        Grid { columns: size, rows: size, spacing: 0.02, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
    let params = SolverParams {
        relaxations: 8,
        coarse_passes,
        shear_compliance: Some(1.0),
        dt: 0.01,
        mass: 0.001,
        gravity: Vec3::new(0.0, -0.0098, 0.0),
        wind: Wind::Seed { scale: 0.001 },
        ..SolverParams::default()
    };
    (mesh, params)
}

#[test]
fn coarse_passes_need_a_grid() {
    let tablecloth = drape::scene::load("tablecloth").unwrap();
    let params = SolverParams { coarse_passes: 2, ..tablecloth.params.clone() };
    let e = Simulation::new(tablecloth.mesh.clone(), params.clone()).unwrap_err();
    assert_eq!(e, SimError::CoarseNeedsGrid { passes: 2 });
    assert!(e.to_string().contains("needs a grid mesh"), "{e}");
    // Asked of a running simulation: refused, and nothing changes.
    let mut sim = Simulation::new(tablecloth.mesh.clone(), tablecloth.params.clone()).unwrap();
    assert_eq!(sim.set_params(params), Err(SimError::CoarseNeedsGrid { passes: 2 }));
    assert_eq!(sim.params().coarse_passes, 0);
    sim.advance(2).unwrap();
}

#[test]
fn pins_are_writes_and_unequal_masses_work() {
    let (mesh, params) = hanging(40, 2);
    let mut sim = Simulation::new(mesh, params.clone()).unwrap();
    sim.advance(20).unwrap();
    // Unpin the top row's middle (columns 10–29) and pin a particle in the
    // middle of the cloth where it is now.
    for c in 10..30 {
        sim.set_fixed(c, false).unwrap();
    }
    let middle = 20 * 40 + 20;
    sim.set_fixed(middle, true).unwrap();
    let held = sim.positions()[middle];
    let corner = sim.positions()[0];
    let freed_before = sim.positions()[20];
    sim.advance(30).unwrap();
    // Fixed particles do not move at all (the coarse phase pushes nothing
    // into them, though it sees them between its nodes); freed ones fall.
    assert_eq!(sim.positions()[middle], held);
    assert_eq!(sim.positions()[0], corner);
    assert!(sim.positions()[20].y < freed_before.y - 0.01, "{} vs {freed_before}", sim.positions()[20]);
    assert!(sim.positions().iter().all(|p| p.is_finite()));

    // Unequal masses: a density and g (edge particles weigh less). The
    // phase keeps the edges as tight as with equal masses: within 2 % over
    // steps 10–30 (measured 0.26 %), against more than 5 % without it
    // (measured 19 %).
    let dense = SolverParams {
        density: Some(0.13),
        gravity_acceleration: Some(Vec3::new(0.0, -9.8, 0.0)),
        wind: Wind::None,
        ..params
    };
    let (mesh, _) = hanging(64, 2);
    let (with, _) = edge_strain_run(&mut Simulation::new(mesh.clone(), dense.clone()).unwrap(), 10, 20);
    let without = SolverParams { coarse_passes: 0, ..dense };
    let (off, _) = edge_strain_run(&mut Simulation::new(mesh, without).unwrap(), 10, 20);
    eprintln!("unequal masses: {with} with, {off} without");
    assert!(with < 0.02 && off > 0.05, "{with} with, {off} without");
}

#[test]
fn the_same_bits_on_one_and_two_threads_and_both_solvers_agree() {
    // 128 × 128: above the fast solver's and the phase's threading
    // thresholds.
    let (mesh, params) = hanging(128, 2);
    let run = |threads: usize, kind: SolverKind| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut sim = Simulation::with_solver(mesh.clone(), params.clone(), kind).unwrap();
            sim.advance(15).unwrap();
            sim
        })
    };
    let one = run(1, SolverKind::Fast);
    let two = run(2, SolverKind::Fast);
    assert_eq!(one.positions(), two.positions());
    // The reference solver runs the same phase on its own layout: the same
    // strain level (measured within 10 % of each other), not the same bits
    // (it sweeps the bars in another order).
    let reference = run(1, SolverKind::Reference);
    let (fast, slow) = (one.edge_strain().max, reference.edge_strain().max);
    assert!(fast < 0.03 && slow < 0.03, "fast {fast}, reference {slow}");
}

#[test]
fn contact_wins_over_the_coarse_push_in_either_solver() {
    // A 48 × 48 sheet of 2 cm (0.94 m) dropped from 0.1 m above a 0.25 m
    // ball, g = 9.8 m/s², 8 passes, soft diagonals, 60 steps of 10 ms in
    // either solver. Contact runs after the coarse phase, so no particle
    // may end a step closer to the centre than r + thickness (f32: 1 µm).
    use drape::sim::{Collider, GridPlane, Pose, Shape};
    let half = 0.5 * 0.02 * 47.0;
    let mesh = Grid {
        columns: 48,
        rows: 48,
        spacing: 0.02,
        plane: GridPlane::Horizontal,
        origin: Some(Vec3::new(-half, 0.35, -half)),
        pins: Pins::None,
        ..Grid::default()
    }
    .build()
    .unwrap();
    let (radius, thickness) = (0.25, 0.01);
    let ball = Collider::fixed(Shape::Sphere { radius }, Pose::default());
    let params = |coarse_passes| SolverParams {
        relaxations: 8,
        coarse_passes,
        shear_compliance: Some(1.0),
        dt: 0.01,
        mass: 0.001,
        gravity: Vec3::new(0.0, -0.0098, 0.0),
        thickness,
        ..SolverParams::default()
    };
    for kind in [SolverKind::Fast, SolverKind::Reference] {
        let mut sim =
            Simulation::with_solver(mesh.clone(), params(2), kind).unwrap().with_colliders(vec![ball.clone()]);
        for _ in 0..60 {
            sim.step().unwrap();
            let closest = sim.positions().iter().map(|p| p.length()).fold(f32::INFINITY, f32::min);
            assert!(closest >= radius + thickness - 1e-6, "{kind:?}: {closest}");
        }
        // It did drape: the centre rests on the ball's top (0.26 m), the
        // corners have fallen below the ball's top.
        assert!(sim.positions()[48 * 24 + 24].y < 0.27 && sim.positions()[0].y < 0.2, "{kind:?}");
        // Where the ball pushes, contact sets the strain (measured worst
        // edge strain over the 60 steps, fast: 17.9 % with the coarse
        // passes, 19.1 % without), so the test asserts contact, not strain.
    }
}

#[test]
fn the_hands_reach_keeps_a_fast_grab_from_tearing_the_cloth() {
    // The bottom-left corner of a 64 × 64 cloth (2 cm, `large-inextensible`'s
    // settings: 8 passes, no coarse passes here) pulled 1 m sideways in
    // 0.1 s (10 m/s), then held for 0.3 s. Without the reach the passes
    // cannot follow a hand that moves a bar's length a substep: measured
    // 169 % worst edge strain. With it: 56 %. Bounds: under 80 % with the
    // reach, over twice that figure without.
    let scene = drape::scene::load("large-inextensible").unwrap();
    let n = 64u32;
    let mesh = Grid { columns: n, rows: n, spacing: 0.02, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
    let params = SolverParams { coarse_passes: 0, ..scene.params.clone() };
    let corner = (n * n - n) as usize;
    let run = |reach: bool| {
        let mut sim = Simulation::new(mesh.clone(), params.clone()).unwrap();
        sim.advance(100).unwrap();
        let start = sim.positions()[corner];
        let mut worst = 0.0f32;
        for k in 1..=40 {
            let target = start + Vec3::new((k as f32 / 10.0).min(1.0), 0.0, 0.0);
            sim.hold_with(corner, target, 200.0, reach).unwrap();
            sim.step().unwrap();
            worst = worst.max(sim.edge_strain().max);
        }
        // The hand moved the corner, and no pin moved.
        assert!(sim.positions()[corner].x - start.x > 0.05, "the corner stayed put");
        worst
    };
    let (with, without) = (run(true), run(false));
    eprintln!("fast grab: worst edge strain {with} with the reach, {without} without");
    assert!(with < 0.8, "with the reach: {with}");
    assert!(without > 2.0 * with, "without the reach: {without} against {with}");
}
