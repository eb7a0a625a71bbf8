//! The egui user interface: the side panel and what is drawn over the 3-D
//! view. The panel does not change the simulation: it returns
//! [`UiCommand`]s, which [`crate::app`] applies.
//!
//! - [`command`]: [`UiCommand`], [`TimeMode`] and the key bindings.
//! - [`mod@panel`]: the side panel.
//! - [`solver_controls`]: the solver part of it.
//! - [`stats`]: timings and strain over time.
//! - [`timeline`]: the timeline bar (scrub, play back, export).
//! - [`overlay`]: strain legend, blow-up message, toasts.
//! - [`painter`]: drawing egui's output with egui-wgpu.

pub mod command;
mod material_controls;
pub mod overlay;
pub mod painter;
pub mod panel;
pub mod solver_controls;
pub mod stats;
pub mod timeline;

pub use command::{KEY_BINDINGS, MOUSE_BINDINGS, TimeMode, UiCommand};
pub use painter::{UiFrame, UiPainter};
pub use panel::{PanelModel, PanelState, panel};
pub use stats::Stats;
