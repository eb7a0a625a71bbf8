//! The air phase on a solver's own lanes ([`Lanes`]: the grid's tiles),
//! read where they are.
//!
//! Each particle has a place, lane l of element e (a slot of eight lanes).
//! A triangle whose corners are lane l of elements (e₀, e₁, e₂), with the
//! seven triangles that take lanes 0..8 of the same three elements, makes
//! an *aligned octet*: its corners load as whole elements and its thirds go
//! out as lanes, with no transpose either way. On a grid's lanes that is
//! every triangle but those across the edge of a block of columns (88 % of
//! the 256 × 256 cloth's); the rest are gathered place by place.
//!
//! Three passes, each on the thread pool for large cloths:
//! 1. tile by tile, while the tile is in cache: x copied out,
//!    u = v_air(x) − d/(h/n) on each element (`noise`: lanes in several
//!    cells of the noise take each its own, and each lane holds its cell's
//!    lattice values from one element to the next, so only a lane that
//!    crossed into another cell takes new ones), and the forces of the
//!    aligned octets inside the tile;
//! 2. the aligned octets across tiles and the gathered triangles;
//! 3. after integration, each element's eight sums, made as the solver
//!    adds them to its lanes ([`Lanes::push_lanes`]): the element's aligned
//!    octets summed in lanes, then its other triangles lane by lane.

use rayon::prelude::*;

use super::noise::{self, Field};
use super::{AeroStep, PointLanes, TRIANGLES, csr, force};
use crate::sim::fast::kernel::{F32x8, LANES, Real};
use crate::sim::fast::simd::dispatch;
use crate::sim::step::{LanePlaces, Lanes};

#[derive(Clone, Debug)]
pub(super) struct LaneForm {
    /// Element of corner k of each aligned octet: those inside tile t
    /// (every corner there) at `tile_octets[t]..tile_octets[t + 1]`, then
    /// those across tiles.
    aligned: Vec<[u32; 3]>,
    tile_octets: Vec<u32>,
    /// First element of each tile, then the end.
    tile_starts: Vec<u32>,
    /// Corner places of the triangles no aligned octet takes.
    triangles: Vec<[u32; 3]>,
    /// m_t of each triangle, kg: the aligned octets' (eight an octet),
    /// then the others'.
    triangle_mass: Vec<f32>,
    /// A third of each aligned octet's forces, N, as lanes.
    octet_force: Vec<PointLanes>,
    /// A third of the force of each triangle of `triangles`, N, as rows.
    third_force: Vec<[f32; 4]>,
    /// The aligned octets with a corner in element e:
    /// `octets[octet_offsets[e]..octet_offsets[e + 1]]`. Lane l of each is
    /// a triangle of place 8e + l, and these are all its aligned ones.
    octet_offsets: Vec<u32>,
    octets: Vec<u32>,
    /// Element e's other triangles, `(lane, index in third_force)`:
    /// `extras[extra_offsets[e]..extra_offsets[e + 1]]`.
    extra_offsets: Vec<u32>,
    extras: Vec<(u32, u32)>,
    /// Positions x, copied out of the lanes as the air's velocity is
    /// computed (the triangles read corners by element).
    x: Vec<PointLanes>,
    /// u = v_air(x) − d/(h/n), m/s.
    relative: Vec<PointLanes>,
    /// (h/n)² / m̄ of the last [`LaneForm::compute`], 0 before it.
    scale: f32,
}

