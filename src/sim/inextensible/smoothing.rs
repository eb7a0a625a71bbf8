//! The project phase's smoothing passes: Gauss–Seidel over the edges
//! alone, the seed's projection (XPBD with β), over-relaxed on rigid edges.
//!
//! A Newton step of the projection is exact for the linearised
//! constraints; where the cloth is curved and moving fast it overshoots
//! locally, and these passes, cheap and local, take that error out so
//! that Newton has only the long-range error left. For speed they run in
//! f32, in an order that sweeps down the cloth as the mesh's does but with
//! no two consecutive edges sharing a particle, cut into runs of
//! independent edges. On rigid edges (β = 0) a run's edges go eight at a
//! time in the lanes of an AVX register (positions as 16-byte rows, eight
//! rows transposed into lanes and back, [`Rows`](crate::sim::fast::rows::Rows)), the run's last
//! `n mod 8` one at a time; each lane computes what the edge alone would
//! ([`move_ends`], written once for both), so the result has the bits of
//! one by one.
//!
//! **On a grid** (built as one, or a triangulated sheet the lane layout
//! finds a grid in) the rigid passes run on the fast solver's lane layout
//! instead ([`EdgeLanes`]: the grid's edges alone, eight column blocks in
//! the lanes, rows swept away from the pins with up
//! to four passes in flight, threaded on large grids), the same projection
//! in the same row-by-row order up to which edges of a row go first (other
//! bits, the same convergence: a test). The runs of rows leave a fifth of
//! the seed's edges one at a time (runs of 10, 9 and 20 edges) and pay two
//! transposes an octet; the lanes have neither. Measured (`cargo bench
//! --no-default-features --bench accuracy`, host D, Zen 4, one thread):
//! `seed-inextensible` 0.533 → 0.415 ms a step, with 8 coarse passes
//! 0.254 → 0.192 ms; the 256 × 256 cloth's inextensible step 85.7 → 55.8 ms
//! (two threads). The same strain.

use std::ops::Range;

use glam::Vec3;

use crate::sim::fast::GridLayout;
use crate::sim::fast::kernel::{LANES, Point, Real, dot, scale, sub};
#[cfg(target_arch = "x86_64")]
use crate::sim::fast::simd::{self, SimdLevel};
use crate::sim::mesh::{BarKind, ClothMesh, MeshParts};
use crate::sim::step::{Solver, Substep};

/// ω of the passes over rigid edges (successive over-relaxation; the
/// edges alone are not over-constrained, unlike the grid with its
/// diagonals, so ω > 1 converges faster). Measured on `seed-inextensible`
/// (typical / worst edge strain, ms per step, smoothing after each Newton
/// iteration only): ω = 1: 0.35 % / 1.7 %, 2.8 ms; 1.3: 0.17 % / 1.1 %;
/// 1.6: 0.10 % / 1.0 %, 2.6 ms; 1.8: 0.07 % / 1.7 %, 2.3 ms.
const OVER_RELAXATION: f32 = 1.8;

/// The edges of the passes in sweep order, one column per field.
#[derive(Clone, Debug, Default)]
struct SweepEdges {
    /// Ends, scene indices.
    a: Vec<u32>,
    b: Vec<u32>,
    /// Each one's index among the edges (for λ and the rest length in f64).
    edge: Vec<u32>,
    /// L_j, metres.
    rest: Vec<f32>,
    /// w_a/(w_a + w_b + β) and w_b/(…) this substep (0 with both ends fixed).
    share_a: Vec<f32>,
    share_b: Vec<f32>,
    /// 1/(w_a + w_b + β) (0 with both ends fixed).
    inverse: Vec<f32>,
}

/// The passes' order, their runs of independent edges and their buffer.
#[derive(Clone, Debug)]
pub(super) struct Smoothing {
    /// The edges in sweep order ([`sweep_order`]), with this substep's shares.
    sweep: SweepEdges,
    /// `sweep` cut into runs in which no two edges share a particle.
    runs: Vec<Range<usize>>,
    /// The positions as `[x, y, z, 0]` rows while rigid passes run.
    rows: Vec<[f32; 4]>,
    /// On a grid, where the rigid passes run instead of on `rows`.
    lanes: Option<EdgeLanes>,
}

