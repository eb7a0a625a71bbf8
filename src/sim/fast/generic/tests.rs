//! The coloured layout's phases against each other: renumbered or not, on
//! one thread or two, with still octets skipped or projected.

use super::*;
use crate::sim::collider::{Collider, Pose, Shape};
use crate::sim::mesh::ClothMesh;

/// A substep of 10 ms with a little wind and gravity, `relaxations`
/// passes, compliance `betas` (structural, bend, shear) and tethers at
/// `tether_slack`.
fn substep<'a>(
    first: Option<(&'a [Vec3], Vec3)>,
    relaxations: u32,
    [stretch_beta, bend_beta, shear_beta]: [f32; 3],
    tether_slack: Option<f32>,
) -> Substep<'a> {
    Substep {
        dt: 0.01,
        keep: 0.98,
        accel: Vec3::new(0.0, 0.0, 1e-4),
        gravity: Vec3::new(0.0, -9.8e-4, 0.0),
        first,
        relaxations,
        tolerance: 0.0,
        over_relaxation: 1.0,
        stretch_beta,
        bend_beta,
        shear_beta,
        tether_slack,
    }
}

/// An n × n triangulated sheet (spacing 0.1 m, a little crumpled) whose
/// particles are numbered in a shuffled order, as subdivision leaves an
/// OBJ's vertices: positions and bars.
fn shuffled_sheet(n: u32) -> (Vec<Vec3>, Vec<Bar>) {
    let count = (n * n) as usize;
    // Fisher–Yates with a fixed linear congruential sequence.
    let mut new_index: Vec<u32> = (0..n * n).collect();
    let mut state = 12345u64;
    for i in (1..count).rev() {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        new_index.swap(i, (state >> 33) as usize % (i + 1));
    }
    let mut positions = vec![Vec3::ZERO; count];
    for (i, &to) in new_index.iter().enumerate() {
        let (c, r) = ((i as u32 % n) as f32, (i as u32 / n) as f32);
        positions[to as usize] = Vec3::new(c * 0.1, -r * 0.1, 0.02 * (c * 1.3 + r * 0.7).sin());
    }
    let mut triangles = Vec::new();
    for r in 0..n - 1 {
        for c in 0..n - 1 {
            let i = r * n + c;
            let [a, b, d, e] = [i, i + 1, i + n, i + n + 1].map(|v| new_index[v as usize]);
            triangles.extend([[a, d, e], [a, e, b]]);
        }
    }
    let mesh = ClothMesh::from_triangles(positions.clone(), triangles, &[], None).expect("valid sheet");
    (positions, mesh.bars().to_vec())
}

#[test]
fn particle_phases_give_the_same_bits_on_one_thread_and_on_two() {
    // 130 × 130 = 16 900 particles: two blocks, so on two threads the
    // phases that go particle by particle (integrate, push, settle, read,
    // the finiteness check) run in chunks on the pool; renumbered, so
    // push, read and the check go through the slots.
    let (positions, bars) = shuffled_sheet(130);
    let n = positions.len();
    let weights: Vec<f32> = (0..n).map(|i| if i % 97 == 0 { 0.0 } else { [1.0, 0.5][i % 2] }).collect();
    let layout = GenericLayout::new(&positions, &positions, &weights, &bars, None);
    let velocity: Vec<Vec3> = (0..n).map(|i| Vec3::new(0.0, 0.0, (i % 7) as f32 * 0.01)).collect();
    let substep = |first| substep(first, 3, [0.0; 3], None);
    let push: Vec<Vec3> = (0..n).map(|i| Vec3::new((i % 11) as f32 * 1e-4, 0.0, 0.0)).collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
        let mut l = layout.clone();
        pool.install(|| {
            assert_eq!(l.uses_pool(), threads > 1);
            for step in 0..3 {
                l.integrate(&substep((step == 0).then_some((&velocity[..], Vec3::ZERO))));
                l.push(&push);
                l.relax(&substep(None));
                l.settle();
            }
            let (mut x, mut x_prev) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
            l.read(&mut x, &mut x_prev);
            assert_eq!(l.first_non_finite(), None);
            // Two particles made non-finite: the check names the first
            // in scene order, whichever chunk of the layout holds it.
            l.set_particle(9000, Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::ZERO);
            l.set_particle(4321, Vec3::new(0.0, 0.0, f32::NAN), Vec3::ZERO);
            let first = l.first_non_finite();
            let bits = x.iter().chain(&x_prev).flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
            (bits, first)
        })
    };
    let (one, first) = run(1);
    assert_eq!((one.clone(), first), run(2));
    assert_eq!(first, Some(4321));
    // The steps moved the sheet (z by its initial velocity).
    assert_ne!(one[..3 * n], positions.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<u32>>());
}