impl LaneForm {
    /// The form for these triangles (scene indices) and their masses, at
    /// the places `lanes` gives.
    pub(super) fn new(triangles: &[[u32; 3]], masses: Vec<f32>, lanes: &LanePlaces) -> Self {
        let placed: Vec<[u32; 3]> = triangles.iter().map(|t| t.map(|i| lanes.place[i as usize])).collect();
        let elements_of = |k: u32| placed[k as usize].map(|p| p / LANES as u32);
        let lane_of = |k: u32| {
            let l = placed[k as usize].map(|p| p % LANES as u32);
            (l[0] == l[1] && l[1] == l[2]).then_some(l[0])
        };
        // Triangles with their corners in one lane, by elements and lane:
        // those with the same elements in lanes 0..8 make an octet. A lane
        // may lack its triangle where its three places hold no particle (a
        // tile's padding): it computes a triangle of padding, of mass 0,
        // whose force the solver never adds (padding weighs 0).
        let elements: usize = lanes.tiles.iter().sum();
        let mut occupied = vec![false; elements * LANES];
        for &p in &lanes.place {
            occupied[p as usize] = true;
        }
        // Sorted by (elements, lane, index): by the first element in one
        // counting pass, then each element's few (≤ 6 a lane on a grid) by
        // the rest. A comparison sort of the whole was about 5 ms of the
        // 256 × 256 cloth's setup.
        let keyed = (0..placed.len() as u32).filter_map(|k| lane_of(k).map(|l| (elements_of(k), l, k)));
        let (firsts, mut candidates) = csr(elements, keyed.map(|key| (key.0[0], key)));
        for bucket in firsts.windows(2) {
            candidates[bucket[0] as usize..bucket[1] as usize].sort_unstable();
        }
        let mut groups: Vec<([u32; 3], [Option<u32>; LANES])> = Vec::new();
        let mut taken = vec![false; placed.len()];
        for group in candidates.chunk_by(|a, b| a.0 == b.0) {
            let elements = group[0].0;
            let mut octet = [None; LANES];
            let mut unique = true;
            for &(_, l, k) in group {
                unique &= octet[l as usize].replace(k).is_none();
            }
            let padding = |l: usize| elements.iter().all(|&e| !occupied[e as usize * LANES + l]);
            if unique && (0..LANES).all(|l| octet[l].is_some() || padding(l)) {
                groups.push((elements, octet));
                for &(_, _, k) in group {
                    taken[k as usize] = true;
                }
            }
        }
        // The octets inside each tile, tile by tile, then those across.
        let tiles = lanes.tiles.len();
        let tile_starts: Vec<u32> = std::iter::once(0)
            .chain(lanes.tiles.iter().scan(0u32, |end, &n| {
                *end += n as u32;
                Some(*end)
            }))
            .collect();
        let tile_of = |octet: &[u32; 3]| {
            let t = tile_starts.partition_point(|&start| start <= octet[0]).saturating_sub(1);
            match tile_starts.get(t..t + 2) {
                Some(&[start, end]) if octet.iter().all(|e| (start..end).contains(e)) => t,
                _ => tiles,
            }
        };
        // By tile, stably (a counting sort, one tile lookup a group): the
        // octets across tiles last, as a tile past the last.
        let (mut tile_octets, groups) = csr(tiles + 1, groups.iter().map(|group| (tile_of(&group.0) as u32, *group)));
        tile_octets.pop();
        let aligned: Vec<[u32; 3]> = groups.iter().map(|(octet, _)| *octet).collect();
        let rest: Vec<u32> = (0..placed.len() as u32).filter(|&k| !taken[k as usize]).collect();
        let octet_masses = groups.iter().flat_map(|(_, octet)| octet.map(|k| k.map_or(0.0, |k| masses[k as usize])));
        let triangle_mass = octet_masses.chain(rest.iter().map(|&k| masses[k as usize])).collect();
        // Per element, its aligned octets, then its other triangles.
        let corners = aligned.iter().enumerate().flat_map(|(j, octet)| octet.map(|e| (e, j as u32)));
        let (octet_offsets, octets) = csr(elements, corners);
        let extra = rest
            .iter()
            .enumerate()
            .flat_map(|(at, &k)| placed[k as usize].map(|p| (p / LANES as u32, (p % LANES as u32, at as u32))));
        let (extra_offsets, extras) = csr(elements, extra);
        let zero = [[0.0; LANES]; 3];
        Self {
            octet_force: vec![zero; aligned.len()],
            aligned,
            tile_octets,
            tile_starts,
            third_force: vec![[0.0; 4]; rest.len()],
            triangles: rest.iter().map(|&k| placed[k as usize]).collect(),
            triangle_mass,
            octet_offsets,
            octets,
            extra_offsets,
            extras,
            x: vec![zero; elements],
            relative: vec![zero; elements],
            scale: 0.0,
        }
    }

    /// The share of triangles in aligned octets.
    pub(super) fn aligned_share(&self) -> f64 {
        let aligned = self.aligned.len() * LANES;
        aligned as f64 / (aligned + self.triangles.len()).max(1) as f64
    }

