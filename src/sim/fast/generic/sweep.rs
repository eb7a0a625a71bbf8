//! One relaxation pass of the coloured layout: colour by colour; within a
//! colour, eight bars at a time in the lanes of an AVX register.
//!
//! Bars of one colour share no particle, so their projections are
//! independent and their order inside the colour does not change a bit.
//! Eight of them are projected at once in lanes ([`super::octets`]): the
//! eight bars' ends are loaded (a particle is 16 bytes, x y z w, one load
//! each), brought into lanes, projected as [`relax_pair`] projects one, and
//! stored.
//! The kernel computes in each lane exactly what it computes for one `f32`,
//! so the lanes give the bits of one bar at a time (a test checks this). The
//! colour's last `n mod 8` bars, and the last group of bars that found no
//! free colour (not independent), go one at a time in their order. Without
//! AVX2 (or with `DRAPE_SIMD=portable`) the octets run in the portable
//! lanes of [`Wide`] (NEON on AArch64, SSE on x86-64's baseline; see
//! [`relax_pass_portable`]). Both skip the octets whose ends are all fixed
//! ([`Colouring::live`]).
//!
//! A fourth cut (tablecloth step 320–334 → 302–304 µs on a Zen 4, AVX2):
//! an octet's overhead out of the loop. The tolerance is a compile-time
//! variant (no excess is computed when none is set), the loop counts
//! octets, and the bar columns are read through pointers checked once a
//! pass: 142 → 126 instructions in an octet paired at both ends.
//!
//! A fifth (tablecloth step ~280 → ~262 µs on the same Zen 4): the chain
//! a division shorter. `perf` put the octet's hottest samples right after
//! its `vdivps` and `vsqrtps`, i.e. on waits: the division waited on the
//! square root. The kernel now divides by ℓ² (W) instead, beside the
//! square root, and multiplies ([`crate::sim::fast::kernel`]'s module docs).
//!
//! A sixth and a seventh (host D, Zen 4; both builds in one process,
//! alternated window by window, so that the host's noise falls on both):
//! the projection's multiply-adds fused, as on the grid (the kernel's
//! module docs), 14–17 % off the tablecloth's and disc-183's step; and
//! at the AVX-512 level the octets built with AVX-512 F + VL, whose 32
//! registers keep the started octet out of the stack (`octets!`), ~4 % off
//! the tablecloth's and 5–10 % off disc-183's. About a third of the
//! octet's instructions are shuffles (the rows' transposes: 32 of some
//! 100 in an octet paired at both ends, counted in the source); an extra
//! shuffle or an extra add an octet costs about the same, half a cycle, so
//! on that Zen 4 the octet is bound by its instruction count, not by one
//! kind of instruction. On an Intel Xeon the shuffles are what it waits
//! on, and the AVX-512 build moves the octet in row form, with 19 of them
//! in place of 32 (an eighth cut: tablecloth −29 %, disc-183 −20 % on one
//! thread there; [`super::octets`]).
//!
//! Why lanes pay here: one bar's projection is a chain of about 60 cycles
//! (square root, then division) and some 70 instructions, so the CPU's
//! reorder window holds fewer than three bars at once; one bar took about
//! 31 cycles (15.6 ns on a 2 GHz Zen 1). Eight bars in one chain share its
//! latency: 6 ns a bar on the same host (`cargo bench --bench solver --
//! mesh/`), where the octet is still bound by that chain and by its ~200
//! instructions (loads, transposes, bounds checks).
//!
//! Two things shortened the octet further (tablecloth, one thread, a Zen 3:
//! 3.2 → 2.4 ns a bar): its ends are addressed through row offsets checked
//! once, when the colouring is built (a quarter of the octet's ~230
//! instructions had been bounds checks and index shifts), and the loop
//! loads the next octet's ends before it finishes the last one, so those
//! loads wait on nothing ([`super::octets`]). A third (2.4 → 2.0 ns): where lanes l
//! and l + 4 hold bars from the two particles of a dimer ([`super::pairs`]),
//! those two rows are one 32-byte load and store, not two 16-byte ones and
//! a shuffle to join or part them.

