//! The solver against numbers derived by hand: discrete free fall, the damping
//! series, fixed particles, relaxation convergence, the catenary, the pendulum.
//!
//! Every test runs on every solver (`SolverKind::ALL`): they implement the same
//! equations, so they must pass the same checks.

use drape::sim::exact::{discrete_catenary, pendulum_period, verlet_free_fall};
use drape::sim::{ClothMesh, Grid, Pins, SimError, Simulation, SolverKind, SolverParams, Wind};
use glam::{DVec2, Vec3};

/// One particle, no bars, at `x0` with velocity `v0`.
fn lone_particle(x0: Vec3, v0: Vec3) -> ClothMesh {
    ClothMesh::from_adjacency(vec![x0], &[], &[vec![]], Some(vec![v0])).unwrap()
}

#[test]
fn free_fall_follows_the_discrete_solution_step_by_step() {
    // Equations 1–2 with a constant force f = (0, −9.8, 0) N on m = 0.2 kg
    // (a = −49 m/s²), h = 0.05 s, v₀ = (1, 2, 0) m/s:
    //   x_1 = x_0 + h v₀                         (Euler start; no force)
    //   x_{k+1} = x_k + (1 − δ)(x_k − x_{k−1}) + h² a
    // δ = 0 gives x_k = x_0 + k h v₀ + a h² (k−1)k/2; for k = 1 and 2:
    //   y_1 = 0 + 0.05·2                  = 0.1
    //   y_2 = 0 + 2·0.05·2 − 49·0.0025·1  = 0.0775
    // δ = 0.02 follows the damped recurrence in `verlet_free_fall`.
    for kind in SolverKind::ALL {
        for damping in [0.0f32, 0.02] {
            let (x0, v0) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 2.0, 0.0));
            let params = SolverParams { damping, relaxations: 5, ..SolverParams::default() };
            let mut sim = Simulation::with_solver(lone_particle(x0, v0), params.clone(), kind).unwrap();
            let a = f64::from(params.gravity.y / params.mass);
            for k in 1..=200u64 {
                sim.step().unwrap();
                let p = sim.positions()[0];
                let (h, d) = (f64::from(params.dt), f64::from(damping));
                let y = verlet_free_fall(0.0, 2.0, a, h, d, k);
                let x = verlet_free_fall(0.0, 1.0, 0.0, h, d, k);
                // A step of equation 1 rounds four times in f32 (difference,
                // scaling by 1 − δ, the two additions), each by at most half
                // an ulp of 1 + |y| (a bound on every intermediate here): at
                // most u = 4 · 2⁻²⁴ = 2⁻²² relative per step. Position Verlet
                // carries the velocity as x_j − x_{j−1}, so an error made at
                // step j is repeated by every later step: after k steps the
                // worst case is u (1 + |y|) k(k + 1)/2. That bound is loose
                // late in the run (11 m at k = 200, where |y| ≈ 2400 m; the
                // errors seen are millimetres) but far below what a wrong
                // equation gives: a missing or doubled h² a term is off by
                // |a| h² k²/2 ≈ 0.06 k² m, over 200 × the bound for k ≤ 200.
                let tol = f64::from(f32::EPSILON) / 2.0 * (1.0 + y.abs()) * (k * (k + 1) / 2) as f64;
                assert!((f64::from(p.y) - y).abs() < tol, "{kind:?} δ={damping} step {k}: y {} vs {y}", p.y);
                assert!((f64::from(p.x) - x).abs() < tol, "{kind:?} δ={damping} step {k}: x {} vs {x}", p.x);
                if k == 1 {
                    assert!((p.y - 0.1).abs() < 1e-7, "Euler start: {}", p.y);
                }
                if k == 2 && damping == 0.0 {
                    assert!((p.y - 0.0775).abs() < 1e-6, "{}", p.y);
                }
            }
        }
    }
}

#[test]
fn kinetic_energy_uses_the_substep_velocity() {
    // One particle at rest, a = f/m = −9.8/0.2 = −49 m/s², δ = 0, h = 0.05 s
    // split in n = 4 substeps of τ = h/n = 0.0125 s. The first substep is the
    // Euler start (x_1 = x_0, since v₀ = 0); each later one adds τ² a to the
    // displacement x_k − x_{k−1}. After K = 10 steps, N = nK = 40 substeps:
    //   x_N − x_{N−1} = (N − 1) τ² a,  v = (N − 1) τ a = 39 · 0.0125 · 49
    //                 = 23.8875 m/s,   E = ½ m v² = 0.1 · 570.61 = 57.061 J.
    // Dividing the last substep's displacement by the whole h instead
    // would give v/4 and E/16 = 3.57 J.
    for kind in SolverKind::ALL {
        let params = SolverParams { damping: 0.0, substeps: 4, wind: Wind::None, ..SolverParams::default() };
        let mut sim = Simulation::with_solver(lone_particle(Vec3::ZERO, Vec3::ZERO), params, kind).unwrap();
        sim.advance(10).unwrap();
        let v = 39.0 * 0.0125 * 49.0;
        let expected = 0.5 * 0.2 * v * v;
        // f32 displacements of ~0.3 m are exact to ~3e-8 relative; 1e-5
        // relative leaves room for the rounding of 40 substeps.
        let energy = sim.kinetic_energy();
        assert!((energy - expected).abs() < 1e-5 * expected, "{kind:?}: {energy} J vs {expected} J");
    }
}

