//! The coarse phase: a grid's stretch taken out on coarser grids first
//! (hierarchical position-based dynamics, Müller 2008, *Hierarchical
//! Position Based Dynamics*; the cascadic form of multigrid).
//!
//! The seed's relaxation projects one bar at a time, so a pass carries a
//! correction one bar further, and the stretch that gravity and the wind
//! spread over a long cloth in one step (on the 256 × 256 cloth every
//! particle falls h²g ≈ 1 mm a step, 5 % of a bar) is smooth across the
//! cloth: the error Gauss–Seidel removes slowest. On a grid coarsened k
//! times, a bar spans 2^k fine bars, so the same pass carries the
//! correction 2^k times as far over a 4^k-th of the bars.
//!
//! **Levels.** Level k ≥ 1 keeps the particles whose column and row are
//! multiples of 2^k (and the last column and row), so every level's nodes
//! are nodes of the level below. Its bars join horizontally and
//! vertically adjacent nodes a and b, with the rest length of the straight
//! line between them in the rest shape, L = |X_a − X_b|. Levels are added
//! until both directions have at most two nodes.
//!
//! **Unilateral bars.** A coarse bar only ever pulls its nodes together:
//!
//! ```text
//! C = |x_a − x_b| − L,   projected only when C > 0:
//! x_a ← x_a − w_a/(w_a + w_b) C n,   x_b ← x_b + w_b/(w_a + w_b) C n,
//! n = (x_a − x_b)/|x_a − x_b|
//! ```
//!
//! Fine bars of rest length ℓ joined in a chain from a to b can never span
//! more than Σ ℓ = L (the triangle inequality), so C ≤ 0 is a consequence of
//! inextensible fine bars, and a coarse bar is never wrong to enforce. A
//! cloth that bends or folds brings its nodes closer than L, which the
//! coarse bar leaves alone: the coarse levels remove stretch, never
//! curvature.
//!
//! **Coarse to fine.** The coarsest level is projected first, `passes`
//! Gauss–Seidel passes (horizontal bars row by row, then vertical bars row
//! pair by row pair). Its nodes' displacement is interpolated bilinearly
//! (over the fine columns and rows between nodes) onto the next level's
//! nodes, which then start from there, and so on down to the fine grid,
//! where every particle receives the interpolated displacement as a push.
//! Interpolating a displacement keeps the fine bars between two nodes
//! evenly stretched or compressed: it is the smooth part of the
//! correction, and the fine passes handle what is local.
//!
//! **Where in the step.** After the relaxation passes, so the step ends
//! with the long-range stretch removed. Measured on the 256 × 256 `large`
//! cloth in its wind (edges' max strain, typical over steps 10–20, 20
//! passes): 16 % without the phase, 10 % with it before the passes, 6.4 %
//! after them. What is left with rigid diagonals is not long-range: every
//! cell's two diagonals are as rigid as its edges, so where the wind
//! shears the cloth they share the error with the edges, fine bar by fine
//! bar, and more coarse passes change nothing (6.2 % at 16 a level). With
//! soft diagonals (`shear_compliance`) the same phase leaves 0.7 %, and
//! 8 passes with 2 coarse passes a level leave about 3 % over 3 s of wind
//! at less than the cost of 20 passes (the `large-inextensible` scene).
//!
//! **Weights.** A node takes its particle's inverse mass w. A node is
//! fixed (w = 0) when any fixed particle is nearer to it than to any other
//! node of its level, so a pin between nodes holds the coarse grid where
//! it is; fixed nodes and fixed particles receive no displacement. Weights
//! are read every substep, so a pin or a grab is a write as everywhere
//! else. The levels' passes run in one thread in a fixed order, and the
//! interpolation onto the particles runs by rows on the thread pool, each
//! row alone: the same input gives the same bits on any thread count.

use glam::Vec3;
use rayon::prelude::*;

use super::mesh::{ClothMesh, GridShape};
use super::self_contact::PARALLEL_PARTICLES;

/// What the coarse phase needs for one substep.
#[derive(Clone, Copy, Debug)]
pub struct CoarseStep<'a> {
    /// Every particle's inverse mass relative to m̄ (0: fixed), scene order.
    pub weights: &'a [f32],
    /// Gauss–Seidel passes over each coarse level's bars (≥ 1).
    pub passes: u32,
    /// Use the thread pool on large cloths.
    pub parallel: bool,
}

