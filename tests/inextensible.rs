//! The inextensible projection (`inextensible = true`): the seed's scene at
//! the strain of real cloth, exact answers (catenary, pendulum, free fall),
//! degenerate input, pins that change, and a grab that does not stretch.

use drape::sim::exact::{discrete_catenary, pendulum_period};
use drape::sim::{ClothMesh, Simulation, SolverKind, SolverParams};
use glam::{DVec2, Vec3};

mod strain;
use strain::edge_strain_run;

#[test]
fn the_seed_scene_inextensible_stays_within_one_percent_and_the_seed_method_does_not() {
    let scene = drape::scene::load("seed-inextensible").unwrap();
    let seed = drape::scene::load("seed").unwrap();
    // The seed's cloth, wind, h, δ and m, exactly.
    let (p, s) = (&scene.params, &seed.params);
    assert_eq!((p.dt, p.damping, p.mass, p.gravity, p.wind), (s.dt, s.damping, s.mass, s.gravity, s.wind));
    assert_eq!(scene.mesh.positions(), seed.mesh.positions());
    assert_eq!(scene.mesh.bars(), seed.mesh.bars());
    // 2 s of warm-up, then 10 s (the figure is over 100 s: the
    // README's `drape run` line). Targets: typical max ≤ 1 %, worst ≤ 2 %.
    let mut sim = Simulation::new(scene.mesh.clone(), scene.params.clone()).unwrap();
    let (typical, worst) = edge_strain_run(&mut sim, 40, 200);
    eprintln!("seed-inextensible: typical {typical}, worst {worst}");
    assert!(typical <= 0.01 && worst <= 0.02, "typical {typical}, worst {worst}");
    // The same settings without the projection: the passes alone leave the
    // edges stretched by tens of percent (the check above is not passed by
    // the scene's gentleness).
    let off = SolverParams { inextensible: false, ..scene.params.clone() };
    let (typical_off, _) = edge_strain_run(&mut Simulation::new(scene.mesh.clone(), off).unwrap(), 40, 200);
    assert!(typical_off > 0.1, "without the projection: typical {typical_off}");
    // And the seed's own method, 20 passes.
    let (typical_seed, _) = edge_strain_run(&mut Simulation::new(seed.mesh, seed.params).unwrap(), 40, 200);
    assert!(typical_seed > 0.1, "the seed's: typical {typical_seed}");
}

#[test]
fn the_fast_scene_stays_within_the_targets_too() {
    // `seed-inextensible-fast`: the seed's cloth, wind, h, δ and m with 8
    // coarse passes, a 1.2 % tolerance and up to 96 edge passes, for twice
    // the fast solver's 20 passes. The tolerance bounds every step's edges
    // (worst ≤ 1.2 % < 2 %); the typical step lands below it (the accuracy
    // benchmark: 0.83 % over 100 s). Targets as above.
    let scene = drape::scene::load("seed-inextensible-fast").unwrap();
    let seed = drape::scene::load("seed").unwrap();
    let (p, s) = (&scene.params, &seed.params);
    assert_eq!((p.dt, p.damping, p.mass, p.gravity, p.wind), (s.dt, s.damping, s.mass, s.gravity, s.wind));
    assert_eq!(scene.mesh.bars(), seed.mesh.bars());
    assert_eq!((p.coarse_passes, p.newton_tolerance, p.newton_smoothing), (8, 0.012, 96));
    let mut sim = Simulation::new(scene.mesh.clone(), scene.params.clone()).unwrap();
    let (typical, worst) = edge_strain_run(&mut sim, 40, 200);
    eprintln!("seed-inextensible-fast: typical {typical}, worst {worst}");
    assert!(typical <= 0.01 && worst <= 0.02, "typical {typical}, worst {worst}");
    // The looser tolerance is what it runs at: some steps end near it.
    assert!(worst > 0.008, "worst {worst}");
}

