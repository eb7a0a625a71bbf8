//! Exact answers the solver is checked against, in f64.
//!
//! - [`verlet_free_fall`]: the discrete solution of equations 1–2 for a
//!   constant force, which the integrator must reproduce to rounding;
//! - [`pendulum_period`]: the period of a simple pendulum at any amplitude;
//! - [`discrete_catenary`]: the rest shape of a chain of equal point masses
//!   joined by equal inextensible links, hanging between two points.

use glam::DVec2;

/// Position after `k ≥ 1` steps of equations 1–2 for one free particle under
/// a constant acceleration: `x₀`, `v₀`, acceleration `a = f/m`, step `h`,
/// damping `δ`. Per axis, with `d_k = x_k − x_{k−1}`:
///
/// ```text
/// d_1 = h v₀                                   (equation 2, no force)
/// d_{k+1} = (1 − δ) d_k + a h²                 (equation 1)
/// x_k = x₀ + Σ_{j=1..k} d_j
/// ```
///
/// which for δ = 0 is `x_k = x₀ + k h v₀ + a h² (k−1) k / 2`.
pub fn verlet_free_fall(x0: f64, v0: f64, a: f64, h: f64, damping: f64, k: u64) -> f64 {
    let mut x = x0;
    let mut d = h * v0;
    for j in 1..=k {
        if j > 1 {
            d = (1.0 - damping) * d + a * h * h;
        }
        x += d;
    }
    x
}

/// The period of a simple pendulum of small-angle period `t0` released from
/// rest at amplitude `theta0` (radians): `T = T₀ / AGM(1, cos(θ₀/2))`.
pub fn pendulum_period(t0: f64, theta0: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (theta0 / 2.0).cos());
    for _ in 0..64 {
        if (a - b).abs() < 1e-16 * a {
            break;
        }
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    t0 / a
}

