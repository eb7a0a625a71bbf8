//! Air and physical units: drag against exact answers, the same cloth at two
//! resolutions, and the air's checks that fail without it.

use drape::sim::{Air, Grid, GridPlane, Pins, Simulation, SolverParams, Wind};
use glam::Vec3;

const G: f32 = 9.81;

/// A flat horizontal square of side 1 m with `n` particles a side, free.
fn square(n: u32) -> Grid {
    Grid {
        columns: n,
        rows: n,
        spacing: 1.0 / (n - 1) as f32,
        plane: GridPlane::Horizontal,
        pins: Pins::None,
        origin: Some(Vec3::new(-0.5, 100.0, -0.5)),
        ..Grid::default()
    }
}

/// Still air, drag 1, no lift.
fn still_air() -> Wind {
    Wind::Air(Air { velocity: Vec3::ZERO, gusts: 0.0, density: 1.2, drag: 1.0, lift: 0.0, ..Air::default() })
}

/// σ = 0.1 kg/m², g = 9.81 m/s², h = 0.01 s, no damping.
fn physical(wind: Wind) -> SolverParams {
    SolverParams {
        dt: 0.01,
        damping: 0.0,
        relaxations: 10,
        density: Some(0.1),
        gravity_acceleration: Some(Vec3::new(0.0, -G, 0.0)),
        wind,
        ..SolverParams::default()
    }
}

/// The mean downward speed of the sheet after `seconds`, m/s.
fn fall_speed(n: u32, wind: Wind, seconds: f32) -> f32 {
    let params = physical(wind);
    let steps = (seconds / params.dt).round() as u64;
    let mut sim = Simulation::new(square(n).build().unwrap(), params.clone()).unwrap();
    sim.advance(steps).unwrap();
    let (x, p) = (sim.positions(), sim.previous_positions());
    let dy: f32 = x.iter().zip(p).map(|(a, b)| a.y - b.y).sum::<f32>() / x.len() as f32;
    -dy / params.dt
}

#[test]
fn a_flat_sheet_falls_at_its_terminal_speed_at_any_resolution() {
    // Drag ½ ρ C_d A v² balances σ A g at v = sqrt(2 σ g / (ρ C_d))
    // = sqrt(2 · 0.1 · 9.81 / 1.2) = 1.2787 m/s. The approach is
    // exponential-like with time scale v/g = 0.13 s, so after 3 s the sheet
    // is there to f32 rounding. The sheet stays flat: each particle's share
    // of the drag is its share of the area, hence of the mass, so every
    // particle decelerates alike; lift is zero with u along n.
    let exact = (2.0 * 0.1 * G / 1.2f32).sqrt();
    let coarse = fall_speed(11, still_air(), 3.0);
    let fine = fall_speed(31, still_air(), 3.0);
    eprintln!("terminal speed: {coarse} m/s (11 × 11), {fine} m/s (31 × 31), exact {exact} m/s");
    // 1 %: the force is exact at steady state; what is left is the Verlet
    // velocity's rounding at y ≈ 100 m (one ulp, 7.6e-6 m, per 0.01 s step
    // is 0.06 % of 1.28 m/s).
    for (n, v) in [(11, coarse), (31, fine)] {
        assert!((v - exact).abs() < 0.01 * exact, "{n} × {n}: {v} m/s against {exact}");
    }
    // The bound is 5 % between resolutions; here they agree far closer.
    assert!((coarse - fine).abs() < 0.05 * fine, "{coarse} vs {fine}");
    // Without the air the same sheet is in free fall: 9.81 · 3 = 29.4 m/s.
    let falling = fall_speed(11, Wind::None, 3.0);
    assert!(falling > 20.0 * exact, "{falling}");
}

#[test]
fn a_sheet_edge_on_to_the_wind_feels_nothing_and_face_on_is_blown_away() {
    // A vertical sheet in the x–y plane, top row fixed, no gravity. Wind
    // along x lies in its plane: u·n = 0, no drag; lift is zero with u in
    // the plane. Wind along z meets it face-on.
    let sheet = Grid { columns: 11, rows: 11, spacing: 0.1, pins: Pins::TopRow, ..Grid::default() };
    let displacement = |velocity: Vec3| {
        let air = Air { velocity, gusts: 0.0, lift: 0.2, ..Air::default() };
        let params = SolverParams {
            dt: 0.01,
            density: Some(0.1),
            gravity_acceleration: Some(Vec3::ZERO),
            wind: Wind::Air(air),
            ..SolverParams::default()
        };
        let mesh = sheet.build().unwrap();
        let start = mesh.positions().to_vec();
        let mut sim = Simulation::new(mesh, params).unwrap();
        sim.advance(100).unwrap();
        sim.positions().iter().zip(&start).map(|(a, b)| a.distance(*b)).fold(0.0f32, f32::max)
    };
    let edge_on = displacement(Vec3::new(8.0, 0.0, 0.0));
    let face_on = displacement(Vec3::new(0.0, 0.0, 8.0));
    assert!(edge_on < 1e-6, "edge-on moved {edge_on} m");
    assert!(face_on > 0.3, "face-on moved only {face_on} m");
}

