//! The winit application: one window, its wgpu surface, and the
//! [`Viewer`] it shows. Everything here is about the desktop — resizing,
//! minimising, scale factors, a surface that goes stale — and nothing about
//! cloth.

use std::sync::Arc;
use std::time::{Duration, Instant};

use winit::application::ApplicationHandler;
use winit::dpi::LogicalSize;
use winit::event::{StartCause, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use super::viewer::{Viewer, ViewerSettings, WindowRequest};
use crate::render::{AdapterPreference, Gpu, GpuError};
use crate::scene::Scene;
use crate::sim::SimError;

/// Why the viewer could not run.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// There is no display to open a window on.
    #[error(
        "cannot open a window ({0}); on a machine without a display, `drape render` draws frames to PNG files \
         with no window, or run the viewer under a virtual display (xvfb-run drape)"
    )]
    NoDisplay(String),
    /// The window system refused the window.
    #[error("cannot create the window: {0}")]
    Window(String),
    /// No graphics adapter, device or surface.
    #[error("{0}")]
    Gpu(GpuError),
    /// The scene could not be simulated.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The event loop stopped with an error.
    #[error("the window's event loop failed: {0}")]
    EventLoop(String),
}

/// Opens the viewer on `scene` and runs until the window closes.
pub fn run(scene: Scene) -> Result<(), AppError> {
    let event_loop = EventLoop::new().map_err(|e| AppError::NoDisplay(e.to_string()))?;
    let mut app = App { scene: Some(scene), running: None, error: None };
    event_loop.run_app(&mut app).map_err(|e| AppError::EventLoop(e.to_string()))?;
    app.error.map_or(Ok(()), Err)
}

/// The application: waiting for its window, or showing it.
struct App {
    scene: Option<Scene>,
    running: Option<Running>,
    error: Option<AppError>,
}

/// The window, its surface and what it shows.
struct Running {
    window: Arc<Window>,
    surface: WindowSurface,
    egui_input: egui_winit::State,
    viewer: Viewer,
    repaint_at: Option<Instant>,
    title: String,
}

/// A window's surface and its configuration.
struct WindowSurface {
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// False while the window has no area (minimised): nothing is drawn.
    visible: bool,
}

impl WindowSurface {
    fn new(gpu: &Gpu, surface: wgpu::Surface<'static>, window: &Window) -> Result<Self, GpuError> {
        let caps = surface.get_capabilities(&gpu.adapter);
        // egui draws correctly into a non-sRGB target and the cloth shaders
        // encode sRGB themselves, so prefer plain 8-bit formats.
        use wgpu::TextureFormat as F;
        let format = [F::Bgra8Unorm, F::Rgba8Unorm, F::Bgra8UnormSrgb, F::Rgba8UnormSrgb]
            .into_iter()
            .find(|f| caps.formats.contains(f))
            .ok_or_else(|| GpuError::NoSurfaceFormat(format!("{:?}", caps.formats)))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        let visible = size.width > 0 && size.height > 0;
        if visible {
            surface.configure(&gpu.device, &config);
        }
        Ok(Self { surface, config, visible })
    }

    /// Follows the window's size; a zero size (minimised) stops drawing
    /// instead of configuring an invalid surface.
    fn resize(&mut self, gpu: &Gpu, width: u32, height: u32) {
        self.visible = width > 0 && height > 0;
        if self.visible {
            self.config.width = width;
            self.config.height = height;
            self.surface.configure(&gpu.device, &self.config);
        }
    }

    fn reconfigure(&mut self, gpu: &Gpu) {
        if self.visible {
            self.surface.configure(&gpu.device, &self.config);
        }
    }

    fn vsync(&self) -> bool {
        !matches!(self.config.present_mode, wgpu::PresentMode::AutoNoVsync)
    }

    fn set_vsync(&mut self, gpu: &Gpu, on: bool) {
        self.config.present_mode = if on { wgpu::PresentMode::AutoVsync } else { wgpu::PresentMode::AutoNoVsync };
        self.reconfigure(gpu);
    }
}

