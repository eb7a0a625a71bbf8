//! The fast path for any mesh: bars reordered by colour.
//!
//! A greedy colouring gives every bar the smallest colour not yet used by a
//! bar at either of its ends; bars are then relaxed colour by colour, eight
//! at a time in SIMD lanes ([`sweep`]). Bars of one colour share no
//! particle, so each projection is independent of the others in its
//! colour: the lanes compute what one bar at a time would, and the
//! creation-order loop's wait on the previous projection's result is gone.
//! Positions and the inverse mass sit together in 16 bytes, one row per
//! particle.
//!
//! The particles are renumbered into dimers ([`order::dimer_order`]): two
//! neighbours in consecutive rows, dimers side by side like rungs of a
//! ladder. Bars are then paired ([`pairs`]) so that an octet's lanes l and
//! l + 4 take the two rows of a dimer at one end or at both, which the AVX2
//! sweep loads and stores as one 32-byte access where it took two and a
//! shuffle.

mod colouring;
mod order;
mod pairs;
mod sweep;

use glam::Vec3;

use super::kernel::{Point, integrate, settle, tether};
use crate::sim::contact::ContactStep;
use crate::sim::mesh::Bar;
use crate::sim::self_contact::{SelfContact, SelfContactStep};
use crate::sim::step::{Solver, Substep};
use crate::sim::tether::Tethers;
use colouring::BlockedBars;
use sweep::Sweep;

#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
struct Particle {
    position: Point<f32>,
    /// Inverse mass relative to m (0: fixed).
    weight: f32,
}

/// Particles in scene order (or renumbered, see [`colouring`]), bars in
/// colour order.
#[derive(Clone, Debug)]
pub(crate) struct GenericLayout {
    particles: Vec<Particle>,
    displacement: Vec<[f32; 3]>,
    predicted: Vec<[f32; 3]>,
    bars: BlockedBars,
    /// Tethers, indexed and anchored in the layout's order.
    tethers: Option<Tethers>,
    /// The particles' order when it is not the scene's.
    renumbering: Option<Renumbering>,
    /// Whether that order starts from a breadth-first one.
    breadth_first: bool,
    /// A weight changed since the bars' still octets were counted
    /// ([`BlockedBars::count_still`]): they are counted again before the
    /// next pass.
    weights_changed: bool,
}

/// Where each particle sits when the layout renumbered them.
#[derive(Clone, Debug)]
struct Renumbering {
    /// `scene[k]`: the scene index of the particle in slot k.
    scene: Vec<u32>,
    /// `slot[i]`: the slot of scene particle i.
    slot: Vec<u32>,
}

impl GenericLayout {
    /// Positions x and x − d in scene order, each as `to` makes it.
    fn read_as<T>(&self, positions: &mut [T], previous: &mut [T], to: impl Fn(Vec3) -> T) {
        for (k, (p, d)) in self.particles.iter().zip(&self.displacement).enumerate() {
            let i = self.scene(k);
            let x = Vec3::from_array(p.position);
            positions[i] = to(x);
            previous[i] = to(x - Vec3::from_array(*d));
        }
    }

    /// The layout of a mesh: its particles in [`order::dimer_order`] (over
    /// the scene's order, or a breadth-first one where the scene's would
    /// put more than 1 bar in 20 between blocks), its bars coloured.
    pub(crate) fn new(
        positions: &[Vec3],
        previous: &[Vec3],
        inverse_mass: &[f32],
        bars: &[Bar],
        tethers: Option<Tethers>,
    ) -> Self {
        let n = positions.len();
        let renumber = |scene: &[u32]| {
            let mut slot = vec![0u32; n];
            for (k, &i) in scene.iter().enumerate() {
                slot[i as usize] = k as u32;
            }
            let moved: Vec<Bar> =
                bars.iter().map(|b| Bar { a: slot[b.a as usize], b: slot[b.b as usize], ..*b }).collect();
            (Renumbering { scene: scene.to_vec(), slot }, moved)
        };
        // More than 1 bar in 20 between blocks: the scene's order is not
        // local, and a breadth-first one may do better.
        let mut base = None;
        let boundary = BlockedBars::boundary_count(bars, n);
        if boundary * 20 > bars.len() {
            let (breadth_first, moved) = renumber(&order::breadth_first_order(n, bars));
            if BlockedBars::boundary_count(&moved, n) < boundary {
                base = Some((breadth_first, moved));
            }
        }
        let (base_scene, base_bars) = match &base {
            Some((r, moved)) => (Some(&r.scene), &moved[..]),
            None => (None, bars),
        };
        let dimers = order::dimer_order(n, base_bars);
        let scene: Vec<u32> = dimers.iter().map(|&k| base_scene.map_or(k, |s| s[k as usize])).collect();
        let (renumbering, moved) = renumber(&scene);
        let mut layout = Self::in_order(positions, previous, inverse_mass, &moved, tethers, Some(renumbering));
        layout.breadth_first = base.is_some();
        layout
    }

