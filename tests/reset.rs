//! A reset keeps the solver's layout and writes its particles back; the
//! steps after it must be the steps of a new simulation, bit for bit, on
//! every layout (the reference's, the grid's lanes, the coloured path) and
//! with every phase that keeps state between steps.

use drape::sim::{Air, Simulation, SolverKind, SolverParams, Wind};
use glam::Vec3;

/// Position bits, particle by particle.
fn bits(sim: &Simulation) -> Vec<[u32; 3]> {
    sim.positions().iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

/// Runs `params` on the bundled `scene` twice: once new, once after some
/// steps, a pin, a grab and a change of parameters (to `params` itself,
/// which the reset keeps) and a reset. Both must then take the same steps.
fn reset_matches_a_new_simulation(scene: &str, kind: SolverKind, params: impl Fn(SolverParams) -> SolverParams) {
    let loaded = drape::scene::load(scene).expect("bundled scene");
    let params = params(loaded.params.clone());
    let mesh = loaded.mesh.clone();
    let n = mesh.positions().len();
    let mut fresh = Simulation::with_solver(mesh.clone(), params.clone(), kind).expect("valid scene");

    // The one to reset: built with the scene's own parameters, stepped,
    // one particle pinned where it is, one grabbed, then given `params`.
    let mut reset = Simulation::with_solver(mesh, loaded.params.clone(), kind).expect("valid scene");
    reset.advance(6).expect("no blow-up");
    let (pinned, grabbed) = (n / 2, n - 1);
    reset.set_fixed(pinned, true).expect("an index of the mesh");
    reset.hold(grabbed, reset.positions()[grabbed] + Vec3::new(0.3, 0.2, 0.0), 50.0).expect("a free particle");
    reset.advance(4).expect("no blow-up");
    reset.set_params(params).expect("valid parameters");
    reset.advance(2).expect("no blow-up");
    // Something to undo: the cloth moved from where a new one starts.
    assert_ne!(bits(&reset), bits(&fresh), "{scene}: the steps before the reset moved nothing");

    reset.reset();
    assert_eq!((reset.steps(), reset.time()), (0, 0.0));
    assert_eq!(bits(&reset), bits(&fresh), "{scene}: not back at the start");
    assert_eq!(reset.solver_description(), fresh.solver_description());
    for step in 1..=12 {
        fresh.step().expect("no blow-up");
        reset.step().expect("no blow-up");
        assert_eq!(bits(&reset), bits(&fresh), "{scene} ({kind:?}): step {step} after the reset differs");
    }
    // The steps moved the cloth (a comparison of two still cloths proves
    // little).
    let start = drape::scene::load(scene).expect("bundled scene");
    let moved = fresh.positions().iter().zip(start.mesh.positions()).filter(|(x, x0)| x != x0).count();
    assert!(moved > n / 4, "{scene}: {moved} of {n} particles moved");
}

#[test]
fn a_reset_seeds_cloth_takes_a_new_ones_steps_on_both_solvers() {
    // The grid's lanes and the reference; the seed's wind and pins, and
    // tethers with compliant bars (state a layout keeps: anchors, μ).
    for kind in [SolverKind::Fast, SolverKind::Reference] {
        reset_matches_a_new_simulation("seed", kind, |p| p);
        reset_matches_a_new_simulation("seed", kind, |p| SolverParams {
            tether_slack: Some(0.02),
            stretch_compliance: 1e-4,
            bend_compliance: 1e-2,
            ..p
        });
    }
}

#[test]
fn a_reset_grid_with_unequal_masses_and_its_other_phases_takes_a_new_ones_steps() {
    // Per-area masses make the weights unequal (the grid's lanes then leave
    // their equal-mass shares); the air phase, self-collision, the
    // inextensible projection and the coarse passes each keep state.
    reset_matches_a_new_simulation("seed", SolverKind::Fast, |p| SolverParams {
        density: Some(0.2),
        mass: 1.0,
        wind: Wind::Air(Air { velocity: Vec3::new(3.0, 0.0, 1.0), gusts: 0.3, ..Air::default() }),
        self_collision: true,
        ..p
    });
    reset_matches_a_new_simulation("seed-inextensible", SolverKind::Fast, |p| p);
    reset_matches_a_new_simulation("large-inextensible", SolverKind::Fast, |p| SolverParams { relaxations: 2, ..p });
}

#[test]
fn a_reset_mesh_on_the_coloured_path_takes_a_new_ones_steps() {
    // The tablecloth (an OBJ mesh, renumbered into dimers): rigid, and
    // compliant with tethers.
    reset_matches_a_new_simulation("tablecloth", SolverKind::Fast, |p| p);
    reset_matches_a_new_simulation("tablecloth", SolverKind::Fast, |p| SolverParams {
        tether_slack: Some(0.0),
        stretch_compliance: 1e-5,
        bend_compliance: 1e-3,
        over_relaxation: 1.2,
        ..p
    });
}
