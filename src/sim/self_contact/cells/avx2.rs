//! [`Cells::pairs_after`] in AVX2 registers. The compiler turned the
//! candidates' lane loop into scalar compares or vector ones depending on the
//! code around it; written out, the query also hashes its 8 cells in lanes,
//! loads their 16 run bounds independently instead of as a chain, and
//! appends its hits by a left-pack instead of a branch per hit.

use std::arch::x86_64::{
    __m256, __m256i, _CMP_GE_OQ, _CMP_LT_OQ, _CMP_UNORD_Q, _mm_cvtsi32_si128, _mm_cvtsi64_si128, _mm256_add_epi32,
    _mm256_add_ps, _mm256_and_ps, _mm256_and_si256, _mm256_andnot_si256, _mm256_blendv_epi8, _mm256_castps_si256,
    _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_cmpgt_epi32, _mm256_cvtepu8_epi32, _mm256_cvttps_epi32, _mm256_floor_ps,
    _mm256_loadu_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_mullo_epi32, _mm256_or_si256,
    _mm256_permutevar8x32_epi32, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setr_epi32, _mm256_setr_ps,
    _mm256_slli_epi32, _mm256_srai_epi32, _mm256_srl_epi32, _mm256_storeu_si256, _mm256_sub_ps, _mm256_xor_si256,
};

use super::{BLOCK_BITS, BLOCK_PRIMES, Cells, FIBONACCI, lanes};
use crate::sim::fast::kernel::LANES;

/// For each 8-bit mask, the lanes of its set bits in order, one byte
/// each: the permutation that packs a lane group's hits to the front.
const PACK: [u64; 256] = {
    let mut table = [0u64; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut packed, mut next, mut lane) = (0u64, 0, 0);
        while lane < 8 {
            if (mask >> lane) & 1 == 1 {
                packed |= (lane as u64) << (8 * next);
                next += 1;
            }
            lane += 1;
        }
        table[mask] = packed;
        mask += 1;
    }
    table
};

/// One query's point and its 8 cells' runs of slots: where each run
/// starts, where its slots after the query's own start, and its end.
#[derive(Clone, Copy)]
struct Runs {
    p: glam::Vec3,
    first: [i32; LANES],
    begin: [i32; LANES],
    end: [i32; LANES],
}

/// The same pairs in the same order as
/// [`super::Cells::pairs_after_portable`]; slots and bucket ends are
/// below 2³¹ (particle counts are `u32`). The next query's hash and
/// bound loads are issued before this one's candidates are tested,
/// whose branches would otherwise hold them back.
#[target_feature(enable = "avx2")]
pub(super) fn pairs_after(
    cells: &Cells,
    first: usize,
    count: usize,
    radius: f32,
    own: &mut Vec<u32>,
    other: &mut Vec<u32>,
) {
    let end = first + count;
    if count == 0 {
        return;
    }
    // What makes `runs`' unchecked loads sound.
    assert_eq!(cells.start.len(), (1 << cells.bits) + 1, "a table built for its bucket count");
    let r2 = radius * radius;
    let mut next = runs(cells, first);
    for slot in first..end {
        let this = next;
        if slot + 1 < end {
            next = runs(cells, slot + 1);
        }
        push_runs(cells, &this, r2, other);
        own.resize(other.len(), slot as u32);
    }
}

