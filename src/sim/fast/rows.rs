//! [`Rows`]: lanes read from a table of 16-byte rows (`[x, y, z, w]`, one
//! row a particle or slot), eight rows at a time, and read back out. The
//! phases that visit particles through an index (the self-collide phase's
//! pairs, the air's triangle corners) run their lane kernels on any type
//! with it: [`F32x8`] everywhere, [`Avx`](super::avx::Avx) where AVX2
//! loads each row once and transposes eight of them in a few shuffles, and
//! [`Wide`](super::wide_lanes::Wide), the portable level's explicit vectors
//! (the coloured path's octets without AVX2), which transposes four rows
//! at a time.

use super::kernel::{F32x8, LANES, Real, per_lane};

/// Asks the CPU to bring the cache line holding `at` into its caches:
/// every level with `INTO_L1`, else L2 and beyond (`prefetcht0` /
/// `prefetcht1` on x86-64; elsewhere nothing). It reads nothing into the
/// program and cannot fault, whatever the address, so `at` need not point
/// into anything: a hint that changes no value. Used where a loop knows
/// which rows it will read later and the hardware's prefetcher cannot (rows
/// read through an index): the coloured layout's next block
/// (`fast/generic/ahead.rs`), the self-collide pairs' far ends
/// (`self_contact/pair.rs`).
#[inline(always)]
#[allow(unsafe_code)]
pub(crate) fn prefetch<const INTO_L1: bool>(at: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of x86-64's baseline, and a prefetch is a hint
    // that reads nothing into the program and cannot fault.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _MM_HINT_T1, _mm_prefetch};
        if INTO_L1 {
            _mm_prefetch::<_MM_HINT_T0>(at.cast());
        } else {
            _mm_prefetch::<_MM_HINT_T1>(at.cast());
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = at;
}

/// Lanes that rows of a table can be gathered into.
pub(crate) trait Rows: Real {
    /// Rows `s[0..8]` as four lanes, [x, y, z, w].
    fn gather(rows: &[[f32; 4]], s: &[usize; LANES]) -> [Self; 4];
    /// The inverse of [`Rows::gather`] for eight consecutive rows: row l
    /// takes lane l of x, y, z and w.
    fn to_rows(lanes: [Self; 4]) -> [[f32; 4]; LANES];
    /// Lanes holding the eight values.
    fn from_values(values: [f32; LANES]) -> Self;
    /// The eight values the lanes hold (the inverse of [`Rows::from_values`]).
    fn to_values(self) -> [f32; LANES];
    /// Bit l set where lane l equals lane l of `other` by `f32`'s `==` (a
    /// NaN equals nothing, −0 equals 0): one compare and a move of the
    /// mask with AVX2, where the lanes stored and compared one by one were
    /// a quarter of the air's noise.
    fn equal_bits(self, other: Self) -> u32;
    /// Lane 0.
    fn first(self) -> f32;
}

impl Rows for F32x8 {
    /// `per_lane!` writes the eight loads out: `std::array::from_fn` was
    /// left a call per lane.
    #[inline(always)]
    fn gather(rows: &[[f32; 4]], s: &[usize; LANES]) -> [Self; 4] {
        [
            per_lane!(|l| rows[s[l]][0]),
            per_lane!(|l| rows[s[l]][1]),
            per_lane!(|l| rows[s[l]][2]),
            per_lane!(|l| rows[s[l]][3]),
        ]
    }
    #[inline(always)]
    fn to_rows([x, y, z, w]: [Self; 4]) -> [[f32; 4]; LANES] {
        std::array::from_fn(|l| [x.0[l], y.0[l], z.0[l], w.0[l]])
    }
    #[inline(always)]
    fn from_values(values: [f32; LANES]) -> Self {
        F32x8(values)
    }
    #[inline(always)]
    fn to_values(self) -> [f32; LANES] {
        self.0
    }
    #[inline(always)]
    fn equal_bits(self, other: Self) -> u32 {
        (0..LANES).fold(0, |bits, l| bits | (u32::from(self.0[l] == other.0[l]) << l))
    }
    #[inline(always)]
    fn first(self) -> f32 {
        self.0[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prefetch_of_any_address_reads_nothing_and_cannot_fault() {
        // The callers prefetch rows past a slice's end or of a block another
        // thread holds (addresses only). A load there would fault or race;
        // a prefetch must not: null, the last byte of the address space and
        // a freed row, at both levels. A row prefetched reads back as it was.
        let row = Box::new([1.5f32, -2.0, 0.25, 1.0]);
        let gone = (&raw const *row).cast::<u8>();
        prefetch::<true>(gone);
        assert_eq!(*row, [1.5, -2.0, 0.25, 1.0]);
        drop(row);
        for at in [std::ptr::null(), usize::MAX as *const u8, gone] {
            prefetch::<true>(at);
            prefetch::<false>(at);
        }
    }

    /// Every method of [`Rows`] on `T`, against the lanes one by one: the
    /// gather and its inverse on rows of distinct values, and the equal
    /// mask on lanes that differ in one lane each (its bit alone clear),
    /// with a NaN (equal to nothing, itself included) and −0 against 0
    /// (equal). `lanes` turns `T` back into values.
    fn check<T: Rows>(lanes: impl Fn(T) -> [f32; LANES]) {
        let rows: Vec<[f32; 4]> = (0..11).map(|r| std::array::from_fn(|k| (4 * r + k) as f32 + 0.5)).collect();
        let s = [3, 10, 0, 7, 7, 1, 9, 4];
        let gathered = T::gather(&rows, &s);
        for (k, lane) in gathered.into_iter().enumerate() {
            assert_eq!(lanes(lane), s.map(|r| rows[r][k]), "component {k} of the gathered rows");
        }
        assert_eq!(T::to_rows(gathered), s.map(|r| rows[r]), "the gather's inverse");
        let values: [f32; LANES] = std::array::from_fn(|l| l as f32 * 1.25 - 3.0);
        let a = T::from_values(values);
        assert_eq!(lanes(a), values);
        assert_eq!(a.first(), values[0]);
        assert_eq!(a.equal_bits(a), 0xFF, "every lane equals itself");
        for l in 0..LANES {
            let mut other = values;
            other[l] += 1.0;
            assert_eq!(a.equal_bits(T::from_values(other)), 0xFF ^ (1 << l), "lane {l} differs");
        }
        let mut signed = [0.0f32; LANES];
        signed[2] = -0.0;
        signed[5] = f32::NAN;
        let signed = T::from_values(signed);
        assert_eq!(signed.equal_bits(T::splat(0.0)), 0xFF ^ (1 << 5), "−0 equals 0; a NaN equals nothing");
        assert_eq!(signed.equal_bits(signed), 0xFF ^ (1 << 5), "a NaN does not equal itself");
    }

    #[test]
    fn every_level_reads_rows_into_lanes_and_compares_lane_by_lane() {
        check::<F32x8>(|x| x.0);
        check::<super::super::wide_lanes::Wide>(|x| x.to_array());
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            #[target_feature(enable = "avx2,fma")]
            fn check_avx() {
                check::<super::super::avx::Avx>(|x| x.lanes());
            }
            // SAFETY: the CPU reports AVX2 and FMA, the features `check_avx`
            // is compiled for (and so the `Avx` contract holds inside it).
            #[allow(unsafe_code)]
            unsafe {
                check_avx()
            };
        }
    }
}
