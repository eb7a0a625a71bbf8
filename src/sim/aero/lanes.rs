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
//!    octets summed in lanes, then its other triangles in rounds of eight
//!    rows, one a lane (round r brings each lane its r-th other triangle,
//!    or −0, which adds nothing), so each lane adds the same values in the
//!    same order as one lane at a time would.

use rayon::prelude::*;

use super::noise::{self, Field};
use super::{AeroStep, PointLanes, TRIANGLES, force};
use crate::sim::csr::csr;
use crate::sim::fast::kernel::LANES;
use crate::sim::fast::rows::Rows;
#[cfg(target_arch = "x86_64")]
use crate::sim::fast::simd::{self, SimdLevel};
use crate::sim::fast::wide_lanes::Wide;
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
    /// A third of the force of each triangle of `triangles`, N, as rows,
    /// then a row of −0 (what a round gives a lane it has nothing for).
    third_force: Vec<[f32; 4]>,
    /// The aligned octets with a corner in element e:
    /// `octets[octet_offsets[e]..octet_offsets[e + 1]]`. Lane l of each is
    /// a triangle of place 8e + l, and these are all its aligned ones.
    octet_offsets: Vec<u32>,
    octets: Vec<u32>,
    /// Element e's other triangles in rounds,
    /// `extras[extra_offsets[e]..extra_offsets[e + 1]]`: lane l of round r
    /// is the index in `third_force` of the r-th other triangle of place
    /// 8e + l, or of the row of −0 when it has fewer.
    extra_offsets: Vec<u32>,
    extras: Vec<[u32; LANES]>,
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
        let (extra_offsets, extras) = rounds(elements, csr(elements, extra), rest.len() as u32);
        let zero = [[0.0; LANES]; 3];
        Self {
            octet_force: vec![zero; aligned.len()],
            aligned,
            tile_octets,
            tile_starts,
            third_force: std::iter::repeat_n([0.0; 4], rest.len()).chain([[-0.0; 4]]).collect(),
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
            // (`aerodynamics` in `simulation/setup.rs`); were another solver to
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
        // The row of −0 at the end is not a triangle's.
        let gathered_tasks = third_force[..triangles.len()]
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

/// (h/n)² F / m̄ at the eight places of one element: each lane the sum
/// of its place's triangles' thirds, `octets` (lane l of each) in lanes,
/// then `rounds` of `rest`'s rows (lane l of each round its place's next
/// other triangle, or the row of −0), times `scale`.
#[allow(unsafe_code)]
fn element_sum(
    octet_force: &[PointLanes],
    octets: &[u32],
    rounds: &[[u32; LANES]],
    rest: &[[f32; 4]],
    scale: f32,
) -> PointLanes {
    #[cfg(target_arch = "x86_64")]
    if simd::level() >= SimdLevel::Avx2 {
        // SAFETY: the level is AVX2 or above only when the CPU reports AVX2
        // and FMA, the features `avx2::element_sum` is compiled for.
        return unsafe { avx2::element_sum(octet_force, octets, rounds, rest, scale) };
    }
    element_sum_in::<Wide>(octet_force, octets, rounds, rest, scale)
}

/// [`element_sum`] in AVX registers.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{LANES, PointLanes, element_sum_in};
    use crate::sim::fast::avx::Avx;

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn element_sum(
        octet_force: &[PointLanes],
        octets: &[u32],
        rounds: &[[u32; LANES]],
        rest: &[[f32; 4]],
        scale: f32,
    ) -> PointLanes {
        element_sum_in::<Avx>(octet_force, octets, rounds, rest, scale)
    }
}

/// [`element_sum`] on lanes of type `T`. Each lane adds the same values in
/// the same order as it would alone (−0 adds nothing to any sum, −0
/// included), so the sums have the bits of one lane at a time.
#[inline(always)]
fn element_sum_in<T: Rows>(
    octet_force: &[PointLanes],
    octets: &[u32],
    rounds: &[[u32; LANES]],
    rest: &[[f32; 4]],
    scale: f32,
) -> PointLanes {
    let mut sum = [T::splat(0.0); 3];
    for &j in octets {
        let f = &octet_force[j as usize];
        for k in 0..3 {
            sum[k] = sum[k] + T::from_values(f[k]);
        }
    }
    for round in rounds {
        let [x, y, z, _] = T::gather(rest, &round.map(|at| at as usize));
        sum = [sum[0] + x, sum[1] + y, sum[2] + z];
    }
    let scale = T::splat(scale);
    [(sum[0] * scale).to_values(), (sum[1] * scale).to_values(), (sum[2] * scale).to_values()]
}

