//! The next block's rows brought into cache while this block is relaxed.
//!
//! A pass over a large mesh sweeps its blocks ([`super::blocks`]) one after
//! another, and each block's colours sweep its rows again and again. A
//! block's 256 KiB of rows stay in a core's L2 for the block's colours, but
//! a whole pass (disc-183: 1.6 MB of rows and 6.4 MB of bar columns) does
//! not, so the block's first colour finds its rows gone and waits on each
//! of them in turn: the octets address them at random, so the hardware's
//! prefetcher does not see them coming.
//!
//! Measured on host G (Intel Xeon, one thread, disc-183, the `avx2`
//! octets): every block relaxed twice in a row, the second sweep (its rows
//! and columns in L2) took 1.26–1.29 ns a bar against 1.40–1.45 ns for the
//! first. Streaming the bar columns faster gained nothing (a software
//! prefetch of the columns 256 bars ahead: step 0.99–1.00 of the old; the
//! ends as 16-bit indices, a third less to stream: 1.02–1.05 at AVX2 and
//! 1.22 at AVX-512, slower), and
//! touching the block's rows just before relaxing it cost more than it
//! saved (1.06–1.10: the prefetches queued behind one another). Spread over
//! a block's octets, one 64-byte line (four rows) an octet, the next
//! block's rows arrive with nothing waiting on them: a block of 12 600
//! particles is 3 150 lines, against some 8 000 octets a pass. They are
//! fetched into L2 only (`_MM_HINT_T1`: a block's 200 KB of rows do not
//! fit the 48 KB L1, where they would push out the rows being relaxed);
//! into every level the gain was much the same (step 0.957–0.977 of the
//! old against 0.950–0.966, three pairs each).
//!
//! disc-183's step, with and without the prefetch alternated window by
//! window in one process (medians of 20 windows of 150 ms), with / without:
//! one thread 0.946–0.966 (AVX2, six runs) and 0.931, 0.934 (AVX-512); two
//! threads 0.950–0.986 (AVX2, four runs) and 0.940, 0.954 (AVX-512). The draped disc with
//! self-collision (two threads, AVX2) 0.964, with contact 0.988. A mesh of
//! one block (the tablecloth) prefetches nothing: 1.002. The portable
//! level's octets do not prefetch.
//!
//! Which block is next is a guess, [`crate::sim::fast::graph::next_at_home`]:
//! the next block of the worker's own share, or its first (the next pass's)
//! after its last. A prefetch reads no value, so the guess moves no bit,
//! and a wrong one costs its prefetches only.

use std::ops::Range;

use super::Particle;
use crate::sim::fast::lines::LINE_BYTES as LINE;
use crate::sim::fast::rows::prefetch;

/// A cursor over rows to prefetch, one line a call of [`Ahead::line`]. It
/// holds the rows' addresses only (it never reads or writes through them),
/// so it borrows nothing and may point past what a group's pass holds.
#[derive(Debug)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(super) struct Ahead {
    /// The next line's address.
    next: *const u8,
    /// One past the last row's last byte.
    end: *const u8,
}

impl Ahead {
    /// Nothing to prefetch.
    pub(super) fn none() -> Self {
        Ahead { next: std::ptr::null(), end: std::ptr::null() }
    }

    /// Rows `run` of the `len` particles at `particles` (nothing when `run`
    /// is not within them). Only addresses are taken, so the particles may
    /// be borrowed elsewhere, even mutably, while the cursor lives.
    pub(super) fn rows(particles: *const Particle, len: usize, run: Range<usize>) -> Self {
        if run.start > run.end || run.end > len {
            return Self::none();
        }
        let at = |i: usize| particles.wrapping_add(i).cast::<u8>();
        Ahead { next: at(run.start), end: at(run.end) }
    }

    /// Lines left to prefetch.
    #[cfg(test)]
    pub(super) fn lines_left(&self) -> usize {
        (self.end as usize).saturating_sub(self.next as usize).div_ceil(LINE)
    }

    /// Prefetches the next line into L2 (module docs), if any is left.
    /// Only the AVX2 octets call it (x86-64).
    #[inline(always)]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) fn line(&mut self) {
        if self.next < self.end {
            prefetch::<false>(self.next);
            self.next = self.next.wrapping_add(LINE);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cursor_covers_the_rows_line_by_line_then_stops() {
        // 10 rows of 16 bytes: 160 bytes, 2½ lines, so 3 prefetches 64
        // bytes apart from the first row.
        let particles = [Particle::default(); 12];
        let rows = |run| Ahead::rows(particles.as_ptr(), particles.len(), run);
        let mut ahead = rows(2..12);
        assert_eq!(ahead.lines_left(), 3);
        for left in [2, 1, 0, 0] {
            ahead.line();
            assert_eq!(ahead.lines_left(), left);
        }
        // Rows outside the particles, and none at all: nothing to fetch.
        assert_eq!(rows(8..13).lines_left(), 0);
        assert_eq!(Ahead::none().lines_left(), 0);
    }
}