/// Where a finer node lies between two nodes of a coarser level along one
/// direction: between coarse nodes `j` and `j + 1`, a share `t` of the way.
#[derive(Clone, Copy, Debug)]
struct Span {
    j: u32,
    t: f32,
}

/// One coarse level.
#[derive(Clone, Debug)]
struct Level {
    /// The fine columns and rows of the nodes, increasing.
    columns: Vec<u32>,
    rows: Vec<u32>,
    /// Where each node column (row) of the next finer level lies between
    /// this level's (the finer level is the fine grid below level 1).
    finer_columns: Vec<Span>,
    finer_rows: Vec<Span>,
    /// Rest lengths of the horizontal bars, row by row (`columns − 1` a row).
    rest_horizontal: Vec<f32>,
    /// Rest lengths of the vertical bars, row pair by row pair.
    rest_vertical: Vec<f32>,
    /// Node positions, row-major, where they started this substep, and
    /// the difference after the level's passes.
    x: Vec<Vec3>,
    start: Vec<Vec3>,
    displacement: Vec<Vec3>,
    /// Node inverse masses (0: fixed).
    weight: Vec<f32>,
}

impl Level {
    fn width(&self) -> usize {
        self.columns.len()
    }

    /// The fine particle index of every node, row-major (the nodes' order).
    fn particles(&self, shape: GridShape) -> impl Iterator<Item = usize> + '_ {
        self.rows.iter().flat_map(move |&r| self.columns.iter().map(move |&c| shape.index(c, r) as usize))
    }

    /// Writes into `out` (one value per span of `columns`) this level's
    /// displacement interpolated bilinearly along the finer row at span
    /// `ry`: the two node rows around it blended once into `blend`, then
    /// each finer column between two blended nodes. The one interpolation
    /// of the phase, for the next level's nodes and for the particles.
    fn interpolate_row(&self, ry: Span, columns: &[Span], blend: &mut Vec<Vec3>, out: &mut [Vec3]) {
        let width = self.width();
        let r0 = ry.j as usize;
        let r1 = (r0 + 1).min(self.rows.len() - 1);
        let (top, bottom) = (&self.displacement[r0 * width..][..width], &self.displacement[r1 * width..][..width]);
        blend.clear();
        blend.extend(top.iter().zip(bottom).map(|(a, b)| a.lerp(*b, ry.t)));
        for (out, cx) in out.iter_mut().zip(columns) {
            let c0 = cx.j as usize;
            *out = blend[c0].lerp(blend[(c0 + 1).min(width - 1)], cx.t);
        }
    }

    /// One Gauss–Seidel pass over the unilateral bars: the horizontal ones
    /// column by column, then the vertical ones row by row, so that
    /// consecutive projections share no node and overlap in the CPU (a row
    /// of horizontal bars taken in turn is one chain of dependent square
    /// roots and divisions).
    fn pass(&mut self) {
        let width = self.width();
        let height = self.rows.len();
        let (x, w) = (&mut self.x, &self.weight);
        let mut project = |a: usize, b: usize, rest: f32| {
            let (wa, wb) = (w[a], w[b]);
            let sum = wa + wb;
            if sum <= 0.0 {
                return;
            }
            let e = x[a] - x[b];
            let length = e.length();
            // Only a stretched bar pulls; a zero-length one has no direction.
            if length > rest && length > 0.0 {
                let shift = e * ((length - rest) / (length * sum));
                x[a] -= shift * wa;
                x[b] += shift * wb;
            }
        };
        for c in 0..width - 1 {
            for r in 0..height {
                let n = r * width + c;
                project(n, n + 1, self.rest_horizontal[r * (width - 1) + c]);
            }
        }
        for r in 0..height - 1 {
            for c in 0..width {
                let n = r * width + c;
                project(n, n + width, self.rest_vertical[n]);
            }
        }
    }
}

/// The node indices along one direction of `count` particles at stride
/// `stride`: the multiples of it and the last.
fn nodes(count: u32, stride: u32) -> Vec<u32> {
    let mut list: Vec<u32> = (0..count).step_by(stride as usize).collect();
    if list.last() != Some(&(count - 1)) {
        list.push(count - 1);
    }
    list
}