/// Each element's other triangles `(lane, index)` (`csr`: offsets by
/// element, then the pairs) as rounds ([`LaneForm::extras`]), the lanes
/// with fewer given `none`.
fn rounds(elements: usize, (offsets, extras): (Vec<u32>, Vec<(u32, u32)>), none: u32) -> (Vec<u32>, Vec<[u32; LANES]>) {
    let mut round_offsets = Vec::with_capacity(elements + 1);
    let mut rounds: Vec<[u32; LANES]> = Vec::new();
    round_offsets.push(0);
    for e in 0..elements {
        let first = rounds.len();
        let mut taken = [0usize; LANES];
        for &(l, at) in &extras[offsets[e] as usize..offsets[e + 1] as usize] {
            let r = first + taken[l as usize];
            if r == rounds.len() {
                rounds.push([none; LANES]);
            }
            rounds[r][l as usize] = at;
            taken[l as usize] += 1;
        }
        round_offsets.push(rounds.len() as u32);
    }
    (round_offsets, rounds)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounds_give_each_lane_its_own_sums_in_order() {
        // Three elements: the first with no other triangles, the second
        // with three in lane 2, one in lane 5 and two in lane 7 (three
        // rounds), the third with one in lane 0. Each lane's sum must add
        // the octets, then its own rows in their order, as one lane alone
        // does: values of mixed sizes, so that another order rounds
        // differently.
        let extras = vec![(2, 4), (7, 1), (2, 0), (5, 3), (7, 5), (2, 2), (0, 6)];
        let offsets = vec![0, 0, 6, 7];
        let (round_offsets, rounds) = rounds(3, (offsets.clone(), extras.clone()), 7);
        assert_eq!(round_offsets, [0, 0, 3, 4]);
        let rest: Vec<[f32; 4]> = [1e8, 1.5, -1e8, 3.0, 0.5, 2.0, 7.0]
            .into_iter()
            .map(|v: f32| [v, -v * 0.37, v * 1.9, 0.0])
            .chain([[-0.0; 4]])
            .collect();
        let octet_force: Vec<PointLanes> = (0..2)
            .map(|j| [0, 1, 2].map(|k| std::array::from_fn(|l| 0.1 + (j * 31 + k * 7 + l) as f32 * 0.3)))
            .collect();
        let octets = [1, 0];
        let scale = 0.73;
        for e in 0..3 {
            let mine = &extras[offsets[e] as usize..offsets[e + 1] as usize];
            let round = &rounds[round_offsets[e] as usize..round_offsets[e + 1] as usize];
            let expected: PointLanes = [0, 1, 2].map(|k| {
                std::array::from_fn(|l| {
                    let mut sum = 0.0f32;
                    for &j in &octets {
                        sum += octet_force[j as usize][k][l];
                    }
                    for &(_, at) in mine.iter().filter(|&&(lane, _)| lane as usize == l) {
                        sum += rest[at as usize][k];
                    }
                    sum * scale
                })
            });
            let bits = |p: PointLanes| p.map(|c| c.map(f32::to_bits));
            let level = element_sum(&octet_force, &octets, round, &rest, scale);
            let portable = element_sum_in::<Wide>(&octet_force, &octets, round, &rest, scale);
            assert_eq!(bits(level), bits(expected), "element {e}");
            assert_eq!(bits(portable), bits(expected), "element {e}, portable");
        }
        // Lane 2 of element 1 adds rows 4, 0 and 2 in that order: 0.5, then
        // 10⁸, which absorbs it and the octets' sum, then −10⁸. By row
        // (0, 2, 4) the sum would keep the 0.5, so the test sees the order.
        let start: f32 = octets.iter().map(|&j| octet_force[j as usize][0][2]).sum();
        let listed = ((start + rest[4][0]) + rest[0][0]) + rest[2][0];
        let by_row = ((start + rest[0][0]) + rest[2][0]) + rest[4][0];
        assert_ne!(listed.to_bits(), by_row.to_bits());
    }
}