/// 21 nodes, 20 links of 7.5 cm, ends 1 m apart at y = 1, starting as a V.
fn chain() -> ClothMesh {
    let (links, link, span) = (20usize, 0.075f32, 1.0f32);
    let dx = span / links as f32;
    let dy = (link * link - dx * dx).sqrt();
    let positions: Vec<Vec3> =
        (0..=links).map(|i| Vec3::new(-span / 2.0 + dx * i as f32, 1.0 - dy * i.min(links - i) as f32, 0.0)).collect();
    let adjacency: Vec<Vec<u64>> = (0..=links).map(|i| if i < links { vec![i as u64 + 1] } else { vec![] }).collect();
    ClothMesh::from_adjacency(positions, &[0, links as u64], &adjacency, None).unwrap()
}

#[test]
fn a_chain_settles_to_the_discrete_catenary_with_no_stretch() {
    // As tests/physics.rs: the exact rest shape of 20 links of 7.5 cm between
    // (±0.5, 1) is the discrete catenary. The projection puts every link at
    // its length to 1e-6 each step (no passes at all), so the settled chain
    // is the catenary up to the step's own bias: the Newton step returns
    // to the nearest point of the constraint set (mass-weighted), not
    // where Gauss–Seidel's sweep ends, so the bias is smaller than the
    // passes' 0.08 mm at h = 2.5 ms. Tolerance: 1e-4 L = 0.15 mm, which the
    // continuous cosh curve (0.8 mm away) fails.
    let exact = discrete_catenary(20, 0.075, DVec2::new(-0.5, 1.0), DVec2::new(0.5, 1.0)).unwrap();
    for kind in SolverKind::ALL {
        let params = SolverParams {
            relaxations: 0,
            damping: 0.05,
            dt: 0.0025,
            inextensible: true,
            newton_tolerance: 1e-6,
            newton_smoothing: 0,
            ..SolverParams::default()
        };
        let mut sim = Simulation::with_solver(chain(), params, kind).unwrap();
        sim.advance(4000).unwrap();
        let worst = sim
            .positions()
            .iter()
            .zip(&exact)
            .map(|(p, e)| (DVec2::new(f64::from(p.x), f64::from(p.y)) - *e).length())
            .fold(0.0, f64::max);
        assert!(worst / 1.5 < 1e-4, "{kind:?}: node error {worst} m");
        assert!(sim.strain().max < 2e-6, "{kind:?}: stretch {}", sim.strain().max);
    }
}

#[test]
fn a_pendulum_swings_with_the_expected_period() {
    // As tests/physics.rs (L = 1 m, m = 0.2 kg, f_g = 9.8 N, 5°: T = 0.89803 s),
    // with the bar held by the projection alone (no passes).
    let (length, mass, theta0) = (1.0f32, 0.2f32, 5f32.to_radians());
    let t0 = 2.0 * std::f64::consts::PI * f64::from(length * mass / 9.8).sqrt();
    let expected = pendulum_period(t0, f64::from(theta0));
    let bob = Vec3::new(length * theta0.sin(), -length * theta0.cos(), 0.0);
    let mesh = ClothMesh::from_adjacency(vec![Vec3::ZERO, bob], &[0], &[vec![1], vec![]], None).unwrap();
    let params = SolverParams {
        relaxations: 0,
        damping: 0.0,
        dt: 0.001,
        mass,
        inextensible: true,
        newton_tolerance: 1e-7,
        ..SolverParams::default()
    };
    let mut sim = Simulation::new(mesh, params).unwrap();
    let mut crossings = Vec::new();
    let mut last_x = sim.positions()[1].x;
    while crossings.len() < 21 {
        let t = sim.time();
        sim.step().unwrap();
        let x = sim.positions()[1].x;
        if (last_x > 0.0) != (x > 0.0) {
            crossings.push(t + 0.001 * f64::from(last_x / (last_x - x)));
        }
        last_x = x;
        assert!(sim.time() < 20.0, "no swing");
    }
    let period = (crossings[20] - crossings[0]) / 10.0;
    let error = (period - expected).abs() / expected;
    assert!(error < 2e-4, "period {period} s, expected {expected} s (error {error})");
    assert!((sim.positions()[1].length() - 1.0).abs() < 1e-5);
}