#[test]
fn a_non_finite_value_anywhere_in_the_rows_is_seen() {
    // 37 values: two blocks of sixteen and a tail of five.
    let rows = vec![0.5f32; 37];
    assert!(rows_are_finite(&rows));
    for at in [0, 15, 16, 31, 32, 36] {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut r = rows.clone();
            r[at] = bad;
            assert!(!rows_are_finite(&r), "{bad} at {at}");
        }
    }
    // The largest finite values stay finite (x · 0 = 0).
    assert!(rows_are_finite(&[f32::MAX, f32::MIN, -0.0, f32::MIN_POSITIVE]));
}

#[test]
fn a_shuffled_mesh_is_renumbered_and_moves_as_if_it_were_not() {
    // 130 × 130 = 16 900 particles: two blocks.
    let (positions, bars) = shuffled_sheet(130);
    let n = positions.len();
    // In the shuffled order nearly every bar would cross between the two
    // blocks (half of them, for random numbers); renumbered, few do.
    let (scene_boundary, all) = BlockedBars::new(&bars, n, &vec![false; n]).boundary_share();
    assert!(scene_boundary * 3 > all, "scene order: boundary {scene_boundary} of {all}");
    // Fixed particles here and there, unequal masses, tethers to particle 0.
    let weights: Vec<f32> = (0..n).map(|i| if i % 97 == 0 { 0.0 } else { [1.0, 0.5, 0.25][i % 3] }).collect();
    let tethers = Tethers {
        anchor: (0..n).map(|i| (i % 5 == 1).then_some(0)).collect(),
        length: (0..n).map(|i| if i % 5 == 1 { positions[i].distance(positions[0]) * 1.01 } else { 0.0 }).collect(),
    };
    let shuffled = GenericLayout::new(&positions, &positions, &weights, &bars, Some(tethers.clone()));
    let Some(r) = shuffled.renumbering.clone() else { panic!("not renumbered") };
    assert!(shuffled.breadth_first);
    let (boundary, _) = shuffled.bars.boundary_share();
    assert!(boundary * 20 < all, "renumbered: boundary {boundary} of {all}");

    // The same mesh numbered in the layout's order from the start (bars
    // in the same creation order) and laid out in that order: its
    // layout holds the same arrays, so every phase must give the same
    // bits, particle for particle, if the renumbering is applied on
    // every way in and out.
    let at = |i: u32| r.slot[i as usize];
    let ordered_positions: Vec<Vec3> = r.scene.iter().map(|&i| positions[i as usize]).collect();
    let ordered_weights: Vec<f32> = r.scene.iter().map(|&i| weights[i as usize]).collect();
    let ordered_bars: Vec<Bar> = bars.iter().map(|b| Bar { a: at(b.a), b: at(b.b), ..*b }).collect();
    let ordered_tethers = Tethers {
        anchor: r.scene.iter().map(|&i| tethers.anchor[i as usize].map(at)).collect(),
        length: r.scene.iter().map(|&i| tethers.length[i as usize]).collect(),
    };
    let ordered = GenericLayout::in_order(
        &ordered_positions,
        &ordered_positions,
        &ordered_weights,
        &ordered_bars,
        Some(ordered_tethers),
        None,
    );

    let velocity: Vec<Vec3> = (0..n).map(|i| Vec3::new(0.0, 0.0, (i % 7) as f32 * 0.01)).collect();
    let ordered_velocity: Vec<Vec3> = r.scene.iter().map(|&i| velocity[i as usize]).collect();
    let push: Vec<Vec3> = (0..n).map(|i| Vec3::new((i % 11) as f32 * 1e-4, 0.0, 0.0)).collect();
    let ordered_push: Vec<Vec3> = r.scene.iter().map(|&i| push[i as usize]).collect();
    let substep = |first| substep(first, 5, [0.1, 1.0, 0.1], Some(0.0));
    let (mut a, mut b) = (shuffled, ordered);
    for step in 0..3 {
        a.integrate(&substep((step == 0).then_some((&velocity[..], Vec3::ZERO))));
        b.integrate(&substep((step == 0).then_some((&ordered_velocity[..], Vec3::ZERO))));
        a.push(&push);
        b.push(&ordered_push);
        assert_eq!(a.relax(&substep(None)), b.relax(&substep(None)));
        a.settle();
        b.settle();
    }
    a.set_inverse_mass(5, 0.0);
    b.set_inverse_mass(at(5) as usize, 0.0);
    a.set_particle(7, Vec3::ONE, Vec3::ONE);
    b.set_particle(at(7) as usize, Vec3::ONE, Vec3::ONE);
    let read = |l: &GenericLayout| {
        let (mut x, mut x_prev) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        l.read(&mut x, &mut x_prev);
        (x, x_prev)
    };
    let ((xa, pa), (xb, pb)) = (read(&a), read(&b));
    for i in 0..n {
        let k = at(i as u32) as usize;
        assert_eq!(xa[i].to_array().map(f32::to_bits), xb[k].to_array().map(f32::to_bits), "particle {i}");
        assert_eq!(pa[i].to_array().map(f32::to_bits), pb[k].to_array().map(f32::to_bits), "particle {i}");
    }
    assert_eq!(xa[7], Vec3::ONE);
    // The sheet moved (the velocity, the push and the wind).
    assert!(xa.iter().zip(&positions).filter(|(x, p)| x != p).count() > n / 2);
    a.set_particle(11, Vec3::NAN, Vec3::ZERO);
    assert_eq!(a.first_non_finite(), Some(11));
}

