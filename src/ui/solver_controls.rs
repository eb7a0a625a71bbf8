//! The solver part of the panel, in one function so that new solver
//! options need one new widget here and nothing else.

use egui::{DragValue, Slider, SliderClamping, Ui};
use glam::Vec3;

use super::command::UiCommand;
use super::material_controls::material_controls;
use crate::sim::{Air, SolverKind, SolverParams, Start, Wind};

/// The solver's own values, for the "scene values" button.
#[derive(Clone, Copy, Debug)]
pub struct SceneDefaults<'a> {
    /// The scene's parameters.
    pub params: &'a SolverParams,
    /// The scene's solver.
    pub solver: SolverKind,
    /// Whether the mesh is a grid (the coarse passes need one).
    pub grid: bool,
}

/// Shows the solver chooser, a line on how the solver in use works (`how`),
/// and one control per parameter. Every edit becomes a
/// [`UiCommand::SetParams`] with the whole edited set, which the app applies
/// to the running simulation at once.
pub fn solver_controls(
    ui: &mut Ui,
    params: &SolverParams,
    solver: SolverKind,
    how: &str,
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
    ui.label(egui::RichText::new(how).small().weak()).on_hover_text(
        "fast: the same equations ordered for SIMD lanes and threads; reference: the seed's loops as written.",
    );

    // Widgets edit a copy; a changed copy is sent whole. New fields of
    // SolverParams ride along untouched. A slider's range is where its
    // handle goes, not what is allowed: a scene's value outside it (200
    // relaxations, h = 0.5 s) is shown and kept, typed values go through
    // as typed, and `SolverParams::validate` in the app is the one judge of
    // what is allowed (a rejected value becomes a message, not a clamp).
    let mut edited = params.clone();
    ui.add(slider(&mut edited.relaxations, 0..=100).text("relaxations"))
        .on_hover_text("Passes over every bar per step: more is stiffer and slower (the seed's Table 1).");
    if scene.grid {
        ui.add(slider(&mut edited.coarse_passes, 0..=20).text("coarse passes")).on_hover_text(
            "Passes over the grid taken 2, 4, 8, … particles apart, after the relaxation: they pull the smooth \
             stretch of a large cloth out at a fraction of a pass's cost (0: off, the seed's). \
             Pair with a soft shear α.",
        );
    }
    inextensible_controls(ui, &mut edited);
    ui.add(slider(&mut edited.damping, 0.0..=0.5).logarithmic(true).smallest_positive(1e-4).text("damping δ"))
        .on_hover_text("Share of last step's motion removed each step (equation 1).");
    ui.add(slider(&mut edited.dt, 0.001..=0.1).logarithmic(true).suffix(" s").text("time step h"))
        .on_hover_text("Simulated seconds per step.");
    material_controls(ui, &mut edited);
    if edited.density.is_none() {
        ui.add(slider(&mut edited.mass, 1e-4..=10.0).logarithmic(true).suffix(" kg").text("mass m"))
            .on_hover_text("Mass of every particle: forces are divided by it.");
    }
    match &mut edited.gravity_acceleration {
        Some(g) => {
            vector_row(ui, "g (m/s²)", g).on_hover_text("Gravity as an acceleration, the same for every particle.");
        }
        None => {
            vector_row(ui, "gravity (N)", &mut edited.gravity).on_hover_text(format!(
                "A force on every particle (the seed's equation 3): {:.2} m/s² at this mass.",
                edited.gravity.length() / edited.mass
            ));
        }
    }
    let weight = match edited.gravity_acceleration {
        Some(g) => g.length() * edited.mass,
        None => edited.gravity.length(),
    };
    wind_controls(ui, &mut edited.wind, weight);
    egui::CollapsingHeader::new("accuracy").default_open(false).show(ui, |ui| accuracy_controls(ui, &mut edited));
    egui::CollapsingHeader::new("contact").default_open(false).show(ui, |ui| contact_controls(ui, &mut edited));
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

/// Inextensible edges: the switch, and when on the Newton iterations,
/// the smoothing passes and the tolerance.
fn inextensible_controls(ui: &mut Ui, p: &mut SolverParams) {
    ui.checkbox(&mut p.inextensible, "inextensible edges").on_hover_text(
        "After the passes, a global Newton solve (sparse Cholesky) puts every horizontal and vertical bar back to \
         its length: cloth that stretches under 1 % in the seed's wind, at about the seed's own cost.",
    );
    if p.inextensible {
        ui.indent("newton", |ui| {
            ui.spacing_mut().slider_width = 72.0;
            ui.add(slider(&mut p.newton_iterations, 1..=10).text("Newton iterations"))
                .on_hover_text("Global solves per step, at most: each about 0.5 ms on the seed's cloth.");
            ui.add(slider(&mut p.newton_smoothing, 0..=200).text("edge passes")).on_hover_text(
                "Passes over the edges after each solve: they remove what the linearisation overshoots.",
            );
            ui.add(small_values(&mut p.newton_tolerance, 0.1, 1e-6, "exact").text("tolerance"))
                .on_hover_text("The solves stop once every edge is within this strain.");
        });
    }
}

/// The solver's accuracy options beyond the seed's (substeps, XPBD
/// compliance, over-relaxation, early stop, tethers, the first step).
fn accuracy_controls(ui: &mut Ui, p: &mut SolverParams) {
    // Indented one level deeper than the other sliders: narrower ones keep
    // the labels inside the panel.
    ui.spacing_mut().slider_width = 72.0;
    ui.add(slider(&mut p.substeps, 1..=100).logarithmic(true).text("substeps")).on_hover_text(
        "Each step of h split in n, each with all the passes: stretch falls as 1/n² (Small Steps), cost grows as n.",
    );
    if p.substeps > 1 && p.relaxations < 2 {
        ui.colored_label(
            egui::Color32::from_rgb(230, 160, 60),
            "One pass per substep makes a grid with both diagonals shiver, and can blow up: use 2 or more.",
        );
    }
    ui.add(slider(&mut p.over_relaxation, 1.0..=1.9).text("over-relaxation ω")).on_hover_text(
        "Each projection moves ω of the way: helps chains, but on the seed's cloth ω > 1 left more strain (measured).",
    );
    ui.add(small_values(&mut p.stretch_compliance, 1e-2, 1e-9, "rigid").text("stretch α (m/N)"))
        .on_hover_text("XPBD compliance: 0 is rigid; larger is softer, whatever the passes.");
    ui.add(small_values(&mut p.bend_compliance, 1e-2, 1e-9, "rigid").text("bend α (m/N)"))
        .on_hover_text("XPBD compliance of bend bars: soft values let the cloth fold without stretching.");
    let mut shear = p.shear_compliance.unwrap_or(p.stretch_compliance);
    let shear_slider = ui.add(small_values(&mut shear, 1e-2, 1e-9, "rigid").text("shear α (m/N)")).on_hover_text(
        "XPBD compliance of a grid's diagonals: soft values let the cloth shear flat instead of buckling into \
         diagonal pleats. Until set, the stretch α.",
    );
    if shear_slider.changed() {
        p.shear_compliance = Some(shear);
    }
    ui.add(small_values(&mut p.tolerance, 0.1, 1e-6, "off").text("early stop"))
        .on_hover_text("Stop relaxing once every bar is within this strain (off: always all passes).");
    ui.horizontal(|ui| {
        let mut on = p.tether_slack.is_some();
        ui.checkbox(&mut on, "tethers").on_hover_text("Keep every particle within its rest path length of a pin.");
        let mut slack = p.tether_slack.unwrap_or(0.05);
        ui.add_enabled(on, slider(&mut slack, 0.0..=0.5).text("slack"));
        p.tether_slack = on.then_some(slack);
    });
    ui.horizontal(|ui| {
        ui.label("first step");
        ui.radio_value(&mut p.start, Start::Euler, "Euler (seed)");
        ui.radio_value(&mut p.start, Start::SecondOrder, "second order");
    });
}

/// Contact with colliders and with itself: thickness, friction,
/// self-collision.
fn contact_controls(ui: &mut Ui, p: &mut SolverParams) {
    ui.spacing_mut().slider_width = 72.0;
    ui.add(slider(&mut p.thickness, 0.0..=0.1).suffix(" m").text("thickness"))
        .on_hover_text("Distance kept from every collider surface, and between layers with self-collision on.");
    ui.add(slider(&mut p.friction, 0.0..=2.0).text("friction μ"))
        .on_hover_text("Coulomb's coefficient of colliders that give none, and between layers.");
    ui.checkbox(&mut p.self_collision, "self-collision").on_hover_text(
        "Keep the cloth from passing through itself (particles stay a thickness apart; motion capped at thickness/4 per substep).",
    );
}

/// A logarithmic slider from 0 to `max` for values that span decades,
/// shown as `1.0e-5` (and `zero` at 0) so the panel keeps its width.
fn small_values<'a>(value: &'a mut f32, max: f32, smallest: f64, zero: &'static str) -> Slider<'a> {
    slider(value, 0.0..=max)
        .logarithmic(true)
        .smallest_positive(smallest)
        .custom_formatter(move |v, _| if v == 0.0 { zero.to_string() } else { format!("{v:.1e}") })
        .custom_parser(move |text| {
            let text = text.trim();
            if text == zero { Some(0.0) } else { text.parse::<f64>().ok() }
        })
}

/// A slider over `range` that never clamps: values outside it, from the
/// scene or typed in, are kept as they are (see [`solver_controls`]).
pub(super) fn slider<Num: egui::emath::Numeric>(value: &mut Num, range: std::ops::RangeInclusive<Num>) -> Slider<'_> {
    Slider::new(value, range).clamping(SliderClamping::Never)
}