/// A grid's edges in the fast solver's lane layout, for the rigid passes.
#[derive(Clone, Debug)]
struct EdgeLanes {
    /// The lane layout over the edges alone.
    layout: GridLayout,
    /// The weights it holds (relative inverse masses, scene order).
    weights: Vec<f32>,
    /// Where [`Solver::read`] writes x − d (unused).
    previous: Vec<Vec3>,
}

impl EdgeLanes {
    /// The lane layout of `mesh`'s grid with the edges `ends` alone, or
    /// `None` when the mesh is not a grid the layout takes (an operation's
    /// lanes finding an edge in some and none in others).
    fn new(mesh: &ClothMesh, ends: &[[u32; 2]], rest: &[f64]) -> Option<Self> {
        // The mesh's grid, or its triangles for the layout to find one in
        // (a triangulated sheet in any numbering).
        let edges = ClothMesh::new(MeshParts {
            positions: mesh.positions().to_vec(),
            fixed: mesh.fixed().to_vec(),
            bars: ends.iter().map(|&[a, b]| (a, b, BarKind::Structural)).collect(),
            rest_lengths: rest.iter().map(|&l| l as f32).collect(),
            triangles: mesh.triangles().to_vec(),
            grid: mesh.grid(),
            ..MeshParts::default()
        })
        .ok()?;
        let weights: Vec<f32> = mesh.fixed().iter().map(|&f| if f { 0.0 } else { 1.0 }).collect();
        let layout = GridLayout::new(&edges, mesh.positions(), mesh.positions(), &weights, None)?;
        Some(Self { layout, weights, previous: vec![Vec3::ZERO; mesh.particle_count()] })
    }

    /// Writes the weights that changed (each a write of one lane; the
    /// layout checks its equal-mass form once, at the next passes).
    fn set_weights(&mut self, weights: &[f32]) {
        for (i, (held, &w)) in self.weights.iter_mut().zip(weights).enumerate() {
            if held.to_bits() != w.to_bits() {
                *held = w;
                self.layout.set_inverse_mass(i, w);
            }
        }
    }

    /// `count` rigid passes over the edges, moving `x` (scene order).
    fn passes(&mut self, count: u32, x: &mut [Vec3]) {
        for (i, &p) in x.iter().enumerate() {
            self.layout.set_particle(i, p, p);
        }
        self.layout.relax(&Substep {
            dt: 0.0,
            keep: 0.0,
            accel: Vec3::ZERO,
            gravity: Vec3::ZERO,
            first: None,
            relaxations: count,
            tolerance: 0.0,
            over_relaxation: OVER_RELAXATION,
            stretch_beta: 0.0,
            bend_beta: 0.0,
            shear_beta: 0.0,
            tether_slack: None,
        });
        self.layout.read(x, &mut self.previous);
    }
}

impl Smoothing {
    /// The passes over the edges `ends` (rest lengths `rest`) of `mesh`.
    pub(super) fn new(mesh: &ClothMesh, ends: &[[u32; 2]], rest: &[f64]) -> Self {
        let order = sweep_order(mesh, ends);
        let runs = independent_runs(&order, ends, mesh.particle_count());
        let mut sweep = SweepEdges::default();
        for &j in &order {
            let [a, b] = ends[j as usize];
            sweep.a.push(a);
            sweep.b.push(b);
            sweep.edge.push(j);
            sweep.rest.push(rest[j as usize] as f32);
        }
        let m = order.len();
        (sweep.share_a, sweep.share_b, sweep.inverse) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        let lanes = EdgeLanes::new(mesh, ends, rest);
        Self { sweep, runs, rows: vec![[0.0; 4]; mesh.particle_count()], lanes }
    }

    /// This substep's weights (relative inverse masses, scene order) and β.
    pub(super) fn set_weights(&mut self, weights: &[f32], beta: f64) {
        if let Some(lanes) = &mut self.lanes {
            lanes.set_weights(weights);
        }
        let w = |i: u32| f64::from(weights[i as usize]);
        let e = &mut self.sweep;
        for k in 0..e.a.len() {
            let sum = w(e.a[k]) + w(e.b[k]);
            let inverse = if sum > 0.0 { 1.0 / (sum + beta) } else { 0.0 };
            e.share_a[k] = (w(e.a[k]) * inverse) as f32;
            e.share_b[k] = (w(e.b[k]) * inverse) as f32;
            e.inverse[k] = inverse as f32;
        }
    }