#[test]
fn a_particle_pinned_and_freed_starts_from_rest() {
    // A lone particle falls for 10 steps (a = −49 m/s², h = 0.05 s), is
    // pinned for 5 and freed. Pinned, it is at rest: the first free step of
    // equation 1 moves it by (1 − δ)·0 + h² a = −0.1225 m exactly as from
    // rest. Keeping the velocity it had when pinned, (x_10 − x_9) ≈ −1.1 m
    // a step, would move it about ten times as far.
    for kind in SolverKind::ALL {
        let mut sim =
            Simulation::with_solver(lone_particle(Vec3::ZERO, Vec3::ZERO), SolverParams::default(), kind).unwrap();
        sim.advance(10).unwrap();
        sim.set_fixed(0, true).unwrap();
        let pinned_at = sim.positions()[0];
        sim.advance(5).unwrap();
        assert_eq!(sim.positions()[0], pinned_at, "{kind:?}: a fixed particle does not move");
        sim.set_fixed(0, false).unwrap();
        sim.step().unwrap();
        let moved = sim.positions()[0] - pinned_at;
        // f32 rounding of y ≈ −5.5 m: a few ulps, 1e-6 m.
        assert!((moved.y + 0.1225).abs() < 1e-5 && moved.x == 0.0, "{kind:?}: moved {moved}");
    }
}

#[test]
fn damping_alone_gives_the_geometric_series() {
    // No force, v₀ = 2 m/s along x, h = 0.05 s, δ = 0.1. Equation 2 moves the
    // particle h v₀ = 0.1 m; each later step moves it (1 − δ) times the last:
    //   x_k = h v₀ Σ_{j<k} (1−δ)^j = h v₀ (1 − (1−δ)^k) / δ  →  h v₀ / δ = 1 m.
    for kind in SolverKind::ALL {
        let params = SolverParams { damping: 0.1, gravity: Vec3::ZERO, wind: Wind::None, ..SolverParams::default() };
        let mesh = lone_particle(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0));
        let mut sim = Simulation::with_solver(mesh, params, kind).unwrap();
        for k in 1..=300i32 {
            sim.step().unwrap();
            let expected = 0.1 * (1.0 - 0.9f64.powi(k)) / 0.1;
            let x = f64::from(sim.positions()[0].x);
            // f32 position Verlet carries the velocity as x_k − x_{k−1}, a
            // whole number n of ulps of x (1.2e-7 at x ≈ 1) once it is small.
            // x + (1 − δ)·n ulps rounds back to x + n ulps while δn < ½, so the
            // particle creeps up to 4 ulps a step (δ = 0.1) instead of
            // stopping: the error may grow by 5e-7 per step.
            let tol = 5e-7 * f64::from(k);
            assert!((x - expected).abs() < tol, "{kind:?} step {k}: {x} vs {expected}");
        }
        // 0.9³⁰⁰ ≈ 1.9e-14: the particle has reached h v₀ / δ = 1 m.
        assert!((sim.positions()[0].x - 1.0).abs() < 5e-7 * 300.0);
        assert_eq!(sim.positions()[0].y, 0.0);
    }
}

#[test]
fn fixed_particles_keep_their_bits() {
    // The seed's scene in its wind for 300 steps: the 20 particles of the top
    // row must not move by a single bit, whatever the solver does around them.
    let scene = drape::scene::load("seed").unwrap();
    for kind in SolverKind::ALL {
        let mut sim = Simulation::with_solver(scene.mesh.clone(), scene.params.clone(), kind).unwrap();
        sim.advance(300).unwrap();
        let fixed = scene.mesh.fixed();
        let mut checked = 0;
        for (i, (&now, &start)) in sim.positions().iter().zip(scene.mesh.positions()).enumerate() {
            if fixed[i] {
                assert_eq!(now.to_array().map(f32::to_bits), start.to_array().map(f32::to_bits), "particle {i}");
                checked += 1;
            } else {
                assert_ne!(now, start, "free particle {i} never moved");
            }
        }
        assert_eq!(checked, 20);
    }
}