#[test]
fn octets_between_fixed_particles_are_skipped_with_the_bits_of_projecting_them() {
    // A 40 × 40 sheet whose first 12 of 40 rows are fixed (y = −0.1 r,
    // so y > −1.15): 30 % of the particles, and some 1 000 bars with
    // both ends among them, which move nothing when projected.
    let (positions, bars) = shuffled_sheet(40);
    let n = positions.len();
    let mut weights: Vec<f32> = positions.iter().map(|p| if p.y > -1.15 { 0.0 } else { 1.0 }).collect();
    let skipping = GenericLayout::new(&positions, &positions, &weights, &bars, None);
    let (still, all) = skipping.bars.still_share();
    assert!(still > all / 10, "{still} of {all} bars skipped");
    // The same layout projecting every bar: no octet counted still.
    let project_all = |l: &mut GenericLayout| {
        let free: Vec<Particle> = l.particles.iter().map(|p| Particle { weight: 1.0, ..*p }).collect();
        l.bars.count_still(&free);
        l.weights_changed = false;
    };
    let mut projecting = skipping.clone();
    project_all(&mut projecting);
    assert_eq!(projecting.bars.still_share().0, 0);

    let substep = |first| substep(first, 5, [0.1, 1.0, 0.1], None);
    let velocity = vec![Vec3::new(0.0, 0.0, 0.01); n];
    let steps = |l: &mut GenericLayout, first: bool| {
        for step in 0..3 {
            l.integrate(&substep((first && step == 0).then_some((&velocity[..], Vec3::ZERO))));
            l.relax(&substep(None));
            l.settle();
        }
    };
    // The bits of every coordinate, but for the sign of a zero: a
    // projection adds w c d = ±0 to a fixed end, which turns a −0 (a
    // row's y = −0.1 · 0 here) into +0, and a skipped one leaves it.
    let bits = |l: &GenericLayout| {
        let (mut x, mut x_prev) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        l.read(&mut x, &mut x_prev);
        x.iter().chain(&x_prev).flat_map(|p| p.to_array().map(|c| (c + 0.0).to_bits())).collect::<Vec<u32>>()
    };
    let (mut skipping, mut stale) = (skipping.clone(), skipping);
    for l in [&mut skipping, &mut stale, &mut projecting] {
        steps(l, true);
    }
    assert_eq!(bits(&skipping), bits(&projecting));

    // Free a particle at an end of the first skipped octet: its bars
    // move again, so the skip must end there. `stale` is not told (its
    // still octets stay as counted): it must then differ, which shows
    // the freed particle's bars were skipped before.
    let colouring = &skipping.bars.blocks[0].colouring;
    let ([first, ..], _) = colouring.live(0);
    assert!(first.start > colouring.colour(0).start, "the first colour starts with still octets");
    let freed = skipping.scene(colouring.bars.ends(colouring.colour(0).start).0);
    weights[freed] = 1.0;
    for l in [&mut skipping, &mut stale, &mut projecting] {
        l.set_inverse_mass(freed, 1.0);
    }
    stale.weights_changed = false;
    project_all(&mut projecting);
    for l in [&mut skipping, &mut stale, &mut projecting] {
        steps(l, false);
    }
    assert!(skipping.bars.still_share().0 < still);
    assert_eq!(bits(&skipping), bits(&projecting));
    assert_ne!(bits(&stale), bits(&projecting));
    // The cloth below the fixed rows moved.
    let (mut x, mut x_prev) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    skipping.read(&mut x, &mut x_prev);
    let moved = (0..n).filter(|&i| weights[i] > 0.0 && x[i] != positions[i]).count();
    assert!(moved > n / 2, "{moved} of {n} moved");
}

