//! The renderer: wgpu only, no window. It draws a [`Simulation`]'s cloth —
//! lit surface, bars, particles, ground and backdrop — into any texture
//! view, so the window, `drape render`, F12 screenshots and the golden-image
//! tests all share one code path.
//!
//! - [`gpu`]: instance, adapter and device; adapter choice and `drape adapters`.
//! - [`camera`]: [`OrbitCamera`] and picking rays.
//! - [`view`]: [`ViewOptions`] (which layers) and the strain colour ramp.
//! - [`geometry`]: CPU-side data: normals, strain, instances, ground placement.
//! - [`renderer`]: [`Renderer`], the passes and the per-frame uploads.
//! - [`targets`]: MSAA and depth textures, offscreen targets and readback.
//! - [`shaders`]: the WGSL sources from `shaders/`.
//!
//! The shaders compute lighting in linear light. When the target format is
//! not sRGB (egui prefers `Rgba8Unorm`/`Bgra8Unorm`), they encode sRGB
//! themselves, so the same frame looks the same on either kind of target.

mod buffers;
pub mod camera;
pub mod colliders;
pub mod geometry;
pub mod gpu;
mod pipelines;
pub mod renderer;
pub mod shaders;
pub mod targets;
pub mod view;

pub use camera::{OrbitCamera, Ray};
pub use gpu::{AdapterPreference, Gpu, GpuError};
pub use renderer::{FrameSpec, Renderer, Viewport};
pub use targets::{OffscreenTarget, ReadbackError, write_png};
pub use view::ViewOptions;

use crate::scene::CameraHint;
use crate::sim::Simulation;

/// The camera for a scene in a viewport of `aspect`: the hint's angles, and
/// its distance and target or, where it leaves them out, a view that fits
/// both where the cloth started and where it is now.
pub fn start_camera(hint: &CameraHint, sim: &Simulation, aspect: f32) -> OrbitCamera {
    OrbitCamera::from_hint(hint, cloth_bounds(sim), aspect)
}

/// The box around the cloth's initial and current positions.
pub fn cloth_bounds(sim: &Simulation) -> (glam::Vec3, glam::Vec3) {
    let (rest_min, rest_max) = sim.mesh().bounds();
    let (now_min, now_max) = crate::sim::mesh::bounds(sim.positions());
    (rest_min.min(now_min), rest_max.max(now_max))
}
