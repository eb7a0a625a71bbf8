//! [`Viewer`]: the interactive viewer without its window — the simulation,
//! the camera, the panel, the mouse and keys, and drawing a frame into any
//! texture view. The window ([`super::run`]) feeds it egui input and shows
//! what it draws; tests drive it offscreen the same way.

use std::path::PathBuf;
use std::time::Duration;

mod commands;
mod input;
mod output;
mod scenes;
pub mod timeline;

use egui::Ui;
use glam::{Vec2, Vec3};
use input::Drag;
use timeline::Timeline;

use super::clock::{Clock, WallClock};
use super::grab::ViewGeometry;
use super::stepper::Stepper;
use crate::render::{Gpu, OrbitCamera, Renderer, ViewOptions, Viewport};
use crate::scene::Scene;
use crate::sim::{SimError, Simulation};
use crate::ui::overlay::{self, Toast};
use crate::ui::panel::panel_width;
use crate::ui::{PanelModel, PanelState, Stats, UiCommand, UiFrame, UiPainter};

/// Seconds a notice stays up.
const TOAST_SECONDS: f64 = 4.0;
/// How often an idle viewer looks whether its scene file was saved.
const WATCH_POLL: Duration = Duration::from_millis(250);

/// What the window must do on the viewer's behalf.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindowRequest {
    /// Close the window and end the program.
    Quit,
    /// Reconfigure presentation with vsync on or off.
    SetVsync(bool),
}

/// One frame's result: egui's drawing, and what the window must do.
pub struct Frame {
    /// egui's output, to draw with [`Viewer::draw`].
    pub ui: UiFrame,
    /// egui's requests to the platform (cursor icon, clipboard, …).
    pub platform: egui::PlatformOutput,
    /// Requests for the window.
    pub requests: Vec<WindowRequest>,
    /// When to draw the next frame if nothing happens: zero while the
    /// simulation runs.
    pub repaint_after: Duration,
}

impl std::fmt::Debug for Frame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Frame")
            .field("ui", &self.ui)
            .field("requests", &self.requests)
            .field("repaint_after", &self.repaint_after)
            .finish_non_exhaustive()
    }
}

/// How a viewer is set up besides its scene.
pub struct ViewerSettings {
    /// Draw egui without dithering or hardware filtering (golden images).
    pub predictable_ui: bool,
    /// Where time comes from.
    pub clock: Box<dyn Clock>,
    /// Where F12 saves PNGs.
    pub screenshot_dir: PathBuf,
    /// Where the timeline's *Export .glb* writes.
    pub export_dir: PathBuf,
    /// What the panel says about the graphics adapter; `None` describes
    /// the real one (tests fix it, since it names the driver version).
    pub adapter_label: Option<String>,
}

impl Default for ViewerSettings {
    fn default() -> Self {
        Self {
            predictable_ui: false,
            clock: Box::new(WallClock::default()),
            screenshot_dir: PathBuf::from("screenshots"),
            export_dir: PathBuf::from("exports"),
            adapter_label: None,
        }
    }
}

/// The viewer's state and behaviour, independent of any window.
pub struct Viewer {
    gpu: Gpu,
    adapter: String,
    scene: Scene,
    sim: Simulation,
    renderer: Renderer,
    painter: UiPainter,
    egui: egui::Context,
    panel: PanelState,
    camera: OrbitCamera,
    camera_placed: bool,
    view: ViewOptions,
    paused: bool,
    stepper: Stepper,
    stats: Stats,
    toasts: Vec<Toast>,
    drag: Drag,
    /// The simulation changed since the renderer last took its positions.
    sim_changed: bool,
    /// The strain of the current state, once computed (O(bars): not redone
    /// for frames in which nothing moved).
    strain: Option<crate::sim::Strain>,
    clock: Box<dyn Clock>,
    last_frame: Option<Duration>,
    vsync: Option<bool>,
    /// The 3-D view's rectangle, points.
    view_rect: egui::Rect,
    pixels_per_point: f32,
    screenshot_dir: PathBuf,
    screenshot_pending: bool,
    /// Recent frames: scrub, play back, resume, export.
    timeline: Timeline,
    /// Why the scene opened in its time mode (the panel says it).
    time_reason: String,
    /// What is absurd about the state shown, if anything (checked when it
    /// changes).
    absurd: Option<crate::sim::health::Absurdity>,
    /// The particle under the cursor, which a click would grab or pin.
    hovered: Option<usize>,
    /// The scene file on disk, watched for saves (none for bundled scenes).
    watcher: Option<super::watch::SceneWatcher>,
    export_dir: PathBuf,
}