#[test]
fn collide_gives_every_collider_s_bits_in_chunks_on_one_thread_and_on_two() {
    // The 130 × 130 sheet laid flat at y = 0 (12.9 m square about the
    // origin), each particle arriving from its own start x0 (below), every
    // 97th particle fixed. A ball of
    // radius 5 with its top at y = 0.02 reaches the particles within about
    // 0.45 m of the middle, and a ceiling at y = 0.035 (normal −y) is off
    // every chunk's box (all at y = 0: 0.035 is farther than the thickness
    // r = 0.01). The ball pushes the middle particles out to its surface
    // plus r, up to y = 0.03, where the ceiling is 0.005 away, closer than
    // r: it pushes them back to 0.035 − 0.01 = 0.025. A chunk that tried
    // only the colliders near its box would leave them at up to 0.03: the
    // fallback to every collider is what puts them at 0.025.
    let (sheet, bars) = shuffled_sheet(130);
    let positions: Vec<Vec3> = sheet.iter().map(|p| Vec3::new(p.x - 6.45, 0.0, -p.y - 6.45)).collect();
    let n = positions.len();
    let weights: Vec<f32> = (0..n).map(|i| if i % 97 == 0 { 0.0 } else { 1.0 }).collect();
    let mut layout = GenericLayout::new(&positions, &positions, &weights, &bars, None);
    for (q, p) in layout.predicted.iter_mut().zip(layout.particles.iter()) {
        *q = p.position;
    }
    // Each particle came from its own start x0 = x − d, up to 2 cm away in
    // each axis and different in each (so lanes that took a start's axes
    // or particles out of order would sweep other paths into the ball).
    for (k, d) in layout.displacement.iter_mut().enumerate() {
        let k = k as f32;
        *d = [0.02 * (0.37 * k).sin(), 0.02 * (1.31 * k).cos(), 0.02 * (0.73 * k).sin()];
    }
    let (mut x, mut starts) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    layout.read(&mut x, &mut starts);
    let colliders = [
        Collider::fixed(Shape::Sphere { radius: 5.0 }, Pose { translation: Vec3::Y * -4.98, ..Pose::default() }),
        Collider::fixed(Shape::Plane { normal: -Vec3::Y }, Pose { translation: Vec3::Y * 0.035, ..Pose::default() }),
    ];
    let contact = ContactStep::new(&colliders, 0.01, 0.3, 0.0, 0.01);
    assert_eq!(contact.near(Vec3::new(-7.0, 0.0, -7.0), Vec3::new(7.0, 0.0, 7.0)), vec![0]);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
        let mut l = layout.clone();
        pool.install(|| {
            assert_eq!(l.uses_pool(), threads > 1);
            l.collide(&contact);
            let (mut x, mut x_prev) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
            l.read(&mut x, &mut x_prev);
            x
        })
    };
    let all = contact.all();
    let expected: Vec<Vec3> = (0..n)
        .map(|i| if weights[i] > 0.0 { contact.resolve(&all, starts[i], positions[i]) } else { positions[i] })
        .collect();
    let bits = |x: &[Vec3]| x.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
    for threads in [1, 2] {
        assert!(bits(&run(threads)) == bits(&expected), "{threads} threads: not every collider's bits");
    }
    let top = expected.iter().map(|p| p.y).fold(f32::NEG_INFINITY, f32::max);
    let under_ceiling = expected.iter().filter(|p| p.y > 0.0249).count();
    assert!((top - 0.025).abs() < 1e-6 && under_ceiling > 3, "top {top}, {under_ceiling} under the ceiling");
}