#[test]
fn unconnected_particles_fall_exactly_as_without_the_projection() {
    // No bars, no edges: the phase has nothing to do and must not change a bit.
    let mesh = ClothMesh::from_adjacency(
        vec![Vec3::ZERO, Vec3::X],
        &[],
        &[vec![], vec![]],
        Some(vec![Vec3::new(1.0, 2.0, 0.0), Vec3::ZERO]),
    )
    .unwrap();
    let on = SolverParams { inextensible: true, ..SolverParams::default() };
    let mut a = Simulation::new(mesh.clone(), on).unwrap();
    let mut b = Simulation::new(mesh, SolverParams::default()).unwrap();
    a.advance(50).unwrap();
    b.advance(50).unwrap();
    assert_eq!(a.positions(), b.positions());
}

#[test]
fn collinear_and_crushed_states_stay_finite() {
    // Every particle of a grid put on one line, then every particle on one
    // point: edge directions are parallel (J W Jᵀ singular without the
    // regularisation) or undefined (zero length).
    let scene = drape::scene::load("seed-inextensible").unwrap();
    let n = scene.mesh.particle_count();
    for state in
        [(0..n).map(|i| Vec3::new(i as f32 * 0.01, 0.0, 0.0)).collect::<Vec<_>>(), vec![Vec3::new(1.0, 2.0, 3.0); n]]
    {
        let mut sim = Simulation::new(scene.mesh.clone(), scene.params.clone()).unwrap();
        sim.set_state(&state, &state).unwrap();
        sim.advance(20).unwrap();
        assert!(sim.positions().iter().all(|p| p.is_finite()));
        assert!(sim.last_projection().is_some_and(|r| r.strain_after.is_finite()));
    }
}

#[test]
fn pins_that_change_while_it_runs_and_unequal_masses() {
    let scene = drape::scene::load("seed-inextensible").unwrap();
    let mut sim = Simulation::new(scene.mesh.clone(), scene.params.clone()).unwrap();
    sim.advance(20).unwrap();
    // Unpin half the top row, pin a bottom corner: writes, no rebuild.
    for i in 0..10 {
        sim.set_fixed(i, false).unwrap();
    }
    sim.set_fixed(scene.mesh.particle_count() - 1, true).unwrap();
    // Half free at the top, the cloth swings wide in the wind; measured
    // 1.7 % typical and 4.1 % worst. Bounds: 3 % and 10 %.
    let (typical, worst) = edge_strain_run(&mut sim, 20, 40);
    assert!(typical < 0.03 && worst < 0.1, "typical {typical}, worst {worst}");
    // A density gives unequal masses (edges and corners lighter).
    let mut params = scene.params.clone();
    params.density = Some(0.2);
    params.gravity_acceleration = Some(Vec3::new(0.0, -9.81, 0.0));
    params.wind = drape::sim::Wind::None;
    let mut sim = Simulation::new(scene.mesh, params).unwrap();
    let (typical, worst) = edge_strain_run(&mut sim, 20, 40);
    assert!(worst < 0.01, "unequal masses: typical {typical}, worst {worst}");
}