impl std::fmt::Debug for Viewer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewer").field("scene", &self.scene.name).field("steps", &self.sim.steps()).finish()
    }
}

impl Viewer {
    /// A viewer of `scene` drawing into targets of `format`.
    pub fn new(
        gpu: Gpu,
        scene: Scene,
        format: wgpu::TextureFormat,
        settings: ViewerSettings,
    ) -> Result<Self, SimError> {
        let sim = scene.simulation()?;
        let mut renderer = Renderer::new(&gpu, format);
        renderer.update(&sim);
        let painter = UiPainter::new(&gpu.device, format, settings.predictable_ui);
        let egui = egui::Context::default();
        egui.set_theme(egui::Theme::Dark);
        let view = ViewOptions::for_mesh(&scene.mesh);
        let mut timeline = Timeline::new(sim.mesh().clone());
        timeline.restart(&sim);
        let mut viewer = Self {
            adapter: settings.adapter_label.unwrap_or_else(|| gpu.adapter_summary()),
            gpu,
            camera: OrbitCamera::default(),
            camera_placed: false,
            scene,
            sim,
            renderer,
            painter,
            egui,
            panel: PanelState::default(),
            view,
            paused: false,
            stepper: Stepper::default(),
            stats: Stats::default(),
            toasts: Vec::new(),
            drag: Drag::None,
            sim_changed: false,
            strain: None,
            clock: settings.clock,
            last_frame: None,
            vsync: None,
            view_rect: egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(800.0, 600.0)),
            pixels_per_point: 1.0,
            screenshot_dir: settings.screenshot_dir,
            screenshot_pending: false,
            timeline,
            time_reason: String::new(),
            absurd: None,
            hovered: None,
            watcher: None,
            export_dir: settings.export_dir,
        };
        viewer.choose_time_mode();
        viewer.watch_scene_file();
        Ok(viewer)
    }

    /// The GPU objects the viewer draws with.
    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// The egui context (the window's egui-winit state feeds it).
    pub fn egui(&self) -> &egui::Context {
        &self.egui
    }

    /// The simulation.
    pub fn simulation(&self) -> &Simulation {
        &self.sim
    }

    /// The simulation, to change it from code (a script, a test). The
    /// change is drawn in the next frame.
    pub fn simulation_mut(&mut self) -> &mut Simulation {
        self.touched();
        &mut self.sim
    }

    /// Where particle `index` is drawn, in points from the window's top-left
    /// corner (as of the last frame); `None` if it is behind the camera.
    pub fn particle_on_screen(&self, index: usize) -> Option<egui::Pos2> {
        self.point_on_screen(*self.sim.positions().get(index)?)
    }

    /// Where the world point `p` is drawn, in points from the window's
    /// top-left corner (as of the last frame); `None` if behind the camera.
    pub fn point_on_screen(&self, p: Vec3) -> Option<egui::Pos2> {
        let geometry = self.view_geometry();
        let (pixel, _) = geometry.camera.project(p, geometry.size, geometry.world_radius)?;
        let points = pixel / self.pixels_per_point;
        Some(self.view_rect.min + egui::vec2(points.x, points.y))
    }

    /// The scene loaded.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The camera.
    pub fn camera(&self) -> &OrbitCamera {
        &self.camera
    }

    /// Whether time is stopped.
    pub fn paused(&self) -> bool {
        self.paused
    }

    /// What is drawn.
    pub fn view_options(&self) -> &ViewOptions {
        &self.view
    }

    /// What is absurd about the state shown (the warning over the view).
    pub fn absurdity(&self) -> Option<&crate::sim::health::Absurdity> {
        self.absurd.as_ref()
    }

    /// The particle under the cursor (highlighted: a click grabs it, or
    /// with Ctrl pins it), as of the last frame.
    pub fn hovered_particle(&self) -> Option<usize> {
        self.hovered
    }

    /// How time advances now.
    pub fn time_mode(&self) -> crate::ui::TimeMode {
        self.stepper.mode
    }

    /// Why the scene opened in its time mode, as the panel says it.
    pub fn time_reason(&self) -> &str {
        &self.time_reason
    }

    /// The timeline: recorded frames and the one shown.
    pub fn timeline(&self) -> &Timeline {
        &self.timeline
    }

    /// The notices currently up, newest last.
    pub fn toasts(&self) -> &[Toast] {
        &self.toasts
    }

    /// The window title for the current scene.
    pub fn title(&self) -> String {
        format!("drape — {}", self.scene.name)
    }

    /// Tells the viewer whether presentation waits for vsync (shown in the
    /// panel); `None` hides the option (no window).
    pub fn set_vsync(&mut self, vsync: Option<bool>) {
        self.vsync = vsync;
    }

    /// The 3-D view's rectangle in physical pixels, from the last frame.
    pub fn viewport(&self) -> Viewport {
        let r = self.view_rect;
        let s = self.pixels_per_point;
        Viewport { x: r.left() * s, y: r.top() * s, width: r.width() * s, height: r.height() * s }
    }

    /// Notes that the simulation's state changed: the renderer must take
    /// the new positions, the strain must be measured again.
    fn touched(&mut self) {
        self.sim_changed = true;
        self.strain = None;
    }

    fn seconds(&mut self) -> f64 {
        self.clock.now().as_secs_f64()
    }

    fn toast(&mut self, text: impl Into<String>, error: bool) {
        let until = self.seconds() + TOAST_SECONDS;
        self.toasts.push(Toast { text: text.into(), error, until });
    }

    /// Runs the interface for one frame on `input`, applies what the user
    /// asked for, advances the simulation, and returns egui's drawing.
    pub fn run_frame(&mut self, input: egui::RawInput) -> Frame {
        self.reload_if_saved();
        let ctx = self.egui.clone();
        let mut commands = Vec::new();
        let output = ctx.run_ui(input, |ui| commands.extend(self.build_ui(ui)));
        self.pixels_per_point = output.pixels_per_point;
        if !self.camera_placed {
            self.reset_camera();
            self.camera_placed = true;
        }
        let mut requests = Vec::new();
        for command in commands {
            requests.extend(self.apply(command));
        }
        self.advance();

        let now = self.seconds();
        self.toasts.retain(|t| t.until > now);
        let running = !self.paused && self.sim.diverged().is_none();
        let egui_delay = output.viewport_output.get(&egui::ViewportId::ROOT).map_or(Duration::MAX, |v| v.repaint_delay);
        let toast_delay = self.toasts.iter().map(|t| Duration::from_secs_f64((t.until - now).max(0.0))).min();
        // A watched file is polled a few times a second even when idle.
        let watch_delay = self.watcher.as_ref().map(|_| WATCH_POLL);
        let repaint_after = if running || !matches!(self.drag, Drag::None) {
            Duration::ZERO
        } else {
            egui_delay.min(toast_delay.unwrap_or(Duration::MAX)).min(watch_delay.unwrap_or(Duration::MAX))
        };
        let primitives = ctx.tessellate(output.shapes, output.pixels_per_point);
        // Textures go up now, whether or not the frame is drawn: a frame
        // skipped while minimised must not lose the font atlas.
        let free_textures = self.painter.upload_textures(&self.gpu.device, &self.gpu.queue, output.textures_delta);
        Frame {
            ui: UiFrame { primitives, free_textures, pixels_per_point: output.pixels_per_point },
            platform: output.platform_output,
            requests,
            repaint_after,
        }
    }

    /// Lays out the panel, the 3-D view and the overlays; returns commands.
    fn build_ui(&mut self, ui: &mut Ui) -> Vec<UiCommand> {
        let mut commands = self.keyboard(ui.ctx());
        let model = PanelModel {
            scene: &self.scene,
            sim: &self.sim,
            paused: self.paused,
            time_mode: self.stepper.mode,
            time_reason: &self.time_reason,
            view: self.view,
            vsync: self.vsync,
            stats: &self.stats,
            adapter: &self.adapter,
        };
        let state = &mut self.panel;
        let width = panel_width(ui.ctx().content_rect().width());
        egui::Panel::right("panel").resizable(false).exact_size(width).show(ui, |ui| {
            commands.extend(crate::ui::panel(ui, state, &model));
        });
        let recording = self.timeline.recording();
        let shown = self.timeline.cursor().and_then(|i| recording.get(i));
        let timeline = crate::ui::timeline::TimelineModel {
            frames: recording.len(),
            cursor: self.timeline.cursor(),
            playing: self.timeline.playing(),
            first_time: recording.get(0).map_or(0.0, |f| f.time),
            time: shown.map_or(self.sim.time(), |f| f.time),
            frame_bytes: recording.frame_bytes(),
            capacity: recording.capacity(),
        };
        egui::Panel::bottom("timeline").show(ui, |ui| {
            commands.extend(crate::ui::timeline::timeline_bar(ui, &timeline));
        });
        egui::CentralPanel::no_frame().show(ui, |ui| self.view_area(ui));
        let ctx = ui.ctx().clone();
        // A scene file dropped on the window opens.
        let dropped: Vec<String> =
            ctx.input(|i| i.raw.dropped_files.iter().map(|f| f.path().display().to_string()).collect());
        commands.extend(dropped.into_iter().map(UiCommand::LoadScene));
        if super::snapshot::shows_strain(&self.view, &self.sim) {
            overlay::strain_legend(&ctx, self.view_rect, self.view.strain_scale);
        }
        if let Some(error) = self.sim.diverged() {
            commands.extend(overlay::diverged_message(&ctx, self.view_rect, &error.to_string()));
        } else if let Some(absurd) = &self.absurd {
            overlay::absurd_warning(&ctx, self.view_rect, &absurd.to_string());
        }
        let now = self.seconds();
        overlay::toasts(&ctx, self.view_rect, &self.toasts, now);
        commands
    }

    fn view_geometry(&self) -> ViewGeometry {
        let vp = self.viewport();
        ViewGeometry {
            camera: self.camera,
            size: Vec2::new(vp.width, vp.height),
            world_radius: self.renderer.world_radius(),
        }
    }

    /// Advances the simulation by this frame's steps (none while paused or
    /// blown up) and records the frame's figures.
    fn advance(&mut self) {
        let now = self.clock.now();
        let frame_seconds = self.last_frame.map_or(0.0, |last| now.saturating_sub(last).as_secs_f64());
        self.last_frame = Some(now);
        if let Drag::Grab(grab) = &self.drag {
            if let Err(e) = grab.hold(&mut self.sim) {
                self.toast(e.to_string(), true);
            }
            self.touched();
        }
        match self.timeline.play_for(frame_seconds, &mut self.sim) {
            Ok(true) => self.touched(),
            Ok(false) => {}
            Err(e) => {
                self.timeline.stop();
                self.toast(e.to_string(), true);
            }
        }
        let mut steps = 0;
        let mut solver_seconds = 0.0;
        let time_before = self.sim.time();
        if !self.paused && self.sim.diverged().is_none() {
            steps = self.stepper.steps_for_frame(
                frame_seconds,
                f64::from(self.sim.params().dt),
                self.stats.solver_seconds_per_step(),
            );
            let start = self.clock.now();
            let result = self.sim.advance(steps);
            solver_seconds = self.clock.now().saturating_sub(start).as_secs_f64();
            self.touched();
            if result.is_err() {
                self.end_drag();
            } else if steps > 0 {
                self.timeline.record(&self.sim);
            }
        }
        let simulated = self.sim.time() - time_before;
        let at = now.as_secs_f64();
        let strain = match self.strain {
            Some(strain) => strain,
            None => {
                let strain = self.sim.edge_strain();
                self.strain = Some(strain);
                self.absurd = crate::sim::health::check(&self.sim, strain.max);
                strain
            }
        };
        self.stats.record_frame(at, frame_seconds, solver_seconds, steps, simulated, strain);
    }
}
