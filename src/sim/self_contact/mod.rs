//! The self-collide phase: cloth kept from passing through itself.
//!
//! With r the thickness, every pair of particles i, j that are closer than
//! r now is pushed apart to
//!
//! ```text
//! d_min = min(r, |X_i − X_j|)          X the rest positions
//! ```
//!
//! so pairs that are neighbours in the rest shape (closer than r there) are
//! only kept at their rest distance and the cloth does not push its own
//! neighbours apart (Ten Minute Physics 15). Each particle moves by its share
//! `w_i / (w_i + w_j)` of `d_min − |x_i − x_j|` along the pair's direction n.
//! Friction between layers is the collider's Coulomb rule applied to the
//! pair's relative motion over the substep, `Δ = (x_i − x0_i) − (x_j − x0_j)`:
//! its tangential part is removed up to μ times the push.
//!
//! **No pass-through.** Before the pairs are found, each particle's motion
//! in the substep is limited to `r/4`: two particles then close in on each
//! other by at most `r/2` per substep, less than the `r` they are kept
//! apart, so no pair can cross between two substeps unseen. The limit is a
//! top speed of `r / (4 h/n)` (2.4 m/s for r = 1 cm at 8 substeps of 1/60 s);
//! it applies only when self-collision is on. Testing paths instead would
//! need triangle–triangle continuous collision, which this phase does not do:
//! it keeps particles apart, so layers stay apart where the particle spacing
//! is about the thickness.
//!
//! **Neighbour search.** A hash grid with cells of side 2r, the particles
//! sorted by cell and their positions copied in that order every substep
//! (a linear pass; rebuilding once per step would need cells of the step's
//! whole travel and visit more pairs). Each pair is found once, by the
//! query of the particle that comes first in the sorted table: its
//! candidates are the later particles of the 8 cells its ball of radius r
//! can reach, tested eight at a time in lanes (`self_contact/cells.rs`,
//! which shows why no candidate counts twice). No all-pairs loop. The pairs
//! found are then pushed apart eight at a time in lanes, both ends of a
//! pair at once (`self_contact/pair.rs`), each end with the bits it gets
//! when computed alone.
//!
//! **Determinism.** Corrections are computed for every pair from the same
//! snapshot of positions (Jacobi) and summed per particle from zero in the
//! order the pairs were found: first its pairs with particles earlier in
//! the table (by that particle), then its own query's, in the query's
//! order. The order depends on neither the thread count nor the SIMD level.
//! Large cloths search and compute pairs in chunks on the rayon pool; the
//! sums run in order after them. The phase reads each pair's data
//! (substep-start positions, weights, rest positions) from copies in the
//! table's order, so the particles near one another are near in memory.

mod cells;
mod pair;

use crate::sim::fast::simd::dispatch;

use glam::Vec3;
use rayon::prelude::*;

use cells::{Cells, gather};
use pair::{Moves, Slots, pair_corrections};

/// Cloths of at least this many particles find their corrections on the
/// thread pool.
pub const PARALLEL_PARTICLES: usize = 8192;

/// The spatial hash and the scratch space of the self-collide phase.
#[derive(Clone, Debug, Default)]
pub struct SelfContact {
    rest: Vec<Vec3>,
    cells: Cells,
    /// Per slot of `cells` (the particles sorted by cell), as the pairs
    /// read them: position and inverse mass, substep-start position, rest
    /// position (`[x, y, z, w or 0]`); and the correction.
    slot_point: Vec<[f32; 4]>,
    slot_start: Vec<[f32; 4]>,
    slot_rest: Vec<[f32; 4]>,
    correction: Vec<Vec3>,
    /// Positions, substep-start positions and weights in scene order, for
    /// solvers whose own layout is not scene order.
    pub(crate) x: Vec<Vec3>,
    pub(crate) x0: Vec<Vec3>,
    pub(crate) w: Vec<f32>,
}

