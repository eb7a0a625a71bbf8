//! What leaves the viewer: each frame drawn into a texture view (the
//! window's, or an offscreen image for tests and F12), screenshots, and the
//! recorded frames exported as glTF.

use super::Viewer;
use crate::render::{self, FrameSpec, OffscreenTarget, ReadbackError};
use crate::ui::UiFrame;

impl Viewer {
    /// Writes the recorded frames as `exports/drape-<scene>-<time>.glb`.
    pub(super) fn export_recording(&mut self) {
        let name: String =
            self.scene.name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
        let path = self.export_dir.join(format!("drape-{name}-{}.glb", timestamp()));
        let recording = self.timeline.recording();
        match crate::export::glb::write_file(&path, recording) {
            Ok(()) => {
                let frames = recording.len();
                self.toast(format!("exported {frames} frames to {}", path.display()), false);
            }
            Err(e) => self.toast(format!("export failed: {e}"), true),
        }
    }

    /// Records and submits the frame: the cloth in the 3-D view, then egui
    /// over it, into `target` (`size` pixels, in the format the viewer was
    /// made for). Takes the F12 screenshot if one was asked for. Call after
    /// [`Self::run_frame`] and before presenting.
    pub fn draw(&mut self, target: &wgpu::TextureView, size: (u32, u32), ui: &UiFrame) {
        let start = self.clock.now();
        self.record_and_submit(target, size, ui);
        let elapsed = self.clock.now().saturating_sub(start).as_secs_f64();
        self.stats.record_render(elapsed);
        if std::mem::take(&mut self.screenshot_pending) {
            self.save_screenshot(size, ui);
        }
        self.painter.free_textures(ui);
    }

    pub(super) fn record_and_submit(&mut self, target: &wgpu::TextureView, size: (u32, u32), ui: &UiFrame) {
        if std::mem::take(&mut self.sim_changed) {
            self.renderer.update(&self.sim);
        }
        let frame = FrameSpec {
            camera: self.camera,
            viewport: self.viewport(),
            options: self.view,
            pixels_per_point: self.pixels_per_point,
        };
        let device = self.gpu.device.clone();
        let queue = self.gpu.queue.clone();
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        self.renderer.render(&mut encoder, target, size, &frame);
        let extra = self.painter.paint(&device, &queue, &mut encoder, target, size, ui);
        queue.submit(extra.into_iter().chain([encoder.finish()]));
    }

    /// Draws the frame into a new offscreen image instead of a window: the
    /// F12 path, and the golden test of the whole window. Frees nothing:
    /// call [`Self::draw`] or [`Self::skip_draw`] for that.
    pub fn render_image(&mut self, size: (u32, u32), ui: &UiFrame) -> Result<image::RgbaImage, ReadbackError> {
        // In the format the renderer and egui were made for (the window's).
        let target = OffscreenTarget::with_format(&self.gpu.device, size.0, size.1, self.renderer.format())?;
        self.record_and_submit(&target.view, size, ui);
        target.read(&self.gpu.device, &self.gpu.queue)
    }

    /// Ends a frame that is not drawn (a minimised window, a surface that
    /// is not ready), or one drawn only with [`Self::render_image`].
    pub fn skip_draw(&mut self, ui: &UiFrame) {
        self.painter.free_textures(ui);
    }

    pub(super) fn save_screenshot(&mut self, size: (u32, u32), ui: &UiFrame) {
        let path = self.screenshot_dir.join(format!("drape-{}.png", timestamp()));
        let result = self.render_image(size, ui).map_err(|e| e.to_string()).and_then(|image| {
            std::fs::create_dir_all(&self.screenshot_dir).map_err(|e| e.to_string())?;
            render::write_png(&path, &image).map_err(|e| e.to_string())
        });
        match result {
            Ok(()) => self.toast(format!("saved {}", path.display()), false),
            Err(e) => self.toast(format!("screenshot failed: {e}"), true),
        }
    }
}

/// `YYYYMMDD-HHMMSS-mmm` in UTC, from the system clock.
fn timestamp() -> String {
    let since = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    let secs = since.as_secs();
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!("{y:04}{m:02}{d:02}-{:02}{:02}{:02}-{:03}", rem / 3600, rem / 60 % 60, rem % 60, since.subsec_millis())
}

/// The proleptic Gregorian date of a day count since 1970-01-01
/// (Howard Hinnant's `civil_from_days`).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    pub(super) fn civil_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(20_759), (2026, 11, 2));
    }
}
