//! [`Stepper`]: how many solver steps a displayed frame takes.

use crate::ui::TimeMode;

/// Longest frame the real-time mode catches up on, seconds: after a stall
/// (a window drag, a breakpoint) the cloth does not jump.
const MAX_FRAME_SECONDS: f64 = 0.25;
/// Wall-clock seconds per frame the real-time mode may spend in the solver.
const SOLVER_BUDGET_SECONDS: f64 = 0.030;
/// Most steps one frame takes in real-time mode, however cheap they are.
const MAX_STEPS_PER_FRAME: u64 = 64;

/// Turns displayed frames into solver steps.
///
/// In [`TimeMode::RealTime`] it is a fixed-step accumulator: elapsed wall
/// time is banked and spent in whole steps of h. The steps one frame may take
/// are capped by a solver-time budget (and at 64); time
/// the cap leaves unspent is dropped rather than carried over, so a solver
/// slower than real time runs slow instead of spiralling into ever longer
/// frames.
#[derive(Clone, Debug, Default)]
pub struct Stepper {
    /// The current mode.
    pub mode: TimeMode,
    banked: f64,
}

impl Stepper {
    /// The steps to take in a frame that lasted `frame_seconds`, for steps
    /// of `dt` seconds that recently cost `solver_seconds_per_step` each
    /// (`None` before the first was timed).
    pub fn steps_for_frame(&mut self, frame_seconds: f64, dt: f64, solver_seconds_per_step: Option<f64>) -> u64 {
        match self.mode {
            TimeMode::StepPerFrame => {
                self.banked = 0.0;
                1
            }
            TimeMode::RealTime => {
                if dt.is_nan() || dt <= 0.0 {
                    return 0;
                }
                self.banked += frame_seconds.clamp(0.0, MAX_FRAME_SECONDS);
                let wanted = (self.banked / dt).floor() as u64;
                let affordable = match solver_seconds_per_step {
                    Some(s) if s > 0.0 => ((SOLVER_BUDGET_SECONDS / s).floor() as u64).max(1),
                    _ => MAX_STEPS_PER_FRAME,
                };
                let cap = affordable.min(MAX_STEPS_PER_FRAME);
                if wanted > cap {
                    self.banked = 0.0;
                    cap
                } else {
                    self.banked -= wanted as f64 * dt;
                    wanted
                }
            }
        }
    }

    /// Forgets banked time (after a pause, a reset or a mode change).
    pub fn reset(&mut self) {
        self.banked = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_per_frame_takes_one_step_whatever_the_frame_length() {
        let mut s = Stepper::default();
        assert_eq!(s.steps_for_frame(0.001, 0.05, None), 1);
        assert_eq!(s.steps_for_frame(2.0, 0.05, Some(1.0)), 1);
    }

    #[test]
    fn real_time_follows_the_clock_on_average() {
        let mut s = Stepper { mode: TimeMode::RealTime, ..Stepper::default() };
        // 60 fps frames, h = 0.02 s: 100 frames are 1.667 s, or 83 steps.
        let steps: u64 = (0..100).map(|_| s.steps_for_frame(1.0 / 60.0, 0.02, Some(1e-4))).sum();
        assert!((82..=84).contains(&steps), "{steps}");
    }

    #[test]
    fn a_slow_solver_is_capped_and_the_rest_dropped() {
        let mut s = Stepper { mode: TimeMode::RealTime, ..Stepper::default() };
        // Steps cost 20 ms: the 30 ms budget allows one per frame.
        for _ in 0..50 {
            assert_eq!(s.steps_for_frame(0.1, 0.01, Some(0.02)), 1);
        }
        // Nothing was banked: a fast frame afterwards takes no backlog.
        assert_eq!(s.steps_for_frame(0.01, 0.01, Some(1e-5)), 1);
    }

    #[test]
    fn a_stall_does_not_make_the_cloth_jump() {
        let mut s = Stepper { mode: TimeMode::RealTime, ..Stepper::default() };
        let steps = s.steps_for_frame(30.0, 0.01, Some(1e-6));
        assert!(steps <= 25, "{steps}");
    }
}