    /// The layout with the particles in the order `renumbering` gives (or
    /// the scene's), `bars` numbered in that order.
    fn in_order(
        positions: &[Vec3],
        previous: &[Vec3],
        inverse_mass: &[f32],
        bars: &[Bar],
        tethers: Option<Tethers>,
        renumbering: Option<Renumbering>,
    ) -> Self {
        let n = positions.len();
        let scene = |k: usize| renumbering.as_ref().map_or(k, |r| r.scene[k] as usize);
        let fixed: Vec<bool> = (0..n).map(|k| inverse_mass[scene(k)] == 0.0).collect();
        let mut layout = GenericLayout {
            particles: vec![Particle::default(); n],
            displacement: vec![[0.0; 3]; n],
            predicted: vec![[0.0; 3]; n],
            bars: BlockedBars::new(bars, n, &fixed),
            tethers: None,
            renumbering,
            breadth_first: false,
            weights_changed: true,
        };
        layout.set_tethers(tethers);
        for i in 0..n {
            layout.set_inverse_mass(i, inverse_mass[i]);
            layout.set_particle(i, positions[i], previous[i]);
        }
        layout.bars.count_still(&layout.particles);
        layout.weights_changed = false;
        layout
    }

    /// The slot of scene particle `i`.
    fn slot(&self, i: usize) -> usize {
        self.renumbering.as_ref().map_or(i, |r| r.slot[i] as usize)
    }

    /// The scene index of the particle in slot `k`.
    fn scene(&self, k: usize) -> usize {
        self.renumbering.as_ref().map_or(k, |r| r.scene[k] as usize)
    }

    fn set_initial_velocity(&mut self, velocity: &[Vec3], dt: f32, extra: Vec3) {
        for k in 0..self.particles.len() {
            let w = self.particles[k].weight;
            if w > 0.0 {
                self.displacement[k] = (velocity[self.scene(k)] * dt + extra * w).to_array();
            }
        }
    }
}

impl Solver for GenericLayout {
    fn integrate(&mut self, s: &Substep) {
        let (keep, accel, gravity) = match s.first {
            Some((v0, extra)) => {
                self.set_initial_velocity(v0, s.dt, extra);
                (1.0, [0.0; 3], [0.0; 3])
            }
            None => (s.keep, s.accel.to_array(), s.gravity.to_array()),
        };
        for ((p, d), q) in self.particles.iter_mut().zip(&mut self.displacement).zip(&mut self.predicted) {
            *q = integrate(&mut p.position, d, p.weight, keep, accel, gravity);
        }
    }

    fn push(&mut self, displacement: &[Vec3]) {
        for k in 0..self.particles.len() {
            let delta = displacement[self.scene(k)];
            let p = &mut self.particles[k];
            if p.weight > 0.0 {
                for k in 0..3 {
                    p.position[k] += p.weight * delta[k];
                }
            }
        }
    }

    fn relax(&mut self, s: &Substep) -> u32 {
        if let (Some(tethers), Some(slack)) = (&self.tethers, s.tether_slack) {
            for i in 0..self.particles.len() {
                if let Some(anchor) = tethers.anchor[i] {
                    let from = self.particles[anchor as usize].position;
                    let p = &mut self.particles[i];
                    tether(&mut p.position, from, tethers.length[i] * (1.0 + slack), p.weight);
                }
            }
        }
        if s.compliant() {
            self.bars.reset_multipliers();
        }
        if self.weights_changed {
            self.bars.count_still(&self.particles);
            self.weights_changed = false;
        }
        let sweep = Sweep { betas: s.betas(), omega: s.over_relaxation, tolerance: s.tolerance };
        let mut sweeps = 0;
        for _ in 0..s.relaxations {
            sweeps += 1;
            let worst = self.bars.relax_pass(&mut self.particles, &sweep);
            if s.tolerance > 0.0 && worst <= 0.0 {
                break;
            }
        }
        sweeps
    }

    /// Particles in scene order; each started the substep at x_pred − d.
    fn collide(&mut self, contact: &ContactStep) {
        let all = contact.all();
        for ((p, d), q) in self.particles.iter_mut().zip(&self.displacement).zip(&self.predicted) {
            if p.weight > 0.0 {
                let x0 = Vec3::from_array(*q) - Vec3::from_array(*d);
                p.position = contact.resolve(&all, x0, Vec3::from_array(p.position)).to_array();
            }
        }
    }

