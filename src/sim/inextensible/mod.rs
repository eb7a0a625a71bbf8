//! The project phase: the cloth's edges put back to their rest lengths
//! all at once, by a global Newton solve (Goldenthal et al. 2007,
//! *Efficient Simulation of Inextensible Cloth*, "fast projection").
//!
//! The seed's relaxation projects one bar at a time, so a correction
//! crosses the cloth one bar per pass, and a jolt (the seed's wind changes
//! by up to 60 m/s² from one step to the next) leaves the bars stretched
//! after any affordable number of passes. The project phase instead solves
//! for every edge's correction together. With the edge constraints
//!
//! ```text
//! C_j(x) = |x_a − x_b| − L_j,          ∇_a C_j = n_j,  ∇_b C_j = −n_j,
//!                                      n_j = (x_a − x_b)/|x_a − x_b|
//! ```
//!
//! (J the matrix of the gradients, one row per edge, W the particles'
//! inverse masses relative to m̄), one Newton iteration finds the smallest
//! mass-weighted move Δx = −W Jᵀ μ that zeroes the linearised constraints:
//!
//! ```text
//! (J W Jᵀ + β) μ = C(x) + β λ,     x ← x − W Jᵀ μ,     λ ← λ − μ
//! ```
//!
//! β = α m̄/(h/n)² is the edges' compliance (XPBD, Macklin et al. 2016;
//! 0 for the inextensible cloth, and λ then plays no part). J W Jᵀ is
//! sparse: entry (j, k) is non-zero only when edges j and k share a
//! particle p, and then it is w_p s_j s_k (n_j · n_k) (s = ±1: which end
//! of the edge p is); the diagonal is w_a + w_b + β. Its pattern is fixed
//! by the mesh, so the fill-reducing ordering and symbolic factorisation
//! (faer's sparse Cholesky, approximate minimum degree) are computed once;
//! an iteration refills the values and factorises them anew, unless no
//! edge has turned by more than about 0.8° since the last factorisation
//! (a cloth at rest, or moving slowly): then the last factor is reused, a
//! chord iteration that costs one solve, and if it does not cut the strain
//! fourfold the next iteration factorises. (Reusing the factor whatever
//! the turn was measured first: on a hanging sheet a chord step right after
//! a Newton step took the largest strain from 0.4 % back up to 13 %,
//! because J W Jᵀ of a nearly flat, nearly inextensible sheet is
//! ill-conditioned and a few degrees of rotation change its solution a
//! lot.) Newton's convergence is quadratic: a 7 % strain falls to 0.4 %,
//! then 10⁻⁵. The iterations stop when every edge is within `tolerance` of
//! its rest length, or after `iterations`.
//!
//! **Smoothing.** Where the cloth is curved and moving fast (the seed's
//! wind moves its free edge further than a bar's length per step) the
//! linearisation overshoots locally. `smoothing` Gauss–Seidel passes over
//! the edges alone (the seed's projection, over-relaxed by ω = 1.8, run as
//! batches of edges that share no particle; on a grid in the fast solver's
//! lane layout) run before the first iteration
//! (unless the last factor still fits: then one solve is cheaper) and after
//! each one that leaves an edge outside the tolerance, in batches of 8
//! with a measure after each, stopping once every edge is within the
//! tolerance (then no Newton iteration is needed at all): they
//! remove the local error, so Newton starts close and has only the
//! long-range error to fix (and is often not needed). Measured on the
//! seed's scene: without them the iterations do not converge (50 % typical
//! strain after 3); with 48 after each, plain, they leave 0.35 % for
//! 2.9 iterations a step; over-relaxed and before as well, 0.26 % (0.8 %
//! worst) for 1.1.
//!
//! **Which bars.** The edges ([`ClothMesh::is_edge`]): on a grid the bars
//! between horizontal and vertical neighbours, the warp and weft along
//! which woven cloth hardly stretches. There are about 2 per particle, so
//! J W Jᵀ is non-singular and the edges can all be at rest length while
//! the cloth shears and bends (held by the diagonals and bend bars, which
//! the relaxation passes still handle). On a triangle mesh every edge is
//! one, about 3 per particle: as many constraints as coordinates, which
//! locks a fully inextensible mesh (Goldenthal et al., section 4); give
//! such meshes a compliance.
//!
//! **Weights.** A fixed particle (w = 0) does not move and couples nothing;
//! an edge with both ends fixed is left out of the right-hand side. The
//! diagonal carries 10⁻⁹ more, so the matrix stays positive definite when
//! edges are degenerate (zero length: n = 0) or redundant; a pivot that
//! still fails is lifted by faer's dynamic regularisation. The solve is
//! sequential and in f64: the same input gives the same bits.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use glam::{DVec3, Vec3};

