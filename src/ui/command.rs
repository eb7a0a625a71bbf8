//! [`UiCommand`]: what the panel and the keyboard ask the app to do.

use crate::render::ViewOptions;
use crate::sim::{SolverKind, SolverParams};

/// How simulated time relates to displayed frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TimeMode {
    /// One solver step of h per displayed frame, as the seed's program did:
    /// the motion's speed depends on the frame rate.
    #[default]
    StepPerFrame,
    /// Simulated time follows the wall clock: as many steps of h as the
    /// elapsed time holds, capped per frame so a slow frame cannot spiral.
    RealTime,
}

/// A request from the user interface; the app applies it.
#[derive(Clone, Debug, PartialEq)]
pub enum UiCommand {
    /// Pause if running, run if paused.
    TogglePause,
    /// Take one step (and stay paused).
    Step,
    /// Back to the scene's initial positions, keeping the parameters.
    Reset,
    /// Load a bundled scene by name or a scene file by path.
    LoadScene(String),
    /// Replace the solver parameters (applied to the running simulation at once).
    SetParams(SolverParams),
    /// Put back the scene's own parameters and solver.
    RestoreSceneParams,
    /// Switch solver, keeping the state.
    SetSolver(SolverKind),
    /// Change what is drawn.
    SetView(ViewOptions),
    /// Change how time advances.
    SetTimeMode(TimeMode),
    /// Wait for the display's refresh (true) or present as fast as possible.
    SetVsync(bool),
    /// Show recorded frame `n` (0 the oldest kept), pausing the simulation
    /// in that frame's state.
    ScrubTo(usize),
    /// Play the recorded frames back at real time (true), or stop (false).
    PlayRecording(bool),
    /// Write the recorded frames as a .glb file.
    ExportRecording,
    /// Move the camera so the whole cloth is in view.
    FitCamera,
    /// Back to the scene's starting view.
    ResetCamera,
    /// Save a PNG of the window into `screenshots/`.
    Screenshot,
    /// Close the viewer.
    Quit,
}

/// The keys the viewer understands, as shown in the panel and the README.
pub const KEY_BINDINGS: &[(&str, &str)] = &[
    ("Space", "pause / resume"),
    ("S", "one step"),
    ("R", "reset the scene"),
    ("F", "fit the cloth in view"),
    ("Home", "back to the scene's view"),
    ("F12", "screenshot into screenshots/"),
    ("P", "play the recorded frames / stop"),
    ("Left / Right", "previous / next recorded frame (pauses)"),
    ("Esc", "quit"),
];

/// What the mouse does in the 3-D view, as shown in the panel and the README.
pub const MOUSE_BINDINGS: &[(&str, &str)] = &[
    ("left-drag on the cloth", "grab a particle and pull it"),
    ("left-drag elsewhere", "orbit"),
    ("right- or middle-drag", "pan"),
    ("wheel", "zoom"),
    ("Ctrl + click", "pin / unpin a particle"),
    ("drop a scene file", "open it"),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_readme_lists_every_binding() {
        let readme = include_str!("../../README.md");
        for (binding, _) in KEY_BINDINGS.iter().chain(MOUSE_BINDINGS) {
            assert!(readme.contains(&format!("| {binding} |")), "README.md's viewer tables lack `{binding}`");
        }
    }
}
