//! The side panel: scene, solver, view and stats. It draws from a read-only
//! [`PanelModel`] and returns [`UiCommand`]s; it changes nothing itself.

use egui::{Color32, RichText, Ui};
use egui_plot::{Line, Plot, PlotPoints};

use super::command::{KEY_BINDINGS, MOUSE_BINDINGS, TimeMode, UiCommand};
use super::solver_controls::{SceneDefaults, solver_controls};
use super::stats::Stats;
use crate::headless::format_duration;
use crate::render::ViewOptions;
use crate::scene::{BUNDLED, Scene};
use crate::sim::Simulation;

/// Narrowest and widest the panel is, in points.
pub const PANEL_WIDTH_RANGE: (f32, f32) = (290.0, 360.0);

/// The panel's width for a window `window_width` points wide: 30 % of it
/// within [`PANEL_WIDTH_RANGE`]. Set every frame, never remembered: the
/// panel follows the window and narrows again when it does; what is wider
/// than the panel wraps rather than widening it.
pub fn panel_width(window_width: f32) -> f32 {
    (0.3 * window_width).clamp(PANEL_WIDTH_RANGE.0, PANEL_WIDTH_RANGE.1)
}

/// Everything the panel shows.
#[derive(Clone, Copy, Debug)]
pub struct PanelModel<'a> {
    /// The scene loaded (its name, description and own parameters).
    pub scene: &'a Scene,
    /// The running simulation.
    pub sim: &'a Simulation,
    /// Whether time is stopped.
    pub paused: bool,
    /// How time advances.
    pub time_mode: TimeMode,
    /// Why the scene opened in that mode.
    pub time_reason: &'a str,
    /// What is drawn.
    pub view: ViewOptions,
    /// Whether presentation waits for vsync; `None` when there is no window.
    pub vsync: Option<bool>,
    /// Timings and strain.
    pub stats: &'a Stats,
    /// One line about the graphics adapter.
    pub adapter: &'a str,
}

/// What the panel remembers between frames on its own account.
#[derive(Clone, Debug, Default)]
pub struct PanelState {
    /// The scene file path being typed.
    pub scene_path: String,
}

/// Draws the panel into `ui` (a side panel's contents) and returns what
/// the user asked for.
pub fn panel(ui: &mut Ui, state: &mut PanelState, model: &PanelModel<'_>) -> Vec<UiCommand> {
    let mut commands = Vec::new();
    ui.add_space(4.0);
    ui.heading(&model.scene.name);
    ui.label(RichText::new(&model.scene.description).small().weak());
    ui.add_space(2.0);
    egui::ScrollArea::vertical().auto_shrink([false, false]).show(ui, |ui| {
        // Sliders share the row with a value box (about 90 points) and a
        // label (about 85): they take what is left, so no row is wider
        // than the panel.
        ui.spacing_mut().slider_width = (ui.available_width() - 190.0).clamp(50.0, 140.0);
        egui::CollapsingHeader::new("Scene").default_open(true).show(ui, |ui| {
            commands.extend(scene_section(ui, state, model));
        });
        egui::CollapsingHeader::new("Solver").default_open(true).show(ui, |ui| {
            let defaults = SceneDefaults {
                params: &model.scene.params,
                solver: model.scene.solver,
                grid: model.sim.mesh().grid().is_some(),
            };
            let mut how =
                format!("{}; {} passes last substep", model.sim.solver_description(), model.sim.last_passes());
            if let Some(r) = model.sim.last_projection() {
                how.push_str(&format!(
                    "; {} Newton iterations, edges to {:.3} %",
                    r.iterations,
                    r.strain_after * 100.0
                ));
            }
            if let Some((searches, substeps)) = model.sim.self_collision_searches() {
                how.push_str(&format!("; self-collision searched {searches} of {substeps} substeps"));
            }
            if let Some((speed, (held, _))) = model.sim.self_collision_top_speed() {
                let share = 100.0 * held as f32 / model.sim.positions().len().max(1) as f32;
                how.push_str(&format!("; top speed {speed:.2} m/s, {share:.0} % held to it"));
                if share >= 1.0 {
                    how.push_str(" (more substeps raise it)");
                }
            }
            commands.extend(solver_controls(ui, model.sim.params(), model.sim.solver(), &how, defaults));
        });
        egui::CollapsingHeader::new("View").default_open(true).show(ui, |ui| {
            commands.extend(view_section(ui, model));
        });
        egui::CollapsingHeader::new("Stats").default_open(true).show(ui, |ui| stats_section(ui, model));
        egui::CollapsingHeader::new("Keys and mouse").default_open(false).show(ui, bindings_section);
    });
    commands
}

