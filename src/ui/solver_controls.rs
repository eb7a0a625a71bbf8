//! The solver part of the panel, in one function so that new solver
//! options need one new widget here and nothing else.

use egui::{DragValue, Slider, Ui};
use glam::Vec3;

use super::command::UiCommand;
use crate::sim::{SolverKind, SolverParams, Wind};

/// The solver's own values, for the "scene values" button.
#[derive(Clone, Copy, Debug)]
pub struct SceneDefaults<'a> {
    /// The scene's parameters.
    pub params: &'a SolverParams,
    /// The scene's solver.
    pub solver: SolverKind,
}

/// Shows the solver chooser and one control per parameter. Every edit
/// becomes a [`UiCommand::SetParams`] with the whole edited set, which the
/// app applies to the running simulation at once.
pub fn solver_controls(
    ui: &mut Ui,
    params: &SolverParams,
    solver: SolverKind,
    scene: SceneDefaults<'_>,
) -> Vec<UiCommand> {
    let mut commands = Vec::new();
    let mut chosen = solver;
    egui::ComboBox::from_label("solver").selected_text(solver.name()).show_ui(ui, |ui| {
        for kind in SolverKind::ALL {
            ui.selectable_value(&mut chosen, kind, kind.name());
        }
    });
    if chosen != solver {
        commands.push(UiCommand::SetSolver(chosen));
    }

    // Widgets edit a copy; a changed copy is sent whole. New fields of
    // SolverParams ride along untouched.
    let mut edited = params.clone();
    ui.add(Slider::new(&mut edited.relaxations, 0..=100).text("relaxations"))
        .on_hover_text("Passes over every bar per step: more is stiffer and slower (the seed's Table 1).");
    ui.add(Slider::new(&mut edited.damping, 0.0..=0.5).logarithmic(true).smallest_positive(1e-4).text("damping δ"))
        .on_hover_text("Share of last step's motion removed each step (equation 1).");
    ui.add(Slider::new(&mut edited.dt, 0.001..=0.1).logarithmic(true).suffix(" s").text("time step h"))
        .on_hover_text("Simulated seconds per step.");
    ui.add(Slider::new(&mut edited.mass, 0.001..=10.0).logarithmic(true).suffix(" kg").text("mass m"))
        .on_hover_text("Mass of every particle: forces are divided by it.");
    vector_row(ui, "gravity (N)", &mut edited.gravity, 0.1);
    wind_controls(ui, &mut edited.wind);
    if edited != *params {
        commands.push(UiCommand::SetParams(edited));
    }

    let at_scene_values = params == scene.params && solver == scene.solver;
    let restore = ui
        .add_enabled(!at_scene_values, egui::Button::new("Scene values"))
        .on_hover_text("Put back the scene's own parameters and solver.");
    if restore.clicked() {
        commands.push(UiCommand::RestoreSceneParams);
    }
    commands
}

fn vector_row(ui: &mut Ui, label: &str, v: &mut Vec3, speed: f64) {
    ui.horizontal(|ui| {
        ui.add(DragValue::new(&mut v.x).speed(speed).prefix("x ").range(-1e3..=1e3));
        ui.add(DragValue::new(&mut v.y).speed(speed).prefix("y ").range(-1e3..=1e3));
        ui.add(DragValue::new(&mut v.z).speed(speed).prefix("z ").range(-1e3..=1e3));
        ui.label(label);
    });
}

fn wind_controls(ui: &mut Ui, wind: &mut Wind) {
    let name = |w: &Wind| match w {
        Wind::None => "none",
        Wind::Seed { .. } => "seed's gusts",
        Wind::Constant { .. } => "constant",
    };
    let mut model = *wind;
    egui::ComboBox::from_label("wind").selected_text(name(wind)).show_ui(ui, |ui| {
        let keep_scale = match *wind {
            Wind::Seed { scale } => scale,
            _ => 1.0,
        };
        let keep_force = match *wind {
            Wind::Constant { force } => force,
            _ => Vec3::new(5.0, 0.0, 0.0),
        };
        for option in [Wind::None, Wind::Seed { scale: keep_scale }, Wind::Constant { force: keep_force }] {
            let label = name(&option);
            ui.selectable_value(&mut model, option, label);
        }
    });
    *wind = model;
    match wind {
        Wind::None => {}
        Wind::Seed { scale } => {
            ui.add(Slider::new(scale, 0.0..=5.0).text("wind scale")).on_hover_text("Multiplies the seed's equation 4.");
        }
        Wind::Constant { force } => vector_row(ui, "wind (N)", force, 0.05),
    }
}