/// Smallest window, logical points.
const MIN_SIZE: (f64, f64) = (480.0, 320.0);
/// Share of the monitor the window opens at, each way.
const MONITOR_SHARE: f64 = 0.8;
/// Largest window it opens at, logical points: beyond it a bigger window
/// only costs frame rate (software rasterisers draw every pixel).
const MAX_SIZE: (f64, f64) = (1600.0, 1000.0);

/// The window's size at opening, in logical points: 80 % of the monitor
/// (`(width, height, scale factor)` in physical pixels) each way, at most
/// 1600 × 1000 and at least the minimum; 1280 × 800 when the monitor is
/// unknown. (winit 0.30 does not report the work area without the
/// taskbar; 80 % leaves room for one.)
fn initial_size(monitor: Option<(u32, u32, f64)>) -> LogicalSize<f64> {
    let Some((width, height, scale)) = monitor.filter(|m| m.0 > 0 && m.1 > 0 && m.2 > 0.0) else {
        return LogicalSize::new(1280.0, 800.0);
    };
    let fit = |physical: u32, max: f64, min: f64| (MONITOR_SHARE * f64::from(physical) / scale).min(max).max(min);
    LogicalSize::new(fit(width, MAX_SIZE.0, MIN_SIZE.0), fit(height, MAX_SIZE.1, MIN_SIZE.1))
}

impl App {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running, AppError> {
        let Some(scene) = self.scene.take() else {
            return Err(AppError::Window("the viewer was started twice".into()));
        };
        let monitor = event_loop.primary_monitor().or_else(|| event_loop.available_monitors().next());
        let size = initial_size(monitor.map(|m| {
            let s = m.size();
            (s.width, s.height, m.scale_factor())
        }));
        let attributes = Window::default_attributes()
            .with_title(format!("drape — {}", scene.name))
            .with_inner_size(size)
            .with_min_inner_size(LogicalSize::new(MIN_SIZE.0, MIN_SIZE.1));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| AppError::Window(e.to_string()))?);
        let descriptor =
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(event_loop.owned_display_handle()));
        let instance = wgpu::Instance::new(descriptor);
        let surface = instance.create_surface(window.clone()).map_err(|e| AppError::Gpu(GpuError::CreateSurface(e)))?;
        let gpu = Gpu::with_instance(instance, Some(&surface), AdapterPreference::Hardware).map_err(AppError::Gpu)?;
        if gpu.is_software() {
            log::warn!("drawing with a software rasteriser ({}): expect a low frame rate", gpu.adapter_summary());
        }
        let surface = WindowSurface::new(&gpu, surface, &window).map_err(AppError::Gpu)?;
        let format = surface.config.format;
        let mut viewer = Viewer::new(gpu, scene, format, ViewerSettings::default())?;
        viewer.set_vsync(Some(surface.vsync()));
        let max_texture = viewer.gpu().device.limits().max_texture_dimension_2d as usize;
        let egui_input = egui_winit::State::new(
            viewer.egui().clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            window.theme(),
            Some(max_texture),
        );
        let title = viewer.title();
        window.request_redraw();
        Ok(Running { window, surface, egui_input, viewer, repaint_at: None, title })
    }
}

impl Running {
    /// One frame: run the interface and the simulation, draw, present.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) {
        let input = self.egui_input.take_egui_input(&self.window);
        let frame = self.viewer.run_frame(input);
        self.egui_input.handle_platform_output(&self.window, frame.platform);
        for request in &frame.requests {
            match *request {
                WindowRequest::Quit => event_loop.exit(),
                WindowRequest::SetVsync(on) => {
                    let gpu = self.viewer.gpu().clone();
                    self.surface.set_vsync(&gpu, on);
                    self.viewer.set_vsync(Some(self.surface.vsync()));
                }
            }
        }
        let title = self.viewer.title();
        if title != self.title {
            self.window.set_title(&title);
            self.title = title;
        }
        self.repaint_at = Instant::now().checked_add(frame.repaint_after);

