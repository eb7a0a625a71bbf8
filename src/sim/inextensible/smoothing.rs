//! The project phase's smoothing passes: Gauss–Seidel over the edges
//! alone, the seed's projection (XPBD with β), over-relaxed on rigid edges.
//!
//! A Newton step of the projection is exact for the linearised
//! constraints; where the cloth is curved and moving fast it overshoots
//! locally, and these passes, cheap and local, take that error out so
//! that Newton has only the long-range error left. For speed they run in
//! f32, in an order that sweeps down the cloth as the mesh's does but with
//! no two consecutive edges sharing a particle, cut into runs that are
//! projected as batches (all lengths, then all square roots and divisions
//! in SIMD lanes, then all moves): the same result as one by one.

use std::ops::Range;

use glam::Vec3;

use crate::sim::mesh::ClothMesh;

/// ω of the passes over rigid edges (successive over-relaxation; the
/// edges alone are not over-constrained, unlike the grid with its
/// diagonals, so ω > 1 converges faster). Measured on `seed-inextensible`
/// (typical / worst edge strain, ms per step, smoothing after each Newton
/// iteration only): ω = 1: 0.35 % / 1.7 %, 2.8 ms; 1.3: 0.17 % / 1.1 %;
/// 1.6: 0.10 % / 1.0 %, 2.6 ms; 1.8: 0.07 % / 1.7 %, 2.3 ms.
const OVER_RELAXATION: f32 = 1.8;

/// One edge of the passes.
#[derive(Clone, Copy, Debug)]
struct SweepEdge {
    a: u32,
    b: u32,
    /// Its index among the edges (for λ and the rest length in f64).
    edge: u32,
    /// L_j, metres.
    rest: f32,
    /// w_a/(w_a + w_b + β) and w_b/(…) this substep (0 with both ends fixed).
    share_a: f32,
    share_b: f32,
    /// 1/(w_a + w_b + β) (0 with both ends fixed).
    inverse: f32,
}

/// The passes' order, their runs of independent edges and their buffers.
#[derive(Clone, Debug)]
pub(super) struct Smoothing {
    /// The edges in sweep order ([`sweep_order`]), with this substep's shares.
    sweep: Vec<SweepEdge>,
    /// `sweep` cut into runs in which no two edges share a particle.
    runs: Vec<Range<usize>>,
    /// Per edge of the longest run: its vector.
    batch: Vec<Vec3>,
    /// Per edge of the longest run: |e|², then ω (1 − L/|e|).
    factor_batch: Vec<f32>,
    /// Per edge of the longest run: L.
    rest_batch: Vec<f32>,
}

impl Smoothing {
    /// The passes over the edges `ends` (rest lengths `rest`) of `mesh`.
    pub(super) fn new(mesh: &ClothMesh, ends: &[[u32; 2]], rest: &[f64]) -> Self {
        let order = sweep_order(mesh, ends);
        let runs = independent_runs(&order, ends, mesh.particle_count());
        let longest = runs.iter().map(|r| r.len()).max().unwrap_or(0);
        let sweep = order
            .iter()
            .map(|&j| {
                let [a, b] = ends[j as usize];
                let rest = rest[j as usize] as f32;
                SweepEdge { a, b, edge: j, rest, share_a: 0.0, share_b: 0.0, inverse: 0.0 }
            })
            .collect();
        Self {
            sweep,
            runs,
            batch: vec![Vec3::ZERO; longest],
            factor_batch: vec![0.0; longest],
            rest_batch: vec![0.0; longest],
        }
    }

    /// This substep's weights (relative inverse masses, scene order) and β.
    pub(super) fn set_weights(&mut self, weights: &[f32], beta: f64) {
        let w = |i: u32| f64::from(weights[i as usize]);
        for edge in &mut self.sweep {
            let sum = w(edge.a) + w(edge.b);
            let inverse = if sum > 0.0 { 1.0 / (sum + beta) } else { 0.0 };
            edge.share_a = (w(edge.a) * inverse) as f32;
            edge.share_b = (w(edge.b) * inverse) as f32;
            edge.inverse = inverse as f32;
        }
    }