use super::mesh::ClothMesh;

mod smoothing;
use smoothing::Smoothing;

/// Added to every diagonal entry of J W Jᵀ (dimensionless, against weights
/// of order 1): keeps the matrix positive definite with degenerate edges.
const REGULARISATION: f64 = 1e-9;
/// 1 − cos θ of the largest turn of an edge since the last factorisation
/// for which that factor is reused (θ ≈ 0.8°): then the step is a chord
/// iteration, one solve instead of a factorisation.
const REUSE_TURN: f64 = 1e-4;
/// Smoothing passes between two measures of the strain (a measure costs
/// about one pass).
const SMOOTHING_BATCH: u32 = 8;

/// What the project phase needs for one substep.
#[derive(Clone, Copy, Debug)]
pub struct ProjectionStep<'a> {
    /// Every particle's inverse mass relative to m̄ (0: fixed), scene order.
    pub weights: &'a [f32],
    /// β = α m̄/(h/n)² of the edges (0: inextensible).
    pub beta: f32,
    /// Most Newton iterations in the substep (≥ 1).
    pub iterations: u32,
    /// Relative strain every edge must be within to stop early.
    pub tolerance: f32,
    /// Gauss–Seidel passes over the edges after each Newton iteration.
    pub smoothing: u32,
}

/// What the last substep's projection did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectionReport {
    /// Newton iterations made (each a solve).
    pub iterations: u32,
    /// Of which with a fresh numeric factorisation (the others reused the
    /// last one: the edges had not turned since).
    pub factorizations: u32,
    /// The largest edge strain before the first iteration.
    pub strain_before: f32,
    /// The largest edge strain after the last.
    pub strain_after: f32,
    /// A factorisation failed (the matrix was not numerically positive
    /// definite even with regularisation); the iterations stopped there.
    pub failed: bool,
}

/// Why the project phase could not be set up.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProjectionError {
    /// faer could not build the symbolic factorisation (too large for
    /// memory, or for its index type).
    #[error("the inextensible projection cannot factorise this mesh's {edges} edges: {reason}")]
    Symbolic {
        /// The number of edges.
        edges: usize,
        /// faer's reason.
        reason: String,
    },
}

/// Edges j < k sharing particle p: entry `slot` of J W Jᵀ gets
/// w_p · sign · (n_j · n_k).
#[derive(Clone, Copy, Debug)]
struct Coupling {
    particle: u32,
    j: u32,
    k: u32,
    slot: u32,
    /// s_j s_k: +1 when p is the same end of both edges, −1 otherwise.
    sign: f64,
}

/// The phase's state: the edges, the matrix pattern and its symbolic
/// factorisation, and the buffers one substep works in.
#[derive(Clone, Debug)]
pub struct FastProjection {
    /// Each edge's particles (a, b).
    ends: Vec<[u32; 2]>,
    /// Each edge's rest length L_j, metres.
    rest: Vec<f64>,
    couplings: Vec<Coupling>,
    /// The smoothing passes' order and buffers.
    smoothing: Smoothing,
    /// Slot of each diagonal entry in `values`.
    diagonal: Vec<usize>,
    /// The lower triangle of J W Jᵀ, compressed by column.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// The numeric factor L's values.
    factor: Vec<f64>,
    scratch: Scratch,
    /// Positions after the relaxation, scene order (the solver writes them;
    /// the phase then works on them in place).
    pub x: Vec<Vec3>,
    /// Positions at the start of the substep (read along with `x`, unused).
    pub x_prev: Vec<Vec3>,
    /// `x` as the solver gave it, for the push.
    start: Vec<Vec3>,
    direction: Vec<DVec3>,
    residual: Vec<f64>,
    solution: Vec<f64>,
    lambda: Vec<f64>,
    /// −Jᵀ μ summed over the iterations: the move of a particle of weight 1.
    push: Vec<Vec3>,
    last: ProjectionReport,
    /// What the factor in `factor` was computed at: the edge directions,
    /// the weights and β (`None`: no usable factor).
    factored_at: Option<(Vec<DVec3>, Vec<f32>, f64)>,
}

