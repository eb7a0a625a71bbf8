//! The collide phase eight particles at a time, for the grid solver's
//! tiles and the coloured layout's chunks.
//!
//! - **Filter** (`may_touch_lanes`): which of eight particles a collider may
//!   move: the broad phase's box test lane by lane, and for a sphere that
//!   stands still, the particles in its box whose path stays clear of the
//!   ball itself (a draped cloth hangs around the ball inside its box).
//! - **Narrow phase** (`resolve_lanes`): [`ContactStep::resolve`] for the
//!   lanes the filter kept, collider by collider in the same order. A still
//!   sphere, handled around its centre in world axes (mod.rs), runs steps 1
//!   to 3 of the module docs in lanes (step 1, the ray cast, where a lane's
//!   path is at least as long as its distance to the ball): every lane does
//!   the operations of the one-particle code in its order, so it gets the
//!   same bits. Lanes of other colliders go one particle at a time.

use glam::Vec3;

use super::{ContactStep, Still};
use crate::sim::fast::kernel::{F32x8, LANES, Point, Real, axes, dot, lane, scale, sub};

/// `Shape::proximity` of a ball of `radius` about the origin, for eight
/// points ℓ: φ = |ℓ| − radius and n = ℓ/|ℓ| (+y at the centre).
#[inline(always)]
fn ball_proximity(l: &Point<F32x8>, radius: f32) -> (F32x8, Point<F32x8>) {
    let (zero, up) = (F32x8::splat(0.0), [F32x8::splat(0.0), F32x8::splat(1.0), F32x8::splat(0.0)]);
    let length = dot(*l, *l).sqrt();
    let normal: Point<F32x8> = axes(|i| F32x8::if_greater(length, zero, l[i] / length, up[i]));
    (length - F32x8::splat(radius), normal)
}

