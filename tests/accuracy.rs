//! The accuracy options against exact answers: substeps (with damping that
//! keeps its meaning), the second-order start, compliant bars (XPBD),
//! over-relaxation and tethers. Every check runs on both solvers.

use drape::sim::{ClothMesh, Grid, Pins, Simulation, SolverKind, SolverParams, Start, Wind};
use glam::Vec3;

fn lone_particle(v0: Vec3) -> ClothMesh {
    ClothMesh::from_adjacency(vec![Vec3::ZERO], &[], &[vec![]], Some(vec![v0])).unwrap()
}

#[test]
fn substeps_keep_damping_per_step() {
    // No force, v₀ = 2 m/s along x, h = 0.05 s, δ = 0.1, n substeps. Each
    // substep keeps 1 − δ_n = 0.9^(1/n) of the last one's motion, so after a
    // whole step the velocity is 0.9 of what it was, whatever n: measured
    // from the displacement over the 5th step against the 4th. The particle
    // stops after (h/n)·v₀ / δ_n: 1 m for n = 1, 0.961677 m for n = 4
    // ((0.0125 · 2) / (1 − 0.9^¼) = 0.025 / 0.0259962).
    //
    // The reference stores x_{i−1}, so once its displacement is a few ulps
    // of x it creeps on by up to ⌊1/(2δ_n)⌋ ulps (6e-8 m below 1 m, 1.2e-7
    // above) a substep instead of stopping; that bound is its tolerance. The
    // fast solver carries the displacement itself and stops (1e-5: the
    // geometric tail 0.9^120 = 3e-6 m plus rounding).
    for kind in SolverKind::ALL {
        for (n, stop) in [(1u32, 1.0f64), (4, 0.961_677)] {
            let params = SolverParams { damping: 0.1, gravity: Vec3::ZERO, substeps: n, ..SolverParams::default() };
            let mut sim = Simulation::with_solver(lone_particle(Vec3::X * 2.0), params, kind).unwrap();
            let xs: Vec<f32> = (0..6)
                .map(|_| {
                    sim.step().unwrap();
                    sim.positions()[0].x
                })
                .collect();
            let ratio = (xs[5] - xs[4]) / (xs[4] - xs[3]);
            assert!((ratio - 0.9).abs() < 1e-4, "{kind:?} n={n}: velocity ratio per step {ratio}");
            sim.advance(114).unwrap();
            let x = f64::from(sim.positions()[0].x);
            let delta_n = 1.0 - 0.9f64.powf(1.0 / f64::from(n));
            let creep = match kind {
                SolverKind::Reference => (0.5 / delta_n).floor() * 1.2e-7 * f64::from(120 * n),
                SolverKind::Fast => 0.0,
            };
            assert!((x - stop).abs() < 1e-5 + creep, "{kind:?} n={n}: stopped at {x}, expected {stop}");
        }
    }
}

#[test]
fn second_order_start_makes_free_fall_exact() {
    // Constant acceleration a = f/m = −49 m/s², v₀ = 3 m/s up, δ = 0. With
    // x₁ = x₀ + h v₀ + ½h²a, equation 1 reproduces the parabola
    // y(t) = v₀t + ½at² at every step; the seed's Euler start, which drops
    // the force from the first step, falls behind it by −a·h·t/2 (1.225 m
    // above the parabola at t = 1 s, h = 0.05 s). f32 rounding over 20 steps
    // at |y| ≲ 25 m stays below 1e-4 m.
    for kind in SolverKind::ALL {
        for (start, lag) in [(Start::SecondOrder, 0.0f64), (Start::Euler, 1.225)] {
            let params = SolverParams { damping: 0.0, start, ..SolverParams::default() };
            let mut sim = Simulation::with_solver(lone_particle(Vec3::Y * 3.0), params, kind).unwrap();
            sim.advance(20).unwrap();
            let t = sim.time();
            let exact = 3.0 * t - 0.5 * 49.0 * t * t;
            let y = f64::from(sim.positions()[0].y);
            assert!((y - (exact + lag)).abs() < 1e-4, "{kind:?} {start:?}: y {y}, parabola {exact}, lag {lag}");
        }
    }
}

/// A particle of `mass` hanging by one bar of rest 1 m from a fixed one.
fn hanging_bob() -> ClothMesh {
    ClothMesh::from_adjacency(vec![Vec3::ZERO, Vec3::new(0.0, -1.0, 0.0)], &[0], &[vec![1], vec![]], None).unwrap()
}

#[test]
fn compliant_bar_stretches_by_load_times_compliance_whatever_the_passes() {
    // Gravity 9.8 N on the bob, α = 1e-3 m/N: a spring of stiffness 1000 N/m
    // holds it 9.8 mm long. That is a property of the material (XPBD), not of
    // the passes or substeps: the rest length must come out the same for 2 or
    // 20 passes and 1 or 4 substeps. Plain projection (α = 0) holds it at 1 m.
    // Tolerance 1 %: the settled state still has the per-step fall h²g
    // corrected inside the pass, a bias of order h²g/length.
    for kind in SolverKind::ALL {
        for (relaxations, substeps) in [(2u32, 1u32), (20, 1), (2, 4)] {
            let params = SolverParams {
                relaxations,
                substeps,
                damping: 0.1,
                dt: 0.01,
                stretch_compliance: 1e-3,
                ..SolverParams::default()
            };
            let mut sim = Simulation::with_solver(hanging_bob(), params, kind).unwrap();
            sim.advance(2000).unwrap();
            let stretch = -sim.positions()[1].y - 1.0;
            assert!((stretch - 9.8e-3).abs() < 9.8e-5, "{kind:?} {relaxations}×{substeps}: stretch {stretch} m");
        }
    }
}

