//! Shared by the solver tests: the edges' strain over a run.

use drape::sim::{Simulation, StrainHistory};

/// The edges' max strain over `steps` steps after `warmup`: (typical, worst).
pub fn edge_strain_run(sim: &mut Simulation, warmup: u64, steps: u64) -> (f64, f32) {
    sim.advance(warmup).unwrap();
    let mut history = StrainHistory::default();
    for _ in 0..steps {
        sim.step().unwrap();
        history.record(sim.edge_strain());
    }
    (history.mean_max(), history.worst_max)
}