use super::Particle;
use super::ahead::Ahead;
use super::colouring::{BarColumns, Colouring, ROW};
use crate::sim::fast::kernel::{LANES, Real, each_lane, excess, relax_pair};
use crate::sim::fast::rows::Rows;
use crate::sim::fast::simd::{self, SimdLevel};
use crate::sim::fast::wide_lanes::Wide;

/// What a pass needs, by bar kind (0 structural, 1 bend, 2 shear).
pub(super) struct Sweep {
    pub(super) betas: [f32; crate::sim::BarKind::COUNT],
    pub(super) omega: f32,
    pub(super) tolerance: f32,
}

/// One pass over every bar; returns `max(|len − rest| − tolerance·rest)`
/// over the bars that can move (−∞ when no tolerance is set). With `lanes`
/// and a CPU with AVX2 ([`simd::level`]), eight bars of a colour at a time,
/// prefetching a line of `ahead` an octet ([`super::ahead`]); otherwise
/// one at a time (the same bits).
#[allow(unsafe_code)]
#[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
pub(super) fn relax_pass(
    particles: &mut [Particle],
    colouring: &Colouring,
    mu: &mut [f32],
    sweep: &Sweep,
    lanes: bool,
    ahead: &mut Ahead,
) -> f32 {
    assert!(particles.len() >= colouring.particles, "the colouring's ends index {} particles", colouring.particles);
    #[cfg(target_arch = "x86_64")]
    if lanes && simd::level() >= SimdLevel::Avx2 {
        // SAFETY: `simd::level` is AVX2 or above only when the CPU reports
        // AVX2 and FMA, and AVX-512 only when it also reports AVX-512 F and
        // VL (`SimdLevel::best_available`): the features `avx2::relax_pass`
        // and `avx512::relax_pass` are compiled for. The particles are as
        // many as the colouring's ends index (checked above).
        return unsafe {
            if simd::level() == SimdLevel::Avx512 {
                super::octets::avx512::relax_pass(particles, colouring, mu, sweep, ahead)
            } else {
                super::octets::avx2::relax_pass(particles, colouring, mu, sweep, ahead)
            }
        };
    }
    relax_pass_portable(particles, colouring, mu, sweep, lanes)
}

/// [`relax_pass`] without `std::arch`: with `lanes`, the octets in the
/// portable lanes ([`Wide`]: two NEON registers on AArch64, two SSE
/// registers on x86-64's baseline), otherwise every bar one at a time. The
/// same bits either way.
///
/// One bar at a time is a chain of a square root and a division that the
/// CPU overlaps with little else. On host F (Intel Xeon, x86-64 baseline
/// build, `DRAPE_SIMD=portable`) the tablecloth's step took 14.9–15.7 ns a
/// projection so, about the reference solver's 17–18 ns; in [`Wide`]'s
/// lanes 5.5–5.8 ns. Both ways alternated in one process: the tablecloth's
/// step 2.5–2.8 → 1.36–1.43 ms, disc-183's 122–165 → 78–86 ms (medians;
/// `docs/performance.md`). The octets in [`F32x8`](crate::sim::fast::kernel::F32x8)
/// were no quicker than one at a time (the compiler kept half of each
/// octet scalar, on x86-64 and AArch64 alike).
fn relax_pass_portable(
    particles: &mut [Particle],
    colouring: &Colouring,
    mu: &mut [f32],
    sweep: &Sweep,
    lanes: bool,
) -> f32 {
    let xpbd = sweep.betas.iter().any(|&b| b > 0.0);
    // The level's rounding: fused where it has FMA (at AVX2 and above this
    // path runs only when the lanes are not asked for, in tests, and
    // `f32::mul_add` gives the fused bits there too).
    let fused = simd::level() >= SimdLevel::Avx2 || simd::PORTABLE_FUSED;
    let mut worst = f32::NEG_INFINITY;
    // Bars `range` one at a time, or (`octets`, with `lanes`) eight at a time.
    let mut relax = |range: std::ops::Range<usize>, octets: bool| {
        let bars = &colouring.bars;
        if octets && lanes {
            let w = match (xpbd, fused) {
                (true, true) => relax_octets::<true, true>(particles, bars, range, mu, sweep),
                (true, false) => relax_octets::<true, false>(particles, bars, range, mu, sweep),
                (false, true) => relax_octets::<false, true>(particles, bars, range, mu, sweep),
                (false, false) => relax_octets::<false, false>(particles, bars, range, mu, sweep),
            };
            worst = worst.max(w);
            return;
        }
        for i in range {
            let mu = &mut mu[i];
            let w = match (xpbd, fused) {
                (true, true) => relax_one::<true, true>(particles, bars, i, mu, sweep),
                (true, false) => relax_one::<true, false>(particles, bars, i, mu, sweep),
                (false, true) => relax_one::<false, true>(particles, bars, i, mu, sweep),
                (false, false) => relax_one::<false, false>(particles, bars, i, mu, sweep),
            };
            worst = worst.max(w);
        }
    };
    // The bars the lanes take, in their order, less the still octets.
    for c in 0..colouring.colours() {
        if c < colouring.independent {
            let (octets, rest) = colouring.live(c);
            octets.into_iter().for_each(|octets| relax(octets, true));
            relax(rest..colouring.colour(c).end, false);
        } else {
            relax(colouring.colour(c), false);
        }
    }
    worst
}