fn scene_section(ui: &mut Ui, state: &mut PanelState, model: &PanelModel<'_>) -> Vec<UiCommand> {
    let mut commands = Vec::new();
    let current = model.scene.source.strip_prefix("bundled:").unwrap_or("file");
    egui::ComboBox::from_label("scene").selected_text(current).show_ui(ui, |ui| {
        for b in BUNDLED {
            if ui.selectable_label(current == b.name, b.name).clicked() {
                commands.push(UiCommand::LoadScene(b.name.to_string()));
            }
        }
    });
    ui.horizontal(|ui| {
        let edit = ui.add(
            egui::TextEdit::singleline(&mut state.scene_path).hint_text("path/to/scene.toml").desired_width(190.0),
        );
        let entered = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        let open = ui.add_enabled(!state.scene_path.trim().is_empty(), egui::Button::new("Open"));
        if (open.clicked() || entered) && !state.scene_path.trim().is_empty() {
            commands.push(UiCommand::LoadScene(state.scene_path.trim().to_string()));
        }
    });
    ui.horizontal(|ui| {
        let stopped = model.sim.diverged().is_some();
        let label = if model.paused { "Run" } else { "Pause" };
        if ui.add_enabled(!stopped, egui::Button::new(label)).on_hover_text("Space").clicked() {
            commands.push(UiCommand::TogglePause);
        }
        if ui.add_enabled(!stopped, egui::Button::new("Step")).on_hover_text("S").clicked() {
            commands.push(UiCommand::Step);
        }
        if ui.button("Reset").on_hover_text("R: back to the start, keeping the parameters").clicked() {
            commands.push(UiCommand::Reset);
        }
    });
    let mut mode = model.time_mode;
    ui.horizontal(|ui| {
        ui.radio_value(&mut mode, TimeMode::StepPerFrame, "step per frame")
            .on_hover_text("One step of h per displayed frame, as the seed did.");
        ui.radio_value(&mut mode, TimeMode::RealTime, "real time")
            .on_hover_text("Simulated time follows the clock (steps per frame capped).");
    });
    if mode != model.time_mode {
        commands.push(UiCommand::SetTimeMode(mode));
    }
    ui.label(RichText::new(model.time_reason).small().weak());
    ui.label(format!("step {} · t = {:.2} s", model.sim.steps(), model.sim.time()));
    commands
}

fn view_section(ui: &mut Ui, model: &PanelModel<'_>) -> Vec<UiCommand> {
    let mut commands = Vec::new();
    let mut view = model.view;
    let has_surface = !model.sim.mesh().triangles().is_empty();
    egui::Grid::new("view toggles").num_columns(2).show(ui, |ui| {
        ui.add_enabled(has_surface, egui::Checkbox::new(&mut view.surface, "surface"));
        ui.add_enabled(has_surface, egui::Checkbox::new(&mut view.wireframe, "wireframe"));
        ui.end_row();
        ui.checkbox(&mut view.structural_bars, "structural bars");
        ui.checkbox(&mut view.bend_bars, "bend bars");
        ui.end_row();
        ui.checkbox(&mut view.particles, "particles");
        ui.checkbox(&mut view.pins, "pins");
        ui.end_row();
        ui.checkbox(&mut view.strain_colours, "strain colours");
        ui.checkbox(&mut view.ground, "ground");
        ui.end_row();
        let has_colliders = !model.sim.colliders().is_empty();
        ui.add_enabled(has_colliders, egui::Checkbox::new(&mut view.colliders, "colliders"));
        ui.end_row();
    });
    let mut percent = view.strain_scale * 100.0;
    let scale = egui::Slider::new(&mut percent, 0.1..=100.0).logarithmic(true).suffix(" %").text("strain scale");
    if ui.add_enabled(view.strain_colours, scale).on_hover_text("The strain shown in dark red.").changed() {
        view.strain_scale = percent / 100.0;
    }
    if view != model.view {
        commands.push(UiCommand::SetView(view));
    }
    ui.horizontal(|ui| {
        if ui.button("Fit cloth").on_hover_text("F").clicked() {
            commands.push(UiCommand::FitCamera);
        }
        if ui.button("Scene view").on_hover_text("Home").clicked() {
            commands.push(UiCommand::ResetCamera);
        }
        if ui.button("Screenshot").on_hover_text("F12").clicked() {
            commands.push(UiCommand::Screenshot);
        }
    });
    if let Some(vsync) = model.vsync {
        let mut on = vsync;
        if ui.checkbox(&mut on, "vsync").changed() {
            commands.push(UiCommand::SetVsync(on));
        }
    }
    commands
}