#[test]
fn a_fast_grab_does_not_stretch_the_inextensible_cloth() {
    // A hand takes the bottom-left corner of the seed's cloth and pulls it 2 m
    // sideways in 0.2 s (4 steps of h = 0.05 s: 10 m/s), then holds it there
    // for 1 s. A hold is a bounded pull (a_max = 200 m/s²), not a hard move,
    // with the weight of a hand, so the projection keeps the edges at
    // length: max edge strain (the measure: horizontal and vertical
    // bars; bend bars shorten as the cloth folds) under 10 % at every step.
    // The same pull as a hard move (the particle fixed and put where the
    // hand is) stretches the edges far more.
    let scene = drape::scene::load("seed-inextensible").unwrap();
    let params = SolverParams { wind: drape::sim::Wind::None, ..scene.params.clone() };
    let corner = (scene.mesh.particle_count() - 20) as usize;
    let mut soft = Simulation::new(scene.mesh.clone(), params.clone()).unwrap();
    let mut hard = Simulation::new(scene.mesh.clone(), params).unwrap();
    soft.advance(20).unwrap();
    hard.advance(20).unwrap();
    let start = soft.positions()[corner];
    hard.set_fixed(corner, true).unwrap();
    let (mut soft_worst, mut hard_worst) = (0.0f32, 0.0f32);
    for k in 1..=24 {
        let target = start + Vec3::new(2.0 * (k as f32 / 4.0).min(1.0), 0.0, 0.0);
        soft.hold(corner, target, 200.0).unwrap();
        hard.move_particle(corner, target).unwrap();
        soft.step().unwrap();
        hard.step().unwrap();
        soft_worst = soft_worst.max(soft.edge_strain().max);
        hard_worst = hard_worst.max(hard.edge_strain().max);
    }
    let moved = soft.positions()[corner].x - start.x;
    eprintln!("held: worst edge strain {soft_worst}, corner moved {moved} m; hard move: {hard_worst}");
    assert!(soft_worst < 0.1, "held: worst max strain {soft_worst}");
    assert!(hard_worst > 2.0 * soft_worst, "hard move: worst edge strain {hard_worst} vs held {soft_worst}");
    // The corner went most of the way with the hand.
    assert!(moved > 1.0, "the held corner moved {moved} m");
    soft.release(corner);
    assert!(soft.holds().is_empty());
}

#[test]
fn with_contact_the_cloth_drapes_stretching_less_and_stays_outside() {
    // The drape-sphere scene (41 × 41, 1 m, onto a 0.35 m ball, 4 substeps),
    // 1 s: the cloth has landed and folds over the ball. Contact runs after
    // the projection and wins where they disagree (a square grid cannot lie
    // on a sphere without stretching or folding), so some stretch remains
    // where the ball pushes: measured 3.9 % max with inextensible edges,
    // 14.2 % with the scene's passes alone. Bounds: under 10 %, and under
    // 0.6 × the passes' figure. No particle inside the ball: every one at
    // least the thickness (8 mm) from its surface, less 1 %.
    let scene = drape::scene::load("drape-sphere").unwrap();
    let run = |inextensible: bool| {
        let params = SolverParams { inextensible, ..scene.params.clone() };
        let mut sim = Simulation::new(scene.mesh.clone(), params).unwrap().with_colliders(scene.colliders.clone());
        sim.advance(60).unwrap();
        sim
    };
    let (sim, passes) = (run(true), run(false));
    let centre = Vec3::new(0.0, 0.35, 0.0);
    let nearest = sim.positions().iter().map(|p| p.distance(centre)).fold(f32::INFINITY, f32::min);
    assert!(nearest >= 0.35 + 0.008 * 0.99, "a particle {nearest} m from the ball's centre");
    assert!(nearest < 0.40, "the cloth has not reached the ball: {nearest} m");
    let (held, loose) = (sim.edge_strain().max, passes.edge_strain().max);
    assert!(held < 0.1 && held < 0.6 * loose, "inextensible {held}, passes alone {loose}");
}

#[test]
fn the_same_run_gives_the_same_bits() {
    let scene = drape::scene::load("seed-inextensible").unwrap();
    let run = || {
        let mut sim = Simulation::new(scene.mesh.clone(), scene.params.clone()).unwrap();
        sim.advance(60).unwrap();
        sim.positions().iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}
