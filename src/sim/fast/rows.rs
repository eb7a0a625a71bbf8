//! [`Rows`]: lanes read from a table of 16-byte rows (`[x, y, z, w]`, one
//! row a particle or slot), eight rows at a time, and read back out. The
//! phases that visit particles through an index (the self-collide phase's
//! pairs, the air's triangle corners) run their lane kernels on any type
//! with it: [`F32x8`] everywhere, and [`Avx`](super::avx::Avx) where AVX2
//! loads each row once and transposes eight of them in a few shuffles.

use super::kernel::{F32x8, LANES, Real, per_lane};

/// Lanes that rows of a table can be gathered into.
pub(crate) trait Rows: Real {
    /// Rows `s[0..8]` as four lanes, [x, y, z, w].
    fn gather(rows: &[[f32; 4]], s: &[usize; LANES]) -> [Self; 4];
    /// The inverse of [`Rows::gather`] for eight consecutive rows: row l
    /// takes lane l of x, y, z and w.
    fn to_rows(lanes: [Self; 4]) -> [[f32; 4]; LANES];
    /// Lanes holding the eight values.
    fn from_values(values: [f32; LANES]) -> Self;
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
    fn equal_bits(self, other: Self) -> u32 {
        (0..LANES).fold(0, |bits, l| bits | (u32::from(self.0[l] == other.0[l]) << l))
    }
    #[inline(always)]
    fn first(self) -> f32 {
        self.0[0]
    }
}