    /// `count` passes over the edges, moving `x` (scene order); with β > 0
    /// each accumulates each edge's λ, as XPBD does.
    pub(super) fn passes(&mut self, count: u32, x: &mut [Vec3], lambda: &mut [f64], rest: &[f64], beta: f64) {
        if beta != 0.0 {
            for _ in 0..count {
                self.compliant_pass(x, lambda, rest, beta);
            }
            return;
        }
        // Rigid edges: λ plays no part, and the passes run in a grid's
        // lanes or on rows.
        if let Some(lanes) = &mut self.lanes {
            lanes.passes(count, x);
            return;
        }
        for (row, p) in self.rows.iter_mut().zip(x.iter()) {
            *row = p.extend(0.0).to_array();
        }
        rigid_passes(&mut self.rows, &self.sweep, &self.runs, count);
        for (p, row) in x.iter_mut().zip(&self.rows) {
            *p = Vec3::new(row[0], row[1], row[2]);
        }
    }

    /// One pass over compliant edges, one at a time (λ in f64).
    fn compliant_pass(&self, x: &mut [Vec3], lambda: &mut [f64], rest: &[f64], beta: f64) {
        let e = &self.sweep;
        for k in 0..e.a.len() {
            let (a, b, j) = (e.a[k] as usize, e.b[k] as usize, e.edge[k] as usize);
            let d = x[a] - x[b];
            let length = d.length();
            if length <= f32::MIN_POSITIVE {
                continue;
            }
            // μ = (C + βλ)/(w_a + w_b + β); the shares are w/(w_a + w_b + β).
            let c = f64::from(length) - rest[j] + beta * lambda[j];
            lambda[j] -= c * f64::from(e.inverse[k]);
            let unit = d / length;
            x[a] -= unit * (c as f32 * e.share_a[k]);
            x[b] += unit * (c as f32 * e.share_b[k]);
        }
    }
}

/// One rigid edge's projection, over-relaxed, on a `f32` or on eight
/// lanes: e = x_a − x_b, k = ω (1 − L/|e|), x_a −= s_a k e, x_b += s_b k e.
/// A zero-length edge has e = 0, so its (finite) factor moves nothing.
#[inline(always)]
fn move_ends<T: Real>(a: &mut Point<T>, b: &mut Point<T>, rest: T, share_a: T, share_b: T) {
    let e = sub(*a, *b);
    let length = dot(e, e).max(T::splat(f32::MIN_POSITIVE)).sqrt();
    let shift = scale(e, (T::splat(1.0) - rest / length) * T::splat(OVER_RELAXATION));
    *a = sub(*a, scale(shift, share_a));
    let pull = scale(shift, share_b);
    *b = [b[0] + pull[0], b[1] + pull[1], b[2] + pull[2]];
}

/// Edge `k` of the sweep alone.
#[inline(always)]
fn move_one(rows: &mut [[f32; 4]], e: &SweepEdges, k: usize) {
    let (ia, ib) = (e.a[k] as usize, e.b[k] as usize);
    let ([ax, ay, az, aw], [bx, by, bz, bw]) = (rows[ia], rows[ib]);
    let (mut a, mut b) = ([ax, ay, az], [bx, by, bz]);
    move_ends(&mut a, &mut b, e.rest[k], e.share_a[k], e.share_b[k]);
    rows[ia] = [a[0], a[1], a[2], aw];
    rows[ib] = [b[0], b[1], b[2], bw];
}

/// `count` rigid passes: run by run, eight edges at a time in AVX lanes
/// where the CPU has them, the rest one at a time (the same bits).
#[allow(unsafe_code)]
fn rigid_passes(rows: &mut [[f32; 4]], edges: &SweepEdges, runs: &[Range<usize>], count: u32) {
    #[cfg(target_arch = "x86_64")]
    if simd::level() >= SimdLevel::Avx2 {
        // SAFETY: the level is AVX2 or above only when the CPU reports AVX2
        // and FMA, the features `avx2::rigid_passes` is compiled for.
        unsafe { avx2::rigid_passes(rows, edges, runs, count) };
        return;
    }
    for _ in 0..count {
        rigid_pass(rows, edges, runs, |_, _| false);
    }
}

/// One rigid pass: each run's edges eight at a time through `octet(rows,
/// first)` while it takes them (returns true), then one at a time.
#[inline(always)]
fn rigid_pass(
    rows: &mut [[f32; 4]],
    edges: &SweepEdges,
    runs: &[Range<usize>],
    mut octet: impl FnMut(&mut [[f32; 4]], usize) -> bool,
) {
    for run in runs {
        let mut next = run.start;
        while next + LANES <= run.end && octet(rows, next) {
            next += LANES;
        }
        for k in next..run.end {
            move_one(rows, edges, k);
        }
    }
}

