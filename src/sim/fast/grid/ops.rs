//! The lane layout's operations: eight bars each, one per lane of two
//! slots, and the list of them every tile shares, checked once against the
//! slots they index so that the sweeps read their slots without a bounds
//! check an operation.

use std::ops::Deref;

/// Marks an operation whose far slot is rotated by one lane (in `Op::b`).
pub(super) const ROTATED: u32 = 1 << 31;
/// The bar kind of an operation ([`crate::sim::BarKind::index`]) sits in
/// the top two bits of `Op::a`.
pub(super) const KIND_SHIFT: u32 = 30;

/// One 8-bar operation: slots `a` (below its kind bits) and `b & !ROTATED`
/// of a tile.
#[derive(Clone, Copy, Debug)]
pub(super) struct Op {
    pub(super) a: u32,
    pub(super) b: u32,
    pub(super) rest: f32,
}

impl Op {
    pub(super) fn slots(self) -> (usize, usize) {
        ((self.a & ((1 << KIND_SHIFT) - 1)) as usize, (self.b & !ROTATED) as usize)
    }
    pub(super) fn rotated(self) -> bool {
        self.b & ROTATED != 0
    }
    pub(super) fn kind(self) -> usize {
        (self.a >> KIND_SHIFT) as usize
    }
}

/// The operations of a layout, with the slots they need: every slot an
/// operation names is below [`Ops::slots`], and every kind below
/// [`crate::sim::BarKind::COUNT`]. Built only by [`Ops::new`], which
/// computes both from the list, and never changed after: the sweeps check
/// a tile's slots against [`Ops::slots`] once a call and then index them
/// unchecked ([`super::sweep`]).
#[derive(Clone, Debug, Default)]
pub(super) struct Ops {
    list: Vec<Op>,
    slots: usize,
}

impl Ops {
    /// The list and the slots it needs (one past the largest it names).
    /// Panics on a kind out of range, which the layout never builds.
    pub(super) fn new(list: Vec<Op>) -> Self {
        assert!(list.iter().all(|op| op.kind() < crate::sim::BarKind::COUNT), "an operation of no bar kind");
        let slots = list.iter().map(|op| op.slots()).map(|(a, b)| a.max(b) + 1).max().unwrap_or(0);
        Ops { list, slots }
    }

    /// One past the largest slot an operation names.
    pub(super) fn slots(&self) -> usize {
        self.slots
    }
}

impl Deref for Ops {
    type Target = [Op];
    fn deref(&self) -> &[Op] {
        &self.list
    }
}
