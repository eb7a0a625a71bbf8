//! The self-collide phase's tests: the rule on single pairs, the speed
//! limit, the kept list against a search every substep, threads.

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
fn the_particles_held_to_the_top_speed_are_counted() {
    // r = 0.02: at most 0.005 m a substep. Particles 1 m apart (no pair),
    // moved 0.001, 0.004, 0.006 and 0.05 m: the last two are held (cut to
    // 0.005); a pinned one moved 0.05 is not (it is not the phase's to
    // move). A second substep with nobody moving holds none, and the run's
    // total stays 2. The same on the pool: 20 000 particles (past
    // PARALLEL_PARTICLES), every third moved 0.006: 6 667 held.
    let step = SelfContactStep { thickness: 0.02, friction: 0.0, parallel: true };
    let rest: Vec<Vec3> = (0..5).map(|i| Vec3::X * i as f32).collect();
    let mut sc = SelfContact::new(&rest);
    let moved = [0.001, 0.004, 0.006, 0.05, 0.05];
    let mut x: Vec<Vec3> = rest.iter().zip(moved).map(|(p, d)| *p + Vec3::Y * d).collect();
    sc.apply(&mut x, &rest, &[1.0, 1.0, 1.0, 1.0, 0.0], &step);
    assert_eq!(sc.held_to_top_speed(), (2, 2));
    assert!((x[3].y - 0.005).abs() < 1e-7 && (x[4].y - 0.05).abs() < 1e-7, "{x:?}");
    let still = x.clone();
    sc.apply(&mut x, &still, &[1.0; 5], &step);
    assert_eq!(sc.held_to_top_speed(), (0, 2));

    let rest: Vec<Vec3> = (0..20_000).map(|i| Vec3::new((i % 200) as f32, 0.0, (i / 200) as f32)).collect();
    let mut x: Vec<Vec3> =
        rest.iter().enumerate().map(|(i, p)| *p + Vec3::Y * if i % 3 == 0 { 0.006 } else { 0.0 }).collect();
    let mut sc = SelfContact::new(&rest);
    sc.apply(&mut x, &rest, &vec![1.0; rest.len()], &step);
    assert_eq!(sc.held_to_top_speed(), (6667, 6667));
}

/// Two 30 × 30 sheets 1.2 cm apart in x and z, the upper 1.1 cm above
/// the lower (r = 1 cm: no pair yet), as rest shape and start.
fn two_sheets() -> (Vec<Vec3>, Vec<Vec3>) {
    let mut x = Vec::new();
    for layer in 0..2 {
        for a in 0..30 {
            for b in 0..30 {
                let offset = 0.006 * layer as f32;
                x.push(Vec3::new(a as f32 * 0.012 + offset, 0.011 * layer as f32, b as f32 * 0.012 + offset));
            }
        }
    }
    // At rest the layers are a metre apart: d_min = r between them.
    let rest = x.iter().enumerate().map(|(i, p)| if i >= 900 { *p + Vec3::Y } else { *p }).collect();
    (rest, x)
}

#[test]
fn a_kept_list_gives_what_a_search_every_substep_gives() {
    // Substep k: every particle jitters by up to 10 µm, and two 5 × 5
    // patches, one of each sheet and above each other, close in by
    // 2 mm a substep from k = 3 (under the r/4 limit). From k = 4 their
    // particles are movers (travel > s/2 = 1.25 mm); the upper patch
    // reaches the still lower sheet around it (mover against
    // non-mover) and the lower patch (mover against mover).
    let (rest, start) = two_sheets();
    let r = 0.01;
    let step = SelfContactStep { thickness: r, friction: 0.3, parallel: false };
    let w: Vec<f32> = (0..start.len()).map(|i| if i % 7 == 0 { 0.0 } else { 1.0 }).collect();
    let patch = |i: usize| (12..17).contains(&(i % 900 / 30)) && (12..17).contains(&(i % 30));
    let at = |k: usize| -> Vec<Vec3> {
        start
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let jitter = 1e-5 * ((i * 7 + k * 13) % 11) as f32 / 11.0;
                let closing = 0.002 * k.saturating_sub(2) as f32;
                let dy = if !patch(i) {
                    0.0
                } else if i >= 900 {
                    -closing
                } else {
                    0.4 * closing
                };
                *p + Vec3::new(jitter, dy, -jitter)
            })
            .collect()
    };
    let mut kept = SelfContact::new(&rest);
    let mut pushed = 0;
    for k in 1..10 {
        let (x0, x) = (at(k - 1), at(k));
        let (mut listed, mut searched) = (x.clone(), x.clone());
        kept.apply(&mut listed, &x0, &w, &step);
        SelfContact::new(&rest).apply(&mut searched, &x0, &w, &step);
        for (i, (a, b)) in listed.iter().zip(&searched).enumerate() {
            // Only the order of a particle's sum differs: a few ulps of
            // coordinates below 0.4 m (an ulp is 3e-8 there); a missed
            // pair would leave its push, ≥ 1e-4 here.
            assert!(a.distance(*b) < 1e-7, "substep {k}, particle {i}: {a} against {b}");
        }
        pushed += listed.iter().zip(&x).filter(|(a, b)| a.distance(**b) > 1e-4).count();
    }
    let (searches, substeps) = kept.searches();
    assert_eq!(substeps, 9);
    assert!(searches <= 3, "{searches} searches: the list was kept");
    assert!(pushed > 100, "{pushed} particle-substeps pushed: the patches met");
}

