//! [`LineAligned`]: a buffer whose first element starts a 64-byte cache
//! line, whatever the allocator returns.
//!
//! A `Vec<T>` starts where the allocator puts it: 16-byte aligned with
//! glibc, and for a large buffer (one mapped by `mmap`, past the allocator's
//! threshold) 16 bytes past a page, so 16 mod 64. The coloured layout loads
//! and stores a dimer's two particles (2 × 16 bytes, from an even index) as
//! one 32-byte access ([`super::generic`]'s octets). From a base 16 or 48
//! mod 64, every other such access straddles two cache lines, and a split
//! access costs the core two. Which base a run got was left to chance: two
//! identical builds of disc-183 in one process differed by up to 9 % on
//! host F, the second build the slower in each of three runs under
//! glibc's allocator.
//!
//! Measured on host F (Intel Xeon, Emerald Rapids; one thread, AVX-512
//! build; a probe allocator that placed chosen buffers at a chosen offset
//! from a 2 MiB boundary, two builds of the same scene in one process
//! alternated window by window, ratio of medians of 12–20 windows): the
//! particles at 16 or 48 mod 64 against 0, disc-183 +2.1, +4.3, +5.2,
//! +4.3 %; the tablecloth +2.9, +6.5 % (16), +1.5, +2.6 % (48). At 32
//! mod 64 (no straddle) −0.4, +0.7 and +3.5 %, within the ±3 % such a
//! probe reads with no change. The cost of this type: up
//! to 63 bytes more.

use std::fmt;
use std::marker::PhantomData;
use std::ops::{Deref, DerefMut};

use bytemuck::{Pod, Zeroable};

/// Bytes in a cache line on x86-64 and most AArch64 cores (four 16-byte
/// rows; Apple's cores have 128, on which a 32-byte access from a 64-byte
/// boundary never straddles either): what a prefetch brings in, and where
/// a [`LineAligned`] starts.
pub(crate) const LINE_BYTES: usize = 64;

/// One cache line of storage: its alignment is what aligns the buffer.
#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C, align(64))]
struct Line([u8; LINE_BYTES]);

/// `len` values of `T` from the start of a cache line (module docs); it
/// derefs to `[T]`. `T` is plain data ([`Pod`]) whose size divides 64
/// (a line holds a whole number of them).
#[derive(Clone)]
pub(crate) struct LineAligned<T: Pod> {
    lines: Vec<Line>,
    len: usize,
    item: PhantomData<T>,
}

impl<T: Pod> LineAligned<T> {
    /// `len` zeroed values, from a line's start.
    pub(crate) fn zeroed(len: usize) -> Self {
        const {
            assert!(
                size_of::<T>() > 0 && LINE_BYTES.is_multiple_of(size_of::<T>()),
                "a line holds a whole number of items (so each is at its alignment)"
            )
        };
        let lines = vec![Line::zeroed(); (len * size_of::<T>()).div_ceil(LINE_BYTES)];
        LineAligned { lines, len, item: PhantomData }
    }
}

impl<T: Pod> Deref for LineAligned<T> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        // A line holds a whole number of `T`s at their alignment (asserted
        // when built), so the cast checks nothing at run time.
        &bytemuck::cast_slice(&self.lines)[..self.len]
    }
}

impl<T: Pod> DerefMut for LineAligned<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut bytemuck::cast_slice_mut(&mut self.lines)[..self.len]
    }
}

impl<T: Pod> Default for LineAligned<T> {
    fn default() -> Self {
        LineAligned { lines: Vec::new(), len: 0, item: PhantomData }
    }
}

impl<T: Pod + fmt::Debug> fmt::Debug for LineAligned<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_the_values_from_a_lines_start_and_its_clones_too() {
        // 13 rows of 16 bytes (208 bytes: 4 lines, the last part filled),
        // the particles' size, and 7 values of 8 bytes (56: 1 line).
        fn copy<T: Pod>(values: &[T]) -> LineAligned<T> {
            let mut buffer = LineAligned::zeroed(values.len());
            buffer.copy_from_slice(values);
            buffer
        }
        let rows: Vec<[f32; 4]> = (0..13).map(|i| [i as f32, 1.0, 2.0, -(i as f32)]).collect();
        let odd: Vec<[f32; 2]> = (0..7).map(|i| [i as f32; 2]).collect();
        let (mut a, b) = (copy(&rows), copy(&odd));
        assert_eq!((&*a, &*b), (&rows[..], &odd[..]));
        // A clone is a new allocation, and its own copy.
        let c = a.clone();
        a[12][0] = 99.0;
        assert_eq!((a[12][0], c[12][0], a.len(), c.len()), (99.0, 12.0, 13, 13));
        assert!(LineAligned::<[f32; 4]>::default().is_empty());
        assert_eq!(&*LineAligned::<[f32; 2]>::zeroed(5), &[[0.0; 2]; 5][..]);
        // Each starts a line: these and 32 more of 1 to 32 rows, kept alive
        // together. Vecs in their place start where the allocator puts them
        // (16-byte aligned with glibc), each on a line by chance one time
        // in four, all 35 about once in 4^35.
        let more: Vec<LineAligned<[f32; 4]>> = (1..=32).map(LineAligned::zeroed).collect();
        let starts = [a.as_ptr() as usize, b.as_ptr() as usize, c.as_ptr() as usize]
            .into_iter()
            .chain(more.iter().map(|m| m.as_ptr() as usize));
        let off: Vec<usize> = starts.map(|s| s % LINE_BYTES).filter(|&o| o != 0).collect();
        assert!(off.is_empty(), "buffers {off:?} bytes past a line's start");
    }
}
