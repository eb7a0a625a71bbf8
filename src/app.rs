//! The interactive viewer: a winit window showing a [`Viewer`].
//!
//! - [`viewer`]: [`Viewer`], everything except the window (testable offscreen);
//!   its input (keys, mouse: orbit, grab, pin, move colliders) in `viewer/input.rs`.
//! - [`grab`]: picking and dragging particles.
//! - [`stepper`]: steps per frame, and the real-time accumulator.
//! - [`clock`]: where time comes from.
//! - [`mod@snapshot`]: one frame as an image, legend included (`drape render`).
//! - [`window`]: the winit application, the surface and its failure modes.

pub mod clock;
pub mod grab;
pub mod snapshot;
pub mod stepper;
pub mod viewer;
pub mod watch;
pub mod window;

pub use snapshot::snapshot;
pub use viewer::{Frame, Viewer, ViewerSettings, WindowRequest};
pub use window::{AppError, run};
