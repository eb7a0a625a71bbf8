//! drape: a cloth simulator after Bernardi, Venturelli & Ferraz, *Physics-Based
//! Cloth Animation* (PUC-Rio, 2020), and an interactive viewer for it.
//!
//! - [`sim`]: the solver (no GPU): Verlet integration, bar relaxation, metrics.
//! - [`scene`]: scene files (TOML) and meshes (OBJ) → a [`sim::Simulation`].
//! - [`headless`]: the `drape run` command's work, for the CLI and for tests.
#![warn(missing_docs)]

pub mod headless;
pub mod scene;
pub mod sim;