/// The rest shape of a hanging chain of `links` equal links of length
/// `link_length` between the fixed ends `left` and `right` (gravity along −y),
/// with equal masses at the nodes: `links + 1` node positions from `left` to
/// `right`.
///
/// Each node carries the same weight and the links carry no load across
/// them, so the horizontal tension H is the same in every link and the
/// vertical tension drops by one node's weight at every node. Link k (from
/// node k to k+1) therefore makes an angle φ_k with
///
/// ```text
/// tan φ_k = β (k − c)
/// ```
///
/// with β = m g / H and c fixed by the ends:
/// `Σ ℓ cos φ_k = right.x − left.x` and `Σ ℓ sin φ_k = right.y − left.y`.
/// Both are solved by nested bisection (each sum is monotone in its unknown).
/// Returns `None` if the chain is too short to span the ends, or `links` is 0.
pub fn discrete_catenary(links: usize, link_length: f64, left: DVec2, right: DVec2) -> Option<Vec<DVec2>> {
    let span = right - left;
    if links == 0 || span.x <= 0.0 || span.length() >= links as f64 * link_length {
        return None;
    }
    let angles = |beta: f64, c: f64| (0..links).map(move |k| (beta * (k as f64 - c)).atan());
    let rise = |beta: f64, c: f64| angles(beta, c).map(|p| link_length * p.sin()).sum::<f64>();
    let run = |beta: f64, c: f64| angles(beta, c).map(|p| link_length * p.cos()).sum::<f64>();
    // For a given β, the c that gives the right rise (rise decreases as c grows).
    let c_for = |beta: f64| {
        let (mut lo, mut hi) = (-1e6, 1e6);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if rise(beta, mid) > span.y {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    // The horizontal run shrinks as β (the sag) grows.
    let (mut lo, mut hi) = (1e-12f64, 1e6f64);
    for _ in 0..200 {
        let mid = (lo * hi).sqrt();
        if run(mid, c_for(mid)) > span.x {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let beta = (lo * hi).sqrt();
    let c = c_for(beta);
    let mut nodes = Vec::with_capacity(links + 1);
    let mut p = left;
    nodes.push(p);
    for phi in angles(beta, c) {
        p += link_length * DVec2::new(phi.cos(), phi.sin());
        nodes.push(p);
    }
    Some(nodes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_fall_closed_form() {
        // δ = 0: x_k = x₀ + k h v₀ + a h² (k−1) k / 2.
        let (x0, v0, a, h) = (1.0, 2.0, -9.8, 0.01);
        for k in [1u64, 2, 10, 100] {
            let kf = k as f64;
            let closed = x0 + kf * h * v0 + a * h * h * (kf - 1.0) * kf / 2.0;
            assert!((verlet_free_fall(x0, v0, a, h, 0.0, k) - closed).abs() < 1e-12);
        }
    }

    #[test]
    fn pendulum_period_small_and_large_amplitude() {
        // Known ratios T/T₀: 1.000476 at 5°, 1.017409 at 30°, 1.180341 at 90°.
        for (deg, ratio) in [(5.0f64, 1.000_476), (30.0, 1.017_409), (90.0, 1.180_341)] {
            let r = pendulum_period(1.0, deg.to_radians());
            assert!((r - ratio).abs() < 2e-6, "{deg}°: {r}");
        }
    }

    #[test]
    fn catenary_has_equal_links_and_meets_both_ends() {
        let (l, r) = (DVec2::new(-0.5, 1.0), DVec2::new(0.5, 1.0));
        let nodes = discrete_catenary(20, 0.075, l, r).unwrap();
        assert_eq!(nodes.len(), 21);
        assert!((nodes[20] - r).length() < 1e-9, "{:?}", nodes[20]);
        for w in nodes.windows(2) {
            assert!(((w[1] - w[0]).length() - 0.075).abs() < 1e-12);
        }
        // Equilibrium of every interior node, checked directly: equal node
        // weights w and a constant horizontal tension H mean the slope
        // tan φ of consecutive links grows by the same w/H at every node.
        let slopes: Vec<f64> = nodes.windows(2).map(|w| (w[1].y - w[0].y) / (w[1].x - w[0].x)).collect();
        let step = slopes[1] - slopes[0];
        assert!(step > 0.0, "a hanging chain turns upward: {step}");
        for s in slopes.windows(2) {
            assert!((s[1] - s[0] - step).abs() < 1e-9 * step, "{} vs {step}", s[1] - s[0]);
        }
        // Symmetric ends: the lowest node is the middle one. Its sag is close
        // to the continuous catenary's with the same length: y = a cosh(x/a)
        // with 2a sinh(0.5/a) = 1.5 m, solved here by bisection, sag
        // a (cosh(0.5/a) − 1) ≈ 0.5026 m. Twenty links differ from the curve
        // by O(ℓ²) = O(6e-3) relative; allow 5e-3 m.
        assert!(nodes.iter().all(|n| n.y >= nodes[10].y - 1e-12));
        let (mut lo, mut hi) = (0.01f64, 100.0f64);
        for _ in 0..200 {
            let a = 0.5 * (lo + hi);
            // The length 2a sinh(0.5/a) falls as a grows.
            if 2.0 * a * (0.5 / a).sinh() > 1.5 { lo = a } else { hi = a }
        }
        let a = 0.5 * (lo + hi);
        let continuous = a * ((0.5 / a).cosh() - 1.0);
        let sag = 1.0 - nodes[10].y;
        assert!((continuous - 0.5026).abs() < 1e-4, "continuous sag {continuous}");
        assert!((sag - continuous).abs() < 5e-3, "sag {sag} vs continuous {continuous}");
        assert!(discrete_catenary(20, 0.04, l, r).is_none(), "0.8 m of chain cannot span 1 m");
    }

    #[test]
    fn catenary_with_uneven_ends() {
        let (l, r) = (DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.4));
        let nodes = discrete_catenary(30, 0.05, l, r).unwrap();
        assert!((nodes[30] - r).length() < 1e-9, "{:?}", nodes[30]);
    }
}
