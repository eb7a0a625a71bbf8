//! The projection of one bar (the seed's Figure 3), as the reference solver
//! writes it, generalised to compliant bars (XPBD) and over-relaxation.
//!
//! A bar between `x_a` and `x_b` with rest length L is restored by moving its
//! ends along it, each in proportion to its inverse mass w:
//!
//! ```text
//! d = x_b − x_a,  ℓ = |d|,  n = d/ℓ,  C = ℓ − L
//! Δλ = ω · (−C − β λ) / (w_a + w_b + β)          λ ← λ + Δλ
//! x_a ← x_a − w_a Δλ n,   x_b ← x_b + w_b Δλ n
//! ```
//!
//! With β = 0 (rigid bars) and ω = 1 this is the seed's relaxation: two free
//! particles of equal mass move half the correction each, a free particle
//! barred to a fixed one (w = 0) moves the whole of it. β = α m / h² is the
//! bar's compliance α (m/N) made dimensionless by the particle mass and the
//! (sub)step (XPBD: Macklin, Müller & Chentanez 2016, with λ scaled by 1/m);
//! λ accumulates over the passes of one substep, so that after enough passes
//! the bar settles where its spring force C/α balances the load, whatever the
//! number of passes. ω > 1 over-relaxes. A bar of zero length has no
//! direction to correct along and is left as it is; so is a bar between two
//! fixed particles.

use glam::Vec3;

/// The corrections `(Δx_a, Δx_b)` of one rigid projection (β = 0, ω = 1):
/// the seed's Figure 3, `s = C / (ℓ (w_a + w_b))`, `Δx_a = w_a s d`,
/// `Δx_b = −w_b s d`, with a single division.
#[inline(always)]
pub fn project_bar(xa: Vec3, xb: Vec3, rest_length: f32, wa: f32, wb: f32) -> (Vec3, Vec3) {
    let d = xb - xa;
    let len = d.length();
    let w = wa + wb;
    if len == 0.0 || w == 0.0 {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let s = (len - rest_length) / (len * w);
    (d * (s * wa), d * (-s * wb))
}

/// The corrections of one projection of a compliant bar with over-relaxation
/// (the general formula above); updates `lambda`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn project_bar_compliant(
    xa: Vec3,
    xb: Vec3,
    rest_length: f32,
    wa: f32,
    wb: f32,
    beta: f32,
    lambda: &mut f32,
    omega: f32,
) -> (Vec3, Vec3) {
    let d = xb - xa;
    let len = d.length();
    let w = wa + wb;
    if len == 0.0 || w == 0.0 {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let delta = omega * (-(len - rest_length) - beta * *lambda) / (w + beta);
    *lambda += delta;
    let f = delta / len;
    (d * (-wa * f), d * (wb * f))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rigid(xa: Vec3, xb: Vec3, rest: f32, wa: f32, wb: f32) -> (Vec3, Vec3) {
        let plain = project_bar(xa, xb, rest, wa, wb);
        let general = project_bar_compliant(xa, xb, rest, wa, wb, 0.0, &mut 0.0, 1.0);
        assert!((plain.0 - general.0).length() < 1e-6 && (plain.1 - general.1).length() < 1e-6);
        plain
    }

    #[test]
    fn equal_masses_share_the_correction() {
        // A bar of rest 1 stretched to 2 along x: each end moves 0.5 inwards.
        let (da, db) = rigid(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), 1.0, 1.0, 1.0);
        assert_eq!(da, Vec3::new(0.5, 0.0, 0.0));
        assert_eq!(db, Vec3::new(-0.5, 0.0, 0.0));
    }

    #[test]
    fn fixed_end_leaves_the_free_end_all_the_correction() {
        // Compressed to 0.5: the free end b moves out by the whole 0.5.
        let (da, db) = rigid(Vec3::ZERO, Vec3::new(0.0, 0.5, 0.0), 1.0, 0.0, 1.0);
        assert_eq!(da, Vec3::ZERO);
        assert_eq!(db, Vec3::new(0.0, 0.5, 0.0));
    }

    #[test]
    fn zero_length_and_fixed_fixed_bars_are_left_alone() {
        assert_eq!(rigid(Vec3::ONE, Vec3::ONE, 1.0, 1.0, 1.0), (Vec3::ZERO, Vec3::ZERO));
        assert_eq!(rigid(Vec3::ZERO, Vec3::X * 3.0, 1.0, 0.0, 0.0), (Vec3::ZERO, Vec3::ZERO));
    }

    #[test]
    fn compliant_bar_converges_to_its_spring_equilibrium() {
        // A free end hangs from a fixed one and is pulled 1 m past rest each
        // substep (standing in for its load). With β = 1 repeated passes
        // converge to C = −βλ, the fixed point of Δλ = (−C − βλ)/(w + β):
        // the bar holds half the pull, i.e. stops 0.5 m long of rest + 1.
        let (mut xb, mut lambda) = (Vec3::new(0.0, 2.0, 0.0), 0.0f32);
        for _ in 0..200 {
            let (_, db) = project_bar_compliant(Vec3::ZERO, xb, 1.0, 0.0, 1.0, 1.0, &mut lambda, 1.0);
            xb += db;
        }
        assert!((xb.y - 1.5).abs() < 1e-5, "{xb}");
        assert!((lambda + 0.5).abs() < 1e-5, "{lambda}");
    }

    #[test]
    fn over_relaxation_overshoots_by_omega() {
        let (_, db) = project_bar_compliant(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), 1.0, 0.0, 1.0, 0.0, &mut 0.0, 1.5);
        assert_eq!(db, Vec3::new(-1.5, 0.0, 0.0));
    }
}