impl FastProjection {
    /// The phase for `mesh`'s edges: the pattern of J W Jᵀ and its
    /// symbolic factorisation, computed once.
    pub fn new(mesh: &ClothMesh) -> Result<Self, ProjectionError> {
        let n = mesh.particle_count();
        let edges: Vec<_> = mesh.bars().iter().filter(|b| mesh.is_edge(b)).collect();
        let m = edges.len();
        let ends: Vec<[u32; 2]> = edges.iter().map(|b| [b.a, b.b]).collect();
        let rest: Vec<f64> = edges.iter().map(|b| f64::from(b.rest_length)).collect();

        // Each particle's edges, with the end it is of each.
        let mut incident: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
        for (j, &[a, b]) in ends.iter().enumerate() {
            incident[a as usize].push((j as u32, 1.0));
            incident[b as usize].push((j as u32, -1.0));
        }
        // The lower triangle's pattern: column j holds row j and every
        // later edge sharing a particle with j.
        let mut columns: Vec<Vec<usize>> = (0..m).map(|j| vec![j]).collect();
        for list in &incident {
            for (x, &(j, _)) in list.iter().enumerate() {
                for &(k, _) in &list[x + 1..] {
                    let (lo, hi) = if j < k { (j, k) } else { (k, j) };
                    columns[lo as usize].push(hi as usize);
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(m + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for column in &mut columns {
            column.sort_unstable();
            column.dedup();
            row_idx.extend_from_slice(column);
            col_ptr.push(row_idx.len());
        }
        let slot = |row: usize, col: usize| -> usize {
            let rows = &row_idx[col_ptr[col]..col_ptr[col + 1]];
            // Every (row, col) looked up was inserted above.
            col_ptr[col] + rows.binary_search(&row).unwrap_or(0)
        };
        let diagonal = (0..m).map(|j| slot(j, j)).collect();
        let mut couplings = Vec::new();
        for (p, list) in incident.iter().enumerate() {
            for (x, &(j, sj)) in list.iter().enumerate() {
                for &(k, sk) in &list[x + 1..] {
                    let (lo, hi) = if j < k { (j, k) } else { (k, j) };
                    couplings.push(Coupling {
                        particle: p as u32,
                        j,
                        k,
                        slot: slot(hi as usize, lo as usize) as u32,
                        sign: sj * sk,
                    });
                }
            }
        }
        let smoothing = Smoothing::new(mesh, &ends, &rest);
        let failed = |reason: String| ProjectionError::Symbolic { edges: m, reason };
        let pattern = SymbolicSparseColMatRef::new_checked(m, m, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| failed(format!("{e:?}")))?;
        let requirement = symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let scratch = Scratch::new(requirement).map_err(|e| failed(format!("{e:?}")))?;
        let factor = vec![0.0; symbolic.len_val()];
        let values = vec![0.0; row_idx.len()];
        Ok(Self {
            ends,
            rest,
            couplings,
            smoothing,
            diagonal,
            col_ptr,
            row_idx,
            values,
            symbolic: Arc::new(symbolic),
            factor,
            scratch,
            x: vec![Vec3::ZERO; n],
            x_prev: vec![Vec3::ZERO; n],
            start: vec![Vec3::ZERO; n],
            direction: vec![DVec3::ZERO; m],
            residual: vec![0.0; m],
            solution: vec![0.0; m],
            lambda: vec![0.0; m],
            push: vec![Vec3::ZERO; n],
            last: ProjectionReport::default(),
            factored_at: None,
        })
    }

    /// The number of edges projected.
    pub fn edge_count(&self) -> usize {
        self.ends.len()
    }

    /// What the last call of [`Self::compute`] did.
    pub fn last_report(&self) -> ProjectionReport {
        self.last
    }

    /// Projects `x` (read by the solver) onto the edges' rest lengths:
    /// `smoothing` passes over the edges (module `smoothing`), then Newton
    /// iterations, each followed by the passes again, until every edge is
    /// within the tolerance. Returns
    /// each particle's move divided by its weight (what
    /// [`super::Solver::push`] multiplies back), scene order.
    pub fn compute(&mut self, step: &ProjectionStep) -> &[Vec3] {
        let weights = step.weights;
        let w = |i: u32| f64::from(weights[i as usize]);
        let beta = f64::from(step.beta);
        self.start.copy_from_slice(&self.x);
        self.lambda.fill(0.0);
        self.smoothing.set_weights(weights, beta);
        let mut report = ProjectionReport::default();
        let mut strain = self.measure(weights);
        report.strain_before = strain as f32;
        if strain > f64::from(step.tolerance) && step.smoothing > 0 && !self.factor_fits(weights, beta) {
            // The passes first: they take out the local error the
            // relaxation left, so Newton starts near (often it is then not
            // needed at all). Not when the last factor still fits (a cloth
            // at rest): one solve with it is cheaper than the passes.
            strain = self.smooth(weights, beta, step);
        }
        let mut refactor = false;
        while report.iterations < step.iterations.max(1) && strain > f64::from(step.tolerance) {
            let reused = !refactor && self.factor_fits(weights, beta);
            if !reused {
                if !self.factorise(weights, beta) {
                    report.failed = true;
                    self.factored_at = None;
                    break;
                }
                report.factorizations += 1;
                self.factored_at = Some((self.direction.clone(), weights.to_vec(), beta));
            }
            let before = strain;
            for (j, (r, &[a, b])) in self.solution.iter_mut().zip(&self.ends).enumerate() {
                *r = if w(a) + w(b) > 0.0 { self.residual[j] + beta * self.lambda[j] } else { 0.0 };
            }
            let llt = LltRef::new(&self.symbolic, &self.factor);
            let m = self.solution.len();
            llt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut self.solution, m, 1),
                Par::Seq,
                MemStack::new(&mut self.scratch.buffer),
            );
            for (j, &[a, b]) in self.ends.iter().enumerate() {
                let mu = self.solution[j];
                self.lambda[j] -= mu;
                let shift = self.direction[j] * mu;
                self.x[a as usize] -= (shift * w(a)).as_vec3();
                self.x[b as usize] += (shift * w(b)).as_vec3();
            }
            report.iterations += 1;
            strain = self.measure(weights);
            // A reused factor that did not cut the strain fourfold is
            // stale: the next iteration factorises.
            refactor = reused && strain > 0.25 * before;
            if strain <= f64::from(step.tolerance) || step.smoothing == 0 {
                // Newton alone got there (at rest, one iteration does):
                // no smoothing needed.
                continue;
            }
            strain = self.smooth(weights, beta, step);
        }
        report.strain_after = strain as f32;
        self.last = report;
        for (((push, x), start), &wi) in self.push.iter_mut().zip(&self.x).zip(&self.start).zip(weights) {
            *push = if wi > 0.0 { (*x - *start) / wi } else { Vec3::ZERO };
        }
        &self.push
    }

    /// `step.smoothing` passes over the edges, in batches of
    /// [`SMOOTHING_BATCH`] with a measure after each, ending early once
    /// every edge is within the tolerance (then Newton is not needed, and
    /// the passes left would cost more than they give). Returns the largest
    /// strain.
    fn smooth(&mut self, weights: &[f32], beta: f64, step: &ProjectionStep) -> f64 {
        let mut done = 0;
        while done < step.smoothing {
            let batch = SMOOTHING_BATCH.min(step.smoothing - done);
            self.smoothing.passes(batch, &mut self.x, &mut self.lambda, &self.rest, beta);
            done += batch;
            let strain = self.strain(weights);
            if strain <= f64::from(step.tolerance) {
                // Within the tolerance: no Newton iteration follows, and
                // the directions are not needed.
                return strain;
            }
        }
        // A Newton iteration may follow: it needs the directions and
        // residuals at the positions the passes left.
        self.measure(weights)
    }

    /// The largest |C_j|/L_j over edges with a free end, as [`Self::measure`]
    /// computes it (the same bits), without the directions and residuals:
    /// between batches of passes only the strain is looked at, and the
    /// directions' three divisions an edge were most of a measure's cost.
    fn strain(&self, weights: &[f32]) -> f64 {
        self.largest_strain(weights, |j| self.edge(j).length() - self.rest[j])
    }

    /// Every edge's direction and residual C_j at `x`; returns the
    /// largest |C_j|/L_j over edges with a free end.
    fn measure(&mut self, weights: &[f32]) -> f64 {
        for j in 0..self.ends.len() {
            let e = self.edge(j);
            let length = e.length();
            self.direction[j] = if length > 1e-12 * self.rest[j] { e / length } else { DVec3::ZERO };
            self.residual[j] = length - self.rest[j];
        }
        self.largest_strain(weights, |j| self.residual[j])
    }

    /// Edge j's vector x_a − x_b at `x`, in f64.
    fn edge(&self, j: usize) -> DVec3 {
        let [a, b] = self.ends[j];
        (self.x[a as usize] - self.x[b as usize]).as_dvec3()
    }

    /// The largest |C_j|/L_j over the edges with a free end, C_j being
    /// `residual(j)`.
    fn largest_strain(&self, weights: &[f32], residual: impl Fn(usize) -> f64) -> f64 {
        let mut largest = 0.0f64;
        for (j, &[a, b]) in self.ends.iter().enumerate() {
            if weights[a as usize] > 0.0 || weights[b as usize] > 0.0 {
                largest = largest.max(residual(j).abs() / self.rest[j]);
            }
        }
        largest
    }

    /// Whether the last factor can serve this iteration: the same weights
    /// and β, and no edge turned by more than [`REUSE_TURN`] since. (At
    /// rest, a hanging cloth's edges do not turn from step to step, and the
    /// factor of the last step is the Jacobian of this one.)
    fn factor_fits(&self, weights: &[f32], beta: f64) -> bool {
        let Some((directions, factored_weights, factored_beta)) = &self.factored_at else {
            return false;
        };
        *factored_beta == beta
            && factored_weights.as_slice() == weights
            && directions.iter().zip(&self.direction).all(|(old, new)| old.dot(*new) >= 1.0 - REUSE_TURN)
    }

    /// Fills J W Jᵀ + β at the current directions and factorises it.
    /// Returns false when the factorisation failed.
    fn factorise(&mut self, weights: &[f32], beta: f64) -> bool {
        let w = |i: u32| f64::from(weights[i as usize]);
        self.values.fill(0.0);
        for (j, &[a, b]) in self.ends.iter().enumerate() {
            let free = w(a) + w(b);
            // An edge with both ends fixed moves nothing; any positive
            // pivot keeps the matrix definite (its right-hand side is 0).
            self.values[self.diagonal[j]] = if free > 0.0 { free + beta } else { 1.0 } + REGULARISATION;
        }
        for c in &self.couplings {
            let dot = self.direction[c.j as usize].dot(self.direction[c.k as usize]);
            self.values[c.slot as usize] += w(c.particle) * c.sign * dot;
        }
        let m = self.diagonal.len();
        let pattern = SymbolicSparseColMatRef::new_checked(m, m, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, &self.values);
        let regularisation =
            LltRegularization { dynamic_regularization_delta: 1e-9, dynamic_regularization_epsilon: 1e-13 };
        self.symbolic
            .factorize_numeric_llt(
                &mut self.factor,
                matrix,
                Side::Lower,
                regularisation,
                Par::Seq,
                MemStack::new(&mut self.scratch.buffer),
                Default::default(),
            )
            .is_ok()
    }
}

/// faer's workspace, sized once (a clone gets its own).
struct Scratch {
    requirement: StackReq,
    buffer: MemBuffer,
}

impl Scratch {
    fn new(requirement: StackReq) -> Result<Self, faer::dyn_stack::mem::AllocError> {
        Ok(Self { requirement, buffer: MemBuffer::try_new(requirement)? })
    }
}

impl Clone for Scratch {
    fn clone(&self) -> Self {
        Self { requirement: self.requirement, buffer: MemBuffer::new(self.requirement) }
    }
}

impl std::fmt::Debug for Scratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scratch").field("requirement", &self.requirement).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, GridPlane, Pins};

    #[test]
    fn the_solve_satisfies_the_linear_system() {
        let mesh =
            Grid { columns: 4, rows: 3, spacing: 1.0, plane: GridPlane::Vertical, pins: Pins::None, ..Grid::default() }
                .build()
                .unwrap();
        let mut phase = FastProjection::new(&mesh).unwrap();
        let weights = vec![1.0f32; mesh.particle_count()];
        for (i, (x, p)) in phase.x.iter_mut().zip(mesh.positions()).enumerate() {
            *x = *p + Vec3::new((i as f32 * 1.7).sin(), (i as f32 * 2.3).cos(), (i as f32 * 0.9).sin()) * 0.1;
        }
        phase.measure(&weights);
        assert!(phase.factorise(&weights, 0.0));
        let rhs = phase.residual.clone();
        phase.solution.copy_from_slice(&rhs);
        let m = rhs.len();
        let llt = LltRef::new(&phase.symbolic, &phase.factor);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut phase.solution, m, 1),
            Par::Seq,
            MemStack::new(&mut phase.scratch.buffer),
        );
        // A μ from the stored lower triangle.
        let mut product = vec![0.0; m];
        for col in 0..m {
            for e in phase.col_ptr[col]..phase.col_ptr[col + 1] {
                let row = phase.row_idx[e];
                product[row] += phase.values[e] * phase.solution[col];
                if row != col {
                    product[col] += phase.values[e] * phase.solution[row];
                }
            }
        }
        for j in 0..m {
            assert!((product[j] - rhs[j]).abs() < 1e-9, "{j}: {} vs {}", product[j], rhs[j]);
        }
    }
}