/// [`rigid_passes`] in AVX registers.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::ops::Range;

    use super::{LANES, SweepEdges, move_ends, rigid_pass};
    use crate::sim::fast::avx::Avx;
    use crate::sim::fast::rows::Rows;

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn rigid_passes(rows: &mut [[f32; 4]], edges: &SweepEdges, runs: &[Range<usize>], count: u32) {
        for _ in 0..count {
            rigid_pass(rows, edges, runs, |rows, first| {
                octet(rows, edges, first);
                true
            });
        }
    }

    /// Edges `first..first + 8` of one run (no shared particle).
    #[inline(always)]
    fn octet(rows: &mut [[f32; 4]], e: &SweepEdges, first: usize) {
        let ia: [usize; LANES] = std::array::from_fn(|l| e.a[first + l] as usize);
        let ib: [usize; LANES] = std::array::from_fn(|l| e.b[first + l] as usize);
        let [ax, ay, az, aw] = Avx::gather(rows, &ia);
        let [bx, by, bz, bw] = Avx::gather(rows, &ib);
        let (mut a, mut b) = ([ax, ay, az], [bx, by, bz]);
        let column = |c: &[f32]| Avx::load(&c[first..]);
        move_ends(&mut a, &mut b, column(&e.rest), column(&e.share_a), column(&e.share_b));
        for (row, &i) in Avx::to_rows([a[0], a[1], a[2], aw]).into_iter().zip(&ia) {
            rows[i] = row;
        }
        for (row, &i) in Avx::to_rows([b[0], b[1], b[2], bw]).into_iter().zip(&ib) {
            rows[i] = row;
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
    fn lanes_give_the_bits_of_one_edge_at_a_time() {
        // The seed's 20 × 30 grid stretched 4 % and crumpled, with unequal
        // weights (1, ½, ⅓ and the pinned top row): rows of 10, 9 and 20
        // edges, so runs go through lanes (8 and 16 edges) and one at a
        // time (the rest).
        let mesh = Grid { columns: 20, rows: 30, spacing: 0.5, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
        let edges: Vec<_> = mesh.bars().iter().filter(|b| mesh.is_edge(b)).collect();
        let ends: Vec<[u32; 2]> = edges.iter().map(|b| [b.a, b.b]).collect();
        let rest: Vec<f64> = edges.iter().map(|b| f64::from(b.rest_length)).collect();
        let weights: Vec<f32> =
            mesh.fixed().iter().enumerate().map(|(i, &f)| if f { 0.0 } else { [1.0, 0.5, 1.0 / 3.0][i % 3] }).collect();
        let start: Vec<Vec3> = mesh
            .positions()
            .iter()
            .enumerate()
            .map(|(i, p)| *p * 1.04 + Vec3::new(0.0, 0.0, 0.05 * (i as f32 * 0.7).sin()))
            .collect();
        let mut smoothing = Smoothing::new(&mesh, &ends, &rest);
        // The runs of rows, which a grid would not use.
        smoothing.lanes = None;
        smoothing.set_weights(&weights, 0.0);
        assert!(smoothing.runs.iter().any(|r| r.len() >= 2 * LANES), "runs long enough for lanes");
        let mut laned = start.clone();
        smoothing.passes(3, &mut laned, &mut [], &rest, 0.0);
        // The same three passes one edge at a time.
        let mut rows: Vec<[f32; 4]> = start.iter().map(|p| p.extend(0.0).to_array()).collect();
        for _ in 0..3 {
            rigid_pass(&mut rows, &smoothing.sweep, &smoothing.runs, |_, _| false);
        }
        let bits = |p: &[f32]| p.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for (i, (p, row)) in laned.iter().zip(&rows).enumerate() {
            assert_eq!(bits(&p.to_array()), bits(&row[..3]), "particle {i}");
        }
        // The passes did something to compare: every free particle moved
        // (by centimetres; the bits above compare every one).
        let moved = laned.iter().zip(&start).filter(|(p, q)| p.distance(**q) > 1e-3).count();
        assert_eq!(moved, weights.iter().filter(|&&w| w > 0.0).count());
    }

    /// The largest |ℓ − L|/L over the edges with a free end.
    fn largest_strain(x: &[Vec3], ends: &[[u32; 2]], rest: &[f64], weights: &[f32]) -> f64 {
        let free = |&(&[a, b], _): &(&[u32; 2], &f64)| weights[a as usize] > 0.0 || weights[b as usize] > 0.0;
        ends.iter()
            .zip(rest)
            .filter(free)
            .map(|(&[a, b], &l)| (f64::from(x[a as usize].distance(x[b as usize])) - l).abs() / l)
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_grids_passes_run_in_the_lanes_and_converge_as_the_rows_do() {
        // The seed's grid, every free particle jolted by up to 1.7 cm (the
        // local error the passes are for: 2.6 % strain), unequal weights;
        // one more particle pinned between calls (a weight that changes is
        // written to the lanes).
        let grid = Grid { columns: 20, rows: 30, spacing: 0.5, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
        // And a triangulated sheet of 24 × 20, chequerboard diagonals,
        // renumbered: its edges' grid comes from its triangles.
        use crate::sim::fast::grid_tests::{ALTERNATE, renumbered, triangle_sheet};
        let sheet = renumbered(&triangle_sheet(24, 20, ALTERNATE));
        // The particle to pin between calls: in the second row, a bar
        // below the pinned first row (so its pin leaves the edges a shape
        // they can take); in the sheet, (5, 1) numbered anew: 29 · 7919 mod
        // 480 = 211.
        for (mesh, pin) in [(grid, 25), (sheet, 211)] {
            grids_passes_run_in_the_lanes(&mesh, pin);
        }
    }

    fn grids_passes_run_in_the_lanes(mesh: &ClothMesh, pin: usize) {
        let edges: Vec<_> = mesh.bars().iter().filter(|b| mesh.is_edge(b)).collect();
        let ends: Vec<[u32; 2]> = edges.iter().map(|b| [b.a, b.b]).collect();
        let rest: Vec<f64> = edges.iter().map(|b| f64::from(b.rest_length)).collect();
        let mut weights: Vec<f32> =
            mesh.fixed().iter().enumerate().map(|(i, &f)| if f { 0.0 } else { [1.0, 0.5, 1.0 / 3.0][i % 3] }).collect();
        let start: Vec<Vec3> = mesh
            .positions()
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                let t = i as f32;
                let jolt = Vec3::new((1.3 * t).sin(), (0.7 * t).cos(), (2.1 * t).sin()) * 0.01;
                if mesh.fixed()[i] { p } else { p + jolt }
            })
            .collect();
        let mut lanes = Smoothing::new(mesh, &ends, &rest);
        assert!(lanes.lanes.is_some(), "a grid's edges go in the lane layout");
        let mut rows = lanes.clone();
        rows.lanes = None;
        let (mut a, mut b) = (start.clone(), start.clone());
        for (smoothing, x) in [(&mut lanes, &mut a), (&mut rows, &mut b)] {
            smoothing.set_weights(&weights, 0.0);
            smoothing.passes(8, x, &mut [], &rest, 0.0);
        }
        weights[pin] = 0.0;
        let held = a[pin];
        for (smoothing, x) in [(&mut lanes, &mut a), (&mut rows, &mut b)] {
            smoothing.set_weights(&weights, 0.0);
            smoothing.passes(40, x, &mut [], &rest, 0.0);
        }
        // Fixed particles stayed where they were, to the bit.
        assert_eq!(a[pin], held);
        for (i, &w) in weights.iter().enumerate() {
            if w == 0.0 && i != pin {
                assert_eq!(a[i], start[i], "pinned particle {i}");
            }
        }
        // Both are the same over-relaxed Gauss–Seidel sweep down the cloth,
        // in another order within each row: from 2.6 % the 48 passes leave
        // 0.075 % in either order (measured); each ends below a tenth of the
        // start and within a factor 1.5 of the other.
        let (before, in_lanes, in_rows) = (
            largest_strain(&start, &ends, &rest, &weights),
            largest_strain(&a, &ends, &rest, &weights),
            largest_strain(&b, &ends, &rest, &weights),
        );
        assert!(before > 0.02, "{before}");
        assert!(in_lanes < before / 10.0 && in_rows < before / 10.0, "{before} → {in_lanes}, {in_rows}");
        assert!(in_lanes < 1.5 * in_rows && in_rows < 1.5 * in_lanes, "lanes {in_lanes}, rows {in_rows}");
    }

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