#[test]
fn the_gusting_flag_flutters_out_of_its_plane_and_runs_the_same_twice() {
    // The bundled flag, 1.5 s. It starts flat in the x–y plane with the
    // wind along x, edge-on: only the gusts' cross-wind components and the
    // drag and lift they set off move it out of its plane (measured: up to
    // 0.95 m). Without the air nothing pushes it out: z stays exactly 0
    // (a flag held along one edge is stiff in its own plane, so "its free
    // edge is downwind" would hold without any air at all: 2.35 m).
    //
    // Its RMS strain, every 10 steps: the flutter is chaotic (a change in
    // the last bit of one force grows to millimetres within ~20 steps),
    // so one step's figure is a draw: 0.015–0.061 over these 15 steps in
    // both forms of the air phase (scene order, the grid's lanes) and at
    // every SIMD level, the mean 0.030–0.032. The mean is held below 0.04
    // and each step below 0.08; a flag that stretches like rubber (its 15
    // relaxations a substep cut to 2) reads a mean of 0.10, steps 0.04–0.17.
    let scene = drape::scene::load("flag").unwrap();
    let run = |wind: Wind| {
        let params = SolverParams { wind, ..scene.params.clone() };
        let mut sim = Simulation::new(scene.mesh.clone(), params).unwrap();
        let mut strains = Vec::new();
        for _ in 0..15 {
            sim.advance(10).unwrap();
            strains.push(drape::sim::metrics::strain(sim.positions(), scene.mesh.bars(), scene.mesh.fixed()).rms);
        }
        (sim.positions().to_vec(), strains)
    };
    let ((a, strains), (b, _)) = (run(scene.params.wind), run(scene.params.wind));
    assert_eq!(a, b, "the same scene must give the same run");
    let mean = strains.iter().sum::<f32>() / strains.len() as f32;
    assert!(mean < 0.04 && strains.iter().all(|&s| s < 0.08), "RMS strain every 10 steps: {strains:?}");
    let out_of_plane = |p: &[Vec3]| p.iter().map(|q| q.z.abs()).fold(0.0f32, f32::max);
    assert!(out_of_plane(&a) > 0.3, "the flag stayed flat: {} m", out_of_plane(&a));
    assert_eq!(out_of_plane(&run(Wind::None).0), 0.0);
}

/// How much a strip of width 0.2 m and length 1 m, hanging from its top
/// row under its own weight, has stretched, m.
fn strip_stretch(spacing: f32, stiffness: f32) -> f32 {
    let columns = (0.2 / spacing).round() as u32 + 1;
    let rows = (1.0 / spacing).round() as u32 + 1;
    let grid = Grid { columns, rows, spacing, pins: Pins::TopRow, ..Grid::default() };
    let params = SolverParams {
        dt: 0.01,
        damping: 0.05,
        relaxations: 100,
        substeps: 2,
        density: Some(0.2),
        gravity_acceleration: Some(Vec3::new(0.0, -G, 0.0)),
        stretch_stiffness: Some(stiffness),
        // Bend bars also join particles along the strip: rigid (the default
        // compliance 0) they would hold it to its length whatever k_s.
        bend_stiffness: Some(1e-5),
        ..SolverParams::default()
    };
    let mesh = grid.build().unwrap();
    let bottom = |p: &[Vec3]| (0..columns).map(|c| p[((rows - 1) * columns + c) as usize].y).sum::<f32>();
    let rest = bottom(mesh.positions()) / columns as f32;
    let mut sim = Simulation::new(mesh, params).unwrap();
    sim.advance(400).unwrap();
    rest - bottom(sim.positions()) / columns as f32
}

#[test]
fn a_hanging_strip_stretches_the_same_at_two_resolutions() {
    // σ g L² / (2 E) with E the grid's modulus along its length: the seed's
    // grid pulls with k_s/2 per unit strain (sim::units), so a 1 m strip of
    // 0.2 kg/m² at k_s = 40 N/m stretches 0.2 · 9.81 / 40 = 49 mm, less
    // where the top row's fixed width stops it narrowing.
    let k = 40.0;
    let coarse = strip_stretch(0.05, k);
    let fine = strip_stretch(0.025, k);
    let expected = 0.2 * G / k;
    eprintln!("strip stretch: {coarse} m at 5 cm, {fine} m at 2.5 cm, about {expected} m expected");
    assert!((coarse - fine).abs() < 0.1 * fine, "{coarse} m at 5 cm, {fine} m at 2.5 cm");
    assert!((0.5 * expected..1.2 * expected).contains(&fine), "{fine} m against about {expected}");
    // Stiffness is what sets it: four times stiffer, about a quarter.
    let stiff = strip_stretch(0.05, 4.0 * k);
    assert!(stiff < 0.35 * coarse, "{stiff} vs {coarse}");
}
