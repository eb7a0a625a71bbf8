//! How far the cloth is from what the relaxation aims at, and how much it moves.
//!
//! ```text
//! strain of a bar      ε = | |x_b − x_a| − L | / L          (L its rest length)
//! max strain           max ε over the bars
//! RMS strain           sqrt( Σ ε² / bars )
//! velocity             v = (x_i − x_{i−1}) / h              (what equation 1 carries)
//! kinetic energy       E_k = Σ ½ m |v|²                      over free particles
//! potential energy     E_p = −Σ f_g · x                      over free particles
//! ```
//!
//! All are O(particles + bars) and cheap enough for every displayed frame.
//!
//! Errors against an exact or converged answer, for the accuracy benchmark:
//!
//! ```text
//! static error     max_i |x_i − x*_i| / L       (x* the exact rest shape, L the chain's length)
//! dynamic error    sqrt( Σ |x_i − x°_i|² / n ) / D   (x° a converged run, D the cloth's diagonal)
//! ```

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::mesh::Bar;

/// Maximum and RMS relative strain over a set of bars.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Strain {
    /// Largest `|len − rest| / rest` over the bars; 0 when there are none.
    pub max: f32,
    /// Root mean square of `|len − rest| / rest`; 0 when there are none.
    pub rms: f32,
}

/// The strain of the bars that can move (not both ends in `fixed`; pass
/// an empty slice to count every bar) at `positions`. Sums in f64 so that
/// the RMS of a million bars is exact to f32 precision.
pub fn strain(positions: &[Vec3], bars: &[Bar], fixed: &[bool]) -> Strain {
    let mut max = 0.0f32;
    let mut sum_sq = 0.0f64;
    let mut count = 0usize;
    let is_fixed = |i: u32| fixed.get(i as usize).copied().unwrap_or(false);
    for bar in bars {
        if is_fixed(bar.a) && is_fixed(bar.b) {
            continue;
        }
        let len = positions[bar.a as usize].distance(positions[bar.b as usize]);
        let e = (len - bar.rest_length).abs() / bar.rest_length;
        max = max.max(e);
        sum_sq += f64::from(e) * f64::from(e);
        count += 1;
    }
    if count == 0 {
        return Strain::default();
    }
    Strain { max, rms: (sum_sq / count as f64).sqrt() as f32 }
}

/// Kinetic energy `Σ ½ m_i |(x − x_prev)/h|²` over the particles not fixed,
/// joules (`masses` in kg, one per particle).
pub fn kinetic_energy(positions: &[Vec3], previous: &[Vec3], fixed: &[bool], masses: &[f32], dt: f32) -> f64 {
    let sum: f64 = positions
        .iter()
        .zip(previous)
        .zip(fixed)
        .zip(masses)
        .filter(|&((_, &f), _)| !f)
        .map(|(((&x, &p), _), &m)| f64::from(m) * f64::from((x - p).length_squared()))
        .sum();
    0.5 * sum / (f64::from(dt) * f64::from(dt))
}

/// Potential energy of a uniform acceleration field `−Σ m_i g · x` over the
/// particles not fixed, joules (gravity's, `g` in m/s², `masses` in kg).
pub fn potential_energy(positions: &[Vec3], fixed: &[bool], masses: &[f32], g: Vec3) -> f64 {
    let g = g.as_dvec3();
    positions
        .iter()
        .zip(fixed)
        .zip(masses)
        .filter(|&((_, &f), _)| !f)
        .map(|((&x, _), &m)| -f64::from(m) * g.dot(x.as_dvec3()))
        .sum()
}

/// Largest distance between matching points divided by `length`: the static
/// error of a chain against its exact rest shape (points in the x–y plane).
pub fn max_distance_error(positions: &[Vec3], exact: &[glam::DVec2], length: f64) -> f64 {
    positions
        .iter()
        .zip(exact)
        .map(|(p, e)| (glam::DVec2::new(f64::from(p.x), f64::from(p.y)) - *e).length())
        .fold(0.0, f64::max)
        / length
}

/// RMS distance between two states of the same cloth divided by `size`: the
/// dynamic error of a run against a converged one.
pub fn rms_distance_error(positions: &[Vec3], converged: &[Vec3], size: f64) -> f64 {
    if positions.is_empty() {
        return 0.0;
    }
    let sum: f64 = positions.iter().zip(converged).map(|(a, b)| f64::from(a.distance_squared(*b))).sum();
    (sum / positions.len() as f64).sqrt() / size
}