/// The runs of the query of `slot`.
#[inline]
#[target_feature(enable = "avx2")]
fn runs(cells: &Cells, slot: usize) -> Runs {
    let p = cells.position(slot);
    // The query's cell, and per axis whether it lies in the lower half
    // of it (−1) or not (0), in lanes 0–2 (`floor().as_ivec3()` kept
    // three scalar saturating conversions, 15 instructions).
    let point = _mm256_setr_ps(p.x, p.y, p.z, 0.0, 0.0, 0.0, 0.0, 0.0);
    let scaled = _mm256_mul_ps(point, _mm256_set1_ps(cells.inverse_side));
    let floor = _mm256_floor_ps(scaled);
    let lower_half = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_sub_ps(scaled, floor), _mm256_set1_ps(0.5));
    let (mut centre, mut below) = ([0i32; LANES], [0i32; LANES]);
    // SAFETY: each store writes the eight values of a `[i32; 8]`.
    unsafe {
        _mm256_storeu_si256(centre.as_mut_ptr() as *mut __m256i, saturate(floor));
        _mm256_storeu_si256(below.as_mut_ptr() as *mut __m256i, _mm256_castps_si256(lower_half));
    }
    // −1 toward the lower neighbour, +1 toward the upper, per axis.
    let (side_y, side_z) = (below[1] | 1, below[2] | 1);
    let low_x = centre[0].wrapping_add(below[0]);
    // Lane k is the cell (k & 1, k >> 1 & 1, k >> 2) steps from the
    // query's lowest along x and toward its sides along y and z: the
    // order of the portable loops.
    let cx = _mm256_add_epi32(_mm256_set1_epi32(low_x), _mm256_setr_epi32(0, 1, 0, 1, 0, 1, 0, 1));
    let step_y = _mm256_and_si256(_mm256_set1_epi32(side_y), _mm256_setr_epi32(0, 0, -1, -1, 0, 0, -1, -1));
    let step_z = _mm256_and_si256(_mm256_set1_epi32(side_z), _mm256_setr_epi32(0, 0, 0, 0, -1, -1, -1, -1));
    let cy = _mm256_add_epi32(_mm256_set1_epi32(centre[1]), step_y);
    let cz = _mm256_add_epi32(_mm256_set1_epi32(centre[2]), step_z);
    let mut h = [0i32; LANES];
    // SAFETY: the store writes the eight values of a `[i32; 8]`.
    unsafe { _mm256_storeu_si256(h.as_mut_ptr() as *mut __m256i, buckets(cx, cy, cz, cells.bits)) };
    // Sixteen plain loads (a gather instruction took longer here),
    // unchecked: the checks were 16 compares and branches a query, 5–8 %
    // of its time on disc-183-like sheets.
    let start = &cells.start;
    let mut runs = Runs { p, first: [0; LANES], begin: [0; LANES], end: [0; LANES] };
    for k in 0..LANES {
        let h = h[k] as u32 as usize;
        // SAFETY: `buckets` gives values below 2^bits (the block's hash
        // in bits 6 and up, below 2^(bits − 6), and the cell's place in
        // its block in bits 0–5), and `pairs_after` checked that the
        // table holds 2^bits + 1 starts: h and h + 1 are in bounds.
        let (first, end) = unsafe { (*start.get_unchecked(h), *start.get_unchecked(h + 1)) };
        runs.first[k] = first as i32;
        runs.begin[k] = runs.first[k].max(slot as i32 + 1);
        runs.end[k] = end as i32;
    }
    runs
}

/// Appends the slots of `runs` near its point, the two cells along x of
/// each pair as one range when their runs are adjacent.
#[inline]
#[target_feature(enable = "avx2")]
fn push_runs(cells: &Cells, runs: &Runs, r2: f32, near: &mut Vec<u32>) {
    // Room for every candidate: a lane group stores eight slots from
    // the current end, but keeps only its hits.
    let candidates: i32 = (0..LANES).map(|k| (runs.end[k] - runs.begin[k]).max(0)).sum();
    near.reserve(candidates as usize + LANES);
    let (begin, end) = (&runs.begin, &runs.end);
    for pair in 0..LANES / 2 {
        let (lower, upper) = (2 * pair, 2 * pair + 1);
        if end[lower] == runs.first[upper] {
            // Adjacent runs (the two cells share a block): one range.
            push_run(cells, begin[lower], end[upper], runs.p, r2, near);
        } else {
            push_run(cells, begin[lower], end[lower], runs.p, r2, near);
            push_run(cells, begin[upper], end[upper], runs.p, r2, near);
        }
    }
}

/// [`super::buckets_of`] eight points at a time: the same buckets.
#[target_feature(enable = "avx2")]
pub(super) fn buckets_of(x: &[glam::Vec3], inverse_side: f32, bits: u32, out: &mut [u32]) {
    let whole = x.len() / LANES * LANES;
    let scale = _mm256_set1_ps(inverse_side);
    for (points, out) in x[..whole].chunks_exact(LANES).zip(out.chunks_exact_mut(LANES)) {
        let (mut xs, mut ys, mut zs) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        for (l, p) in points.iter().enumerate() {
            (xs[l], ys[l], zs[l]) = (p.x, p.y, p.z);
        }
        // SAFETY: each load reads the eight values of a `[f32; 8]`.
        let (cx, cy, cz) = unsafe {
            (
                cells_in_lanes(_mm256_loadu_ps(xs.as_ptr()), scale),
                cells_in_lanes(_mm256_loadu_ps(ys.as_ptr()), scale),
                cells_in_lanes(_mm256_loadu_ps(zs.as_ptr()), scale),
            )
        };
        // SAFETY: the store writes the eight values of a `[u32; 8]`.
        unsafe { _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, buckets(cx, cy, cz, bits)) };
    }
    super::buckets_body(&x[whole..], inverse_side, bits, &mut out[whole..]);
}

/// ⌊v · `scale`⌋ as `i32` in lanes: the cells of [`super::cell_of`].
#[inline]
#[target_feature(enable = "avx2")]
fn cells_in_lanes(v: __m256, scale: __m256) -> __m256i {
    saturate(_mm256_floor_ps(_mm256_mul_ps(v, scale)))
}