/// Three numbers in a row; the drag speed follows the vector's size so
/// that both 9.8 N and 0.0098 N can be adjusted.
fn vector_row(ui: &mut Ui, label: &str, v: &mut Vec3) -> egui::Response {
    let speed = f64::from(v.abs().max_element()).max(1e-3) * 0.01;
    // Wrapped: in a narrow panel the label moves to the next line instead
    // of being cut off at the panel's edge.
    ui.horizontal_wrapped(|ui| {
        for (value, axis) in [(&mut v.x, "x "), (&mut v.y, "y "), (&mut v.z, "z ")] {
            ui.add(DragValue::new(value).speed(speed).prefix(axis).max_decimals(5));
        }
        ui.label(label)
    })
    .inner
}

/// The wind model and its numbers. A model switched on starts at about the
/// particles' `weight` (newtons), which suits any scene's scale of mass.
fn wind_controls(ui: &mut Ui, wind: &mut Wind, weight: f32) {
    let name = |w: &Wind| match w {
        Wind::None => "none",
        Wind::Seed { .. } => "seed's gusts",
        Wind::Constant { .. } => "constant",
        Wind::Air(_) => "air",
    };
    let mut model = *wind;
    egui::ComboBox::from_label("wind").selected_text(name(wind)).show_ui(ui, |ui| {
        // The seed's gusts average about 9 N at scale 1.
        let keep_scale = match *wind {
            Wind::Seed { scale } => scale,
            _ => (weight / 9.0).clamp(1e-4, 5.0),
        };
        let keep_force = match *wind {
            Wind::Constant { force } => force,
            _ => Vec3::new(0.5 * weight, 0.0, 0.0),
        };
        let keep_air = match *wind {
            Wind::Air(air) => air,
            _ => Air { velocity: Vec3::new(5.0, 0.0, 0.0), gusts: 0.3, ..Air::default() },
        };
        let options =
            [Wind::None, Wind::Seed { scale: keep_scale }, Wind::Constant { force: keep_force }, Wind::Air(keep_air)];
        for option in options {
            let label = name(&option);
            ui.selectable_value(&mut model, option, label);
        }
    });
    *wind = model;
    match wind {
        Wind::None => {}
        Wind::Seed { scale } => {
            ui.add(slider(scale, 0.0..=5.0).logarithmic(true).smallest_positive(1e-4).text("wind scale"))
                .on_hover_text("Multiplies the seed's equation 4.");
        }
        Wind::Constant { force } => {
            vector_row(ui, "wind (N)", force);
        }
        Wind::Air(air) => {
            vector_row(ui, "air (m/s)", &mut air.velocity)
                .on_hover_text("The mean wind: drag and lift on every triangle from the air's relative velocity.");
            ui.add(slider(&mut air.gusts, 0.0..=1.0).text("gusts"))
                .on_hover_text("Turbulence: RMS speed as a share of the mean wind's.");
            ui.add(slider(&mut air.gust_scale, 0.1..=10.0).logarithmic(true).suffix(" m, s").text("gust scale"))
                .on_hover_text("Size of the gusts in metres, and their lifetime in seconds.");
            ui.add(slider(&mut air.drag, 0.0..=2.0).text("drag C_d"));
            ui.add(slider(&mut air.lift, 0.0..=1.0).text("lift C_l"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values a scene may hold (they pass `SolverParams::validate`) but that
    /// lie outside every slider's range.
    fn beyond_the_sliders() -> SolverParams {
        let params = SolverParams {
            relaxations: 200,
            damping: 0.7,
            dt: 0.5,
            mass: 50.0,
            gravity: Vec3::new(0.0, -5000.0, 0.0),
            wind: Wind::Seed { scale: 20.0 },
            substeps: 500,
            over_relaxation: 1.95,
            tether_slack: Some(0.8),
            ..SolverParams::default()
        };
        assert_eq!(params.validate(), Ok(()), "the test's values must be allowed");
        params
    }

    /// Runs `draw` in one headless egui frame, as the viewer does each frame.
    fn headless(mut draw: impl FnMut(&mut Ui)) {
        let mut output = egui::Context::default().run_ui(egui::RawInput::default(), |ui| draw(ui));
        // No renderer here to upload the font atlas to.
        output.textures_delta.clear();
    }

    /// Draws the panel's solver part once and returns what it asked for.
    fn one_frame(params: &SolverParams) -> Vec<UiCommand> {
        let mut commands = Vec::new();
        let scene = SceneDefaults { params, solver: SolverKind::Fast, grid: true };
        headless(|ui| commands = solver_controls(ui, params, SolverKind::Fast, "", scene));
        commands
    }

    #[test]
    fn a_scene_value_outside_a_slider_is_kept_not_clamped() {
        let params = beyond_the_sliders();
        // A clamping slider would rewrite 200 relaxations to 100 on the first
        // frame and send it as if the user had dragged it.
        assert!(one_frame(&params).is_empty());
        // Same for the accuracy options, drawn open.
        let mut edited = params.clone();
        headless(|ui| accuracy_controls(ui, &mut edited));
        assert_eq!(edited, params);
    }

    #[test]
    fn values_inside_the_sliders_are_left_alone_too() {
        // The counter-check: with the scene's own values nothing is sent
        // either, so the test above fails only through clamping.
        assert!(one_frame(&SolverParams::default()).is_empty());
    }
}