/// What one self-collide phase needs besides the positions.
#[derive(Clone, Copy, Debug)]
pub struct SelfContactStep {
    /// r, metres.
    pub thickness: f32,
    /// μ between layers.
    pub friction: f32,
    /// Find corrections on the thread pool.
    pub parallel: bool,
}

/// The pairs found by the queries of a run of slots, each pair once, and
/// what its two slots do to each other.
#[derive(Default)]
struct Pairs {
    own: Vec<u32>,
    other: Vec<u32>,
    moved_own: Vec<Vec3>,
    moved_other: Vec<Vec3>,
}

dispatch! {
    /// The pairs of slots `first..first + count` with later slots.
    fn pairs_of(phase: &SelfContact, first: usize, count: usize, step: &SelfContactStep) -> Pairs
        = pairs_body, best = ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"]
}

#[inline(always)]
fn pairs_body(phase: &SelfContact, first: usize, count: usize, step: &SelfContactStep) -> Pairs {
    let mut pairs = Pairs::default();
    phase.cells.pairs_after(first, count, step.thickness, &mut pairs.own, &mut pairs.other);
    // Two pinned particles do not touch each other (w_i + w_j = 0).
    let free = |slot: u32| phase.slot_point[slot as usize][3] > 0.0;
    if !(first..first + count).all(|slot| free(slot as u32)) {
        let mut kept = 0;
        for k in 0..pairs.own.len() {
            if free(pairs.own[k]) || free(pairs.other[k]) {
                (pairs.own[kept], pairs.other[kept]) = (pairs.own[k], pairs.other[k]);
                kept += 1;
            }
        }
        pairs.own.truncate(kept);
        pairs.other.truncate(kept);
    }
    pairs.moved_own = vec![Vec3::ZERO; pairs.own.len()];
    pairs.moved_other = vec![Vec3::ZERO; pairs.own.len()];
    let slots = Slots { point: &phase.slot_point, start: &phase.slot_start, rest: &phase.slot_rest };
    let moves = Moves { own: &mut pairs.moved_own, other: &mut pairs.moved_other };
    pair_corrections(&slots, &pairs.own, &pairs.other, moves, step);
    pairs
}

/// Slots of the sorted table one task of the thread pool takes.
const CHUNK: usize = 1024;

impl SelfContact {
    /// For a cloth whose rest shape is `rest`.
    pub fn new(rest: &[Vec3]) -> Self {
        Self { rest: rest.to_vec(), ..Self::default() }
    }

    /// The phase on positions `x` (scene order) that started the substep at
    /// `x0`, with inverse masses `w`.
    pub fn apply(&mut self, x: &mut [Vec3], x0: &[Vec3], w: &[f32], step: &SelfContactStep) {
        let r = step.thickness;
        let n = x.len();
        if n < 2 || r <= 0.0 {
            return;
        }
        // Motion per substep at most r/4.
        let limit = 0.25 * r;
        for i in 0..n {
            let d = x[i] - x0[i];
            let len = d.length();
            if w[i] > 0.0 && len > limit {
                x[i] = x0[i] + d * (limit / len);
            }
        }
        let parallel = step.parallel && n >= PARALLEL_PARTICLES && rayon::current_num_threads() > 1;
        self.cells.build(x, 2.0 * r, parallel);
        let order = &self.cells.order;
        let row = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
        let (x_now, rest): (&[Vec3], &[Vec3]) = (x, &self.rest);
        gather(&mut self.slot_point, order, parallel, |i| row(x_now[i], w[i]));
        gather(&mut self.slot_start, order, parallel, |i| row(x0[i], 0.0));
        gather(&mut self.slot_rest, order, parallel, |i| row(rest[i], 0.0));
        let this = &*self;
        let find = |c: usize| pairs_of(this, c * CHUNK, CHUNK.min(n - c * CHUNK), step);
        let chunks = n.div_ceil(CHUNK);
        let found: Vec<Pairs> =
            if parallel { (0..chunks).into_par_iter().map(find).collect() } else { (0..chunks).map(find).collect() };
        // Each slot sums its pairs from zero in the order they were found:
        // those with earlier slots (by the earlier slot), then its own.
        let mut correction = std::mem::take(&mut self.correction);
        correction.clear();
        correction.resize(n, Vec3::ZERO);
        for pairs in &found {
            for k in 0..pairs.own.len() {
                correction[pairs.own[k] as usize] += pairs.moved_own[k];
                correction[pairs.other[k] as usize] += pairs.moved_other[k];
            }
        }
        for (&i, c) in self.cells.order.iter().zip(&correction) {
            x[i as usize] += *c;
        }
        self.correction = correction;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pair_closer_than_the_thickness_is_pushed_apart_to_it() {
        // Two free particles 1 m apart at rest, now 0.004 apart along x with
        // r = 0.01: each moves 0.003 away, so they end 0.01 apart.
        let rest = [Vec3::ZERO, Vec3::X];
        let mut sc = SelfContact::new(&rest);
        let mut x = [Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.504, 0.0, 0.0)];
        let x0 = x;
        let step = SelfContactStep { thickness: 0.01, friction: 0.0, parallel: false };
        sc.apply(&mut x, &x0, &[1.0, 1.0], &step);
        assert!((x[0].distance(x[1]) - 0.01).abs() < 1e-6, "{x:?}");
        assert!((x[0].x - 0.497).abs() < 1e-6, "each moves half: {x:?}");
    }

