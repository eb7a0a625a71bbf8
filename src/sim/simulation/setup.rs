//! What a [`super::Simulation`] is built from: masses and compliances
//! derived from the parameters and the mesh, the solver of a kind, and the
//! phases that exist only when the parameters ask for them (coarse, air).

use glam::Vec3;

use super::{SimError, SolverKind};
use crate::sim::aero::Aerodynamics;
use crate::sim::fast;
use crate::sim::hierarchy::Hierarchy;
use crate::sim::mesh::ClothMesh;
use crate::sim::params::{MAX_COMPLIANCE, ParamError, SolverParams};
use crate::sim::reference::ReferenceSolver;
use crate::sim::step::Solver;
use crate::sim::tether::Tethers;
use crate::sim::units;

/// What the parameters and the mesh make of masses and stiffness.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Derived {
    /// m_i, kg.
    pub(super) mass: Vec<f32>,
    /// m̄, kg.
    pub(super) mean: f32,
    /// m̄ / m_i: the weight of each particle while free.
    pub(super) weight: Vec<f32>,
    /// α of structural, bend and shear bars, m/N.
    pub(super) stretch_compliance: f32,
    pub(super) bend_compliance: f32,
    pub(super) shear_compliance: f32,
}

impl Derived {
    pub(super) fn new(mesh: &ClothMesh, p: &SolverParams) -> Result<Self, ParamError> {
        let n = mesh.particle_count();
        let (mass, mean, weight) = match p.density {
            None => (vec![p.mass; n], p.mass, vec![1.0; n]),
            Some(sigma) => {
                let mass = units::particle_masses(mesh, sigma)?;
                let mean = (mass.iter().map(|&m| f64::from(m)).sum::<f64>() / n.max(1) as f64) as f32;
                let weight = mass.iter().map(|&m| mean / m).collect();
                (mass, mean, weight)
            }
        };
        let stretch_compliance = match p.stretch_stiffness {
            Some(k) => units::stretch_compliance(mesh, k)?.min(MAX_COMPLIANCE),
            None => p.stretch_compliance,
        };
        let bend_compliance = match p.bend_stiffness {
            Some(b) => units::bend_compliance(mesh, b)?.min(MAX_COMPLIANCE),
            None => p.bend_compliance,
        };
        let shear_compliance = p.shear_compliance.unwrap_or(stretch_compliance);
        Ok(Self { mass, mean, weight, stretch_compliance, bend_compliance, shear_compliance })
    }
}

/// The coarse phase when `p` asks for coarse passes; an error on a mesh
/// that is not a grid.
pub(super) fn hierarchy(mesh: &ClothMesh, p: &SolverParams) -> Result<Option<Hierarchy>, SimError> {
    if p.coarse_passes == 0 {
        return Ok(None);
    }
    Hierarchy::new(mesh).map(Some).ok_or(SimError::CoarseNeedsGrid { passes: p.coarse_passes })
}

/// The air phase, when the wind is "air" (the mesh has triangles:
/// [`units::check_surface`]), reading `solver`'s lanes where it has them.
pub(super) fn aerodynamics(
    mesh: &ClothMesh,
    p: &SolverParams,
    m: &Derived,
    solver: &dyn Solver,
) -> Option<Aerodynamics> {
    p.wind.air().map(|_| Aerodynamics::new(mesh, &m.mass, solver.lanes().map(|lanes| lanes.places()).as_ref()))
}

/// The solver of this kind for this state.
pub(super) fn build_solver(
    kind: SolverKind,
    mesh: &ClothMesh,
    state: (&[Vec3], &[Vec3]),
    inverse_mass: &[f32],
    tethers: Option<Tethers>,
) -> Box<dyn Solver> {
    let (positions, previous) = state;
    match kind {
        SolverKind::Reference => {
            Box::new(ReferenceSolver::new(positions, previous, inverse_mass, mesh.bars(), tethers))
        }
        SolverKind::Fast => fast::new(mesh, positions, previous, inverse_mass, mesh.bars(), tethers),
    }
}