#[cfg(test)]
thread_local! {
    /// Octets [`relax_octets`] projected on this thread: the bit test below
    /// counts them, since a pass that never took the lanes would give the
    /// bits of one bar at a time too.
    static PORTABLE_OCTETS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// The octets `range` (bars of one colour, a multiple of eight) in the
/// portable lanes, one octet at a time: each lane computes what
/// [`relax_one`] computes for its bar (the kernel is one source for `f32`
/// and the lanes), and bars of one colour share no particle, so the octet's
/// order among its bars changes nothing.
#[inline(always)]
fn relax_octets<const XPBD: bool, const FUSED: bool>(
    particles: &mut [Particle],
    bars: &BarColumns,
    range: std::ops::Range<usize>,
    mu: &mut [f32],
    sweep: &Sweep,
) -> f32 {
    let rows: &mut [[f32; 4]] = bytemuck::cast_slice_mut(particles);
    let (a, b, rest, kind) =
        (&bars.a[range.clone()], &bars.b[range.clone()], &bars.rest[range.clone()], &bars.kind[range.clone()]);
    let mu = &mut mu[range];
    let omega = Wide::splat(sweep.omega);
    let mut worst = f32::NEG_INFINITY;
    let octets = a.chunks_exact(LANES).zip(b.chunks_exact(LANES)).zip(rest.chunks_exact(LANES));
    for (((a, b), rest), (kind, mu)) in octets.zip(kind.chunks_exact(LANES).zip(mu.chunks_exact_mut(LANES))) {
        #[cfg(test)]
        PORTABLE_OCTETS.with(|n| n.set(n.get() + 1));
        let (ia, ib) = (each_lane!(|l| (a[l] / ROW) as usize), each_lane!(|l| (b[l] / ROW) as usize));
        let [ax, ay, az, wa] = Wide::gather(rows, &ia);
        let [bx, by, bz, wb] = Wide::gather(rows, &ib);
        let (mut pa, mut pb) = ([ax, ay, az], [bx, by, bz]);
        let rest = Wide::from_values(each_lane!(|l| rest[l]));
        let beta =
            if XPBD { Wide::from_values(each_lane!(|l| sweep.betas[usize::from(kind[l])])) } else { Wide::splat(0.0) };
        let mut mu8 = if XPBD { Wide::from_values(each_lane!(|l| mu[l])) } else { Wide::splat(0.0) };
        let v = relax_pair::<Wide, XPBD, FUSED>(&mut pa, wa, &mut pb, wb, rest, &mut mu8, beta, omega);
        if XPBD {
            mu.copy_from_slice(mu8.as_array());
        }
        // Bars of one colour share no particle: end a's rows, then end b's.
        for (row, &i) in Wide::to_rows([pa[0], pa[1], pa[2], wa]).into_iter().zip(&ia) {
            rows[i] = row;
        }
        for (row, &i) in Wide::to_rows([pb[0], pb[1], pb[2], wb]).into_iter().zip(&ib) {
            rows[i] = row;
        }
        if sweep.tolerance > 0.0 {
            let excess = excess(v, wa, wb, Wide::splat(sweep.tolerance) * rest);
            worst = excess.to_array().into_iter().fold(worst, Real::max);
        }
    }
    worst
}

/// Projects bar `i` alone, its multiply-adds fused with `FUSED`.
#[inline(always)]
pub(super) fn relax_one<const XPBD: bool, const FUSED: bool>(
    particles: &mut [Particle],
    bars: &BarColumns,
    i: usize,
    mu: &mut f32,
    sweep: &Sweep,
) -> f32 {
    let (ia, ib) = bars.ends(i);
    let (mut a, mut b) = (particles[ia], particles[ib]);
    let (wa, wb) = (a.weight, b.weight);
    let rest = bars.rest[i];
    let beta = sweep.betas[usize::from(bars.kind[i])];
    let v = relax_pair::<f32, XPBD, FUSED>(&mut a.position, wa, &mut b.position, wb, rest, mu, beta, sweep.omega);
    particles[ia] = a;
    particles[ib] = b;
    if sweep.tolerance > 0.0 { excess(v, wa, wb, sweep.tolerance * rest) } else { f32::NEG_INFINITY }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::super::GenericLayout;
    #[cfg(target_arch = "x86_64")]
    use super::super::octets::{avx2, avx512};
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

    /// Positions, weights and multipliers, as bits (the row form moves
    /// whole rows, weights included: they must come back unchanged).
    fn bits(layout: &GenericLayout) -> Vec<u32> {
        let positions =
            layout.particles.iter().flat_map(|p| [p.position.map(f32::to_bits), [p.weight.to_bits(); 3]]).flatten();
        positions.chain(layout.bars.blocks[0].multipliers.iter().map(|m| m.to_bits())).collect()
    }

    /// Unequal masses for `n` particles: weights 1, ½, ⅓ and 0 (fixed) in
    /// turn.
    fn unequal_weights(n: usize) -> Vec<f32> {
        (0..n).map(|i| [1.0, 0.5, 1.0 / 3.0, 0.0][i % 4]).collect()
    }

    /// The four variants the sweep compiles: rigid bars, and compliant ones
    /// of three different β over-relaxed, each with and without a
    /// tolerance.
    fn variants() -> [Sweep; 4] {
        let (rigid, compliant) = (([0.0; 3], 1.0), ([0.3, 2.0, 0.7], 1.2));
        [(rigid, 0.0), (rigid, 0.001), (compliant, 0.0), (compliant, 0.001)].map(|((betas, omega), tolerance)| Sweep {
            betas,
            omega,
            tolerance,
        })
    }

    #[test]
    fn lanes_give_the_bits_of_one_bar_at_a_time() {
        if simd::level() < SimdLevel::Avx2 {
            eprintln!("no AVX2 here (or DRAPE_SIMD): the AVX lanes are not used (the portable ones are tested below)");
            return;
        }
        lanes_match_one_at_a_time(|p, c, mu, sweep| relax_pass(p, c, mu, sweep, true, &mut Ahead::none()));
    }

    #[test]
    fn portable_lanes_give_the_bits_of_one_bar_at_a_time() {
        // At any level: the portable octets are what a CPU without AVX2
        // runs (and `DRAPE_SIMD=portable`).
        PORTABLE_OCTETS.with(|n| n.set(0));
        let live = lanes_match_one_at_a_time(|p, c, mu, sweep| relax_pass_portable(p, c, mu, sweep, true));
        // The same bits could come from a pass that skipped the lanes: every
        // live octet went through them, in each of the 4 variants × 3
        // passes (the passes one bar at a time take none).
        assert_eq!(PORTABLE_OCTETS.with(|n| n.get()), 4 * 3 * live, "octets through the portable lanes");
    }

    /// Three passes of `lanes` against three of one bar at a time, bit for
    /// bit (positions, weights, multipliers, the worst excess), with unequal
    /// masses and every variant the sweep compiles: the lanes take weights
    /// and β per bar, and the excess. Returns the live octets of the sheet's
    /// colouring (what a pass in lanes takes: more than 8 bars in 10).
    fn lanes_match_one_at_a_time(lanes: impl Fn(&mut [Particle], &Colouring, &mut [f32], &Sweep) -> f32) -> usize {
        let (positions, bars) = crumpled_sheet(40);
        let weights = unequal_weights(positions.len());
        for sweep in variants() {
            let betas = sweep.betas;
            let layout = GenericLayout::new(&positions, &positions, &weights, &bars, None);
            assert_eq!(layout.bars.blocks.len(), 1, "a small sheet is one block");
            let (mut one, mut in_lanes) = (layout.clone(), layout);
            for pass in 0..3 {
                let (g1, g8) = (&mut one.bars.blocks[0], &mut in_lanes.bars.blocks[0]);
                let w1 = relax_pass_portable(&mut one.particles, &g1.colouring, &mut g1.multipliers, &sweep, false);
                let w8 = lanes(&mut in_lanes.particles, &g8.colouring, &mut g8.multipliers, &sweep);
                assert_eq!(w1.to_bits(), w8.to_bits(), "worst excess, pass {pass}, β {betas:?}");
            }
            assert_eq!(bits(&one), bits(&in_lanes), "β {betas:?}");
            // The sweeps moved the sheet (it was stretched 3 %), and most bars
            // went through lanes: colours of at least 8 bars.
            let moved = one.particles.iter().zip(&positions).filter(|(p, x)| p.position != x.to_array()).count();
            assert!(moved > positions.len() / 2, "{moved} of {} particles moved", positions.len());
            let colouring = &one.bars.blocks[0].colouring;
            let in_lanes: usize = (0..colouring.independent).map(|c| colouring.colour(c).len() / LANES * LANES).sum();
            assert!(in_lanes > bars.len() * 9 / 10, "{in_lanes} of {} bars in lanes", bars.len());
            // All three pairings of an octet's lanes l and l + 4 ran: rows
            // paired at both ends, at end a, and not at all (a load of the
            // wrong rows in any of them would change the bits above).
            let ([both, a_end], _) = one.bars.paired_share();
            let others = in_lanes - both - a_end;
            assert!(both > bars.len() / 4 && a_end > bars.len() / 4 && others > 0, "{both} {a_end} {others}");
        }
        let layout = GenericLayout::new(&positions, &positions, &weights, &bars, None);
        let colouring = &layout.bars.blocks[0].colouring;
        let live: usize = (0..colouring.independent)
            .map(|c| colouring.live(c).0.iter().map(|r| r.len() / LANES).sum::<usize>())
            .sum();
        assert!(live * LANES > bars.len() * 8 / 10, "{live} octets for {} bars", bars.len());
        live
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    fn the_avx512_build_of_the_octets_gives_the_avx2_bits() {
        if SimdLevel::best_available() < SimdLevel::Avx512 {
            eprintln!("no AVX-512 here: only the AVX2 build of the octets runs");
            return;
        }
        // The two modules are one source compiled with more registers for
        // one of them; every variant and unequal masses, as in the test
        // above.
        let (positions, bars) = crumpled_sheet(40);
        let weights = unequal_weights(positions.len());
        for sweep in variants() {
            let betas = sweep.betas;
            let layout = GenericLayout::new(&positions, &positions, &weights, &bars, None);
            let before = bits(&layout);
            let (mut narrow, mut wide) = (layout.clone(), layout);
            for pass in 0..3 {
                let (g2, g5) = (&mut narrow.bars.blocks[0], &mut wide.bars.blocks[0]);
                // SAFETY: the CPU has AVX-512 F + VL, AVX2 and FMA (checked
                // above), and each layout's particles are as many as its
                // colouring indexes (one block holds them all).
                let (w2, w5) = unsafe {
                    (
                        avx2::relax_pass(
                            &mut narrow.particles,
                            &g2.colouring,
                            &mut g2.multipliers,
                            &sweep,
                            &mut Ahead::none(),
                        ),
                        avx512::relax_pass(
                            &mut wide.particles,
                            &g5.colouring,
                            &mut g5.multipliers,
                            &sweep,
                            &mut Ahead::none(),
                        ),
                    )
                };
                assert_eq!(w2.to_bits(), w5.to_bits(), "worst excess, pass {pass}, β {betas:?}");
            }
            assert_eq!(bits(&narrow), bits(&wide), "β {betas:?}");
            assert_ne!(bits(&narrow)[..3 * positions.len()], before[..3 * positions.len()], "the passes moved nothing");
        }
    }

    #[test]
    #[should_panic(expected = "the colouring's ends index 1600 particles")]
    fn a_colouring_swept_over_too_few_particles_is_refused() {
        // The AVX2 sweep loads and stores without bounds checks, trusting
        // that the particles are as many as the colouring's ends index: a
        // shorter slice must stop at the check, not be read past its end.
        let (positions, bars) = crumpled_sheet(40);
        let weights = vec![1.0; positions.len()];
        let mut layout = GenericLayout::new(&positions, &positions, &weights, &bars, None);
        let sweep = Sweep { betas: [0.0; 3], omega: 1.0, tolerance: 0.0 };
        let group = &mut layout.bars.blocks[0];
        relax_pass(
            &mut layout.particles[..1599],
            &group.colouring,
            &mut group.multipliers,
            &sweep,
            true,
            &mut Ahead::none(),
        );
    }

    #[test]
    fn blocks_and_seams_give_the_same_bits_on_one_thread_and_on_two() {
        // 130 × 130 = 16 900 particles, more than one block holds: four
        // blocks (a multiple of four) and three seams between them; unequal
        // masses and compliant bars as above. Four more bars join the first
        // row to the last (blocks 0 and 3, not neighbours), each 10 % longer
        // than its rest length: the group relaxed on one thread.
        let (positions, mut bars) = crumpled_sheet(130);
        let n = positions.len();
        let far: Vec<(u32, u32)> = (0..4).map(|c| (c * 40, 129 * 130 + c * 40 + 1)).collect();
        for &(a, b) in &far {
            let rest_length = positions[a as usize].distance(positions[b as usize]) / 1.1;
            bars.push(crate::sim::mesh::Bar { a, b, rest_length, kind: crate::sim::BarKind::Bend });
        }
        let weights = unequal_weights(n);
        let weights: Vec<f32> = weights
            .iter()
            .enumerate()
            .map(|(i, &w)| if far.iter().any(|f| f.0 as usize == i) { 1.0 } else { w })
            .collect();
        // In the scene's order (rows), so that the far bars stay far.
        let layout = GenericLayout::in_order(&positions, &positions, &weights, &bars, None, None);
        assert_eq!(layout.bars.blocks.len(), 4);
        assert_eq!(layout.bars.far_bars(), 4);
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
            let (mut x, mut x_prev) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
            crate::sim::step::Solver::read(&l, &mut x, &mut x_prev);
            let bits = l
                .particles
                .iter()
                .flat_map(|p| p.position.map(f32::to_bits))
                .chain(l.bars.multipliers().map(f32::to_bits))
                .collect::<Vec<u32>>();
            (bits, x)
        };
        let (one, x) = run(1);
        assert_eq!(one, run(2).0);
        // The passes moved the sheet, and each far bar got shorter (its free
        // end at row 0 pulled toward the last row).
        assert_ne!(x, positions);
        for &(a, b) in &far {
            let (before, after) =
                (positions[a as usize].distance(positions[b as usize]), x[a as usize].distance(x[b as usize]));
            assert!(after < before - 0.01, "far bar {a}–{b}: {before} → {after}");
        }
    }
}