/// Where each of `finer` lies between the nodes `coarse` (both increasing,
/// `coarse` a subset of `finer` with the same ends).
fn spans(coarse: &[u32], finer: &[u32]) -> Vec<Span> {
    let mut j = 0usize;
    finer
        .iter()
        .map(|&f| {
            while j + 1 < coarse.len() && coarse[j + 1] <= f && j + 2 < coarse.len() {
                j += 1;
            }
            match coarse.get(j + 1) {
                Some(&next) if next > coarse[j] => {
                    Span { j: j as u32, t: (f.saturating_sub(coarse[j])) as f32 / (next - coarse[j]) as f32 }
                }
                _ => Span { j: j as u32, t: 0.0 },
            }
        })
        .collect()
}

/// The coarse phase's state: the levels and the buffers one substep works
/// in.
#[derive(Clone, Debug)]
pub struct Hierarchy {
    shape: GridShape,
    /// Level 1 (stride 2) first.
    levels: Vec<Level>,
    /// Where each fine column and row lies between level 1's nodes.
    fine_columns: Vec<Span>,
    fine_rows: Vec<Span>,
    /// The weights the nodes' weights were derived from.
    weights_seen: Vec<f32>,
    /// Positions before the phase, scene order (the solver writes them).
    pub x: Vec<Vec3>,
    /// Positions at the start of the substep (read along with `x`, unused).
    pub x_prev: Vec<Vec3>,
    push: Vec<Vec3>,
    /// A row of interpolated displacements and a blended node row, for the
    /// levels below the coarsest.
    row: Vec<Vec3>,
    blend: Vec<Vec3>,
}

impl Hierarchy {
    /// The levels of `mesh`'s grid, or `None` when the mesh is not a grid
    /// (the phase needs the grid's rows and columns).
    pub fn new(mesh: &ClothMesh) -> Option<Self> {
        let shape = mesh.grid()?;
        let rest = mesh.positions();
        let fine_columns: Vec<u32> = (0..shape.columns).collect();
        let fine_rows: Vec<u32> = (0..shape.rows).collect();
        let mut levels: Vec<Level> = Vec::new();
        let mut stride = 2u32;
        loop {
            let (finer_c, finer_r) = match levels.last() {
                Some(l) => (l.columns.clone(), l.rows.clone()),
                None => (fine_columns.clone(), fine_rows.clone()),
            };
            if finer_c.len() <= 2 && finer_r.len() <= 2 {
                break;
            }
            let columns = nodes(shape.columns, stride);
            let rows = nodes(shape.rows, stride);
            let (width, height) = (columns.len(), rows.len());
            let at = |c: usize, r: usize| rest[shape.index(columns[c], rows[r]) as usize];
            let mut rest_horizontal = Vec::with_capacity(height * width.saturating_sub(1));
            for r in 0..height {
                for c in 0..width - 1 {
                    rest_horizontal.push(at(c, r).distance(at(c + 1, r)));
                }
            }
            let mut rest_vertical = Vec::with_capacity(height.saturating_sub(1) * width);
            for r in 0..height - 1 {
                for c in 0..width {
                    rest_vertical.push(at(c, r).distance(at(c, r + 1)));
                }
            }
            let count = width * height;
            levels.push(Level {
                finer_columns: spans(&columns, &finer_c),
                finer_rows: spans(&rows, &finer_r),
                columns,
                rows,
                rest_horizontal,
                rest_vertical,
                x: vec![Vec3::ZERO; count],
                start: vec![Vec3::ZERO; count],
                displacement: vec![Vec3::ZERO; count],
                weight: vec![1.0; count],
            });
            stride *= 2;
        }
        let (fine_c, fine_r) = match levels.first() {
            Some(l) => (spans(&l.columns, &fine_columns), spans(&l.rows, &fine_rows)),
            None => (Vec::new(), Vec::new()),
        };
        let n = mesh.particle_count();
        Some(Self {
            shape,
            levels,
            fine_columns: fine_c,
            fine_rows: fine_r,
            weights_seen: Vec::new(),
            x: vec![Vec3::ZERO; n],
            x_prev: vec![Vec3::ZERO; n],
            push: vec![Vec3::ZERO; n],
            row: Vec::new(),
            blend: Vec::new(),
        })
    }