impl ContactStep<'_> {
    /// Which of eight particles, moving from `x0` to `x` (lanes), collider
    /// `k` may move, as a bit mask (bit l: lane l). Conservative: a clear
    /// bit is a particle that [`Self::resolve`] leaves exactly where it is.
    ///
    /// [`Self::may_touch`] on each lane's box of `x0` and `x` (the test
    /// `resolve` makes); and for a sphere that stands still, the particles
    /// in its box but clear of it: farther than r from the surface and
    /// farther from it than the path is long (so neither the ray cast nor
    /// the push can act), each by a margin of 10⁻⁴ of the distance to the
    /// centre, far above the rounding (a few ulps) of the same distances as
    /// `resolve` computes them.
    #[inline(always)]
    pub(crate) fn may_touch_lanes(&self, k: usize, x0: &Point<F32x8>, x: &Point<F32x8>) -> u8 {
        let boxed = self.boxed_lanes(k, u8::MAX, x0, x);
        match self.colliders[k].still {
            Some(Still::Ball { centre, radius }) if boxed != 0 => boxed & !self.clear_of_ball(centre, radius, x0, x),
            _ => boxed,
        }
    }

    /// The lanes of `lanes` whose box of `x0` and `x` collider `k` may
    /// touch: [`Self::may_touch`], the test `resolve` makes, in lanes (the
    /// same comparisons of the same values: `f32::min` and `max` as
    /// `Vec3::min` and `max`, the plane's distance in `Vec3::dot`'s order).
    /// One lane at a time, it was 4 % of a draped 256 × 256 cloth's step.
    #[inline(always)]
    fn boxed_lanes(&self, k: usize, lanes: u8, x0: &Point<F32x8>, x: &Point<F32x8>) -> u8 {
        let lo: Point<F32x8> = axes(|i| F32x8(std::array::from_fn(|l| x0[i].0[l].min(x[i].0[l]))));
        let hi: Point<F32x8> = axes(|i| F32x8(std::array::from_fn(|l| x0[i].0[l].max(x[i].0[l]))));
        let c = &self.colliders[k];
        let mut touching = 0u8;
        match (c.bounds, c.plane) {
            (Some((b0, b1)), _) => {
                let (b0, b1) = (b0.to_array(), b1.to_array());
                for l in 0..LANES {
                    let below = lo[0].0[l] <= b1[0] && lo[1].0[l] <= b1[1] && lo[2].0[l] <= b1[2];
                    let above = hi[0].0[l] >= b0[0] && hi[1].0[l] >= b0[1] && hi[2].0[l] >= b0[2];
                    touching |= u8::from(below && above) << l;
                }
            }
            (None, Some(plane)) => {
                for (n, point) in plane {
                    // The box corner deepest on the plane's closed side.
                    let corner: Point<F32x8> = axes(|i| if n[i] >= 0.0 { lo[i] } else { hi[i] });
                    let offset = sub(corner, point.to_array().map(F32x8::splat));
                    let distance = dot(offset, n.to_array().map(F32x8::splat));
                    for l in 0..LANES {
                        touching |= u8::from(distance.0[l] < self.thickness) << l;
                    }
                }
            }
            (None, None) => touching = u8::MAX,
        }
        touching & lanes
    }

    /// The lanes whose path `x0 → x` stays clear of a still sphere (see
    /// [`Self::may_touch_lanes`]), as a bit mask.
    #[inline(always)]
    fn clear_of_ball(&self, centre: Vec3, radius: f32, x0: &Point<F32x8>, x: &Point<F32x8>) -> u8 {
        let offset = sub(*x, centre.to_array().map(F32x8::splat));
        let path = sub(*x, *x0);
        let (distance, path) = (dot(offset, offset).sqrt(), dot(path, path).sqrt());
        (0..LANES).fold(0u8, |m, l| {
            let (d, p) = (distance.0[l], path.0[l]);
            let margin = 1e-4 * d;
            let gap = d - radius;
            let clear = gap - self.thickness > margin && gap - p > margin;
            m | (u8::from(clear) << l)
        })
    }

    /// The collide phase for eight particles moving from `x0` to `x`, all
    /// inside the box `lo..hi` whose colliders are `near`: the lanes the
    /// filter keeps ([`Self::may_touch_lanes`]) among those `moving` gives
    /// (asked only when the filter keeps one) are resolved
    /// ([`Self::resolve_lanes`]). Returns the lanes resolved.
    #[inline(always)]
    pub(crate) fn collide_lanes(
        &self,
        near: &[usize],
        bounds: (Vec3, Vec3),
        moving: impl FnOnce() -> u8,
        x0: &Point<F32x8>,
        x: &mut Point<F32x8>,
    ) -> u8 {
        // A loop, not `Iterator::fold`: the fold was left out of line,
        // where it lacks the caller's CPU features (its lanes ran as SSE,
        // 4 % of a draped 256 × 256 cloth's step).
        let mut touching = 0u8;
        for &k in near {
            touching |= self.may_touch_lanes(k, x0, x);
        }
        let lanes = if touching == 0 { 0 } else { touching & moving() };
        if lanes != 0 {
            self.resolve_lanes(near, bounds, lanes, x0, x);
        }
        lanes
    }

    /// [`Self::resolve`] against every collider for the lanes set in
    /// `lanes` of eight particles moving from `x0` to `x`, all inside the
    /// box `lo..hi` whose colliders are `near` ([`Self::near`]): the same
    /// bits, lane by lane (module docs). A lane that a push takes out of
    /// the box (where a collider off it might touch, as a larger box than
    /// the particle's own touches more) is resolved again from its start
    /// against every collider.
    #[inline(always)]
    pub(crate) fn resolve_lanes(
        &self,
        near: &[usize],
        (lo, hi): (Vec3, Vec3),
        lanes: u8,
        x0: &Point<F32x8>,
        x: &mut Point<F32x8>,
    ) {
        let start = *x;
        let (lo, hi) = (lo.to_array(), hi.to_array());
        let mut escaped = 0u8;
        for &k in near {
            let boxed = self.boxed_lanes(k, lanes & !escaped, x0, x);
            if boxed == 0 {
                continue;
            }
            match self.colliders[k].still {
                Some(still) => self.resolve_still(k, still, boxed, x0, x),
                None => {
                    for l in (0..LANES).filter(|l| boxed & (1 << l) != 0) {
                        let out = self.resolve_one(k, lane(x0, l), lane(x, l));
                        for (axis, value) in x.iter_mut().zip(out.to_array()) {
                            axis.0[l] = value;
                        }
                    }
                }
            }
            let mut outside = 0u8;
            for l in 0..LANES {
                let mut inside = true;
                for i in 0..3 {
                    inside &= x[i].0[l] >= lo[i] && x[i].0[l] <= hi[i];
                }
                outside |= u8::from(!inside) << l;
            }
            escaped |= outside & boxed;
        }
        if escaped != 0 {
            let all = self.all();
            for l in (0..LANES).filter(|l| escaped & (1 << l) != 0) {
                let out = self.resolve(&all, lane(x0, l), lane(&start, l));
                for (axis, value) in x.iter_mut().zip(out.to_array()) {
                    axis.0[l] = value;
                }
            }
        }
    }

    /// Steps 1 to 3 against the still collider `k` for the lanes in
    /// `lanes`, written in the order of `resolve_one` (and of
    /// `Shape::entry` and `Shape::proximity` for a ball), so every lane gets
    /// the bits `resolve_one` gives it.
    #[inline(always)]
    fn resolve_still(&self, k: usize, still: Still, lanes: u8, x0: &Point<F32x8>, x: &mut Point<F32x8>) {
        let zero = F32x8::splat(0.0);
        let thickness = F32x8::splat(self.thickness);
        let c = still.origin().to_array().map(F32x8::splat);
        let (l0, mut l) = (sub(*x0, c), sub(*x, c));
        // Proximity: φ and n at ℓ.
        let up = [zero, F32x8::splat(1.0), zero];
        let (mut distance, mut normal) = match still {
            Still::Ball { radius, .. } => ball_proximity(&l, radius),
            Still::Plane { normal, .. } => {
                let normal = normal.to_array().map(F32x8::splat);
                (dot(l, normal), normal)
            }
        };
        // D (the depth pushed) and the last push's normal, where one acted.
        let (mut depth, mut pushed_along) = (zero, normal);
        let mut pushed = 0u8;
        // Step 1 (a ball only: a half-space cannot be jumped), where the end
        // is no farther from the ball than the path is long: the ray cast of
        // `Shape::entry`, from ℓ0 along the unit path u, t = −b − √h with
        // b = ℓ0·u, h = b² − (|ℓ0|² − r²), entering when ℓ0 is outside
        // (|ℓ0|² > r²), the ray heads in (b < 0), meets the ball (h ≥ 0) and
        // within the path (t ≤ |path|).
        if let Still::Ball { radius, .. } = still {
            let path = sub(l, l0);
            let length = dot(path, path).sqrt();
            let candidates = (0..LANES).fold(0u8, |m, i| m | (u8::from(distance.0[i] <= length.0[i]) << i)) & lanes;
            if candidates != 0 {
                let unit: Point<F32x8> = axes(|i| path[i] / length);
                let outside = dot(l0, l0) - F32x8::splat(radius * radius);
                let b = dot(l0, unit);
                let h = b * b - outside;
                let t = -b - h.sqrt();
                let point: Point<F32x8> = axes(|i| l0[i] + unit[i] * t);
                // `normalize_or(+y)`: times 1/|p| where that is finite and > 0.
                let reciprocal = F32x8::splat(1.0) / dot(point, point).sqrt();
                let finite = F32x8(std::array::from_fn(|i| {
                    let r = reciprocal.0[i];
                    if r > 0.0 && r < f32::INFINITY { 1.0 } else { 0.0 }
                }));
                let entry_normal: Point<F32x8> =
                    axes(|i| F32x8::if_greater(finite, zero, point[i] * reciprocal, up[i]));
                let push = thickness - dot(sub(l, point), entry_normal);
                let mut entered = 0u8;
                for i in 0..LANES {
                    let hits =
                        outside.0[i] > 0.0 && b.0[i] < 0.0 && h.0[i] >= 0.0 && t.0[i] <= length.0[i] && push.0[i] > 0.0;
                    entered |= u8::from(hits) << i;
                }
                entered &= candidates;
                if entered != 0 {
                    let on = F32x8(std::array::from_fn(|i| if entered & (1 << i) != 0 { 1.0 } else { 0.0 }));
                    let pick = |then: F32x8, otherwise: F32x8| F32x8::if_greater(on, zero, then, otherwise);
                    l = axes(|i| pick(l[i] + entry_normal[i] * push, l[i]));
                    depth = pick(push, depth);
                    pushed_along = axes(|i| pick(entry_normal[i], pushed_along[i]));
                    let (after, after_normal) = ball_proximity(&l, radius);
                    distance = pick(after, distance);
                    normal = axes(|i| pick(after_normal[i], normal[i]));
                    pushed = entered;
                }
            }
        }
        // Step 2: within the thickness of the surface, out along the normal.
        let push = thickness - distance;
        let mut within = 0u8;
        for i in 0..LANES {
            within |= u8::from(push.0[i] > 0.0) << i;
        }
        l = axes(|i| F32x8::if_greater(push, zero, l[i] + normal[i] * push, l[i]));
        depth = F32x8::if_greater(push, zero, depth + push, depth);
        pushed_along = axes(|i| F32x8::if_greater(push, zero, normal[i], pushed_along[i]));
        pushed |= within;
        // Step 3 with D and the last push's normal n.
        let n = pushed_along;
        let motion = sub(l, l0);
        let tangential = sub(motion, scale(n, dot(motion, n)));
        let slide = dot(tangential, tangential).sqrt();
        let bound = F32x8::splat(self.colliders[k].friction) * depth;
        // |Δ_t| ≤ μD: all of Δ_t; otherwise Δ_t · μD/|Δ_t| (|Δ_t| > μD ≥ 0).
        let kinetic = bound / slide;
        let removed: Point<F32x8> = axes(|i| F32x8::if_greater(slide, bound, tangential[i] * kinetic, tangential[i]));
        let out: Point<F32x8> = axes(|i| (l[i] - removed[i]) + c[i]);
        // Lanes not pushed come out where they went in, as in `resolve_one`.
        let take = lanes & pushed;
        for i in (0..LANES).filter(|i| take & (1 << i) != 0) {
            for (axis, value) in x.iter_mut().zip(&out) {
                axis.0[i] = value.0[i];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::collider::{Collider, Pose, Shape};

    #[test]
    fn the_lanes_filter_clears_only_particles_resolve_leaves_alone() {
        // A still sphere (r 0.5 at (0, 0.6, 0)), a tilted ground, and a
        // sphere moving over the substep; 4000 particles on short and long
        // paths around them, eight at a time. A clear lane must come out of
        // `resolve` bit for bit where it went in; the box part of the filter
        // must agree with `may_touch` exactly; and the sphere test must clear
        // many particles inside the sphere's box (or it proves nothing).
        let tilted = Pose { rotation: glam::Quat::from_rotation_z(0.2), translation: Vec3::new(0.0, -0.1, 0.0) };
        let mut moving = Collider::fixed(Shape::Sphere { radius: 0.3 }, Pose::default());
        moving.pose.translation = Vec3::new(0.9, 0.2, 0.0);
        moving.motion =
            crate::sim::collider::Motion::Moving { velocity: Vec3::new(0.0, 1.0, 0.0), angular_velocity: Vec3::ZERO };
        let colliders = vec![
            Collider::fixed(
                Shape::Sphere { radius: 0.5 },
                Pose { translation: Vec3::new(0.0, 0.6, 0.0), ..Pose::default() },
            ),
            Collider::fixed(Shape::Plane { normal: Vec3::Y }, tilted),
            moving,
        ];
        let step = ContactStep::new(&colliders, 0.01, 0.3, 0.0, 0.01);
        let all = step.all();
        let mut state = 7u32;
        let mut random = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let (mut cleared_in_box, mut moved) = (0, 0);
        for group in 0..500 {
            let reach = if group % 2 == 0 { 0.02 } else { 0.4 };
            let pairs: [(Vec3, Vec3); LANES] = std::array::from_fn(|_| {
                let x = Vec3::new(random() * 2.4, 0.6 + random() * 2.4, random() * 2.4);
                (x + Vec3::new(random(), random(), random()) * reach, x)
            });
            let lanes = |pick: fn(&(Vec3, Vec3)) -> Vec3| -> Point<F32x8> {
                std::array::from_fn(|i| F32x8(std::array::from_fn(|l| pick(&pairs[l])[i])))
            };
            let (x0, x) = (lanes(|p| p.0), lanes(|p| p.1));
            let masks: Vec<u8> = (0..colliders.len()).map(|k| step.may_touch_lanes(k, &x0, &x)).collect();
            for (l, &(a, b)) in pairs.iter().enumerate() {
                let out = step.resolve(&all, a, b);
                moved += usize::from(out != b);
                if masks.iter().all(|m| m & (1 << l) == 0) {
                    assert_eq!(out.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits), "{a} -> {b}");
                }
                for k in [1, 2] {
                    assert_eq!(masks[k] & (1 << l) != 0, step.may_touch(k, a.min(b), a.max(b)), "collider {k}");
                }
                let boxed = step.may_touch(0, a.min(b), a.max(b));
                cleared_in_box += usize::from(boxed && masks[0] & (1 << l) == 0);
                assert!(boxed || masks[0] & (1 << l) == 0);
            }
        }
        assert!(cleared_in_box > 50, "{cleared_in_box} cleared inside the still sphere's box");
        assert!(moved > 200, "{moved} particles moved by contact");
    }

    #[test]
    fn the_lanes_narrow_phase_gives_each_particle_the_bits_of_resolve() {
        // A still sphere (turned, so its rotation really is left out), a
        // tilted ground and a moving sphere; 4000 particles, eight at a time,
        // resting on or near the still ball or the ground (paths of 0.1 to
        // 6 mm), pressed into them, and fast (paths up to 0.3 m, which take
        // the ray cast against the ball).
        // `resolve_lanes` must give every lane the bits `resolve` gives it,
        // and the ball's lanes must really run in lanes, with paths entering
        // the ball, pushes and both kinds of friction among them (or the test
        // proves nothing).
        let turned = Pose { rotation: glam::Quat::from_rotation_x(0.7), translation: Vec3::new(0.0, 0.6, 0.0) };
        let tilted = Pose { rotation: glam::Quat::from_rotation_z(0.2), translation: Vec3::new(0.0, -0.1, 0.0) };
        let mut moving = Collider::fixed(Shape::Sphere { radius: 0.3 }, Pose::default());
        moving.pose.translation = Vec3::new(0.6, 0.4, 0.0);
        moving.motion =
            crate::sim::collider::Motion::Moving { velocity: Vec3::new(0.0, 1.0, 0.0), angular_velocity: Vec3::ZERO };
        let colliders = vec![
            Collider::fixed(Shape::Sphere { radius: 0.5 }, turned),
            Collider::fixed(Shape::Plane { normal: Vec3::Y }, tilted),
            moving,
        ];
        let step = ContactStep::new(&colliders, 0.01, 0.3, 0.0, 0.01);
        let all = step.all();
        let mut state = 11u32;
        let mut random = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let (mut in_lanes, mut entered) = (0u32, 0u32);
        let (mut pushed, mut sticking, mut sliding, mut plane_moved) = (0, 0, 0, 0);
        for group in 0..500 {
            let reach = [0.0002, 0.006, 0.3][group % 3];
            let on_plane = group % 2 == 1;
            let pairs: [(Vec3, Vec3); LANES] = std::array::from_fn(|_| {
                let height = 0.025 * (random() + 0.3);
                let x = if on_plane {
                    // In a band from 5 mm under the tilted ground to 2 cm over
                    // it, away from the balls.
                    let (u, v) = (tilted.rotation * Vec3::X, tilted.rotation * Vec3::Z);
                    let n = tilted.rotation * Vec3::Y;
                    tilted.translation + u * (-1.5 + random()) + v * 2.0 * random() + n * height
                } else {
                    // On a shell from 5 mm inside the ball to 2 cm outside it.
                    let direction = Vec3::new(random(), random(), random()).normalize_or(Vec3::Y);
                    Vec3::new(0.0, 0.6, 0.0) + direction * (0.5 + height)
                };
                (x + Vec3::new(random(), random(), random()) * reach, x)
            });
            let points = |pick: fn(&(Vec3, Vec3)) -> Vec3| -> Point<F32x8> {
                std::array::from_fn(|i| F32x8(std::array::from_fn(|l| pick(&pairs[l])[i])))
            };
            let (x0, mut x) = (points(|p| p.0), points(|p| p.1));
            let lanes = 0b1011_1111; // one lane left out: it must not move
            let mut ball = x;
            let boxed = step.boxed_lanes(0, lanes, &x0, &x);
            let still = step.colliders[0].still.expect("a still ball");
            step.resolve_still(0, still, boxed, &x0, &mut ball);
            in_lanes += boxed.count_ones();
            // The lanes whose path entered the ball: step 1's ray cast acts.
            let centre = Vec3::new(0.0, 0.6, 0.0);
            let shape = &step.colliders[0].shape;
            for (l, &(a, b)) in pairs.iter().enumerate() {
                if boxed & (1 << l) == 0 {
                    continue;
                }
                let (l0, l1) = (a - centre, b - centre);
                let entry = shape.entry(l0, l1).filter(|e| step.thickness > (l1 - e.point).dot(e.normal));
                entered += u32::from(entry.is_some());
            }
            step.resolve_lanes(&all, (Vec3::NEG_INFINITY, Vec3::INFINITY), lanes, &x0, &mut x);
            if on_plane {
                plane_moved += (0..LANES).filter(|&l| lane(&x, l) != pairs[l].1).count();
            }
            for (l, &(a, b)) in pairs.iter().enumerate() {
                let expected = if lanes & (1 << l) != 0 { step.resolve(&all, a, b) } else { b };
                assert_eq!(
                    lane(&x, l).to_array().map(f32::to_bits),
                    expected.to_array().map(f32::to_bits),
                    "{a} -> {b}"
                );
                if boxed & (1 << l) != 0 && lane(&ball, l) != b {
                    pushed += 1;
                    // Friction stuck it (no tangential motion left) or let it slide.
                    let n = (lane(&ball, l) - centre).normalize();
                    let motion = lane(&ball, l) - a;
                    if (motion - n * motion.dot(n)).length() < 1e-6 { sticking += 1 } else { sliding += 1 }
                }
            }
        }
        assert!(in_lanes > 500 && entered > 50, "{in_lanes} ball lanes, {entered} of them entering the ball");
        assert!(pushed > 250 && sticking > 50 && sliding > 50, "{pushed} pushed: {sticking} stuck, {sliding} slid");
        assert!(plane_moved > 500, "{plane_moved} particles moved by the tilted ground");
    }

    #[test]
    fn a_lane_pushed_out_of_its_box_meets_the_colliders_off_the_box() {
        // Eight particles at rest at y = 0, x = 0 … 0.07, over a ball of
        // radius 5 whose top is at y = 0.02, under a ceiling at y = 0.035
        // (normal −y); thickness r = 0.01. Their box (y = 0) is 0.035 from
        // the ceiling, more than r: only the ball is near it. The ball
        // pushes each out along its normal to 0.03 − x²/(2·5) or so, 0.005
        // or less from the ceiling, which pushes it back to y = 0.025.
        // Resolved against the box's colliders alone, they would stay near
        // 0.03: the lanes must go back to every collider.
        let colliders = vec![
            Collider::fixed(Shape::Sphere { radius: 5.0 }, Pose { translation: Vec3::Y * -4.98, ..Pose::default() }),
            Collider::fixed(
                Shape::Plane { normal: -Vec3::Y },
                Pose { translation: Vec3::Y * 0.035, ..Pose::default() },
            ),
        ];
        let step = ContactStep::new(&colliders, 0.01, 0.3, 0.0, 0.01);
        let start: [Vec3; LANES] = std::array::from_fn(|l| Vec3::new(0.01 * l as f32, 0.0, 0.0));
        let (lo, hi) = (start[0], start[LANES - 1]);
        let near = step.near(lo, hi);
        assert_eq!(near, vec![0]);
        let x0: Point<F32x8> = std::array::from_fn(|i| F32x8(std::array::from_fn(|l| start[l][i])));
        let mut x = x0;
        step.resolve_lanes(&near, (lo, hi), u8::MAX, &x0, &mut x);
        let all = step.all();
        for (l, &p) in start.iter().enumerate() {
            let expected = step.resolve(&all, p, p);
            assert_eq!(lane(&x, l).to_array().map(f32::to_bits), expected.to_array().map(f32::to_bits), "lane {l}");
            assert!((expected.y - 0.025).abs() < 1e-6, "lane {l} at {expected}");
            assert!(step.resolve(&near, p, p).y > 0.0295, "lane {l}: the ball alone leaves it near 0.03");
        }
    }
}