#[test]
fn a_kept_list_counts_a_movers_pairs_once_and_two_pinned_ends_not_at_all() {
    // Two 20 × 20 sheets 12 mm apart in x and z, the upper 9 mm above
    // the lower (r = 1 cm): every particle is pushed by the one below
    // or above it, from the first substep, so these pairs are in the
    // kept list. The first row of each sheet is pinned: its pairs
    // across, 9 mm apart, have two pinned ends. From k = 3 a 4 × 4
    // patch of the upper sheet and the 2 × 2 patch below its middle
    // slide along x by 1.5 mm a substep: movers (travel > s/2 = 1.25
    // mm; 20 of 800, within the 1 in 32 allowed), each still within r
    // of its old partner for two substeps. Those pairs are both in the
    // list and found again by the movers' searches, so the list must
    // leave them out; the pinned pairs must give nothing (not 0/0).
    let r = 0.01;
    let mut start = Vec::new();
    for layer in 0..2 {
        for a in 0..20 {
            for b in 0..20 {
                start.push(Vec3::new(a as f32 * 0.012, 0.009 * layer as f32, b as f32 * 0.012));
            }
        }
    }
    let rest: Vec<Vec3> = start.iter().enumerate().map(|(i, p)| if i >= 400 { *p + Vec3::Y } else { *p }).collect();
    let w: Vec<f32> = (0..800).map(|i| if i % 400 / 20 == 0 { 0.0 } else { 1.0 }).collect();
    let within =
        |i: usize, from: usize, to: usize| (from..to).contains(&(i % 400 / 20)) && (from..to).contains(&(i % 20));
    let slides = |i: usize| if i >= 400 { within(i, 8, 12) } else { within(i, 9, 11) };
    let at = |k: usize| -> Vec<Vec3> {
        let shift = 0.0015 * k.saturating_sub(2) as f32;
        start.iter().enumerate().map(|(i, p)| if slides(i) { *p + Vec3::X * shift } else { *p }).collect()
    };
    let step = SelfContactStep { thickness: r, friction: 0.3, parallel: false };
    let mut kept = SelfContact::new(&rest);
    let mut movers_pushed = 0;
    for k in 1..7 {
        let (x0, x) = (at(k - 1), at(k));
        let (mut listed, mut searched) = (x.clone(), x.clone());
        kept.apply(&mut listed, &x0, &w, &step);
        SelfContact::new(&rest).apply(&mut searched, &x0, &w, &step);
        for (i, (a, b)) in listed.iter().zip(&searched).enumerate() {
            // As above: the order of a sum only (a pair counted twice
            // would double its push, ≥ 1e-4 here; 0/0 would be NaN).
            assert!(a.distance(*b) < 1e-7, "substep {k}, particle {i}: {a} against {b}");
        }
        if k >= 3 {
            movers_pushed += (0..800).filter(|&i| slides(i) && listed[i].distance(x[i]) > 1e-4).count();
        }
    }
    assert_eq!(kept.searches(), (2, 6), "a plain search, one with the skin, then the list");
    assert!(movers_pushed >= 20, "{movers_pushed}: the sliding particles were pushed");
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
    // Four substeps: a plain search, then the list (kept, with movers).
    let run = |parallel| {
        let mut sc = SelfContact::new(&rest);
        let mut x = folded.clone();
        for _ in 0..4 {
            let x0 = x.clone();
            sc.apply(&mut x, &x0, &w, &SelfContactStep { thickness: 0.01, friction: 0.3, parallel });
        }
        assert!(sc.searches().0 < 4, "{:?}: the list was kept", sc.searches());
        x
    };
    let (one, many) = (run(false), run(true));
    assert!(one.iter().zip(&many).all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)));
    assert!(one.iter().zip(&folded).any(|(a, b)| a.distance(*b) > 1e-3), "the layers were pushed apart");
}