    #[test]
    fn neighbours_in_the_rest_shape_are_kept_only_at_their_rest_distance() {
        // 0.005 apart at rest (< r): pushed back to 0.005, not to r.
        let rest = [Vec3::ZERO, Vec3::new(0.005, 0.0, 0.0)];
        let mut sc = SelfContact::new(&rest);
        let mut x = [Vec3::ZERO, Vec3::new(0.002, 0.0, 0.0)];
        let x0 = x;
        let step = SelfContactStep { thickness: 0.01, friction: 0.0, parallel: false };
        sc.apply(&mut x, &x0, &[1.0, 1.0], &step);
        assert!((x[0].distance(x[1]) - 0.005).abs() < 1e-6, "{x:?}");
        let mut at_rest = rest;
        sc.apply(&mut at_rest, &rest, &[1.0, 1.0], &step);
        assert_eq!(at_rest, rest, "at their rest distance they are left alone");
    }

    #[test]
    fn motion_is_limited_to_a_quarter_of_the_thickness_per_substep() {
        let rest = [Vec3::ZERO, Vec3::X * 10.0];
        let mut sc = SelfContact::new(&rest);
        let x0 = rest;
        let mut x = [Vec3::new(0.0, -1.0, 0.0), Vec3::X * 10.0];
        let step = SelfContactStep { thickness: 0.02, friction: 0.0, parallel: false };
        sc.apply(&mut x, &x0, &[1.0, 1.0], &step);
        assert!((x[0].y + 0.005).abs() < 1e-7, "{x:?}");
    }

    #[test]
    fn threads_give_the_same_bits() {
        // A 100 × 100 sheet folded onto itself at 3 mm: every thread count
        // gives the same result.
        let mut rest = Vec::new();
        for a in 0..100 {
            for b in 0..100 {
                rest.push(Vec3::new(a as f32 * 0.01, 0.0, b as f32 * 0.01));
            }
        }
        let folded: Vec<Vec3> =
            rest.iter().map(|p| if p.x > 0.495 { Vec3::new(0.99 - p.x, 0.003, p.z + 0.001) } else { *p }).collect();
        let w = vec![1.0; rest.len()];
        let run = |parallel| {
            let mut sc = SelfContact::new(&rest);
            let mut x = folded.clone();
            sc.apply(&mut x, &folded, &w, &SelfContactStep { thickness: 0.01, friction: 0.3, parallel });
            x
        };
        let (one, many) = (run(false), run(true));
        assert!(one.iter().zip(&many).all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)));
        assert!(one.iter().zip(&folded).any(|(a, b)| a.distance(*b) > 1e-3), "the layers were pushed apart");
    }
}