    /// The number of coarse levels (0 for a grid too small to coarsen).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Every level's node weights from the particles' (module docs).
    fn set_weights(&mut self, weights: &[f32]) {
        let shape = self.shape;
        for level in &mut self.levels {
            let mut node_weights = std::mem::take(&mut level.weight);
            for (w, i) in node_weights.iter_mut().zip(level.particles(shape)) {
                *w = weights[i];
            }
            level.weight = node_weights;
            // A fixed particle fixes its nearest node.
            let nearest = |list: &[u32], f: u32| match list.binary_search(&f) {
                Ok(k) => k,
                Err(0) => 0,
                Err(k) if k >= list.len() => list.len() - 1,
                Err(k) => {
                    if f - list[k - 1] <= list[k] - f {
                        k - 1
                    } else {
                        k
                    }
                }
            };
            for (i, _) in weights.iter().enumerate().filter(|(_, w)| **w == 0.0) {
                let (c, r) = (i as u32 % shape.columns, i as u32 / shape.columns);
                let n = nearest(&level.rows, r) * level.width() + nearest(&level.columns, c);
                level.weight[n] = 0.0;
            }
        }
        self.weights_seen.clear();
        self.weights_seen.extend_from_slice(weights);
    }

    /// Takes the stretch out of `x` (read by the solver) level by level,
    /// coarsest first. Returns each particle's move divided by its weight
    /// (what [`super::Solver::push`] multiplies back), scene order.
    pub fn compute(&mut self, step: &CoarseStep) -> &[Vec3] {
        if self.levels.is_empty() {
            self.push.fill(Vec3::ZERO);
            return &self.push;
        }
        if self.weights_seen.as_slice() != step.weights {
            self.set_weights(step.weights);
        }
        let shape = self.shape;
        for level in &mut self.levels {
            let mut start = std::mem::take(&mut level.start);
            for (p, i) in start.iter_mut().zip(level.particles(shape)) {
                *p = self.x[i];
            }
            level.x.copy_from_slice(&start);
            level.start = start;
        }
        for k in (0..self.levels.len()).rev() {
            if k + 1 < self.levels.len() {
                // The coarser level's displacement onto this level's free
                // nodes, which start from there.
                let (finer, coarser) = self.levels.split_at_mut(k + 1);
                let (level, coarser) = (&mut finer[k], &coarser[0]);
                let width = level.width();
                self.row.resize(width, Vec3::ZERO);
                for (r, &ry) in coarser.finer_rows.iter().enumerate() {
                    coarser.interpolate_row(ry, &coarser.finer_columns, &mut self.blend, &mut self.row);
                    let nodes = r * width..(r + 1) * width;
                    let (x, start, weight) =
                        (&mut level.x[nodes.clone()], &level.start[nodes.clone()], &level.weight[nodes]);
                    for (((x, start), &w), d) in x.iter_mut().zip(start).zip(weight).zip(&self.row) {
                        if w > 0.0 {
                            *x = *start + *d;
                        }
                    }
                }
            }
            let level = &mut self.levels[k];
            for _ in 0..step.passes {
                level.pass();
            }
            for ((d, x), start) in level.displacement.iter_mut().zip(&level.x).zip(&level.start) {
                *d = *x - *start;
            }
        }
        // Level 1's displacement onto every particle, divided by its weight
        // (rows in parallel on large cloths, each with its own blend row:
        // each row is computed alone, so the bits do not depend on the
        // threads).
        let level = &self.levels[0];
        let fine_columns = &self.fine_columns;
        let fill_row = |blend: &mut Vec<Vec3>, ((push, weights), &ry): ((&mut [Vec3], &[f32]), &Span)| {
            level.interpolate_row(ry, fine_columns, blend, push);
            for (push, &w) in push.iter_mut().zip(weights) {
                *push = if w > 0.0 { *push / w } else { Vec3::ZERO };
            }
        };
        let columns = shape.columns as usize;
        if step.parallel && self.push.len() >= PARALLEL_PARTICLES && rayon::current_num_threads() > 1 {
            let rows = self.push.par_chunks_mut(columns).zip(step.weights.par_chunks(columns));
            rows.zip(self.fine_rows.par_iter()).for_each_init(Vec::new, fill_row);
        } else {
            let rows = self.push.chunks_mut(columns).zip(step.weights.chunks(columns));
            let blend = &mut self.blend;
            rows.zip(self.fine_rows.iter()).for_each(|row| fill_row(blend, row));
        }
        &self.push
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, GridPlane, Pins};