    /// Passes 1 and 2 (module docs) on `lanes`, the solver's.
    pub(super) fn compute(&mut self, lanes: Option<&dyn Lanes>, step: &AeroStep, gusts: &Field, parallel: bool) {
        let Self { aligned, tile_octets, tile_starts, triangles, triangle_mass, octet_force, third_force, .. } = self;
        let (air, dt) = (step.air, step.dt);
        let tiles = lanes.map(|lanes| lanes.tiles()).unwrap_or_default();
        let fits = tiles.len() + 1 == tile_starts.len()
            && tiles.iter().zip(tile_starts.windows(2)).all(|((x, _), w)| x.len() == (w[1] - w[0]) as usize);
        if !fits {
            // The simulation builds the phase for its solver's lanes
            // (`aerodynamics` in `simulation.rs`); were another solver to
            // get it, the air would push nothing, and says so.
            log::error!("the air phase was built for lanes the solver does not have: no air force");
            self.scale = 0.0;
            return;
        }
        self.scale = step.displacement_per_newton;
        // Pass 1, tile by tile.
        let (inside, across) = aligned.split_at(tile_octets[tiles.len()] as usize);
        let (inside_force, across_force) = octet_force.split_at_mut(inside.len());
        let (inside_masses, rest_masses) = triangle_mass.split_at(inside.len() * LANES);
        let (across_masses, rest_masses) = rest_masses.split_at(across.len() * LANES);
        let mut tasks = Vec::with_capacity(tiles.len());
        let (mut x_left, mut u_left, mut f_left) = (&mut self.x[..], &mut self.relative[..], inside_force);
        for (t, (position, displacement)) in tiles.into_iter().enumerate() {
            let octets = tile_octets[t] as usize..tile_octets[t + 1] as usize;
            let (x, x_next) = std::mem::take(&mut x_left).split_at_mut(position.len());
            let (u, u_next) = std::mem::take(&mut u_left).split_at_mut(position.len());
            let (f, f_next) = std::mem::take(&mut f_left).split_at_mut(octets.len());
            (x_left, u_left, f_left) = (x_next, u_next, f_next);
            let masses = &inside_masses[octets.start * LANES..octets.end * LANES];
            let first = tile_starts[t] as usize;
            tasks.push(TileTask { position, displacement, first, x, u, octets: &inside[octets], masses, out: f });
        }
        let tile = |task: TileTask| {
            task.x.copy_from_slice(task.position);
            noise::relative_lanes(gusts, dt, task.position, task.displacement, task.u);
            force::aligned_forces(&air, dt, (task.x, task.u, task.first), task.octets, task.masses, task.out);
        };
        if parallel {
            tasks.into_par_iter().for_each(tile);
        } else {
            tasks.into_iter().for_each(tile);
        }
        // Pass 2: the octets across tiles, then the gathered triangles, in
        // chunks, one list of tasks.
        let (x, relative) = (&self.x[..], &self.relative[..]);
        const OCTETS: usize = TRIANGLES / LANES;
        let octet_tasks = across_force
            .chunks_mut(OCTETS)
            .zip(across.chunks(OCTETS).zip(across_masses.chunks(TRIANGLES)))
            .map(|(out, (octets, masses))| ForceTask::Aligned(out, octets, masses));
        let gathered_tasks = third_force
            .chunks_mut(TRIANGLES)
            .zip(triangles.chunks(TRIANGLES).zip(rest_masses.chunks(TRIANGLES)))
            .map(|(out, (triangles, masses))| ForceTask::Gathered(out, triangles, masses));
        let tasks: Vec<_> = octet_tasks.chain(gathered_tasks).collect();
        let forces = |task: ForceTask| match task {
            ForceTask::Aligned(out, octets, masses) => {
                force::aligned_forces(&air, dt, (x, relative, 0), octets, masses, out);
            }
            ForceTask::Gathered(out, triangles, masses) => {
                force::gathered_forces(&air, dt, x, relative, triangles, masses, out);
            }
        };
        if parallel {
            tasks.into_par_iter().for_each(forces);
        } else {
            tasks.into_iter().for_each(forces);
        }
    }

    /// Pass 3 (module docs): each element's sums, added by the solver.
    pub(super) fn push(&self, lanes: &mut dyn Lanes) {
        let slot = |e: usize| -> PointLanes {
            let octets = &self.octets[self.octet_offsets[e] as usize..self.octet_offsets[e + 1] as usize];
            let extras = &self.extras[self.extra_offsets[e] as usize..self.extra_offsets[e + 1] as usize];
            element_sum(&self.octet_force, octets, extras, &self.third_force, self.scale)
        };
        lanes.push_lanes(&slot);
    }
}

/// Pass 1 on one tile: its positions and displacements (from element
/// `first`), the copy of x and the air's velocity to write, and its
/// aligned octets with their masses and thirds.
struct TileTask<'a, 'b> {
    position: &'a [PointLanes],
    displacement: &'a [PointLanes],
    first: usize,
    x: &'b mut [PointLanes],
    u: &'b mut [PointLanes],
    octets: &'b [[u32; 3]],
    masses: &'b [f32],
    out: &'b mut [PointLanes],
}

/// A task of pass 2: aligned octets, or triangles gathered place by place;
/// each with their thirds, corners and masses.
enum ForceTask<'a> {
    Aligned(&'a mut [PointLanes], &'a [[u32; 3]], &'a [f32]),
    Gathered(&'a mut [[f32; 4]], &'a [[u32; 3]], &'a [f32]),
}

dispatch! {
    /// (h/n)² F / m̄ at the eight places of one element: each lane the sum
    /// of its place's triangles' thirds, `octets` (lane l of each) in
    /// lanes, then `extras` (lane, index in `rest`) one by one, times
    /// `scale`.
    fn element_sum(
        octet_force: &[PointLanes],
        octets: &[u32],
        extras: &[(u32, u32)],
        rest: &[[f32; 4]],
        scale: f32,
    ) -> PointLanes = element_sum_body, best = ["x86_64+avx2+fma"]
}

#[inline(always)]
fn element_sum_body(
    octet_force: &[PointLanes],
    octets: &[u32],
    extras: &[(u32, u32)],
    rest: &[[f32; 4]],
    scale: f32,
) -> PointLanes {
    let mut sum = [F32x8::splat(0.0); 3];
    for &j in octets {
        let f = &octet_force[j as usize];
        for k in 0..3 {
            sum[k] = sum[k] + F32x8(f[k]);
        }
    }
    for &(l, at) in extras {
        let f = &rest[at as usize];
        for k in 0..3 {
            sum[k].0[l as usize] += f[k];
        }
    }
    let scale = F32x8::splat(scale);
    [(sum[0] * scale).0, (sum[1] * scale).0, (sum[2] * scale).0]
}