    /// Gathers positions, start positions (x_pred − d) and weights, runs
    /// the phase, writes the positions back.
    fn self_collide(&mut self, phase: &mut SelfContact, step: &SelfContactStep) {
        let (mut x, mut x0, mut w) =
            (std::mem::take(&mut phase.x), std::mem::take(&mut phase.x0), std::mem::take(&mut phase.w));
        x.clear();
        x0.clear();
        w.clear();
        for i in 0..self.particles.len() {
            let k = self.slot(i);
            let (p, d, q) = (&self.particles[k], self.displacement[k], self.predicted[k]);
            x.push(Vec3::from_array(p.position));
            x0.push(Vec3::from_array(q) - Vec3::from_array(d));
            w.push(p.weight);
        }
        phase.apply(&mut x, &x0, &w, step);
        for (i, x) in x.iter().enumerate() {
            let k = self.slot(i);
            self.particles[k].position = x.to_array();
        }
        (phase.x, phase.x0, phase.w) = (x, x0, w);
    }

    fn settle(&mut self) {
        for ((p, d), q) in self.particles.iter().zip(&mut self.displacement).zip(&self.predicted) {
            settle(d, p.position, *q, p.weight);
        }
    }

    fn read(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        self.read_as(positions, previous, |p| p);
    }

    fn read_rows(&self, positions: &mut [[f32; 4]], previous: &mut [[f32; 4]]) {
        self.read_as(positions, previous, |p| p.extend(0.0).to_array());
    }

    fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        let k = self.slot(index);
        self.particles[k].position = position.to_array();
        self.displacement[k] = (position - previous).to_array();
    }

    fn set_inverse_mass(&mut self, index: usize, weight: f32) {
        let k = self.slot(index);
        self.particles[k].weight = weight;
        self.weights_changed = true;
    }

    /// Keeps them in the layout's order: particle and anchor renumbered.
    fn set_tethers(&mut self, tethers: Option<Tethers>) {
        self.tethers = match (tethers, &self.renumbering) {
            (Some(t), Some(r)) => {
                let mut moved = Tethers { anchor: vec![None; t.anchor.len()], length: vec![0.0; t.length.len()] };
                for (i, (anchor, length)) in t.anchor.iter().zip(&t.length).enumerate() {
                    let k = r.slot[i] as usize;
                    moved.anchor[k] = anchor.map(|a| r.slot[a as usize]);
                    moved.length[k] = *length;
                }
                Some(moved)
            }
            (tethers, _) => tethers,
        };
    }

    fn first_non_finite(&self) -> Option<usize> {
        (0..self.particles.len()).find(|&i| !self.particles[self.slot(i)].position.iter().all(|c| c.is_finite()))
    }

    fn uses_pool(&self) -> bool {
        self.bars.blocks.len() > 1 && rayon::current_num_threads() > 1
    }

    fn describe(&self) -> String {
        let (colours, boundary_colours) = self.bars.colours();
        let ([both, a_end], all) = self.bars.paired_share();
        let percent = |n: usize| (100 * n).checked_div(all).unwrap_or(0);
        let lanes = if super::simd::level() >= super::simd::SimdLevel::Avx2 {
            format!("8 bars a lane op ({} % paired at both ends, {} % at one)", percent(both), percent(a_end))
        } else {
            "one bar at a time".to_string()
        };
        let lanes = match self.bars.still_share().0 {
            0 => lanes,
            still => format!("{lanes}, {still} bars between fixed particles skipped ({} %)", percent(still)),
        };
        match self.bars.blocks.len() {
            1 => format!("coloured: {colours} colours, {lanes}, one thread"),
            blocks => {
                let (boundary, all) = self.bars.boundary_share();
                let order = if self.breadth_first { "particles renumbered breadth-first, " } else { "" };
                format!(
                    "coloured: {order}{blocks} blocks of ≤ {colours} colours on {} threads, {lanes}; boundary {boundary} of {all} bars in {boundary_colours} colours",
                    rayon::current_num_threads()
                )
            }
        }
    }

    fn boxed_clone(&self) -> Box<dyn Solver> {
        Box::new(self.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::mesh::ClothMesh;

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
        let substep = |first| Substep {
            dt: 0.01,
            keep: 0.98,
            accel: Vec3::new(0.0, 0.0, 1e-4),
            gravity: Vec3::new(0.0, -9.8e-4, 0.0),
            first,
            relaxations: 5,
            tolerance: 0.0,
            over_relaxation: 1.0,
            stretch_beta: 0.1,
            bend_beta: 1.0,
            shear_beta: 0.1,
            tether_slack: Some(0.0),
        };
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

        let substep = |first| Substep {
            dt: 0.01,
            keep: 0.98,
            accel: Vec3::new(0.0, 0.0, 1e-4),
            gravity: Vec3::new(0.0, -9.8e-4, 0.0),
            first,
            relaxations: 5,
            tolerance: 0.0,
            over_relaxation: 1.0,
            stretch_beta: 0.1,
            bend_beta: 1.0,
            shear_beta: 0.1,
            tether_slack: None,
        };
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
}
