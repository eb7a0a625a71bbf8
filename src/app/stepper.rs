//! [`Stepper`]: how many solver steps a displayed frame takes.

use super::clock::Clock;
use crate::scene::Playback;
use crate::sim::Simulation;
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

/// Largest share of wall time the solver may need for real time to be the
/// default: the rest is for drawing the frame.
pub const REAL_TIME_SHARE: f64 = 0.5;

/// The time mode a scene opens in, and a line saying why (the panel shows
/// it). With [`Playback::Auto`] the choice is measured: `seconds_per_step`
/// (the solver's time for one step, timed on the scene when it loads) over
/// h is the share of wall time real time would take; at most
/// [`REAL_TIME_SHARE`] opens in real time, more in a step per frame.
pub fn initial_mode(playback: Playback, seconds_per_step: f64, dt: f64) -> (TimeMode, String) {
    match playback {
        Playback::RealTime => (TimeMode::RealTime, "real time (the scene's choice)".to_string()),
        Playback::StepPerFrame => (TimeMode::StepPerFrame, "a step per frame (the scene's choice)".to_string()),
        Playback::Auto => {
            let share = seconds_per_step / dt;
            if share <= REAL_TIME_SHARE {
                let why = format!("real time: the solver needs {:.1} % of it", 100.0 * share);
                (TimeMode::RealTime, why)
            } else {
                let why = format!("a step per frame: real time would need {:.0} % of the CPU", 100.0 * share);
                (TimeMode::StepPerFrame, why)
            }
        }
    }
}

/// Times up to `steps` solver steps of a copy of `sim` with `clock`: the
/// fastest, in seconds (the copy's first step may set up caches). Stops
/// after a step slower than 0.1 s, which settles the question.
pub fn time_a_step(sim: &Simulation, clock: &mut dyn Clock, steps: u32) -> f64 {
    let mut copy = sim.clone();
    let mut best = f64::INFINITY;
    for _ in 0..steps {
        let start = clock.now();
        if copy.step().is_err() {
            break;
        }
        best = best.min(clock.now().saturating_sub(start).as_secs_f64());
        // A step this slow is far from real time already: do not make the
        // scene wait for more of them.
        if best > 0.1 {
            break;
        }
    }
    if best.is_finite() { best } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scene_or_the_measured_cost_chooses_the_mode() {
        // 1 ms steps of h = 0.01 s: 10 % of real time.
        let (mode, why) = initial_mode(Playback::Auto, 1e-3, 0.01);
        assert_eq!(mode, TimeMode::RealTime);
        assert!(why.contains("10.0 %"), "{why}");
        // 20 ms steps of h = 0.02 s would need the whole CPU.
        let (mode, why) = initial_mode(Playback::Auto, 0.02, 0.02);
        assert_eq!(mode, TimeMode::StepPerFrame);
        assert!(why.contains("100 %"), "{why}");
        assert_eq!(initial_mode(Playback::StepPerFrame, 0.0, 0.01).0, TimeMode::StepPerFrame);
        assert_eq!(initial_mode(Playback::RealTime, 1.0, 0.01).0, TimeMode::RealTime);
    }

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
