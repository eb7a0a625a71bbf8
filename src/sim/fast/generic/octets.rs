//! The coloured path's octets: eight bars of one colour projected at once
//! in the lanes of a 256-bit register, in two builds (`octets!`): `avx2`
//! (AVX2 + FMA, 16 registers) and `avx512` (AVX-512 F + VL as well: the
//! same 256-bit instructions, 32 registers).
//!
//! An octet's sixteen ends are rows `[x, y, z, w]` (w the inverse mass).
//! Lanes l and l + 4 sit in one register's two halves: one 32-byte load
//! where the colouring paired them as a dimer's two rows
//! ([`super::pairs`]), two 16-byte loads otherwise. The projection
//! ([`crate::sim::fast::kernel`]) needs d = x_b − x_a and the weights in
//! lanes; it gives, per bar, the multiples c_a, c_b of d that move the ends
//! (x_a += c_a d, x_b −= c_b d).
//!
//! **Row form.** d is taken in rows (four subtractions), its w replaced by
//! w_a (a blend, not a shuffle), and only that is transposed (8 shuffles,
//! giving d and w_a in lanes); w_b takes 3. The square root and division
//! stay in lanes, eight bars an instruction. The moves are made in rows:
//! c_a and c_b are spread over each register's halves (one in-lane permute
//! per register and end, 8) and x ± c d is one multiply-add per register
//! with d's w masked to 0, so w is kept exactly (w + c · 0 = w). The same
//! bits as one bar at a time: d, ℓ², c_a, c_b and each fused x ± c d are
//! the same operations on the same values (a test checks both builds
//! against one bar at a time and each other).
//!
//! **Why rows.** The octets had been *transposed*: both ends' rows into
//! lanes (x, y, z, w of eight bars: 8 shuffles an end), projected in lanes
//! and transposed back (8 an end), 32 shuffles an octet where the row form
//! takes 19. On an Intel Xeon (Emerald Rapids, host F) the shuffles were
//! what an octet waited on: leaving the transposes back out (a throwaway
//! build) took the tablecloth's step from 393 to 331 µs with the stores
//! kept, 226 µs without either. The row form took it from 379–415 to
//! 270–295 µs (−25 to −29 %), and disc-183's one-thread step from 24.3–25.6
//! to 19.4–20.9 ms (−20 %), in the `avx512` build (the two forms
//! alternated window by window in one process).
//!
//! **Pipelined or not.** The `avx512` build starts octet k + 1 (loads its
//! rows, takes d and ℓ²) before it finishes octet k, which its 32
//! registers hold. In the `avx2` build the started octet (11 registers)
//! cannot stay in registers across the next one's start: pipelined, the
//! row form spilled and was no quicker than the transposed form there
//! (host F: tablecloth −5 % to +4 %, disc-183 +2 % to +6 %; host G +22 to
//! +25 % on disc-183), so that build had kept the transposes. Not
//! pipelined, one octet at a time, the `avx2` build's row form holds in
//! registers but for four rows, and the core's out-of-order window
//! overlaps consecutive octets by itself (bars of one colour share no
//! particle, so the next octet's loads do not wait for this one's stores).
//! On host G (Intel Xeon, AVX-512, the `avx2` build forced) against the
//! transposed, pipelined octets, alternated window by window in one
//! process (medians of 20 windows): the tablecloth on one thread −9 to
//! −10 % (0.249 → 0.226 ms), disc-183 on one thread −2 % (17.9 → 17.5 ms),
//! on two threads −1.6 %. The `avx512` build pipelined stays 1–4 % quicker
//! than the same build not pipelined (tablecloth 0.218 against 0.224 ms,
//! disc-183 16.1 against 16.7 ms), so it keeps the pipeline.
//!
//! Bars of one colour share no particle, so the lanes compute what one bar
//! at a time would ([`relax_one`]), in any order.

#[cfg(target_arch = "x86_64")]
use super::Particle;
#[cfg(target_arch = "x86_64")]
use super::ahead::Ahead;
#[cfg(target_arch = "x86_64")]
use super::colouring::{BarColumns, Colouring};
#[cfg(target_arch = "x86_64")]
use super::sweep::{Sweep, relax_one};