#[test]
fn self_collide_runs_the_phase_in_the_layouts_order_on_one_thread_and_on_two() {
    // The shuffled 130 × 130 sheet of 0.1 m (renumbered: two blocks)
    // squeezed to 0.3 of its width, at rest (x0 = x), r = 0.12: neighbours
    // along a row are 0.03 m apart, 0.1 m in the rest shape, so the phase
    // pushes them back towards 0.1; diagonal neighbours (0.104 m now, 0.141
    // at rest) towards r. The layout runs the phase on its own rows (copied
    // in chunks on the pool with two threads), numbered by its
    // renumbering: with another particle's rest position, most neighbours
    // would be pushed towards r instead, and neighbours along a column (0.1
    // apart now) would be pushed too.
    let (rest, bars) = shuffled_sheet(130);
    let squeezed: Vec<Vec3> = rest.iter().map(|p| Vec3::new(p.x * 0.3, p.y, p.z)).collect();
    let n = rest.len();
    let weights: Vec<f32> = (0..n).map(|i| if i % 97 == 0 { 0.0 } else { 1.0 }).collect();
    let mut layout = GenericLayout::new(&squeezed, &squeezed, &weights, &bars, None);
    let scene = layout.renumbering.as_ref().expect("renumbered").scene.clone();
    for (q, p) in layout.predicted.iter_mut().zip(layout.particles.iter()) {
        *q = p.position;
    }
    let step = SelfContactStep { thickness: 0.12, friction: 0.2, parallel: true };
    // The phase on the scene's arrays in scene order.
    let mut in_scene_order = squeezed.clone();
    SelfContact::new(&rest).apply(&mut in_scene_order, &squeezed, &weights, &step);
    let moved = in_scene_order.iter().zip(&squeezed).filter(|(a, b)| a != b).count();
    assert!(moved > n / 2, "the phase moved {moved} of {n} particles");
    // The phase on the same arrays in the layout's order.
    let by_row = |v: &[Vec3]| -> Vec<Vec3> { scene.iter().map(|&i| v[i as usize]).collect() };
    let mut rows = by_row(&squeezed);
    let row_weights: Vec<f32> = scene.iter().map(|&i| weights[i as usize]).collect();
    SelfContact::new(&rest).apply_numbered(&mut rows, &by_row(&squeezed), &row_weights, Some(&scene), &step);
    let mut expected = vec![Vec3::ZERO; n];
    for (k, &i) in scene.iter().enumerate() {
        expected[i as usize] = rows[k];
    }
    // The same pairs and pushes: only the order of a particle's sum
    // differs, a few ulps of coordinates below 1.3 m (an ulp is 1.2e-7
    // there); a pair given the wrong rest position would move by ≥ 1e-3.
    for (a, b) in expected.iter().zip(&in_scene_order) {
        assert!(a.distance(*b) < 1e-6, "{a} against {b}");
    }
    let bits = |x: &[Vec3]| x.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
        let x = pool.install(|| {
            let mut l = layout.clone();
            assert_eq!(l.uses_pool(), threads > 1);
            l.self_collide(&mut SelfContact::new(&rest), &step);
            let (mut x, mut x_prev) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
            l.read(&mut x, &mut x_prev);
            x
        });
        assert!(bits(&x) == bits(&expected), "{threads} threads: not the phase's bits");
    }
}