/// A deterministic pseudo-random number in [−1, 1) (a 64-bit LCG).
fn jitter(state: &mut u64) -> f32 {
    *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((*state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
}

#[test]
fn relaxation_converges_as_passes_grow() {
    // A free 12 × 12 grid (spacing 0.1 m) is stretched by 30 % and jittered by
    // up to 3 cm, then given one step with no force and K passes. Each pass
    // is a Gauss–Seidel sweep over the bars, so the strain left falls as K
    // grows and reaches the f32 round-off floor (~1e-6 here) given enough.
    let mesh = Grid { columns: 12, rows: 12, spacing: 0.1, pins: Pins::None, ..Grid::default() }.build().unwrap();
    let mut seed = 7u64;
    let stretched: Vec<Vec3> = mesh
        .positions()
        .iter()
        .map(|&p| p * 1.3 + Vec3::new(jitter(&mut seed), jitter(&mut seed), 0.0) * 0.03)
        .collect();
    for kind in SolverKind::ALL {
        let mut last = f32::INFINITY;
        let mut results = Vec::new();
        for k in [1u32, 2, 4, 8, 16, 32, 64, 128, 256, 1024, 4096] {
            let params = SolverParams { relaxations: k, gravity: Vec3::ZERO, ..SolverParams::default() };
            let mut sim = Simulation::with_solver(mesh.clone(), params, kind).unwrap();
            sim.set_state(&stretched, &stretched).unwrap();
            sim.step().unwrap();
            let s = sim.strain().max;
            results.push((k, s));
            // Below 2e-6 the strain is f32 round-off (ulp of 1 m is 1.2e-7,
            // divided by 0.13 m bars) and may wobble.
            assert!(
                s <= last * 1.0001 || s < 2e-6,
                "{kind:?}: max strain grew from {last} to {s} at {k} passes: {results:?}"
            );
            last = s;
        }
        assert!(results[0].1 > 0.05, "{kind:?}: one pass should leave visible strain: {results:?}");
        assert!(last < 1e-5, "{kind:?}: {results:?}");
    }
}

/// The seed-style chain: 21 nodes, 20 links of 7.5 cm, ends 1 m apart at
/// y = 1, starting as a V of straight links.
fn chain(links: usize, link: f32, span: f32) -> ClothMesh {
    let dx = span / links as f32;
    let dy = (link * link - dx * dx).sqrt();
    let positions: Vec<Vec3> =
        (0..=links).map(|i| Vec3::new(-span / 2.0 + dx * i as f32, 1.0 - dy * i.min(links - i) as f32, 0.0)).collect();
    let adjacency: Vec<Vec<u64>> = (0..=links).map(|i| if i < links { vec![i as u64 + 1] } else { vec![] }).collect();
    ClothMesh::from_adjacency(positions, &[0, links as u64], &adjacency, None).unwrap()
}

/// Runs the chain for 10 s of simulated time with step `dt` and returns the
/// largest node distance from the exact catenary (m), the residual max strain
/// and the kinetic energy (J).
fn settled_chain(kind: SolverKind, dt: f32, exact: &[DVec2]) -> (f64, f32, f64) {
    let params = SolverParams { relaxations: 400, damping: 0.05, dt, ..SolverParams::default() };
    let mut sim = Simulation::with_solver(chain(20, 0.075, 1.0), params, kind).unwrap();
    // 10 s: the swing has decayed by 0.95^(10/dt) < 1e-88.
    sim.advance((10.0 / dt).round() as u64).unwrap();
    let worst = sim
        .positions()
        .iter()
        .zip(exact)
        .map(|(p, e)| (DVec2::new(f64::from(p.x), f64::from(p.y)) - *e).length())
        .fold(0.0, f64::max);
    (worst, sim.strain().max, sim.kinetic_energy())
}

#[test]
fn hanging_chain_settles_to_the_discrete_catenary() {
    // 21 equal masses on 20 links of ℓ = 7.5 cm (L = 1.5 m), ends at (±0.5, 1).
    // The exact rest shape is the discrete catenary (equal horizontal tension
    // in every link; `drape::sim::exact::discrete_catenary`), whose middle node
    // hangs 0.50345 m low; the continuous cosh curve hangs 0.50263 m low, 0.8 mm
    // (5.5e-4 L) away.
    //
    // Tolerance. At rest every step still moves each node by h²|f|/m
    // (0.31 mm at h = 2.5 ms) and the 400 Gauss–Seidel passes pull it back.
    // Gauss–Seidel does not return to the closest point of the constraint set,
    // so the fixed point is off the true equilibrium by an amount that shrinks
    // with h² (measured: 0.74 mm at 10 ms, 0.20 mm at 5 ms, 0.08 mm at 2.5 ms).
    // We require at h = 2.5 ms an error below 1e-4 L = 0.15 mm, which the cosh
    // curve fails by 5×, and that halving h from 5 ms at least halves the error.
    let exact = discrete_catenary(20, 0.075, DVec2::new(-0.5, 1.0), DVec2::new(0.5, 1.0)).unwrap();
    for kind in SolverKind::ALL {
        let (fine, strain, energy) = settled_chain(kind, 0.0025, &exact);
        let (coarse, _, _) = settled_chain(kind, 0.005, &exact);
        assert!(fine / 1.5 < 1e-4, "{kind:?}: node error {fine} m = {} L", fine / 1.5);
        assert!(coarse > 2.0 * fine, "{kind:?}: error {coarse} m at 5 ms vs {fine} m at 2.5 ms");
        assert!(strain < 1e-5, "{kind:?}: residual stretch {strain}");
        // At rest up to the passes' round-off: under 2 µm per step (6.6e-4 m/s,
        // 19 free nodes of 0.2 kg → 8e-7 J).
        assert!(energy < 8e-7, "{kind:?}: not at rest: {energy} J");
    }
}

#[test]
fn pendulum_swings_with_the_expected_period() {
    // One bar of L = 1 m from a fixed particle at the origin to a free one of
    // m = 0.2 kg, gravity 9.8 N (a force: g_eff = 9.8/0.2 = 49 m/s²), δ = 0,
    // h = 1 ms, one pass per step (a single bar is exact in one pass).
    // Small-angle period T₀ = 2π·sqrt(L·m/|f_g|) = 2π·sqrt(1·0.2/9.8) = 0.89760 s;
    // released at 5° from rest the exact period is T₀/AGM(1, cos 2.5°) =
    // 1.000476 T₀ = 0.89803 s.
    //
    // Measured from the times x crosses zero (linear interpolation between
    // steps), over 10 periods. Verlet with projection is second order: the
    // period error is O((ωh)²) = (7 rad/s · 1 ms)² ≈ 5e-5 relative, and the
    // Euler start shifts the phase by at most one step, which the differences
    // of crossing times remove. Tolerance 2e-4 relative: 4× the bound.
    let (length, mass, theta0) = (1.0f32, 0.2f32, 5f32.to_radians());
    let t0 = 2.0 * std::f64::consts::PI * f64::from(length * mass / 9.8).sqrt();
    let expected = pendulum_period(t0, f64::from(theta0));
    for kind in SolverKind::ALL {
        let bob = Vec3::new(length * theta0.sin(), -length * theta0.cos(), 0.0);
        let mesh = ClothMesh::from_adjacency(vec![Vec3::ZERO, bob], &[0], &[vec![1], vec![]], None).unwrap();
        let params = SolverParams { relaxations: 1, damping: 0.0, dt: 0.001, mass, ..SolverParams::default() };
        let mut sim = Simulation::with_solver(mesh, params, kind).unwrap();
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
            assert!(sim.time() < 20.0, "{kind:?}: no swing");
        }
        // Zero crossings come twice a period.
        let period = (crossings[20] - crossings[0]) / 10.0;
        let error = (period - expected).abs() / expected;
        assert!(error < 2e-4, "{kind:?}: period {period} s, expected {expected} s (error {error})");
        // Length is held by the bar at every step.
        let l = sim.positions()[1].length();
        assert!((l - 1.0).abs() < 1e-5, "{kind:?}: bar length {l}");
    }
}

#[test]
fn blow_up_stops_with_the_step_it_happened_at() {
    // Within the parameter ranges the projection keeps a pinned cloth bounded,
    // so the blow-up is brought in through the state: a cloth torn 1e20 m
    // apart has bar lengths whose squares overflow f32 (max 3.4e38), and the
    // first relaxation turns them into NaN.
    let mesh = Grid { columns: 4, rows: 4, pins: Pins::TopCorners, ..Grid::default() }.build().unwrap();
    let mut sim = Simulation::new(mesh.clone(), SolverParams::default()).unwrap();
    sim.advance(3).unwrap();
    let torn: Vec<Vec3> =
        mesh.positions().iter().enumerate().map(|(i, &p)| if i >= 8 { p + Vec3::X * 1e20 } else { p }).collect();
    sim.set_state(&torn, &torn).unwrap();
    let err = sim.advance(10).unwrap_err();
    let SimError::Diverged { step, .. } = err else { panic!("{err}") };
    assert_eq!(step, 4, "{err}");
    assert!(err.to_string().contains("step 4"), "{err}");
    // The positions reported stay the last finite ones, and stepping stays refused.
    assert!(sim.positions().iter().all(|p| p.is_finite()));
    assert!(sim.step().is_err());
}
