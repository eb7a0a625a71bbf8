//! What each of the panel's commands ([`UiCommand`]) does to the viewer:
//! the panel and the keys return commands, and [`Viewer::apply`] is the
//! one place that carries them out.

use super::{Viewer, WindowRequest};
use crate::render;
use crate::ui::UiCommand;

impl Viewer {
    /// Applies one command; returns what the window must do, if anything.
    pub fn apply(&mut self, command: UiCommand) -> Option<WindowRequest> {
        match command {
            UiCommand::TogglePause => {
                if self.sim.diverged().is_none() {
                    self.paused = !self.paused;
                    self.stepper.reset();
                    if !self.paused {
                        self.resume_timeline();
                    }
                }
            }
            UiCommand::Step => {
                self.paused = true;
                if self.sim.diverged().is_none() {
                    self.resume_timeline();
                    if self.sim.step().is_ok() {
                        self.timeline.record(&self.sim);
                    }
                    self.touched();
                }
            }
            UiCommand::ScrubTo(index) => {
                self.paused = true;
                self.stepper.reset();
                if let Err(e) = self.timeline.scrub(index, &mut self.sim) {
                    self.toast(e.to_string(), true);
                }
                self.touched();
            }
            UiCommand::PlayRecording(play) => {
                if play {
                    self.paused = true;
                    self.stepper.reset();
                    if let Err(e) = self.timeline.play(&mut self.sim) {
                        self.toast(e.to_string(), true);
                    }
                    self.touched();
                } else {
                    self.timeline.stop();
                }
            }
            UiCommand::ExportRecording => self.export_recording(),
            UiCommand::Reset => {
                self.end_drag();
                self.sim.reset();
                // Colliders moved by hand go back where the scene puts them.
                self.sim.set_colliders(self.scene.colliders.clone());
                self.stepper.reset();
                self.timeline.restart(&self.sim);
                self.touched();
            }
            UiCommand::LoadScene(name) => self.load_scene(&name),
            UiCommand::SetParams(params) => {
                if let Err(e) = self.sim.set_params(params) {
                    self.toast(e.to_string(), true);
                }
            }
            UiCommand::RestoreSceneParams => {
                if let Err(e) = self.sim.set_params(self.scene.params.clone()) {
                    self.toast(e.to_string(), true);
                }
                self.sim.set_solver(self.scene.solver);
            }
            UiCommand::SetSolver(kind) => self.sim.set_solver(kind),
            UiCommand::SetView(view) => self.view = view,
            UiCommand::SetTimeMode(mode) => {
                if mode != self.stepper.mode {
                    self.time_reason = "chosen in the panel".to_string();
                }
                self.stepper.mode = mode;
                self.stepper.reset();
            }
            UiCommand::SetVsync(on) => return Some(WindowRequest::SetVsync(on)),
            UiCommand::FitCamera => {
                self.camera.fit(render::cloth_bounds(&self.sim), self.viewport().aspect());
            }
            UiCommand::ResetCamera => self.reset_camera(),
            UiCommand::Screenshot => self.screenshot_pending = true,
            UiCommand::Quit => return Some(WindowRequest::Quit),
        }
        None
    }

    /// The simulation runs on from the frame shown: later frames go.
    pub(super) fn resume_timeline(&mut self) {
        let from = self.sim.time();
        let dropped = self.timeline.resume();
        if dropped > 0 {
            self.toast(format!("resumed from {from:.2} s: the {dropped} later frames were dropped"), false);
        }
    }
}
