//! One relaxation pass of the coloured layout: colour by colour; within a
//! colour, eight bars at a time in the lanes of an AVX register.
//!
//! Bars of one colour share no particle, so their projections are
//! independent and their order inside the colour does not change a bit.
//! Eight of them are projected by one call of [`relax_pair`] on lanes: the
//! eight bars' ends are loaded (a particle is 16 bytes, x y z w, one load
//! each) and transposed into lanes, projected, transposed back and stored.
//! The kernel computes in each lane exactly what it computes for one `f32`,
//! so the lanes give the bits of one bar at a time (a test checks this). The
//! colour's last `n mod 8` bars, and the last group of bars that found no
//! free colour (not independent), go one at a time in their order. Without
//! AVX2 (or with `DRAPE_SIMD=portable`) every bar goes one at a time.
//!
//! Why lanes pay here: one bar's projection is a chain of about 60 cycles
//! (square root, then division) and some 70 instructions, so the CPU's
//! reorder window holds fewer than three bars at once; one bar took about
//! 31 cycles (15.6 ns on a 2 GHz Zen 1). Eight bars in one chain share its
//! latency: 6 ns a bar on the same host (`cargo bench --bench solver --
//! mesh/`), where the octet is still bound by that chain and by its ~200
//! instructions (loads, transposes, bounds checks).

use super::Particle;
use super::colouring::{BarColumns, Colouring};
use crate::sim::fast::kernel::{LANES, excess, relax_pair};
use crate::sim::fast::simd::{self, SimdLevel};

/// What a pass needs, by bar kind (0 structural, 1 bend, 2 shear).
pub(super) struct Sweep {
    pub(super) betas: [f32; crate::sim::BarKind::COUNT],
    pub(super) omega: f32,
    pub(super) tolerance: f32,
}

/// One pass over every bar; returns `max(|len − rest| − tolerance·rest)`
/// over the bars that can move (−∞ when no tolerance is set). With `lanes`
/// and a CPU with AVX2 ([`simd::level`]), eight bars of a colour at a time;
/// otherwise one at a time (the same bits).
#[allow(unsafe_code)]
pub(super) fn relax_pass(
    particles: &mut [Particle],
    colouring: &Colouring,
    mu: &mut [f32],
    sweep: &Sweep,
    lanes: bool,
) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if lanes && simd::level() >= SimdLevel::Avx2 {
        // SAFETY: `simd::level` is AVX2 or above only when the CPU reports
        // AVX2 and FMA (`SimdLevel::best_available`), the features
        // `avx2::relax_pass` is compiled for.
        return unsafe { avx2::relax_pass(particles, colouring, mu, sweep) };
    }
    let _ = (lanes, SimdLevel::Avx2);
    if sweep.betas.iter().any(|&b| b > 0.0) {
        relax_colours::<true>(particles, colouring, mu, sweep, |_, _, _| None)
    } else {
        relax_colours::<false>(particles, colouring, mu, sweep, |_, _, _| None)
    }
}

/// Colour by colour: `octet(particles, first, mu)` projects bars
/// `first..first + 8` of an independent colour if it can (`Some(worst)`);
/// the rest go one at a time.
#[inline(always)]
fn relax_colours<const XPBD: bool>(
    particles: &mut [Particle],
    colouring: &Colouring,
    mu: &mut [f32],
    sweep: &Sweep,
    mut octet: impl FnMut(&mut [Particle], usize, &mut [f32]) -> Option<f32>,
) -> f32 {
    let mut worst = f32::NEG_INFINITY;
    for c in 0..colouring.ends.len() {
        let range = colouring.colour(c);
        let mut next = range.start;
        if c < colouring.independent {
            while next + LANES <= range.end {
                let Some(w) = octet(particles, next, mu) else { break };
                worst = worst.max(w);
                next += LANES;
            }
        }
        for (i, mu) in mu.iter_mut().enumerate().take(range.end).skip(next) {
            worst = worst.max(relax_one::<XPBD>(particles, &colouring.bars, i, mu, sweep));
        }
    }
    worst
}

/// Projects bar `i` alone.
#[inline(always)]
fn relax_one<const XPBD: bool>(
    particles: &mut [Particle],
    bars: &BarColumns,
    i: usize,
    mu: &mut f32,
    sweep: &Sweep,
) -> f32 {
    let (ia, ib) = (bars.a[i] as usize, bars.b[i] as usize);
    let (mut a, mut b) = (particles[ia], particles[ib]);
    let (wa, wb) = (a.weight, b.weight);
    let rest = bars.rest[i];
    let beta = sweep.betas[usize::from(bars.kind[i])];
    let v = relax_pair::<f32, XPBD>(&mut a.position, wa, &mut b.position, wb, rest, mu, beta, sweep.omega);
    particles[ia] = a;
    particles[ib] = b;
    if sweep.tolerance > 0.0 { excess(v, wa, wb, sweep.tolerance * rest) } else { f32::NEG_INFINITY }
}