    #[test]
    fn nodes_are_the_multiples_and_the_last() {
        assert_eq!(nodes(9, 2), vec![0, 2, 4, 6, 8]);
        assert_eq!(nodes(10, 4), vec![0, 4, 8, 9]);
        assert_eq!(nodes(1, 2), vec![0]);
        let s = spans(&[0, 4, 8, 9], &[0, 2, 4, 6, 8, 9]);
        let got: Vec<(u32, f32)> = s.iter().map(|s| (s.j, s.t)).collect();
        assert_eq!(got, vec![(0, 0.0), (0, 0.5), (1, 0.0), (1, 0.5), (2, 0.0), (2, 1.0)]);
    }

    #[test]
    fn levels_halve_until_two_nodes_remain() {
        let mesh = Grid { columns: 256, rows: 256, ..Grid::default() }.build().unwrap();
        let h = Hierarchy::new(&mesh).unwrap();
        // 256 → 129 (0, 2, …, 254, 255) → 65 → 33 → 17 → 9 → 5 → 3 → 2
        // nodes a side: 8 levels.
        let widths: Vec<usize> = h.levels.iter().map(Level::width).collect();
        assert_eq!(widths, vec![129, 65, 33, 17, 9, 5, 3, 2]);
    }

    /// A vertical strip stretched uniformly by 10 % (every particle below
    /// the pinned top moved down in proportion) is brought back to its rest
    /// length by the coarse levels alone: the stretch is perfectly smooth,
    /// exactly what they remove.
    #[test]
    fn a_uniform_stretch_is_removed() {
        let mesh = Grid {
            columns: 5,
            rows: 65,
            spacing: 0.1,
            plane: GridPlane::Vertical,
            pins: Pins::TopRow,
            ..Grid::default()
        }
        .build()
        .unwrap();
        let mut h = Hierarchy::new(&mesh).unwrap();
        let top = mesh.positions()[0].y;
        for (x, p) in h.x.iter_mut().zip(mesh.positions()) {
            *x = Vec3::new(p.x, top - (top - p.y) * 1.1, p.z);
        }
        let weights: Vec<f32> = mesh.fixed().iter().map(|&f| if f { 0.0 } else { 1.0 }).collect();
        let push = h.compute(&CoarseStep { weights: &weights, passes: 4, parallel: false }).to_vec();
        let length = |i: usize| (h.x[i] + push[i]).y;
        // The bottom was 6.4 × 1.1 = 7.04 m below the top; now within 1 %
        // of 6.4 m (the bottom-most coarse bars see every stretch above).
        let bottom = 64 * 5;
        let hang = top - length(bottom);
        assert!((hang - 6.4).abs() < 0.064, "hangs {hang} m");
        // Without the phase it would still hang 7.04 m: the push is what did it.
        assert!(push[bottom].y > 0.5, "{}", push[bottom]);
        // The top row is pinned and stays.
        assert_eq!(push[0], Vec3::ZERO);
    }

    /// A cloth folded in two (compressed, not stretched) is left alone:
    /// coarse bars only pull.
    #[test]
    fn compression_and_folds_are_left_alone() {
        let mesh = Grid { columns: 9, rows: 9, spacing: 0.1, pins: Pins::None, ..Grid::default() }.build().unwrap();
        let mut h = Hierarchy::new(&mesh).unwrap();
        for (x, p) in h.x.iter_mut().zip(mesh.positions()) {
            *x = *p * 0.7;
        }
        let weights = vec![1.0; mesh.particle_count()];
        let push = h.compute(&CoarseStep { weights: &weights, passes: 4, parallel: false });
        assert!(push.iter().all(|p| *p == Vec3::ZERO));
    }
}