        if !self.surface.visible {
            self.viewer.skip_draw(&frame.ui);
            return;
        }
        let gpu = self.viewer.gpu().clone();
        let (texture, suboptimal) = match self.surface.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) => (t, false),
            // Draw this one, then match the surface to the window.
            wgpu::CurrentSurfaceTexture::Suboptimal(t) => (t, true),
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                self.viewer.skip_draw(&frame.ui);
                self.repaint_at = Instant::now().checked_add(Duration::from_millis(100));
                return;
            }
            wgpu::CurrentSurfaceTexture::Outdated => {
                self.resize_to_window(&gpu);
                self.viewer.skip_draw(&frame.ui);
                self.window.request_redraw();
                return;
            }
            wgpu::CurrentSurfaceTexture::Lost => {
                match gpu.instance.create_surface(self.window.clone()) {
                    Ok(surface) => {
                        self.surface.surface = surface;
                        self.resize_to_window(&gpu);
                    }
                    Err(e) => log::error!("the window's surface was lost and cannot be recreated: {e}"),
                }
                self.viewer.skip_draw(&frame.ui);
                self.window.request_redraw();
                return;
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                log::error!("the surface reported a validation error; skipping a frame");
                self.viewer.skip_draw(&frame.ui);
                return;
            }
        };
        let view = texture.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let size = (texture.texture.width(), texture.texture.height());
        self.viewer.draw(&view, size, &frame.ui);
        self.window.pre_present_notify();
        gpu.queue.present(texture);
        if suboptimal {
            self.resize_to_window(&gpu);
        }
    }

    fn resize_to_window(&mut self, gpu: &Gpu) {
        let size = self.window.inner_size();
        self.surface.resize(gpu, size.width, size.height);
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.start(event_loop) {
            Ok(running) => self.running = Some(running),
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn new_events(&mut self, _event_loop: &ActiveEventLoop, cause: StartCause) {
        if let (StartCause::ResumeTimeReached { .. }, Some(running)) = (cause, &self.running) {
            running.window.request_redraw();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(running) = &mut self.running else { return };
        let response = running.egui_input.on_window_event(&running.window, &event);
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => event_loop.exit(),
            WindowEvent::Resized(size) => {
                let gpu = running.viewer.gpu().clone();
                running.surface.resize(&gpu, size.width, size.height);
                running.window.request_redraw();
            }
            WindowEvent::ScaleFactorChanged { .. } => running.window.request_redraw(),
            WindowEvent::RedrawRequested => running.redraw(event_loop),
            _ => {}
        }
        if response.repaint {
            running.window.request_redraw();
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let Some(running) = &self.running else { return };
        match running.repaint_at {
            Some(at) if at <= Instant::now() => {
                running.window.request_redraw();
                event_loop.set_control_flow(ControlFlow::Wait);
            }
            Some(at) => event_loop.set_control_flow(ControlFlow::WaitUntil(at)),
            None => event_loop.set_control_flow(ControlFlow::Wait),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_fits_the_monitor() {
        // A 1366 × 768 laptop at scale 1: 80 % is 1092.8 × 614.4 points.
        let s = initial_size(Some((1366, 768, 1.0)));
        assert!((s.width - 1092.8).abs() < 1e-9 && (s.height - 614.4).abs() < 1e-9, "{s:?}");
        // A 4K monitor at scale 2 is 1920 × 1080 points: 1536 × 864; at
        // scale 1, 80 % is 3072 × 1728, capped at 1600 × 1000.
        assert_eq!(initial_size(Some((3840, 2160, 2.0))), LogicalSize::new(1536.0, 864.0));
        assert_eq!(initial_size(Some((3840, 2160, 1.0))), LogicalSize::new(1600.0, 1000.0));
        // A tiny screen still gets the minimum; an unknown one 1280 × 800.
        assert_eq!(initial_size(Some((400, 300, 1.0))), LogicalSize::new(480.0, 320.0));
        assert_eq!(initial_size(None), LogicalSize::new(1280.0, 800.0));
    }
}
