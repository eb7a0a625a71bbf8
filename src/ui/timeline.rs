//! The timeline bar under the 3-D view: the recorded frames, a slider to
//! scrub through them, playback at real time, back to live, and export.
//! Like the panel it changes nothing itself and returns [`UiCommand`]s.

use egui::{RichText, Ui};

use super::command::UiCommand;

/// What the timeline bar shows.
#[derive(Clone, Copy, Debug)]
pub struct TimelineModel {
    /// Frames recorded.
    pub frames: usize,
    /// The frame shown while scrubbing or playing back; `None` when live.
    pub cursor: Option<usize>,
    /// Whether the recording is playing back.
    pub playing: bool,
    /// Simulated time of the first and of the shown frame, seconds.
    pub first_time: f64,
    /// Simulated time shown.
    pub time: f64,
    /// Bytes one frame takes, and the most frames kept.
    pub frame_bytes: usize,
    /// The most frames the cache holds.
    pub capacity: usize,
}

/// Draws the bar; returns what the user asked for.
pub fn timeline_bar(ui: &mut Ui, model: &TimelineModel) -> Vec<UiCommand> {
    let mut commands = Vec::new();
    let last = model.frames.saturating_sub(1);
    let shown = model.cursor.unwrap_or(last);
    ui.horizontal(|ui| {
        let play = if model.playing { "Stop" } else { "Play" };
        let hint = "Play the recorded frames at real time (P); the simulation stays paused";
        if ui.add_enabled(model.frames > 1, egui::Button::new(play)).on_hover_text(hint).clicked() {
            commands.push(UiCommand::PlayRecording(!model.playing));
        }
        let live = model.cursor.is_none();
        if ui
            .add_enabled(!live, egui::Button::new("Latest"))
            .on_hover_text("Show the newest frame; Run continues from it without dropping anything")
            .clicked()
        {
            commands.push(UiCommand::ScrubTo(last));
        }
        if ui
            .add_enabled(model.frames > 0, egui::Button::new("Export .glb"))
            .on_hover_text("Write the recorded frames as an animated glTF file into exports/")
            .clicked()
        {
            commands.push(UiCommand::ExportRecording);
        }
        let status = match model.cursor {
            None => "live".to_string(),
            Some(_) => format!("{:.2} s", model.time),
        };
        ui.label(RichText::new(status).monospace());
        // The slider takes the rest of the row.
        let mut index = shown;
        ui.spacing_mut().slider_width = (ui.available_width() - 120.0).max(60.0);
        let slider = egui::Slider::new(&mut index, 0..=last.max(1))
            .show_value(false)
            .handle_shape(egui::style::HandleShape::Rect { aspect_ratio: 0.5 });
        let response = ui.add_enabled(model.frames > 1, slider).on_hover_text(format!(
            "frame {} of {}, from {:.2} s; drag to scrub (Left/Right step one frame). Run resumes from the frame \
             shown and drops the later ones. {} KB a frame, at most {} frames kept",
            shown + 1,
            model.frames,
            model.first_time,
            model.frame_bytes / 1024,
            model.capacity
        ));
        if response.changed() && index != shown {
            commands.push(UiCommand::ScrubTo(index.min(last)));
        }
        ui.label(RichText::new(format!("{}/{}", shown + 1, model.frames)).monospace().small());
    });
    commands
}
