//! What egui draws over the 3-D view: the strain legend, the message shown
//! when the simulation blows up, and short-lived notices (toasts).

use egui::{Align2, Color32, Rect, RichText, Stroke, pos2, vec2};

use super::command::UiCommand;
use crate::render::view::strain_colour_srgb;

/// A strain legend in the bottom-left corner of `view`: the colour ramp
/// from no strain to `scale`, labelled in percent.
pub fn strain_legend(ctx: &egui::Context, view: Rect, scale: f32) {
    let size = vec2(180.0, 12.0);
    let origin = pos2(view.left() + 14.0, view.bottom() - 40.0);
    egui::Area::new(egui::Id::unique("strain legend")).fixed_pos(origin).interactable(false).show(ctx, |ui| {
        egui::Frame::popup(ui.style()).inner_margin(6.0).show(ui, |ui| {
            ui.label(RichText::new("strain").small());
            let (rect, _) = ui.allocate_exact_size(size, egui::Sense::hover());
            let painter = ui.painter();
            const SEGMENTS: usize = 48;
            for i in 0..SEGMENTS {
                let t = (i as f32 + 0.5) / SEGMENTS as f32;
                let [r, g, b] = strain_colour_srgb(t * scale, scale);
                let x0 = rect.left() + rect.width() * i as f32 / SEGMENTS as f32;
                let x1 = rect.left() + rect.width() * (i + 1) as f32 / SEGMENTS as f32;
                let segment = Rect::from_min_max(pos2(x0, rect.top()), pos2(x1 + 0.5, rect.bottom()));
                painter.rect_filled(segment, 0.0, Color32::from_rgb(r, g, b));
            }
            painter.rect_stroke(rect, 0.0, Stroke::new(1.0, Color32::from_gray(40)), egui::StrokeKind::Outside);
            ui.horizontal(|ui| {
                ui.set_width(size.x);
                let label = |v: f32| RichText::new(format!("{:.3}%", v * 100.0).replace(".000", "")).small();
                ui.label(label(0.0));
                ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                    ui.label(label(scale));
                    ui.add_space(size.x * 0.5 - 40.0);
                    ui.label(label(scale * 0.5));
                });
            });
        });
    });
}

/// The blown-up message, centred on `view`, with ways out.
pub fn diverged_message(ctx: &egui::Context, view: Rect, error: &str) -> Vec<UiCommand> {
    let mut commands = Vec::new();
    egui::Area::new(egui::Id::unique("diverged")).pivot(Align2::CENTER_CENTER).fixed_pos(view.center()).show(
        ctx,
        |ui| {
            egui::Frame::popup(ui.style()).fill(Color32::from_rgb(60, 20, 20)).inner_margin(14.0).show(ui, |ui| {
                ui.set_max_width(360.0);
                ui.label(RichText::new("The simulation blew up").heading().color(Color32::from_rgb(255, 140, 120)));
                ui.label(RichText::new(error).color(Color32::from_gray(230)));
                ui.label(
                    RichText::new("It is stopped and shows the last finite state.")
                        .small()
                        .color(Color32::from_gray(200)),
                );
                ui.horizontal(|ui| {
                    if ui.button("Reset").clicked() {
                        commands.push(UiCommand::Reset);
                    }
                    if ui.button("Scene values and reset").clicked() {
                        commands.push(UiCommand::RestoreSceneParams);
                        commands.push(UiCommand::Reset);
                    }
                });
            });
        },
    );
    commands
}

/// A warning across the top of `view` while the state is absurd (finite,
/// but no longer cloth): what is wrong and what to change.
pub fn absurd_warning(ctx: &egui::Context, view: Rect, text: &str) {
    egui::Area::new(egui::Id::unique("absurd"))
        .pivot(Align2::CENTER_TOP)
        .fixed_pos(view.center_top() + vec2(0.0, 10.0))
        .interactable(false)
        .show(ctx, |ui| {
            egui::Frame::popup(ui.style()).fill(Color32::from_rgb(110, 80, 10)).inner_margin(10.0).show(ui, |ui| {
                ui.set_max_width((view.width() * 0.7).max(200.0));
                ui.label(RichText::new("This is no longer cloth").strong().color(Color32::from_rgb(255, 220, 140)));
                ui.label(RichText::new(text).color(Color32::WHITE));
            });
        });
}

/// A notice shown for a few seconds.
#[derive(Clone, Debug, PartialEq)]
pub struct Toast {
    /// What it says.
    pub text: String,
    /// Whether it reports a failure (drawn in red).
    pub error: bool,
    /// Seconds (viewer time) after which it disappears.
    pub until: f64,
}

/// Draws the toasts still current at `now`, newest last, in the top-left
/// corner of `view`.
pub fn toasts(ctx: &egui::Context, view: Rect, toasts: &[Toast], now: f64) {
    let current: Vec<&Toast> = toasts.iter().filter(|t| t.until > now).collect();
    if current.is_empty() {
        return;
    }
    egui::Area::new(egui::Id::unique("toasts")).fixed_pos(view.left_top() + vec2(12.0, 12.0)).interactable(false).show(
        ctx,
        |ui| {
            for toast in current {
                let fill = if toast.error { Color32::from_rgb(120, 30, 30) } else { Color32::from_rgb(30, 60, 40) };
                egui::Frame::popup(ui.style()).fill(fill).show(ui, |ui| {
                    ui.set_max_width(view.width() * 0.6);
                    ui.label(RichText::new(&toast.text).color(Color32::WHITE));
                });
            }
        },
    );
}
