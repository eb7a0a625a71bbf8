//! [`UiPainter`]: draws egui's output over a frame with egui-wgpu, into any
//! texture view (the window's surface or an offscreen texture).

use egui_wgpu::{Renderer, RendererOptions, ScreenDescriptor};

/// egui's wgpu renderer, with the call order egui-wgpu expects.
pub struct UiPainter {
    renderer: Renderer,
}

impl std::fmt::Debug for UiPainter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UiPainter").finish_non_exhaustive()
    }
}

/// One frame of egui output, tessellated.
#[derive(Debug)]
pub struct UiFrame {
    /// Triangles and clip rectangles.
    pub primitives: Vec<egui::ClippedPrimitive>,
    /// Textures to free once the frame is drawn (the new ones were uploaded
    /// by [`UiPainter::upload_textures`]).
    pub free_textures: Vec<egui::TextureId>,
    /// Physical pixels per point.
    pub pixels_per_point: f32,
}

impl UiPainter {
    /// A painter for targets of `format`. `predictable` turns off dithering
    /// and hardware texture filtering, so images are the same on every
    /// adapter (for golden images).
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat, predictable: bool) -> Self {
        let options = if predictable { RendererOptions::PREDICTABLE } else { RendererOptions::default() };
        Self { renderer: Renderer::new(device, format, options) }
    }

    /// Uploads new and changed textures; call once per frame, before
    /// painting. Returns the textures to free after the frame is drawn.
    pub fn upload_textures(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        mut textures: egui::TexturesDelta,
    ) -> Vec<egui::TextureId> {
        for (id, deltas) in textures.set.drain() {
            for delta in deltas {
                self.renderer.update_texture(device, queue, id, &delta);
            }
        }
        textures.free.drain().collect()
    }

    /// Uploads the frame's vertices and records drawing it over
    /// what `target` (`size` pixels) already holds. Returns command buffers
    /// to submit before `encoder`'s.
    pub fn paint(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        size: (u32, u32),
        frame: &UiFrame,
    ) -> Vec<wgpu::CommandBuffer> {
        let screen = ScreenDescriptor { size_in_pixels: [size.0, size.1], pixels_per_point: frame.pixels_per_point };
        let extra = self.renderer.update_buffers(device, queue, encoder, &frame.primitives, &screen);
        let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("egui"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                resolve_target: None,
                depth_slice: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        self.renderer.render(&mut pass.forget_lifetime(), &frame.primitives, &screen);
        extra
    }

    /// Frees the textures egui no longer needs; call after submitting.
    pub fn free_textures(&mut self, frame: &UiFrame) {
        for id in &frame.free_textures {
            self.renderer.free_texture(id);
        }
    }
}
