//! The cloth solver: particles, bars, Verlet integration and relaxation.
//!
//! This module has no GPU, window or UI dependency; `cargo build
//! --no-default-features` builds it alone.
//!
//! # Theory
//!
//! A cloth is a set of particles joined by bars (the seed, section 2). Each
//! particle i has a position x, a mass m and is either free or fixed. Each bar
//! joins two particles and has a rest length: the distance between them in
//! the mesh as given. A step of length h does two things.
//!
//! **Integration.** Every free particle moves by position Verlet with
//! damping δ (the seed's equation 1):
//!
//! ```text
//! x_{i+1} = x_i + (1 − δ)(x_i − x_{i−1}) + h²/m · f                  (1)
//! ```
//!
//! The scheme carries velocity implicitly as (x_i − x_{i−1})/h. It needs two
//! positions to start, so the first step is an Euler step from the initial
//! velocity v₀ (equation 2), which ignores the force:
//!
//! ```text
//! x_1 = x_0 + h v_0                                                   (2)
//! ```
//!
//! For constant acceleration a = f/m and δ = 0, equation 1 gives exactly
//! x_k = x_1 + (k−1)·h·v₀ + a h² (k−1)k/2 after the Euler start; a particle
//! with initial velocity and no force travels h|v₀|·Σ(1−δ)^j, which converges
//! to h|v₀|/δ. The integration tests check both.
//!
//! **Forces.** Every free particle feels the same force, gravity plus wind
//! (equations 3–5): f = f_g + f_w(t), with f_g = (0, −9.8, 0) N by default and
//! f_w the seed's time-varying wind ([`wind`]). Gravity is a force, not an
//! acceleration: a particle of m = 0.2 kg accelerates at 49 m/s².
//! Beside the seed's way, gravity may be an acceleration g, particles may
//! weigh an area density times their area ([`units`]), and the wind may be
//! moving air, whose drag and lift act on each triangle by its orientation
//! and motion ([`aero`]).
//!
//! **Relaxation.** Integration stretches and compresses the bars; relaxation
//! restores them (the seed's Figure 3). One pass visits every bar and moves
//! its ends along it so that it regains its rest length, each end in
//! proportion to its inverse mass ([`relax`]): a free–free bar of equal
//! masses moves both ends half way, a free–fixed bar moves the free end the
//! whole way, and a bar joining two fixed particles has zero weight at both
//! ends and moves nothing (it is kept, so that pinning or freeing a
//! particle is a write of its inverse mass, never a rebuild). Passes
//! are Gauss–Seidel (each projection sees the positions that earlier
//! projections left) and repeat `relaxations` times per step. This is
//! position-based dynamics with stiffness 1 (Jakobsen 2001; Müller et al.
//! 2007): the stretch left after a step falls roughly as 1/relaxations, and
//! more passes make the cloth both less stretchy and more rigid, as the seed
//! observes.
//!
//! # Map
//!
//! - [`params`]: h, δ, m, relaxations, gravity and wind, with ranges.
//! - [`mesh`]: particles, bars, triangles; grids, adjacency lists, triangle meshes.
//! - [`simulation`]: [`Simulation`], the clock and the public state.
//! - [`step`]: the substep as named phases (integrate, relax, self-collide,
//!   collide, settle) and the [`Solver`] trait each solver implements.
//! - [`collider`], [`contact`]: colliders, and the collide phase with friction.
//! - [`self_contact`]: the self-collide phase (cloth against itself).
//! - [`reference`](mod@reference): the seed's loops written plainly, the yardstick.
//! - [`fast`]: the same equations ordered for speed (colouring, SIMD lanes, threads).
//! - [`metrics`]: strain and energies.
//! - [`health`]: finite but absurd states (stretch, run-away, speed), named.
//! - [`tether`]: long-range attachments that bound stretch.
//! - [`aero`]: the air phase (drag and lift on triangles, turbulence).
//! - [`units`], [`material`]: masses and stiffness in physical units, fabric presets.
//! - [`exact`]: exact answers (discrete free fall, pendulum, catenary) for tests and error measures.

pub mod aero;
pub mod collider;
pub mod contact;
pub(crate) mod csr;
pub mod exact;
pub mod fast;
pub mod health;
pub mod hierarchy;
pub mod hold;
pub mod inextensible;
pub mod material;
pub mod mesh;
pub mod metrics;
pub mod params;
pub mod reference;
pub mod relax;
pub mod self_contact;
pub mod simulation;
pub mod step;
pub mod tether;
pub mod units;
pub mod wind;

pub use collider::{Collider, Keyframe, MeshShape, Motion, Pose, Shape};
pub use material::Material;
pub use mesh::{Bar, BarKind, ClothMesh, Grid, GridPlane, GridShape, MeshError, MeshParts, Pins};
pub use metrics::{Strain, StrainHistory};
pub use params::{ParamError, SolverParams, Start};
pub use simulation::{SimError, Simulation, SolverKind};
pub use step::{Solver, Substep};
pub use wind::{Air, Wind};
