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
//!   `[f32; 8]` compiled for AVX2 and selected at run time (`multiversion`),
//!   with a baseline SSE2 fallback; no `unsafe`.
//! - **Overlapped passes**: on a single tile up to four passes are in flight
//!   three rows apart, which is exactly equivalent (such rows share no
//!   particle) and gives the CPU independent work.
//! - **Threads** (grids of at least 16 384 particles): the cloth is cut into
//!   tiles of eight blocks of columns, swept in parallel with rayon, even
//!   tiles then odd ones. The tiling depends on the grid only, so every
//!   thread count gives the same bits.
//! - **Any mesh** (module `generic`): bars are greedily coloured and relaxed colour
//!   by colour, one thread.
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

mod generic;
mod grid;
mod kernel;

use glam::Vec3;

use super::mesh::{Bar, ClothMesh};
use super::simulation::Substep;
use super::tether::Tethers;
use generic::GenericLayout;
use grid::GridLayout;

#[derive(Clone, Debug)]
enum Layout {
    Grid(GridLayout),
    Generic(GenericLayout),
}

/// The fast solver's state; see the module docs.
#[derive(Clone, Debug)]
pub struct FastSolver {
    layout: Layout,
    parallel: bool,
}

impl FastSolver {
    /// Lays out the state for speed: the lane layout for a grid mesh, the
    /// coloured layout otherwise. `bars` are the bars to relax (used by the
    /// coloured layout; the lane layout derives them from the grid).
    pub fn new(
        mesh: &ClothMesh,
        positions: &[Vec3],
        previous: &[Vec3],
        fixed: &[bool],
        bars: &[Bar],
        tethers: Option<Tethers>,
    ) -> Self {
        let parallel = positions.len() >= grid::PARALLEL_PARTICLES;
        let layout = match GridLayout::new(mesh, positions, previous, fixed, tethers.clone()) {
            Some(g) => Layout::Grid(g),
            None => Layout::Generic(GenericLayout::new(positions, previous, fixed, bars, tethers)),
        };
        Self { layout, parallel }
    }

    /// One substep (see [`Substep`]). Returns the relaxation passes done.
    pub fn step(&mut self, substep: &Substep) -> u32 {
        let parallel = self.parallel && rayon::current_num_threads() > 1;
        match &mut self.layout {
            Layout::Grid(g) => g.step(substep, parallel),
            Layout::Generic(g) => g.step(substep),
        }
    }

    /// Current and previous positions in scene order.
    pub fn read(&self, positions: &mut [Vec3], previous: &mut [Vec3]) {
        match &self.layout {
            Layout::Grid(g) => g.read_state(positions, previous),
            Layout::Generic(g) => g.read_state(positions, previous),
        }
    }

    /// Sets one particle's position and previous position.
    pub fn set_particle(&mut self, index: usize, position: Vec3, previous: Vec3) {
        match &mut self.layout {
            Layout::Grid(g) => g.set_particle(index, position, previous),
            Layout::Generic(g) => g.set_particle(index, position, previous),
        }
    }

    /// The first particle (scene order) with a non-finite coordinate.
    pub fn first_non_finite(&self) -> Option<usize> {
        match &self.layout {
            Layout::Grid(g) => g.first_non_finite(),
            Layout::Generic(g) => g.first_non_finite(),
        }
    }

    /// Which layout runs, in a few words (for the viewer and benchmarks).
    pub fn describe(&self) -> String {
        let simd = simd_name();
        match &self.layout {
            Layout::Grid(g) => {
                format!("lanes: {}, {simd}{}", g.describe(), if self.parallel { ", threaded" } else { "" })
            }
            Layout::Generic(g) => format!("coloured: {} colours, one thread", g.colours()),
        }
    }
}

/// The instruction set the kernels were dispatched to.
fn simd_name() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        return "AVX2";
    }
    "baseline SIMD"
}