/// Whole numbers `floor` as `i32` in lanes, as `as` converts them
/// (saturating, NaN to 0).
#[inline]
#[target_feature(enable = "avx2")]
fn saturate(floor: __m256) -> __m256i {
    // Out of range (either way) and NaN convert to i32::MIN here.
    let converted = _mm256_cvttps_epi32(floor);
    let over = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(floor, _mm256_set1_ps(2_147_483_648.0)));
    let nan = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_UNORD_Q>(floor, floor));
    let saturated = _mm256_blendv_epi8(converted, _mm256_set1_epi32(i32::MAX), over);
    _mm256_andnot_si256(nan, saturated)
}

/// The buckets of cells (x, y, z) in lanes: `super::bucket` lane by lane.
#[inline]
#[target_feature(enable = "avx2")]
fn buckets(cx: __m256i, cy: __m256i, cz: __m256i, bits: u32) -> __m256i {
    let (bx, by, bz) = (
        _mm256_srai_epi32::<{ BLOCK_BITS as i32 }>(cx),
        _mm256_srai_epi32::<{ BLOCK_BITS as i32 }>(cy),
        _mm256_srai_epi32::<{ BLOCK_BITS as i32 }>(cz),
    );
    let mixed = _mm256_xor_si256(
        _mm256_xor_si256(
            _mm256_mullo_epi32(bx, _mm256_set1_epi32(BLOCK_PRIMES[0] as i32)),
            _mm256_mullo_epi32(by, _mm256_set1_epi32(BLOCK_PRIMES[1] as i32)),
        ),
        _mm256_mullo_epi32(bz, _mm256_set1_epi32(BLOCK_PRIMES[2] as i32)),
    );
    let block_bits = bits - 3 * BLOCK_BITS;
    let hashed = _mm256_srl_epi32(
        _mm256_mullo_epi32(mixed, _mm256_set1_epi32(FIBONACCI as i32)),
        _mm_cvtsi32_si128((32 - block_bits) as i32),
    );
    let within = _mm256_set1_epi32((1 << BLOCK_BITS) - 1);
    let local = _mm256_or_si256(
        _mm256_or_si256(
            _mm256_and_si256(cx, within),
            _mm256_slli_epi32::<{ BLOCK_BITS as i32 }>(_mm256_and_si256(cy, within)),
        ),
        _mm256_slli_epi32::<{ 2 * BLOCK_BITS as i32 }>(_mm256_and_si256(cz, within)),
    );
    _mm256_or_si256(_mm256_slli_epi32::<{ 3 * BLOCK_BITS as i32 }>(hashed), local)
}

/// Appends the slots of `from..to` closer than √`r2` to `p`; `near`
/// has room for `to − from` more slots and eight beyond.
#[inline]
#[target_feature(enable = "avx2")]
fn push_run(cells: &Cells, from: i32, to: i32, p: glam::Vec3, r2: f32, near: &mut Vec<u32>) {
    let mut lane = from;
    while lane < to {
        let first = lane as usize;
        let (xs, ys, zs) = (lanes(&cells.axes[0], first), lanes(&cells.axes[1], first), lanes(&cells.axes[2], first));
        // SAFETY: each load reads the eight values of a `[f32; 8]`.
        let (x, y, z) =
            unsafe { (_mm256_loadu_ps(xs.as_ptr()), _mm256_loadu_ps(ys.as_ptr()), _mm256_loadu_ps(zs.as_ptr())) };
        let dx = _mm256_sub_ps(_mm256_set1_ps(p.x), x);
        let dy = _mm256_sub_ps(_mm256_set1_ps(p.y), y);
        let dz = _mm256_sub_ps(_mm256_set1_ps(p.z), z);
        // (dx² + dy²) + dz², the order of the lane loop (no fused multiply-add).
        let d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
        let close = _mm256_cmp_ps::<_CMP_LT_OQ>(d2, _mm256_set1_ps(r2));
        let slots = _mm256_add_epi32(_mm256_set1_epi32(lane), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        let before_end = _mm256_cmpgt_epi32(_mm256_set1_epi32(to), slots);
        let hits = _mm256_movemask_ps(_mm256_and_ps(close, _mm256_castsi256_ps(before_end))) as usize;
        let order = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(PACK[hits] as i64));
        let packed = _mm256_permutevar8x32_epi32(slots, order);
        let count = near.len();
        // SAFETY: `near` has room for eight slots past its end (the
        // caller reserved the run's length and eight more, and each
        // group adds at most as many slots as it tests); the first
        // `hits.count_ones()` of them are the hits, now written.
        unsafe {
            _mm256_storeu_si256(near.as_mut_ptr().add(count) as *mut __m256i, packed);
            near.set_len(count + hits.count_ones() as usize);
        }
        lane += LANES as i32;
    }
}
