//! The operations' shares in the share form, stored once for each distinct
//! value ([`ShareTable`]).
//!
//! In the share form (every inverse mass 0 or 1) an operation's eight bars
//! move their ends by the shares `[s_a, s_b] = [own_a · partner_b,
//! own_b · partner_a]` of [`Weights::shares`] (`ω/2` each between two free
//! particles of equal mass, `ω` and 0 against a fixed one, for the bars'
//! kind's β). A sheet has few distinct values of them: every operation
//! between two free slots has the same, and only those at pins, at the
//! lane padding and at a rotated operation's lane 7 differ. The seed's
//! 20 × 30 cloth has 6 distinct values among its 525 operations; each of
//! the 256 × 256 cloth's four tiles 6 among 12 248. Stored one per
//! operation they were 64 bytes an operation, the largest stream a pass
//! reads (784 KB a tile of 256 × 256, beside its 0.2 MB of positions);
//! stored once each with a 4-byte index an operation, 49 KB.
//!
//! Measured on host G (Intel Xeon, model 167; `--bench ratios -- 256`,
//! three processes of each build alternated): 256 × 256 on two threads
//! 28.7–30.7× the reference before, 31.0–31.4× after at AVX-512 (256-bit),
//! 29.8–31.6× → 32.2–32.6× at AVX2, 24.8–25.7× → 26.6–26.8× at 512 bits;
//! the seed's one-tile step unchanged within the host's noise (its pass
//! was 48.5 KB against a 48 KB L1, now 17 KB; the step did not move).
//! Same values, same bits.

use super::Op;
use crate::sim::fast::kernel::{F32x8, LANES, Weights};

/// An operation's shares: of end a and of end b, lane by lane ([`op_shares`]).
pub(super) type OpShares = [F32x8; 2];

/// Operation `op`'s shares from its slots' (`shared`, of the operation's
/// kind), lane by lane ([`Weights::shares`]). A rotated operation's far slot
/// is rotated down with it, and its lane 7 (whose partner is a seam bar,
/// projected on its own) gets share 0 at both ends: neither moves there.
pub(super) fn op_shares(shared: &[Weights<F32x8>], op: Op) -> OpShares {
    let (ia, ib) = op.slots();
    let wa = shared[ia];
    let wb = if op.rotated() {
        let mut wb = Weights { own: shared[ib].own.rotate_down(), partner: shared[ib].partner.rotate_down() };
        wb.own.0[LANES - 1] = 0.0;
        wb.partner.0[LANES - 1] = 0.0;
        wb
    } else {
        shared[ib]
    };
    wa.shares(wb)
}

/// Every operation's shares: the distinct values, and for each operation
/// the index of its own. Built only by [`ShareTable::build`] (or empty), so
/// every index is below the values' count and a sweep reads them unchecked.
#[derive(Clone, Debug, Default)]
pub(super) struct ShareTable {
    values: Vec<OpShares>,
    of_op: Vec<u32>,
}

impl ShareTable {
    /// The shares of `ops`, each slot's of its operation's kind in
    /// `shared`. Two values are the same when their bits are (the sweep
    /// then computes the same bits from either). O(operations).
    pub(super) fn build<'a>(ops: impl IntoIterator<Item = &'a Op>, shared: &[Vec<Weights<F32x8>>]) -> Self {
        let mut index = std::collections::HashMap::<[u32; 2 * LANES], u32>::new();
        let mut values = Vec::new();
        // The last value looked up: an operation whose value is its
        // predecessor's (nearly every one) takes its index unhashed.
        let mut last: Option<([u32; 2 * LANES], u32)> = None;
        let of_op = ops
            .into_iter()
            .map(|&op| {
                let value = op_shares(&shared[op.kind()], op);
                let key: [u32; 2 * LANES] = std::array::from_fn(|i| value[i / LANES].0[i % LANES].to_bits());
                if let Some((last_key, i)) = last
                    && last_key == key
                {
                    return i;
                }
                let i = *index.entry(key).or_insert_with(|| {
                    values.push(value);
                    // A tile's operations number far fewer than 2³² (each
                    // names slots below 2³⁰), so neither do their values.
                    (values.len() - 1) as u32
                });
                last = Some((key, i));
                i
            })
            .collect();
        ShareTable { values, of_op }
    }

    /// The operations it holds shares for.
    pub(super) fn len(&self) -> usize {
        self.of_op.len()
    }

    /// The distinct values.
    #[cfg(test)]
    pub(super) fn distinct(&self) -> usize {
        self.values.len()
    }

    /// Operation `j`'s shares.
    #[cfg(test)]
    pub(super) fn get(&self, j: usize) -> OpShares {
        self.values[self.of_op[j] as usize]
    }

    /// Operation `j`'s shares, unchecked.
    ///
    /// # Safety
    /// `j` is below [`Self::len`].
    #[inline(always)]
    #[allow(unsafe_code)]
    pub(super) unsafe fn get_unchecked(&self, j: usize) -> OpShares {
        // SAFETY: `j` is below the operations' count (the caller's
        // promise), and every index was made by `build` from a value it
        // pushed, so it is below the values' count.
        unsafe { *self.values.get_unchecked(*self.of_op.get_unchecked(j) as usize) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::fast::kernel::Real;

    fn lanes(v: [f32; LANES]) -> F32x8 {
        F32x8(v)
    }

    #[test]
    fn each_operation_reads_its_own_shares_and_equal_ones_are_stored_once() {
        // Four slots of one kind: slot 0 has a fixed particle in lane 2,
        // the others are free. With own = 1 and partner = 1/2 for a free
        // particle (ω = 1, β = 0: Figure 3's halves) and own = 0, partner = 1
        // for a fixed one, a bar between two free ends moves each by 1/2;
        // against the fixed one in lane 2, the fixed end by 0 and the free
        // end by 1.
        let free = Weights { own: F32x8::splat(1.0), partner: F32x8::splat(0.5) };
        let mut pinned = free;
        pinned.own.0[2] = 0.0;
        pinned.partner.0[2] = 1.0;
        let shared = vec![vec![pinned, free, free, free]];
        let op = |a: u32, b: u32| Op { a, b, rest: 1.0 };
        let ops = [op(1, 2), op(0, 1), op(2, 3), op(0, 2), op(1, 3)];
        let table = ShareTable::build(&ops, &shared);
        assert_eq!(table.len(), 5);
        // Free–free (ops 0, 2, 4) and the two at the pinned slot (1, 3),
        // which are alike: two values.
        assert_eq!(table.distinct(), 2);
        let half = F32x8::splat(0.5);
        for j in [0, 2, 4] {
            assert_eq!(table.get(j), [half, half]);
        }
        let at_pin_a = lanes([0.5, 0.5, 0.0, 0.5, 0.5, 0.5, 0.5, 0.5]);
        let at_pin_b = lanes([0.5, 0.5, 1.0, 0.5, 0.5, 0.5, 0.5, 0.5]);
        for j in [1, 3] {
            assert_eq!(table.get(j), [at_pin_a, at_pin_b]);
            assert_eq!(table.get(j), op_shares(&shared[0], ops[j]));
        }
        // A rotated operation's lane 7 does not move either end.
        let rotated = [op(1, 2 | super::super::ops::ROTATED)];
        let table = ShareTable::build(&rotated, &shared);
        let [sa, sb] = table.get(0);
        assert_eq!((sa.0[LANES - 1], sb.0[LANES - 1]), (0.0, 0.0));
        assert_eq!((sa.0[0], sb.0[0]), (0.5, 0.5));
    }
}
