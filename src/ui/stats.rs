//! [`Stats`]: frame, solver and render timings and strain, smoothed for
//! display and kept over the last seconds for the panel's plots.

use std::collections::VecDeque;

use crate::sim::Strain;

/// Seconds of history the plots show.
pub const HISTORY_SECONDS: f64 = 10.0;
/// Weight of a new sample in the displayed averages.
const SMOOTHING: f64 = 0.1;

/// One frame's figures, as plotted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Wall-clock seconds since the viewer started.
    pub at: f64,
    /// Solver milliseconds per step in that frame; `None` if it took none.
    pub solver_ms: Option<f64>,
    /// Largest bar strain after the frame.
    pub max_strain: f32,
    /// RMS bar strain after the frame.
    pub rms_strain: f32,
}

/// Running figures for the stats panel.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    frame_seconds: Option<f64>,
    solver_seconds: Option<f64>,
    render_seconds: Option<f64>,
    sim_per_wall: Option<f64>,
    strain: Strain,
    history: VecDeque<Sample>,
}

fn smooth(old: Option<f64>, new: f64) -> Option<f64> {
    Some(old.map_or(new, |o| o + SMOOTHING * (new - o)))
}

impl Stats {
    /// Records one displayed frame: its wall-clock length, the solver's
    /// time and steps in it, the simulated seconds it advanced, and the
    /// strain after it. `at` is seconds since the viewer started.
    pub fn record_frame(
        &mut self,
        at: f64,
        frame_seconds: f64,
        solver_seconds: f64,
        steps: u64,
        simulated: f64,
        strain: Strain,
    ) {
        self.frame_seconds = smooth(self.frame_seconds, frame_seconds);
        let per_step = (steps > 0).then(|| solver_seconds / steps as f64);
        if let Some(s) = per_step {
            self.solver_seconds = smooth(self.solver_seconds, s);
        }
        if frame_seconds > 0.0 {
            self.sim_per_wall = smooth(self.sim_per_wall, simulated / frame_seconds);
        }
        self.strain = strain;
        self.history.push_back(Sample {
            at,
            solver_ms: per_step.map(|s| s * 1e3),
            max_strain: strain.max,
            rms_strain: strain.rms,
        });
        while self.history.front().is_some_and(|s| at - s.at > HISTORY_SECONDS) {
            self.history.pop_front();
        }
    }

    /// Records the CPU time spent recording and submitting a frame's drawing.
    pub fn record_render(&mut self, seconds: f64) {
        self.render_seconds = smooth(self.render_seconds, seconds);
    }

    /// Displayed frames per second (smoothed), once a frame has been timed.
    pub fn fps(&self) -> Option<f64> {
        self.frame_seconds.filter(|&s| s > 0.0).map(|s| 1.0 / s)
    }

    /// Solver seconds per step (smoothed), once a step has been timed.
    pub fn solver_seconds_per_step(&self) -> Option<f64> {
        self.solver_seconds
    }

    /// CPU seconds to record and submit a frame (smoothed).
    pub fn render_seconds(&self) -> Option<f64> {
        self.render_seconds
    }

    /// Simulated seconds per wall-clock second (smoothed).
    pub fn speed(&self) -> Option<f64> {
        self.sim_per_wall
    }

    /// The strain after the last frame.
    pub fn strain(&self) -> Strain {
        self.strain
    }

    /// The samples of the last [`HISTORY_SECONDS`], oldest first.
    pub fn history(&self) -> impl Iterator<Item = &Sample> {
        self.history.iter()
    }

    /// Forgets everything (a new scene).
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn history_keeps_the_last_ten_seconds_and_averages_smooth() {
        let mut stats = Stats::default();
        for i in 0..200 {
            let strain = Strain { max: 0.1, rms: 0.01 };
            stats.record_frame(i as f64 * 0.1, 0.1, 0.02, 2, 0.1, strain);
        }
        let oldest = stats.history().next().unwrap().at;
        assert!((19.9 - oldest) <= HISTORY_SECONDS + 1e-9 && oldest > 9.0, "{oldest}");
        assert!((stats.fps().unwrap() - 10.0).abs() < 1e-9);
        assert!((stats.solver_seconds_per_step().unwrap() - 0.01).abs() < 1e-12);
        assert!((stats.speed().unwrap() - 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_frame_without_steps_does_not_change_the_solver_time() {
        let mut stats = Stats::default();
        stats.record_frame(0.0, 0.016, 0.004, 1, 0.05, Strain::default());
        stats.record_frame(0.016, 0.016, 0.0, 0, 0.0, Strain::default());
        assert_eq!(stats.solver_seconds_per_step(), Some(0.004));
        assert_eq!(stats.history().last().unwrap().solver_ms, None);
    }
}