/// Strain over a run: the worst step's max, and the means over the steps of
/// each step's max and RMS.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StrainHistory {
    /// Largest max strain of any recorded step.
    pub worst_max: f32,
    /// Sum of the recorded steps' max strain.
    pub max_sum: f64,
    /// Sum of the recorded steps' RMS strain.
    pub rms_sum: f64,
    /// Steps recorded.
    pub steps: u64,
}

impl StrainHistory {
    /// Adds one step's strain.
    pub fn record(&mut self, s: Strain) {
        self.worst_max = self.worst_max.max(s.max);
        self.max_sum += f64::from(s.max);
        self.rms_sum += f64::from(s.rms);
        self.steps += 1;
    }
    /// Mean over the recorded steps of each step's max strain (0 before any).
    pub fn mean_max(&self) -> f64 {
        if self.steps == 0 { 0.0 } else { self.max_sum / self.steps as f64 }
    }
    /// Mean RMS strain over the recorded steps (0 before any).
    pub fn mean_rms(&self) -> f64 {
        if self.steps == 0 { 0.0 } else { self.rms_sum / self.steps as f64 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::mesh::BarKind;

    #[test]
    fn strain_of_a_stretched_and_a_compressed_bar() {
        let positions = [Vec3::ZERO, Vec3::new(1.1, 0.0, 0.0), Vec3::new(1.1, 0.8, 0.0)];
        let bars = [
            Bar { a: 0, b: 1, rest_length: 1.0, kind: BarKind::Structural }, // 10 % long
            Bar { a: 1, b: 2, rest_length: 1.0, kind: BarKind::Structural }, // 20 % short
        ];
        let s = strain(&positions, &bars, &[]);
        assert!((s.max - 0.2).abs() < 1e-6, "{s:?}");
        // sqrt((0.1² + 0.2²)/2) = sqrt(0.025) = 0.158114
        assert!((s.rms - 0.158_114).abs() < 1e-5, "{s:?}");
        assert_eq!(strain(&positions, &[], &[]), Strain::default());
    }

    #[test]
    fn error_measures() {
        let exact = [glam::DVec2::new(0.0, 0.0), glam::DVec2::new(1.0, 0.0)];
        let positions = [Vec3::new(0.0, 0.3, 5.0), Vec3::new(1.0, -0.4, 0.0)];
        // The larger of 0.3 and 0.4, over a length of 2; z is ignored.
        assert!((max_distance_error(&positions, &exact, 2.0) - 0.2).abs() < 1e-7);
        let moved = [Vec3::new(0.0, 0.3, 0.0), Vec3::new(1.0, 0.0, 0.4)];
        // sqrt((0.09 + 0.16) / 2) / 1 = 0.353553
        let e = rms_distance_error(&[Vec3::ZERO, Vec3::X], &moved, 1.0);
        assert!((e - 0.353_553).abs() < 1e-6, "{e}");
        let mut h = StrainHistory::default();
        h.record(Strain { max: 0.1, rms: 0.02 });
        h.record(Strain { max: 0.3, rms: 0.04 });
        assert_eq!(h.worst_max, 0.3);
        assert!((h.mean_max() - 0.2).abs() < 1e-7);
        assert!((h.mean_rms() - 0.03).abs() < 1e-9);
    }

    #[test]
    fn kinetic_energy_skips_fixed_particles() {
        // Particle 0 moved 0.1 m in h = 0.05 s → v = 2 m/s → ½·0.2·4 = 0.4 J.
        let x = [Vec3::new(0.1, 0.0, 0.0), Vec3::new(5.0, 0.0, 0.0)];
        let p = [Vec3::ZERO, Vec3::ZERO];
        let e = kinetic_energy(&x, &p, &[false, true], &[0.2, 0.2], 0.05);
        assert!((e - 0.4).abs() < 1e-6, "{e}");
    }

    #[test]
    fn potential_energy_of_gravity_is_weight_times_height() {
        // 0.5 kg at 2 m under 9.8 m/s²: 9.8 J.
        let e = potential_energy(&[Vec3::new(0.0, 2.0, 0.0)], &[false], &[0.5], Vec3::new(0.0, -9.8, 0.0));
        assert!((e - 9.8).abs() < 1e-5, "{e}");
    }
}