#[test]
fn compliant_bar_oscillates_with_the_spring_period() {
    // No gravity; α = 1e-3 m/N and m = 1 kg make a spring of k = 1000 N/m,
    // period 2π·sqrt(m α) = 0.198692 s (XPBD paper, §6.1). Released 0.1 m
    // long; h = 0.5 ms, δ = 0, 10 passes. Tolerance 1 %: XPBD's first-order
    // treatment of the constraint damps and slightly lengthens the period,
    // by O(ωh) = 0.016 here.
    let t = 2.0 * std::f64::consts::PI * (1.0f64 * 1e-3).sqrt();
    for kind in SolverKind::ALL {
        let mesh =
            ClothMesh::from_adjacency(vec![Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)], &[0], &[vec![1], vec![]], None)
                .unwrap();
        let params = SolverParams {
            relaxations: 10,
            damping: 0.0,
            dt: 0.0005,
            mass: 1.0,
            gravity: Vec3::ZERO,
            stretch_compliance: 1e-3,
            ..SolverParams::default()
        };
        let mut sim = Simulation::with_solver(mesh, params, kind).unwrap();
        let released = [Vec3::ZERO, Vec3::new(1.1, 0.0, 0.0)];
        sim.set_state(&released, &released).unwrap();
        let (mut crossings, mut last) = (Vec::new(), 0.1f32);
        while crossings.len() < 7 && sim.time() < 2.0 {
            let before = sim.time();
            sim.step().unwrap();
            let e = sim.positions()[1].x - 1.0;
            if (last > 0.0) != (e > 0.0) {
                crossings.push(before + 0.0005 * f64::from(last / (last - e)));
            }
            last = e;
        }
        assert_eq!(crossings.len(), 7, "{kind:?}: the spring does not oscillate");
        let period = (crossings[6] - crossings[0]) / 3.0;
        assert!((period - t).abs() / t < 0.01, "{kind:?}: period {period} s, expected {t} s");
    }
}

#[test]
fn over_relaxation_converges_in_fewer_passes() {
    // The seed-style chain (21 nodes, 1.5 m, ends 1 m apart) at 10 passes per
    // step: over-relaxing each projection by ω = 1.5 leaves less stretch than
    // plain projection, and both stay finite.
    let chain = || {
        let n = 20usize;
        let (dx, link) = (0.05f32, 0.075f32);
        let dy = (link * link - dx * dx).sqrt();
        let positions = (0..=n).map(|i| Vec3::new(-0.5 + dx * i as f32, 1.0 - dy * i.min(n - i) as f32, 0.0)).collect();
        let adjacency: Vec<Vec<u64>> = (0..=n).map(|i| if i < n { vec![i as u64 + 1] } else { vec![] }).collect();
        ClothMesh::from_adjacency(positions, &[0, n as u64], &adjacency, None).unwrap()
    };
    for kind in SolverKind::ALL {
        let stretch = |omega: f32| {
            let params = SolverParams {
                relaxations: 10,
                damping: 0.05,
                dt: 0.005,
                mass: 0.01,
                gravity: Vec3::new(0.0, -0.098, 0.0),
                over_relaxation: omega,
                ..SolverParams::default()
            };
            let mut sim = Simulation::with_solver(chain(), params, kind).unwrap();
            sim.advance(2000).unwrap();
            sim.strain().max
        };
        let (plain, over) = (stretch(1.0), stretch(1.5));
        assert!(over < 0.7 * plain, "{kind:?}: stretch {over} at ω = 1.5 vs {plain} at ω = 1");
    }
}

#[test]
fn tethers_stop_a_long_cloth_stretching_down_its_length() {
    // A 20 × 60 cloth (spacing 2 cm, 1.18 m long) hung by its top row with
    // only 3 passes per step of 20 ms: every step adds h²g = 3.9 mm of fall
    // and the passes carry the top's correction only a few rows down, so the
    // cloth stretches down its length. With tethers every particle is held
    // within its rest path length of the top row, so the cloth's length stays
    // within 2 % (what the passes after the tethers undo of them).
    let mesh = Grid { columns: 20, rows: 60, spacing: 0.02, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
    let rest_length = 0.02 * 59.0;
    for kind in SolverKind::ALL {
        let length = |tether_slack| {
            let params = SolverParams {
                relaxations: 3,
                dt: 0.02,
                damping: 0.05,
                mass: 0.001,
                gravity: Vec3::new(0.0, -0.0098, 0.0),
                wind: Wind::None,
                tether_slack,
                ..SolverParams::default()
            };
            let mut sim = Simulation::with_solver(mesh.clone(), params, kind).unwrap();
            sim.advance(500).unwrap();
            sim.positions()[10].y - sim.positions()[59 * 20 + 10].y
        };
        let (loose, tied) = (length(None), length(Some(0.0)));
        assert!(loose > 1.15 * rest_length, "{kind:?}: without tethers the cloth is {loose} m long");
        assert!(tied < 1.02 * rest_length, "{kind:?}: with tethers the cloth is {tied} m long ({rest_length} at rest)");
    }
}