/// The octets of a pass, in row form (module docs). With `$pipelined` (the
/// `avx512` build) the loop starts octet k + 1 (loads its rows, takes d and
/// ℓ²) before it finishes octet k (the division, the moves, the stores):
/// the loads' latency hides behind the last octet's arithmetic. Octets of
/// one colour share no particle, so starting the next before the last is
/// stored reads what the one-at-a-time order reads; a colour's last octet
/// is finished before the next colour starts. Without it (the `avx2` build,
/// whose 16 registers cannot hold a started octet across the next one's
/// start) the octets go one at a time, and the core overlaps them; the
/// AVX2 build pipelined was slower on Intel and on a Zen 3 too (there the
/// tablecloth's quickest windows 5–18 % longer: `docs/performance.md`, host
/// J, 2026-12-07).
///
/// The ends are loaded and stored through raw pointers: the indices were
/// checked once, when the colouring was built (each is below
/// [`Colouring::particles`]), and [`super::sweep::relax_pass`] checks that the
/// particles are that many; the bounds checks of 32 indexed loads and stores
/// an octet were a tenth of the pass (measured in the README).
///
/// One source, two modules: `avx2` compiled for AVX2 + FMA, `avx512` for
/// AVX-512 F + VL as well. The second still computes on 256-bit registers
/// (the same bits), but has 32 of them where AVX2 has 16 (with the
/// transposed octets: stack references in the pass 1 042 → 630, and on a
/// Zen 4 the tablecloth's step ~4 % and disc-183's ~5–10 % shorter, both
/// builds in one process, alternated: `docs/performance.md`).
macro_rules! octets {
    ($module:ident, $features:literal, $pipelined:literal) => {
        #[cfg(target_arch = "x86_64")]
        #[allow(unsafe_code)]
        pub(super) mod $module {
            use std::arch::x86_64::{
                __m128, __m256, _mm_cvtsi64_si128, _mm_loadu_ps, _mm_storeu_ps, _mm256_and_ps, _mm256_blend_ps,
                _mm256_castps256_ps128, _mm256_castsi256_ps, _mm256_cvtepu8_epi32, _mm256_extractf128_ps,
                _mm256_fmadd_ps, _mm256_fnmadd_ps, _mm256_loadu_ps, _mm256_permute_ps, _mm256_permutevar8x32_ps,
                _mm256_set_m128, _mm256_setr_epi32, _mm256_setr_ps, _mm256_shuffle_ps, _mm256_storeu_ps, _mm256_sub_ps,
                _mm256_unpackhi_ps,
            };

            use super::{Ahead, BarColumns, Colouring, Particle, Sweep, relax_one};
            use crate::sim::fast::avx::{Avx, transpose_pairs};
            use crate::sim::fast::kernel::{LANES, Real, excess, length_squared, pair_shares};

            /// Whether an octet is started before the last one is finished
            /// (`octets!`).
            const PIPELINED: bool = $pipelined;

            /// [`crate::sim::fast::generic::sweep::relax_pass`] with eight bars
            /// at a time.
            ///
            /// # Safety
            /// The CPU has the features this module is compiled for (`octets!`),
            /// and `particles.len() >= colouring.particles`.
            #[target_feature(enable = $features)]
            pub(in crate::sim::fast::generic) unsafe fn relax_pass(
                particles: &mut [Particle],
                colouring: &Colouring,
                mu: &mut [f32],
                sweep: &Sweep,
                ahead: &mut Ahead,
            ) -> f32 {
                let columns = Columns::new(&colouring.bars, mu);
                // SAFETY: the caller's promise, passed on.
                unsafe {
                    match (sweep.betas.iter().any(|&b| b > 0.0), sweep.tolerance > 0.0) {
                        (true, true) => relax_colours::<true, true>(particles, colouring, columns, mu, sweep, ahead),
                        (true, false) => relax_colours::<true, false>(particles, colouring, columns, mu, sweep, ahead),
                        (false, true) => relax_colours::<false, true>(particles, colouring, columns, mu, sweep, ahead),
                        (false, false) => {
                            relax_colours::<false, false>(particles, colouring, columns, mu, sweep, ahead)
                        }
                    }
                }
            }

            /// The bar columns and the multipliers as pointers, checked once a pass
            /// to be as long as one another (the multipliers' pointer is taken anew
            /// for each colour, as the particles' rows are): an octet reads eight of each without
            /// a bounds check (the checks, the loop's iterator and the excess when
            /// no tolerance is set were about 30 of an octet's 142 instructions).
            #[derive(Clone, Copy)]
            struct Columns {
                a: *const u32,
                b: *const u32,
                rest: *const f32,
                kind: *const u8,
                mu: *mut f32,
            }

            impl Columns {
                fn new(bars: &BarColumns, mu: &mut [f32]) -> Self {
                    let n = mu.len();
                    assert!(
                        bars.a.len() == n && bars.b.len() == n && bars.rest.len() == n && bars.kind.len() == n,
                        "the colouring's columns and multipliers differ in length"
                    );
                    Columns {
                        a: bars.a.as_ptr(),
                        b: bars.b.as_ptr(),
                        rest: bars.rest.as_ptr(),
                        kind: bars.kind.as_ptr(),
                        mu: mu.as_mut_ptr(),
                    }
                }
            }

            /// Colour by colour, octets pipelined, then the colour's last bars one at
            /// a time ([`relax_one`]).
            ///
            /// # Safety
            /// As [`relax_pass`].
            #[target_feature(enable = $features)]
            unsafe fn relax_colours<const XPBD: bool, const TOLERANCE: bool>(
                particles: &mut [Particle],
                colouring: &Colouring,
                columns: Columns,
                mu: &mut [f32],
                sweep: &Sweep,
                ahead: &mut Ahead,
            ) -> f32 {
                let bars = &colouring.bars;
                let mut worst = f32::NEG_INFINITY;
                for c in 0..colouring.ends.len() {
                    let range = colouring.colour(c);
                    let mut next = range.start;
                    if c < colouring.independent {
                        // Taken anew for each colour: the last colour's bars after
                        // its octets went through `particles` and `mu` themselves.
                        let rows = particles.as_mut_ptr().cast::<f32>();
                        let cols = Columns { mu: mu.as_mut_ptr(), ..columns };
                        let ([both, a_end, others], rest) = colouring.live(c);
                        // SAFETY (each call): `rows` holds `colouring.particles`
                        // rows (the caller's promise), every end of the colouring is
                        // below that, the octets are within the columns (a colour
                        // is), and the colouring lays out the octets paired at both
                        // ends and at end a as `octets_of` requires.
                        unsafe {
                            worst = worst.max(octets_of::<XPBD, TOLERANCE, true, true>(rows, cols, both, sweep, ahead));
                            worst =
                                worst.max(octets_of::<XPBD, TOLERANCE, true, false>(rows, cols, a_end, sweep, ahead));
                            worst =
                                worst.max(octets_of::<XPBD, TOLERANCE, false, false>(rows, cols, others, sweep, ahead));
                        }
                        next = rest;
                    }
                    for (i, mu) in mu.iter_mut().enumerate().take(range.end).skip(next) {
                        worst = worst.max(relax_one::<XPBD, true>(particles, bars, i, mu, sweep));
                    }
                }
                worst
            }

            /// The octets `range` (of one colour, a multiple of eight bars),
            /// pipelined, each prefetching a line of `ahead` (the next block's
            /// rows, [`super::super::ahead`]). With `PA` (`PB`), each octet's lane l + 4 has as end a
            /// (b) the row after lane l's, and each pair of rows is loaded and
            /// stored as one 32 bytes.
            ///
            /// # Safety
            /// As [`start`].
            #[inline(always)]
            unsafe fn octets_of<const XPBD: bool, const TOLERANCE: bool, const PA: bool, const PB: bool>(
                rows: *mut f32,
                columns: Columns,
                range: std::ops::Range<usize>,
                sweep: &Sweep,
                ahead: &mut Ahead,
            ) -> f32 {
                let mut worst = f32::NEG_INFINITY;
                if range.is_empty() {
                    return worst;
                }
                if !PIPELINED {
                    let mut first = range.start;
                    while first < range.end {
                        ahead.line();
                        // SAFETY (`start` and `finish`): the caller's promise.
                        let started = unsafe { start::<PA, PB>(rows, columns, first) };
                        worst = worst.max(unsafe { finish::<XPBD, TOLERANCE, PA, PB>(rows, columns, started, sweep) });
                        first += LANES;
                    }
                    return worst;
                }
                // Written out here, not one function taking `start` and
                // `finish` as closures: closures handed to another function were
                // not inlined into the `target_feature` code (as with
                // `array::map` in `load_rows`), and their calls out of line made
                // the pass fifty times slower (measured). Closures called where
                // they are defined are inlined.
                // SAFETY (each `start` and `finish`): the caller's promise.
                let mut pending = unsafe { start::<PA, PB>(rows, columns, range.start) };
                let mut next = range.start + LANES;
                while next < range.end {
                    ahead.line();
                    let started = unsafe { start::<PA, PB>(rows, columns, next) };
                    worst = worst.max(unsafe { finish::<XPBD, TOLERANCE, PA, PB>(rows, columns, pending, sweep) });
                    pending = started;
                    next += LANES;
                }
                worst.max(unsafe { finish::<XPBD, TOLERANCE, PA, PB>(rows, columns, pending, sweep) })
            }

            /// An octet started: its first bar, its ends' rows as loaded
            /// (register l: lane l's row in its low half, lane l + 4's in its
            /// high), the weights in lanes, and the bars' squared lengths ℓ².
            #[derive(Clone, Copy)]
            struct Started {
                first: usize,
                ra: [__m256; 4],
                rb: [__m256; 4],
                wa: Avx,
                wb: Avx,
                square: Avx,
            }

            /// Rows `index[l]` (low half) and `index[l + 4]` (high half) of
            /// register l: with `PAIRED` one 32-byte load (`index[l + 4]` is the
            /// row after `index[l]`), else two 16-byte ones joined.
            ///
            /// # Safety
            /// AVX2 is available; every index is a row of `rows`; `PAIRED`, each
            /// `index[l + 4]` is the row after `index[l]`.
            #[inline(always)]
            unsafe fn load_rows<const PAIRED: bool>(rows: *const f32, index: &[u32; LANES]) -> [__m256; 4] {
                // Written out, not `[0, 1, 2, 3].map(..)`: the closure handed to
                // `map` was not inlined into the AVX-512 build, and its calls out
                // of line made the pass eight times slower (measured).
                // SAFETY: the caller's promise (each offset is a row's first f32;
                // paired, the next row is lane l + 4's).
                unsafe {
                    if PAIRED {
                        let pair = |l: usize| _mm256_loadu_ps(rows.add(index[l] as usize));
                        [pair(0), pair(1), pair(2), pair(3)]
                    } else {
                        let row = |l: usize| -> __m128 { _mm_loadu_ps(rows.add(index[l] as usize)) };
                        [
                            _mm256_set_m128(row(4), row(0)),
                            _mm256_set_m128(row(5), row(1)),
                            _mm256_set_m128(row(6), row(2)),
                            _mm256_set_m128(row(7), row(3)),
                        ]
                    }
                }
            }

            /// The inverse of [`load_rows`].
            ///
            /// # Safety
            /// As [`load_rows`].
            #[inline(always)]
            unsafe fn store_rows<const PAIRED: bool>(rows: *mut f32, index: &[u32; LANES], pairs: [__m256; 4]) {
                // SAFETY: AVX2 is available and every index is a row of `rows`
                // (paired, the next row is lane l + 4's): the caller's promise.
                unsafe {
                    for (l, pair) in pairs.into_iter().enumerate() {
                        if PAIRED {
                            _mm256_storeu_ps(rows.add(index[l] as usize), pair);
                        } else {
                            _mm_storeu_ps(rows.add(index[l] as usize), _mm256_castps256_ps128(pair));
                            _mm_storeu_ps(rows.add(index[l + 4] as usize), _mm256_extractf128_ps::<1>(pair));
                        }
                    }
                }
            }

            /// Loads bars `first..first + 8`'s ends and takes their squared
            /// lengths: d = x_b − x_a in rows, its w replaced by w_a (a blend),
            /// transposed into lanes (d and w_a), w_b gathered from end b's
            /// rows, and ℓ² = d·d as
            /// [`bar_square`](crate::sim::fast::kernel::bar_square) takes it
            /// ([`length_squared`]).
            ///
            /// # Safety
            /// AVX2 is available; bars `first..first + 8` are within `columns`;
            /// every end of these bars indexes a row of `rows`; with `PA` (`PB`),
            /// each lane l + 4's end a (b) is the row after lane l's.
            #[inline(always)]
            unsafe fn start<const PA: bool, const PB: bool>(
                rows: *const f32,
                columns: Columns,
                first: usize,
            ) -> Started {
                // SAFETY: the caller's promise; AVX2 is available.
                unsafe {
                    let (ia, ib) = (ends(columns.a, first), ends(columns.b, first));
                    let (ra, rb) = (load_rows::<PA>(rows, &ia), load_rows::<PB>(rows, &ib));
                    // [dx, dy, dz, w_a] of lanes l and l + 4 (blend bits 3 and 7:
                    // the w of each half from end a's row).
                    let with_wa = |l: usize| _mm256_blend_ps::<0x88>(_mm256_sub_ps(rb[l], ra[l]), ra[l]);
                    let [dx, dy, dz, wa] = transpose_pairs([with_wa(0), with_wa(1), with_wa(2), with_wa(3)]);
                    // [z z w w] of rows l, l + 1 (each half), then the w's of four.
                    let (t, u) = (_mm256_unpackhi_ps(rb[0], rb[1]), _mm256_unpackhi_ps(rb[2], rb[3]));
                    let wb = Avx(_mm256_shuffle_ps::<0xEE>(t, u));
                    let square = length_squared::<Avx, true>(&[dx, dy, dz]);
                    Started { first, ra, rb, wa, wb, square }
                }
            }

            /// Projects a started octet and stores its ends; returns its largest
            /// excess (as [`super::relax_one`]). c_a and c_b in lanes
            /// ([`pair_shares`]), each spread over its bar's half of a register
            /// (an in-lane permute), and x_a + c_a d, x_b − c_b d as one
            /// multiply-add a register, d's w masked to 0 so that w comes back
            /// as it was: the same operations on the same values as
            /// [`correct_pair`](crate::sim::fast::kernel::correct_pair)'s moves, so
            /// the same bits.
            ///
            /// End a's eight indices are read, its rows stored, and only then end
            /// b's indices read. The compiler cannot tell the index columns from
            /// the rows, so it does not read b's before a's rows are stored: eight
            /// indices are live at a time, not sixteen, and the column pointers
            /// keep their registers. Reading all sixteen first (as the octet's
            /// start does, with no store in between) left the pointers on the
            /// stack, reloaded before each index (`mov 0x8(%rsp)`). The loop of
            /// the octets paired at end a, `avx512` build: 131–145 instructions
            /// with 5–19 stack references before, 125 with none in this order
            /// (`perf annotate` of the loops). On host F (Intel Xeon, Emerald
            /// Rapids) the tablecloth's step took 2–9 % less at AVX-512,
            /// disc-183's 4 % (medians of 20 windows, the two orders alternated
            /// in one process).
            ///
            /// # Safety
            /// As [`start`], and no particle was stored between the octet's start
            /// and this call.
            #[inline(always)]
            unsafe fn finish<const XPBD: bool, const TOLERANCE: bool, const PA: bool, const PB: bool>(
                rows: *mut f32,
                columns: Columns,
                started: Started,
                sweep: &Sweep,
            ) -> f32 {
                let Started { first, mut ra, mut rb, wa, wb, square } = started;
                // SAFETY: bars `first..first + 8` are within the columns (the
                // caller's promise); AVX2 is available.
                let rest = unsafe { Avx(_mm256_loadu_ps(columns.rest.add(first))) };
                // SAFETY: as above, and every end indexes a row (the caller's
                // promise); FMA is available.
                let v = unsafe {
                    let beta = if XPBD { betas(columns.kind.add(first), sweep) } else { Avx::splat(0.0) };
                    let mut mu8 = if XPBD { Avx(_mm256_loadu_ps(columns.mu.add(first))) } else { Avx::splat(0.0) };
                    let omega = Avx::splat(sweep.omega);
                    let (ca, cb, v) = pair_shares::<Avx, XPBD, true>(wa, wb, square, rest, &mut mu8, beta, omega);
                    if XPBD {
                        _mm256_storeu_ps(columns.mu.add(first), mu8.0);
                    }
                    let xyz = _mm256_castsi256_ps(_mm256_setr_epi32(-1, -1, -1, 0, -1, -1, -1, 0));
                    // Lane l's share over the low half, lane l + 4's over the high.
                    let spread = |c: Avx| {
                        [
                            _mm256_permute_ps::<0x00>(c.0),
                            _mm256_permute_ps::<0x55>(c.0),
                            _mm256_permute_ps::<0xAA>(c.0),
                            _mm256_permute_ps::<0xFF>(c.0),
                        ]
                    };
                    let (sa, sb) = (spread(ca), spread(cb));
                    for l in 0..4 {
                        let d = _mm256_and_ps(_mm256_sub_ps(rb[l], ra[l]), xyz);
                        ra[l] = _mm256_fmadd_ps(sa[l], d, ra[l]);
                        rb[l] = _mm256_fnmadd_ps(sb[l], d, rb[l]);
                    }
                    // End a's indices, its rows stored, then end b's (above).
                    store_rows::<PA>(rows, &ends(columns.a, first), ra);
                    store_rows::<PB>(rows, &ends(columns.b, first), rb);
                    v
                };
                largest_excess::<TOLERANCE>(v, wa, wb, rest, sweep)
            }

            /// The octet's largest excess over the tolerance (as
            /// [`super::relax_one`]), from its bars' |ℓ − L| (`v`); −∞ without a
            /// tolerance (`TOLERANCE` false), which no pass then reads.
            #[inline(always)]
            fn largest_excess<const TOLERANCE: bool>(v: Avx, wa: Avx, wb: Avx, rest: Avx, sweep: &Sweep) -> f32 {
                if TOLERANCE {
                    excess(v, wa, wb, Avx::splat(sweep.tolerance) * rest)
                        .lanes()
                        .into_iter()
                        .fold(f32::NEG_INFINITY, Real::max)
                } else {
                    f32::NEG_INFINITY
                }
            }

            /// β of eight bars, by kind: their eight kind bytes (at `kind`),
            /// widened to lanes, pick from the kinds' β (`vpermps`) where eight
            /// checked table lookups went through memory before.
            ///
            /// # Safety
            /// AVX2 is available; `kind` points at eight bytes.
            #[inline(always)]
            unsafe fn betas(kind: *const u8, sweep: &Sweep) -> Avx {
                // SAFETY: the caller's promise.
                let kinds = unsafe { kind.cast::<[u8; LANES]>().read_unaligned() };
                let [b0, b1, b2] = sweep.betas;
                // SAFETY: AVX2 is available (the caller's promise). A kind is below
                // `BarKind::COUNT` = 3; `vpermps` reads only the low three bits of
                // each index, so no lane can pick outside the register.
                unsafe {
                    let table = _mm256_setr_ps(b0, b1, b2, 0.0, 0.0, 0.0, 0.0, 0.0);
                    let index = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(i64::from_le_bytes(kinds)));
                    Avx(_mm256_permutevar8x32_ps(table, index))
                }
            }

            /// The ends at one side (`column`: the columns' `a` or `b`) of bars
            /// `first..first + 8`.
            ///
            /// # Safety
            /// Bars `first..first + 8` are within `column`.
            #[inline(always)]
            unsafe fn ends(column: *const u32, first: usize) -> [u32; LANES] {
                // SAFETY: the caller's promise.
                unsafe { column.add(first).cast::<[u32; LANES]>().read_unaligned() }
            }
        }
    };
}
octets!(avx2, "avx2,fma", false);
octets!(avx512, "avx2,fma,avx512f,avx512vl", true);