/// The AVX2 octet. The compiler does not find the transposes in a lane loop
/// (it spilled every lane to the stack and ran no faster than one bar at a
/// time), and split the kernel on [`F32x8`] here into 4-wide halves; so the
/// octet runs the shared kernel on [`Avx`](crate::sim::fast::avx::Avx), eight lanes in one AVX
/// register, with `std::arch` loads and transposes.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx2 {
    use super::{BarColumns, Colouring, Particle, Sweep, relax_colours};
    use crate::sim::fast::avx::{Avx, gather_rows};
    use crate::sim::fast::kernel::{LANES, Point, Real, excess, relax_pair};
    use crate::sim::fast::rows::Rows;

    /// [`super::relax_pass`] with eight bars at a time.
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn relax_pass(particles: &mut [Particle], colouring: &Colouring, mu: &mut [f32], sweep: &Sweep) -> f32 {
        let bars = &colouring.bars;
        if sweep.betas.iter().any(|&b| b > 0.0) {
            relax_colours::<true>(particles, colouring, mu, sweep, |p, first, mu| {
                Some(relax_octet::<true>(p, bars, first, mu, sweep))
            })
        } else {
            relax_colours::<false>(particles, colouring, mu, sweep, |p, first, mu| {
                Some(relax_octet::<false>(p, bars, first, mu, sweep))
            })
        }
    }

    /// Projects bars `first..first + 8` (one colour: no shared particle).
    #[target_feature(enable = "avx2,fma")]
    fn relax_octet<const XPBD: bool>(
        particles: &mut [Particle],
        bars: &BarColumns,
        first: usize,
        mu: &mut [f32],
        sweep: &Sweep,
    ) -> f32 {
        let ia: [usize; LANES] = std::array::from_fn(|l| bars.a[first + l] as usize);
        let ib: [usize; LANES] = std::array::from_fn(|l| bars.b[first + l] as usize);
        let (mut a, wa) = gather(particles, &ia);
        let (mut b, wb) = gather(particles, &ib);
        let rest = Avx::load(&bars.rest[first..]);
        // Not compliant: every β is 0.
        let beta = if XPBD {
            Avx::from(std::array::from_fn(|l| sweep.betas[usize::from(bars.kind[first + l])]))
        } else {
            Avx::splat(0.0)
        };
        let mut mu8 = Avx::load(&mu[first..]);
        let v = relax_pair::<Avx, XPBD>(&mut a, wa, &mut b, wb, rest, &mut mu8, beta, Avx::splat(sweep.omega));
        if XPBD {
            mu[first..first + LANES].copy_from_slice(&mu8.lanes());
        }
        scatter(particles, &ia, a, wa);
        scatter(particles, &ib, b, wb);
        if sweep.tolerance > 0.0 {
            excess(v, wa, wb, Avx::splat(sweep.tolerance) * rest).lanes().into_iter().fold(f32::NEG_INFINITY, Real::max)
        } else {
            f32::NEG_INFINITY
        }
    }

    /// Eight particles (x y z w each) transposed into lanes: positions and
    /// weights.
    #[inline(always)]
    fn gather(particles: &[Particle], index: &[usize; LANES]) -> (Point<Avx>, Avx) {
        let [x, y, z, w] = gather_rows(bytemuck::cast_slice(particles), index);
        ([x, y, z], w)
    }

    /// The inverse of [`gather`]: particle `index[l]` takes lane l.
    #[inline(always)]
    fn scatter(particles: &mut [Particle], index: &[usize; LANES], x: Point<Avx>, w: Avx) {
        for (row, &i) in Avx::to_rows([x[0], x[1], x[2], w]).into_iter().zip(index) {
            particles[i] = bytemuck::cast(row);
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::super::GenericLayout;
    use super::*;
    use crate::sim::mesh::ClothMesh;

    /// An n × n triangulated sheet, crumpled a little out of its plane and
    /// stretched 3 %, so every bar starts away from its rest length.
    fn crumpled_sheet(n: u32) -> (Vec<Vec3>, Vec<crate::sim::mesh::Bar>) {
        let positions: Vec<Vec3> = (0..n * n)
            .map(|i| {
                let (c, r) = ((i % n) as f32, (i / n) as f32);
                Vec3::new(c * 0.1, r * 0.1, 0.03 * (c * 1.7 + r * 0.9).sin())
            })
            .collect();
        let mut triangles = Vec::new();
        for r in 0..n - 1 {
            for c in 0..n - 1 {
                let i = r * n + c;
                triangles.extend([[i, i + n, i + n + 1], [i, i + n + 1, i + 1]]);
            }
        }
        let mesh =
            ClothMesh::from_triangles(positions.clone(), triangles, &[0, u64::from(n - 1)], None).expect("valid sheet");
        (positions.iter().map(|p| *p * 1.03).collect(), mesh.bars().to_vec())
    }

    /// Positions and multipliers, as bits.
    fn bits(layout: &GenericLayout) -> Vec<u32> {
        let positions = layout.particles.iter().flat_map(|p| p.position.map(f32::to_bits));
        positions.chain(layout.bars.blocks[0].multipliers.iter().map(|m| m.to_bits())).collect()
    }

    #[test]
    fn lanes_give_the_bits_of_one_bar_at_a_time() {
        if simd::level() < SimdLevel::Avx2 {
            eprintln!("no AVX2 here (or DRAPE_SIMD): the lanes are not used, nothing to compare");
            return;
        }
        // Unequal masses (1, ½, ⅓, fixed); rigid bars, then compliant ones
        // of three different β over-relaxed with a tolerance: the lanes take
        // weights and β per bar, and the excess.
        let (positions, bars) = crumpled_sheet(40);
        let weights: Vec<f32> = (0..positions.len()).map(|i| [1.0, 0.5, 1.0 / 3.0, 0.0][i % 4]).collect();
        for (betas, omega, tolerance) in [([0.0; 3], 1.0, 0.0), ([0.3, 2.0, 0.7], 1.2, 0.001)] {
            let layout = GenericLayout::new(&positions, &positions, &weights, &bars, None);
            assert_eq!(layout.bars.blocks.len(), 1, "a small sheet is one block");
            let sweep = Sweep { betas, omega, tolerance };
            let (mut one, mut lanes) = (layout.clone(), layout);
            for pass in 0..3 {
                let (g1, g8) = (&mut one.bars.blocks[0], &mut lanes.bars.blocks[0]);
                let w1 = relax_pass(&mut one.particles, &g1.colouring, &mut g1.multipliers, &sweep, false);
                let w8 = relax_pass(&mut lanes.particles, &g8.colouring, &mut g8.multipliers, &sweep, true);
                assert_eq!(w1.to_bits(), w8.to_bits(), "worst excess, pass {pass}, β {betas:?}");
            }
            assert_eq!(bits(&one), bits(&lanes), "β {betas:?}");
            // The sweeps moved the sheet (it was stretched 3 %), and most bars
            // went through lanes: colours of at least 8 bars.
            let moved = one.particles.iter().zip(&positions).filter(|(p, x)| p.position != x.to_array()).count();
            assert!(moved > positions.len() / 2, "{moved} of {} particles moved", positions.len());
            let colouring = &one.bars.blocks[0].colouring;
            let in_lanes: usize = (0..colouring.independent).map(|c| colouring.colour(c).len() / LANES * LANES).sum();
            assert!(in_lanes > bars.len() * 9 / 10, "{in_lanes} of {} bars in lanes", bars.len());
        }
    }

    #[test]
    fn blocks_give_the_same_bits_on_one_thread_and_on_two() {
        // 130 × 130 = 16 900 particles, more than one block holds: four
        // blocks (a multiple of four) and a boundary between them; unequal
        // masses and compliant bars as above.
        let (positions, bars) = crumpled_sheet(130);
        let weights: Vec<f32> = (0..positions.len()).map(|i| [1.0, 0.5, 1.0 / 3.0, 0.0][i % 4]).collect();
        let layout = GenericLayout::new(&positions, &positions, &weights, &bars, None);
        assert_eq!(layout.bars.blocks.len(), 4);
        let (boundary, all) = layout.bars.boundary_share();
        // Three cuts, each along a row of 130 particles: at least its bars to
        // the next row, and far fewer than 1 bar in 20.
        assert!(boundary > 3 * 130 && boundary < all / 20, "boundary {boundary} of {all}");
        let sweep = Sweep { betas: [0.3, 2.0, 0.7], omega: 1.2, tolerance: 0.0 };
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
            let mut l = layout.clone();
            pool.install(|| {
                for _ in 0..3 {
                    l.bars.relax_pass(&mut l.particles, &sweep);
                }
            });
            let multipliers = l.bars.blocks.iter().chain([&l.bars.boundary]).flat_map(|g| g.multipliers.clone());
            l.particles
                .iter()
                .flat_map(|p| p.position.map(f32::to_bits))
                .chain(multipliers.map(f32::to_bits))
                .collect::<Vec<u32>>()
        };
        let one = run(1);
        assert_eq!(one, run(2));
        // The passes moved the sheet.
        assert_ne!(
            one[..positions.len() * 3],
            positions.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<u32>>()[..]
        );
    }
}
