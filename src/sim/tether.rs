//! Long-range attachments ("tethers", Kim, Chentanez & Müller 2012).
//!
//! Relaxation passes move a correction one bar per pass, so a cloth hanging
//! from its top row stretches down its length unless the passes are many.
//! A tether bounds that stretch directly: every free particle may be no
//! farther from its attachment — the fixed particle nearest to it along the
//! bars — than the length of that path in the rest state (times 1 + slack):
//!
//! ```text
//! |x_i − x_anchor(i)| ≤ (1 + slack) · L_i,   L_i = shortest rest path from anchor(i) to i
//! ```
//!
//! The constraint is one-sided (only too far is corrected), moves the free
//! particle only, and costs one pass over the particles per substep. In the
//! rest state every particle satisfies it, since a straight line is never
//! longer than a path along bars. L_i comes from Dijkstra's algorithm started
//! from every fixed particle at once.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::Vec3;

use super::mesh::Bar;

/// Each particle's attachment: the nearest fixed particle along the bars and
/// the rest length of that path. Fixed particles and particles with no path to
/// a fixed one have none.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tethers {
    /// `anchor[i]`: the fixed particle particle i is tied to, or `None`.
    pub anchor: Vec<Option<u32>>,
    /// `length[i]`: the rest path length to it, metres (0 without anchor).
    pub length: Vec<f32>,
}

/// `x` put back onto the sphere of radius `reach` around `anchor` if it is
/// outside it (the one-sided constraint above), else `x` unchanged.
#[inline]
pub fn pull_within(x: Vec3, anchor: Vec3, reach: f32) -> Vec3 {
    let d = x - anchor;
    let len = d.length();
    if len > reach { anchor + d * (reach / len) } else { x }
}

/// f64 distances ordered for the heap.
#[derive(Clone, Copy, PartialEq)]
struct Distance(f64);
impl Eq for Distance {}
impl PartialOrd for Distance {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Distance {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

impl Tethers {
    /// Attachments for `particles` particles joined by `bars`, with `fixed`
    /// the fixed flags. Ties between equally near fixed particles go to the
    /// lower index, so the result is deterministic.
    pub fn new(particles: usize, bars: &[Bar], fixed: &[bool]) -> Self {
        let mut neighbours: Vec<Vec<(u32, f32)>> = vec![Vec::new(); particles];
        for bar in bars {
            neighbours[bar.a as usize].push((bar.b, bar.rest_length));
            neighbours[bar.b as usize].push((bar.a, bar.rest_length));
        }
        let mut best: Vec<(f64, u32)> = vec![(f64::INFINITY, u32::MAX); particles];
        let mut heap = BinaryHeap::new();
        for (i, _) in fixed.iter().enumerate().filter(|(_, f)| **f) {
            best[i] = (0.0, i as u32);
            heap.push(Reverse((Distance(0.0), i as u32, i as u32)));
        }
        while let Some(Reverse((Distance(d), anchor, i))) = heap.pop() {
            if (d, anchor) > best[i as usize] {
                continue;
            }
            for &(j, l) in &neighbours[i as usize] {
                let candidate = (d + f64::from(l), anchor);
                if candidate < best[j as usize] {
                    best[j as usize] = candidate;
                    heap.push(Reverse((Distance(candidate.0), anchor, j)));
                }
            }
        }
        let mut anchor = Vec::with_capacity(particles);
        let mut length = Vec::with_capacity(particles);
        for (i, &(d, a)) in best.iter().enumerate() {
            let tied = !fixed[i] && d.is_finite();
            anchor.push(tied.then_some(a));
            length.push(if tied { d as f32 } else { 0.0 });
        }
        Tethers { anchor, length }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::mesh::{Grid, Pins};

    #[test]
    fn a_hanging_grid_is_tied_straight_up() {
        // 3 × 4 grid, spacing 1, top row fixed: particle (c, r) hangs r bars
        // below (c, 0), and no path through the pins is shorter.
        let mesh = Grid { columns: 3, rows: 4, spacing: 1.0, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
        let t = Tethers::new(12, mesh.bars(), mesh.fixed());
        for r in 1..4u32 {
            for c in 0..3u32 {
                let i = (r * 3 + c) as usize;
                assert_eq!(t.anchor[i], Some(c), "particle ({c}, {r})");
                assert!((t.length[i] - r as f32).abs() < 1e-6, "particle ({c}, {r}): {}", t.length[i]);
            }
        }
        assert_eq!(t.anchor[0], None, "fixed particles have no tether");
    }

    #[test]
    fn unreachable_particles_are_untied() {
        let mesh = Grid { columns: 3, rows: 3, spacing: 1.0, pins: Pins::None, ..Grid::default() }.build().unwrap();
        let t = Tethers::new(9, mesh.bars(), mesh.fixed());
        assert!(t.anchor.iter().all(Option::is_none));
    }
}