fn optional(value: Option<f64>, show: impl Fn(f64) -> String) -> String {
    value.map_or_else(|| "–".to_string(), show)
}

fn stats_section(ui: &mut Ui, model: &PanelModel<'_>) {
    let stats = model.stats;
    let strain = stats.strain();
    let figures = [
        ("frame rate", optional(stats.fps(), |f| format!("{f:.1}/s"))),
        ("solver/step", optional(stats.solver_seconds_per_step(), format_duration)),
        ("render", optional(stats.render_seconds(), format_duration)),
        ("speed", optional(stats.speed(), |s| format!("{s:.2}× real"))),
        ("particles", model.sim.positions().len().to_string()),
        ("bars", model.sim.movable_bar_count().to_string()),
        ("max stretch", format!("{:.2} %", strain.max * 100.0)),
        ("RMS stretch", format!("{:.3} %", strain.rms * 100.0)),
    ];
    // Names in the normal text colour, figures in the strong one, both at
    // the body size: readable at a glance on the dark panel.
    // Two figures a row where the panel is wide enough for them at this
    // size, one a row otherwise.
    let strong = ui.visuals().strong_text_color();
    let per_row = if ui.available_width() >= 340.0 { 2 } else { 1 };
    egui::Grid::new("stats").num_columns(2 * per_row).striped(true).spacing([8.0, 3.0]).show(ui, |ui| {
        for row in figures.chunks(per_row) {
            for (name, value) in row {
                ui.label(*name);
                ui.label(RichText::new(value).monospace().color(strong));
            }
            ui.end_row();
        }
    });
    let now = stats.history().last().map_or(0.0, |s| s.at);
    let solver: PlotPoints<'_> = stats.history().filter_map(|s| Some([s.at - now, s.solver_ms?])).collect();
    let max: PlotPoints<'_> = stats.history().map(|s| [s.at - now, f64::from(s.max_strain) * 100.0]).collect();
    let rms: PlotPoints<'_> = stats.history().map(|s| [s.at - now, f64::from(s.rms_strain) * 100.0]).collect();
    ui.label(RichText::new("solver ms per step over the last seconds").small());
    small_plot("solver plot")
        .show(ui, |p| p.line(Line::new("solver ms", solver).color(Color32::from_rgb(90, 160, 255))));
    ui.label(RichText::new("stretch of the edges %: max (red), RMS (yellow)").small());
    small_plot("strain plot").show(ui, |p| {
        p.line(Line::new("max strain %", max).color(Color32::from_rgb(240, 90, 70)));
        p.line(Line::new("RMS strain %", rms).color(Color32::from_rgb(240, 200, 80)));
    });
    ui.label(RichText::new(model.adapter).small().weak());
}

fn small_plot(id: &str) -> Plot<'_> {
    Plot::new(id)
        .height(56.0)
        .include_y(0.0)
        .include_x(0.0)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .allow_boxed_zoom(false)
        .allow_double_click_reset(false)
        .show_x(false)
        .show_y(false)
        .y_axis_min_width(28.0)
}

fn bindings_section(ui: &mut Ui) {
    egui::Grid::new("bindings").num_columns(2).show(ui, |ui| {
        for (key, what) in KEY_BINDINGS.iter().chain(MOUSE_BINDINGS) {
            ui.label(RichText::new(*key).strong());
            ui.label(*what);
            ui.end_row();
        }
    });
}
