//! drape: a cloth simulator after Bernardi, Venturelli & Ferraz, *Physics-Based
//! Cloth Animation* (PUC-Rio, 2020), and an interactive viewer for it.
//!
//! - [`sim`]: the solver (no GPU): Verlet integration, bar relaxation, metrics.
//! - [`scene`]: scene files (TOML) and meshes (OBJ) → a [`sim::Simulation`].
//! - [`export`]: recorded frames, and glTF / OBJ files of them.
//! - [`headless`]: the `drape run` command's work, for the CLI and for tests.
//! - [`render`] (feature `viewer`): the wgpu renderer, windowless.
//! - [`ui`] (feature `viewer`): the egui panel, returning commands.
//! - [`app`] (feature `viewer`): the window, and the viewer it shows.
#![warn(missing_docs)]
#![deny(unsafe_code)]

#[cfg(feature = "viewer")]
pub mod app;
pub mod export;
pub mod headless;
#[cfg(feature = "viewer")]
pub mod render;
pub mod scene;
pub mod sim;
#[cfg(feature = "viewer")]
pub mod ui;
