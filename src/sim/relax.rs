//! The projection of one bar (the seed's Figure 3), shared by every solver.
//!
//! A bar between `x_a` and `x_b` with rest length L is restored by moving its
//! ends along the bar, each in proportion to its inverse mass w:
//!
//! ```text
//! d   = x_b − x_a,   ℓ = |d|
//! s   = (ℓ − L) / (ℓ · (w_a + w_b))
//! x_a ← x_a + w_a · s · d
//! x_b ← x_b − w_b · s · d
//! ```
//!
//! Two free particles of equal mass move half the correction each; a free
//! particle barred to a fixed one (w = 0) moves the whole of it. A bar of zero
//! length has no direction to correct along and is left as it is; so is a bar
//! whose ends are both fixed.

use glam::Vec3;

/// The corrections `(Δx_a, Δx_b)` that restore a bar's rest length.
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_masses_share_the_correction() {
        // A bar of rest 1 stretched to 2 along x: each end moves 0.5 inwards.
        let (da, db) = project_bar(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), 1.0, 5.0, 5.0);
        assert_eq!(da, Vec3::new(0.5, 0.0, 0.0));
        assert_eq!(db, Vec3::new(-0.5, 0.0, 0.0));
    }

    #[test]
    fn fixed_end_leaves_the_free_end_all_the_correction() {
        // Compressed to 0.5: the free end b moves out by the whole 0.5.
        let (da, db) = project_bar(Vec3::ZERO, Vec3::new(0.0, 0.5, 0.0), 1.0, 0.0, 5.0);
        assert_eq!(da, Vec3::ZERO);
        assert_eq!(db, Vec3::new(0.0, 0.5, 0.0));
    }

    #[test]
    fn zero_length_and_fixed_fixed_bars_are_left_alone() {
        assert_eq!(project_bar(Vec3::ONE, Vec3::ONE, 1.0, 1.0, 1.0), (Vec3::ZERO, Vec3::ZERO));
        assert_eq!(project_bar(Vec3::ZERO, Vec3::X * 3.0, 1.0, 0.0, 0.0), (Vec3::ZERO, Vec3::ZERO));
    }
}
