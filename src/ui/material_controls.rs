//! The material part of the solver panel: a menu of fabric presets, and
//! the physical values (area density, stretch and bend stiffness) when the
//! cloth uses them.

use egui::Ui;

use super::solver_controls::slider;
use crate::sim::{Material, SolverParams};

/// The seed's way: a mass per particle and compliances.
const PER_PARTICLE: &str = "per particle (seed)";

/// The preset whose fabric (density and stiffness) `p` holds, if any; a
/// scene may set its own friction and thickness beside a preset.
fn current(p: &SolverParams) -> Option<Material> {
    Material::ALL.into_iter().find(|m| {
        let f = m.properties();
        p.density == Some(f.density)
            && p.stretch_stiffness == Some(f.stretch_stiffness)
            && p.bend_stiffness == Some(f.bend_stiffness)
    })
}

/// Shows the material menu and, for a cloth in physical units, its
/// density and stiffness; edits `p` in place.
pub(super) fn material_controls(ui: &mut Ui, p: &mut SolverParams) {
    let physical = p.density.is_some() || p.stretch_stiffness.is_some() || p.bend_stiffness.is_some();
    let shown = match current(p) {
        Some(m) => m.name(),
        None if physical => "custom",
        None => PER_PARTICLE,
    };
    let mut chosen: Option<Option<Material>> = None;
    egui::ComboBox::from_label("material").selected_text(shown).show_ui(ui, |ui| {
        if ui.selectable_label(!physical, PER_PARTICLE).clicked() {
            chosen = Some(None);
        }
        for m in Material::ALL {
            if ui.selectable_label(shown == m.name(), m.name()).clicked() {
                chosen = Some(Some(m));
            }
        }
    });
    match chosen {
        Some(Some(m)) => m.select(p),
        Some(None) => {
            p.density = None;
            p.stretch_stiffness = None;
            p.bend_stiffness = None;
        }
        None => {}
    }
    if let Some(sigma) = &mut p.density {
        ui.add(slider(sigma, 0.01..=2.0).logarithmic(true).suffix(" kg/m²").text("density σ"))
            .on_hover_text("Mass per area: each particle weighs σ times a third of its triangles' area.");
    }
    if let Some(k) = &mut p.stretch_stiffness {
        ui.add(slider(k, 10.0..=1e5).logarithmic(true).suffix(" N/m").text("stretch k_s"))
            .on_hover_text("Force per width per unit strain; the same cloth at every resolution (soft below the passes' own stiffness).");
    }
    if let Some(b) = &mut p.bend_stiffness {
        // Scientific notation: 7.85e-6, not 0.00000785, keeps the row narrow.
        let scientific = |v: f64, _: std::ops::RangeInclusive<usize>| format!("{v:.2e}");
        let parse = |s: &str| s.trim().trim_end_matches("N·m").trim().parse::<f64>().ok();
        ui.add(
            slider(b, 1e-7..=1e-2)
                .logarithmic(true)
                .custom_formatter(scientific)
                .custom_parser(parse)
                .suffix(" N·m")
                .text("bend B"),
        )
        .on_hover_text("Flexural rigidity: silk 2e-6, cotton 8e-6, denim 1e-4 N·m.");
    }
}