    /// One pass over the edges, moving `x` (scene order); with β > 0 it
    /// accumulates each edge's λ, as XPBD does.
    pub(super) fn pass(&mut self, x: &mut [Vec3], lambda: &mut [f64], rest: &[f64], beta: f64) {
        if beta == 0.0 {
            // Rigid edges: λ plays no part.
            for run in &self.runs {
                let edges = &self.sweep[run.clone()];
                let count = edges.len();
                for (((e, lsq), rest), edge) in
                    self.batch.iter_mut().zip(&mut self.factor_batch).zip(&mut self.rest_batch).zip(edges)
                {
                    *e = x[edge.a as usize] - x[edge.b as usize];
                    *lsq = e.length_squared();
                    *rest = edge.rest;
                }
                // ω (1 − L/|e|): contiguous, so the square roots and
                // divisions of the run go in SIMD lanes. A zero-length edge
                // has e = 0, so its (finite) factor moves nothing.
                for (k, &rest) in self.factor_batch[..count].iter_mut().zip(&self.rest_batch[..count]) {
                    *k = (1.0 - rest / k.max(f32::MIN_POSITIVE).sqrt()) * OVER_RELAXATION;
                }
                for ((e, &k), edge) in self.batch.iter().zip(&self.factor_batch).zip(edges) {
                    let shift = *e * k;
                    x[edge.a as usize] -= shift * edge.share_a;
                    x[edge.b as usize] += shift * edge.share_b;
                }
            }
            return;
        }
        for edge in &self.sweep {
            let (a, b, j) = (edge.a as usize, edge.b as usize, edge.edge as usize);
            let e = x[a] - x[b];
            let length = e.length();
            if length <= f32::MIN_POSITIVE {
                continue;
            }
            // μ = (C + βλ)/(w_a + w_b + β); the shares are w/(w_a + w_b + β).
            let c = f64::from(length) - rest[j] + beta * lambda[j];
            lambda[j] -= c * f64::from(edge.inverse);
            let unit = e / length;
            x[a] -= unit * (c as f32 * edge.share_a);
            x[b] += unit * (c as f32 * edge.share_b);
        }
    }
}

/// The order of the passes. On a grid: row by row from the first, and
/// within a row its horizontal edges of even columns, then of odd columns,
/// then the vertical edges down to the next row. The sweep still runs down
/// the cloth as the mesh's order does (measured: a global colour order, all
/// of one colour before the next, converges worse), but no two consecutive
/// edges share a particle. Other meshes: mesh order.
fn sweep_order(mesh: &ClothMesh, ends: &[[u32; 2]]) -> Vec<u32> {
    let Some(shape) = mesh.grid() else {
        return (0..ends.len() as u32).collect();
    };
    let key = |&[a, b]: &[u32; 2]| {
        let (lo, hi) = (a.min(b), a.max(b));
        let (row, column) = (lo / shape.columns, lo % shape.columns);
        let group = if hi - lo == 1 && hi / shape.columns == row { column % 2 } else { 2 };
        (row, group, column)
    };
    let mut order: Vec<u32> = (0..ends.len() as u32).collect();
    order.sort_by_key(|&j| key(&ends[j as usize]));
    order
}

/// Cuts `order` into maximal runs of consecutive edges that share no
/// particle.
fn independent_runs(order: &[u32], ends: &[[u32; 2]], particles: usize) -> Vec<Range<usize>> {
    let mut runs = Vec::new();
    let mut in_run = vec![false; particles];
    let mut start = 0;
    for (t, &j) in order.iter().enumerate() {
        let [a, b] = ends[j as usize];
        if in_run[a as usize] || in_run[b as usize] {
            for &k in &order[start..t] {
                let [c, d] = ends[k as usize];
                in_run[c as usize] = false;
                in_run[d as usize] = false;
            }
            runs.push(start..t);
            start = t;
        }
        in_run[a as usize] = true;
        in_run[b as usize] = true;
    }
    if start < order.len() {
        runs.push(start..order.len());
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, Pins};

    #[test]
    fn runs_share_no_particle_and_cover_every_edge_once() {
        let mesh = Grid { columns: 5, rows: 4, spacing: 1.0, pins: Pins::None, ..Grid::default() }.build().unwrap();
        let ends: Vec<[u32; 2]> = mesh.bars().iter().filter(|b| mesh.is_edge(b)).map(|b| [b.a, b.b]).collect();
        // 4 × 4 horizontal + 5 × 3 vertical edges.
        assert_eq!(ends.len(), 31);
        let order = sweep_order(&mesh, &ends);
        let runs = independent_runs(&order, &ends, mesh.particle_count());
        let mut seen = vec![0; ends.len()];
        for run in &runs {
            let mut used = std::collections::HashSet::new();
            for &j in &order[run.clone()] {
                seen[j as usize] += 1;
                let [a, b] = ends[j as usize];
                assert!(used.insert(a) && used.insert(b), "run {run:?} shares a particle");
            }
        }
        assert!(seen.iter().all(|&n| n == 1));
        // Per row: even horizontals, odd horizontals, verticals (3 runs,
        // the last row without verticals): 4 × 3 − 1 = 11.
        assert_eq!(runs.len(), 11);
    }
}
