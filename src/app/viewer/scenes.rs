//! Scenes in the viewer: loading and switching (the panel's list or a
//! typed path, a file dropped on the window), reloading a scene file when
//! it is saved (the camera kept), and the time mode a scene opens in (real
//! time, or a step a frame when the solver is too slow for it).

use super::{Drag, Timeline, Viewer};
use crate::render::{OrbitCamera, ViewOptions};
use crate::scene;

impl Viewer {
    /// Opens the scene in real time or a step per frame, as it asks or as
    /// the solver's measured speed allows.
    pub(super) fn choose_time_mode(&mut self) {
        let seconds = match self.scene.playback {
            scene::Playback::Auto => crate::app::stepper::time_a_step(&self.sim, self.clock.as_mut(), 3),
            _ => 0.0,
        };
        let (mode, why) =
            crate::app::stepper::initial_mode(self.scene.playback, seconds, f64::from(self.sim.params().dt));
        self.stepper.mode = mode;
        self.stepper.reset();
        self.time_reason = why;
    }
    /// Watches the scene's file, if it came from one, for saves.
    pub(super) fn watch_scene_file(&mut self) {
        self.watcher = None;
        if self.scene.source.starts_with("bundled:") || self.scene.source.starts_with('<') {
            return;
        }
        match crate::app::watch::SceneWatcher::new(std::path::Path::new(&self.scene.source)) {
            Ok(w) => self.watcher = Some(w),
            Err(e) => self.toast(format!("cannot watch {} for changes: {e}", self.scene.source), true),
        }
    }

    /// Reloads the scene if its file was saved, keeping the camera.
    pub(super) fn reload_if_saved(&mut self) {
        let Some(watcher) = &self.watcher else { return };
        match watcher.changed() {
            Ok(false) => {}
            Ok(true) => {
                let path = watcher.file().display().to_string();
                self.load_scene_keeping_camera(&path, true);
            }
            Err(e) => {
                let text = format!("stopped watching {}: {e}", self.scene.source);
                self.watcher = None;
                self.toast(text, true);
            }
        }
    }

    pub(super) fn reset_camera(&mut self) {
        self.camera = OrbitCamera::from_hint(&self.scene.camera, self.sim.mesh().bounds(), self.viewport().aspect());
    }

    pub(super) fn load_scene(&mut self, name: &str) {
        self.load_scene_keeping_camera(name, false);
    }

    /// Loads a scene; `keep_camera` leaves the view where it is (a reload of
    /// the same file after it was saved).
    pub(super) fn load_scene_keeping_camera(&mut self, name: &str, keep_camera: bool) {
        let loaded = scene::load(name).map_err(|e| e.to_string()).and_then(|scene| {
            let sim = scene.simulation().map_err(|e| e.to_string())?;
            Ok((scene, sim))
        });
        match loaded {
            Ok((scene, sim)) => {
                self.drag = Drag::None;
                self.view = ViewOptions { strain_scale: self.view.strain_scale, ..ViewOptions::for_mesh(&scene.mesh) };
                self.scene = scene;
                self.sim = sim;
                self.timeline = Timeline::new(self.sim.mesh().clone());
                self.timeline.restart(&self.sim);
                self.renderer.update(&self.sim);
                self.renderer.set_highlight(None);
                self.stats.clear();
                self.choose_time_mode();
                if !keep_camera {
                    self.reset_camera();
                }
                self.sim_changed = false;
                self.strain = None;
                let verb = if keep_camera { "reloaded" } else { "loaded" };
                let text = format!("{verb} {}", self.scene.name);
                self.toast(text, false);
                if !keep_camera {
                    self.watch_scene_file();
                }
            }
            Err(e) => self.toast(format!("cannot load {name}: {e}"), true),
        }
    }
}
