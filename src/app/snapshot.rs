//! [`snapshot`]: one frame of a simulation as an image, as `drape render`
//! writes it: the renderer's picture, with the strain legend drawn by egui
//! when strain colours are shown.

use crate::render::{FrameSpec, Gpu, OffscreenTarget, OrbitCamera, ReadbackError, Renderer, ViewOptions, Viewport};
use crate::sim::Simulation;
use crate::ui::overlay;
use crate::ui::{UiFrame, UiPainter};

/// egui passes run before the legend is drawn.
const LEGEND_PASSES: u32 = 4;

/// Whether `options` colour anything by strain on this simulation's mesh.
pub fn shows_strain(options: &ViewOptions, sim: &Simulation) -> bool {
    options.strain_colours
        && ((options.surface && !sim.mesh().triangles().is_empty()) || options.structural_bars || options.bend_bars)
}

/// Renders `sim` as it is now into a new `width × height` image with
/// `renderer` (made for [`OffscreenTarget::FORMAT`]).
pub fn snapshot(
    gpu: &Gpu,
    renderer: &mut Renderer,
    sim: &Simulation,
    camera: &OrbitCamera,
    options: &ViewOptions,
    (width, height): (u32, u32),
) -> Result<image::RgbaImage, ReadbackError> {
    let target = OffscreenTarget::new(&gpu.device, width, height)?;
    // Whatever the GPU rejects while drawing (out of memory for a large
    // image, most likely) comes back as an error, not a panic.
    let validation = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let memory = gpu.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    renderer.update(sim);
    let frame = FrameSpec {
        camera: *camera,
        viewport: Viewport::full(width, height),
        options: *options,
        pixels_per_point: 1.0,
    };
    let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("snapshot") });
    renderer.render(&mut encoder, &target.view, (width, height), &frame);
    let mut extra = Vec::new();
    let mut legend = None;
    if shows_strain(options, sim) {
        let ctx = egui::Context::default();
        ctx.set_theme(egui::Theme::Dark);
        let rect = egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(width as f32, height as f32));
        // egui measures a new area in its first pass and fades it in: run
        // passes until it is settled, keeping every texture change.
        let mut textures = egui::TexturesDelta::default();
        let mut output = None;
        for pass in 0..LEGEND_PASSES {
            let input =
                egui::RawInput { screen_rect: Some(rect), time: Some(f64::from(pass) * 0.1), ..Default::default() };
            let mut out = ctx.run_ui(input, |ui| overlay::strain_legend(ui.ctx(), rect, options.strain_scale));
            textures.append(std::mem::take(&mut out.textures_delta));
            output = Some(out);
        }
        let Some(output) = output else { unreachable!("LEGEND_PASSES > 0") };
        let mut painter = UiPainter::new(&gpu.device, OffscreenTarget::FORMAT, true);
        let free_textures = painter.upload_textures(&gpu.device, &gpu.queue, textures);
        let primitives = ctx.tessellate(output.shapes, output.pixels_per_point);
        let ui = UiFrame { primitives, free_textures, pixels_per_point: output.pixels_per_point };
        extra = painter.paint(&gpu.device, &gpu.queue, &mut encoder, &target.view, (width, height), &ui);
        legend = Some((painter, ui));
    }
    gpu.queue.submit(extra.into_iter().chain([encoder.finish()]));
    // Scopes pop in reverse order of pushing.
    let errors = [pollster::block_on(memory.pop()), pollster::block_on(validation.pop())];
    let image = match errors.into_iter().flatten().next() {
        Some(error) => Err(ReadbackError::Gpu(error.to_string())),
        None => target.read(&gpu.device, &gpu.queue),
    };
    if let Some((mut painter, ui)) = legend {
        painter.free_textures(&ui);
    }
    image
}
