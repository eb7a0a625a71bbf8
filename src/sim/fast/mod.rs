//! The fast solver: the seed's equations, ordered for the machine.
//!
//! It computes what [`super::reference`] computes — equation 1 for every free
//! particle, then `relaxations` Gauss–Seidel passes of Figure 3 over every
//! bar — but in an order that lets the CPU work in parallel:
//!
//! - **Colouring.** In the reference loop consecutive bars share a particle, so
//!   each projection waits for the one before (about 15 ns each here). Bars
//!   grouped so that no two in a group share a particle can be projected
//!   back to back, overlapped by the CPU, or side by side in SIMD lanes.
//! - **Lanes** (grids, module `grid`): eight blocks of columns sit in the
//!   eight lanes of a vector, so one 8-wide instruction projects eight bars,
//!   and rows are swept away from the pins. The kernels are plain loops over
//!   `[f32; 8]` compiled for AVX-512, AVX2 and the baseline and selected at
//!   run time (`multiversion`; `DRAPE_SIMD` forces a level, [`simd`]); no
//!   `unsafe`.
//! - **Overlapped passes**: on a single tile up to four passes are in flight
//!   three rows apart, which is exactly equivalent (such rows share no
//!   particle) and gives the CPU independent work.
//! - **Threads** (grids of at least 16 384 particles): the cloth is cut into
//!   tiles of eight blocks of columns, swept in parallel with rayon, even
//!   tiles then odd ones, a step's passes as a graph of tasks (`graph`,
//!   which the coloured layout's blocks use too) so that a tile waits only
//!   on its neighbours. The tiling depends on the grid only, so every
//!   thread count gives the same bits.
//! - **Any mesh** (module `generic`): bars are greedily coloured and relaxed
//!   colour by colour, eight bars of a colour in one AVX2 register (the one
//!   place with `unsafe`: `std::arch` transposes, measured 2.5× faster than
//!   one bar at a time); meshes of at least 16 384 particles are cut into
//!   blocks of consecutive particles swept in parallel, then the bars
//!   between blocks.
//! - **Phases.** Both layouts implement [`super::step::Solver`]: the order
//!   of the phases is written once, in [`super::step::run_substep`].
//!
//! The order of projections within a pass differs from the reference (row by
//! row, and within a row class by class), so the two agree to the accuracy of
//! the relaxation, not bit for bit; `tests/solvers.rs` measures it.
//!
//! **Integration in displacement form.** Equation 1 is evaluated as
//!
//! ```text
//! d ← (1 − δ) d + h² f / m        x_pred = x + d        (integration)
//! x ← relax(x_pred)                                      (relaxation)
//! d ← d + (x − x_pred)                                   (d = x_{i+1} − x_i)
//! ```
//!
//! which equals `x_{i+1} = x_i + (1 − δ)(x_i − x_{i−1}) + h²f/m` in exact
//! arithmetic. The reference stores x_{i−1} and forms `x_i − x_{i−1}` from two
//! rounded positions; once a particle slows to a few ulps of its coordinate
//! per step, `x + (1 − δ)·n ulps` rounds back to `x + n ulps` and it creeps
//! forever (up to 24 ulps a step at δ = 0.02). Carrying d itself removes the
//! creep: a damped particle comes to rest.

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx;
pub(crate) mod f32x8;
mod generic;
mod graph;
mod grid;
pub(crate) mod kernel;
mod lines;
pub(crate) mod rows;
pub mod simd;
pub(crate) mod wide_lanes;

use glam::Vec3;

/// Pieces of a layout swept in parallel (the coloured layout's blocks, the
/// grid layout's tiles) come in a multiple of this many, so that two or
/// four threads get equal shares: pieces are equal, and a count the
/// threads do not divide leaves one idle for the last. The count depends
/// on the mesh alone, never on the thread count, so every thread count
/// computes the same bits. Measured on host D (Zen 4, two threads): a
/// 320 × 320 sheet in 7 coloured blocks 14.6–15.2 ms a step, in 8 12.8
/// ms; a 200 × 200 sheet in 3 blocks 6.9 ms, in 4 4.8–5.2 ms; a 320-column
/// sheet on the grid's lanes in 5 tiles 6.65 ms, in 4 4.94 ms (one thread
/// unchanged within 1 ms).
const THREAD_SHARES: usize = 4;

use super::mesh::{Bar, ClothMesh};
use super::step::Solver;
use super::tether::Tethers;
use generic::GenericLayout;
pub(crate) use grid::GridLayout;
#[cfg(test)]
pub(crate) use grid::tests as grid_tests;

/// The fast solver for a mesh: the lane layout for a grid mesh, the
/// coloured layout otherwise. `inverse_mass` is each particle's weight
/// relative to m (0: fixed); `bars` are the bars to relax (used by the
/// coloured layout; the lane layout derives them from the grid).
pub fn new(
    mesh: &ClothMesh,
    positions: &[Vec3],
    previous: &[Vec3],
    inverse_mass: &[f32],
    bars: &[Bar],
    tethers: Option<Tethers>,
) -> Box<dyn Solver> {
    match GridLayout::new(mesh, positions, previous, inverse_mass, tethers.clone()) {
        Some(g) => Box::new(g),
        None => Box::new(GenericLayout::new(positions, previous, inverse_mass, bars, tethers)),
    }
}

/// The instruction set the kernels run with ([`simd::level`]).
pub(crate) fn simd_name() -> &'static str {
    simd::level().label()
}
