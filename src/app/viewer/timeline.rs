//! The viewer's timeline: the recent frames kept in memory, scrubbing
//! through them, playing them back at real time, and resuming the
//! simulation from any of them.
//!
//! One frame is recorded per displayed frame in which the simulation
//! advanced (so at most the display's rate, whatever h is), holding the
//! positions and previous positions, 24 bytes per particle: the seed's 600
//! particles take 14 KB a frame, a 256 × 256 cloth 1.6 MB. The cache keeps
//! at most [`CACHE_BYTES`] (512 MiB) and drops the oldest frames past it:
//! about 37 000 frames of the seed's cloth (10 minutes at 60 frames per
//! second), 340 of a 256 × 256 one.
//!
//! Scrubbing puts the simulation itself in the chosen frame's state
//! ([`Recording::restore`]), so what is drawn, measured and grabbed is that
//! frame; running the simulation from there drops the later frames.

use std::sync::Arc;

use crate::export::{Recording, RestoreError};
use crate::sim::{ClothMesh, Simulation};

/// Most bytes of frames the viewer keeps.
pub const CACHE_BYTES: usize = 512 << 20;

/// Recorded frames and where the viewer is among them.
#[derive(Debug)]
pub struct Timeline {
    recording: Recording,
    /// The frame shown while scrubbing or playing back; `None` while the
    /// simulation shows its own latest state (live).
    cursor: Option<usize>,
    /// Playing the recording back: the simulated time reached, seconds.
    playback: Option<f64>,
}

impl Timeline {
    /// An empty timeline for `mesh`.
    pub fn new(mesh: Arc<ClothMesh>) -> Self {
        Timeline { recording: Recording::resumable(mesh, CACHE_BYTES), cursor: None, playback: None }
    }

    /// The frames.
    pub fn recording(&self) -> &Recording {
        &self.recording
    }

    /// The frame shown, if not live.
    pub fn cursor(&self) -> Option<usize> {
        self.cursor
    }

    /// Whether the recording is playing back.
    pub fn playing(&self) -> bool {
        self.playback.is_some()
    }

    /// Drops every frame and records `sim`'s state as the first.
    pub fn restart(&mut self, sim: &Simulation) {
        self.recording.clear();
        self.cursor = None;
        self.playback = None;
        self.recording.record(sim);
    }

    /// Records `sim`'s state as the newest frame (the simulation advanced).
    pub fn record(&mut self, sim: &Simulation) {
        self.recording.record(sim);
    }

    /// Before the simulation runs on: if a past frame is shown, the frames
    /// after it are dropped (they belong to another future). Returns how
    /// many were dropped.
    pub fn resume(&mut self) -> usize {
        self.playback = None;
        match self.cursor.take() {
            Some(i) => {
                let dropped = self.recording.len().saturating_sub(i + 1);
                self.recording.truncate_after(i);
                dropped
            }
            None => 0,
        }
    }

    /// Shows frame `index` (clamped to the frames there are): puts `sim` in
    /// its state and stops playback.
    pub fn scrub(&mut self, index: usize, sim: &mut Simulation) -> Result<(), RestoreError> {
        self.playback = None;
        self.show(index.min(self.recording.len().saturating_sub(1)), sim)
    }

    fn show(&mut self, index: usize, sim: &mut Simulation) -> Result<(), RestoreError> {
        self.recording.restore(index, sim)?;
        self.cursor = Some(index);
        Ok(())
    }

    /// Starts playing back from the frame shown, or from the first if the
    /// newest is shown (or none).
    pub fn play(&mut self, sim: &mut Simulation) -> Result<(), RestoreError> {
        let last = self.recording.len().saturating_sub(1);
        let start = match self.cursor {
            Some(i) if i < last => i,
            _ => 0,
        };
        self.show(start, sim)?;
        self.playback = self.recording.get(start).map(|f| f.time);
        Ok(())
    }

    /// Stops playing back, staying on the frame shown.
    pub fn stop(&mut self) {
        self.playback = None;
    }

    /// Advances playback by `seconds` of wall time (= simulated time: it
    /// plays at real time), showing the last frame at or before the time
    /// reached; stops at the newest frame. Returns whether a new frame is
    /// shown.
    pub fn play_for(&mut self, seconds: f64, sim: &mut Simulation) -> Result<bool, RestoreError> {
        let Some(time) = self.playback else { return Ok(false) };
        let time = time + seconds.max(0.0);
        let frames = self.recording.frames();
        // Frames are in time order: the last one not after `time`.
        let index = frames.partition_point(|f| f.time <= time).saturating_sub(1);
        let last = frames.len().saturating_sub(1);
        self.playback = if index >= last { None } else { Some(time) };
        if Some(index) == self.cursor {
            return Ok(false);
        }
        self.show(index, sim)?;
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, SolverParams};

    fn sim_and_timeline(steps: usize) -> (Simulation, Timeline) {
        let mesh = Grid { columns: 3, rows: 3, ..Grid::default() }.build().unwrap();
        let mut sim = Simulation::new(mesh, SolverParams::default()).unwrap();
        let mut timeline = Timeline::new(sim.mesh().clone());
        timeline.restart(&sim);
        for _ in 0..steps {
            sim.step().unwrap();
            timeline.record(&sim);
        }
        (sim, timeline)
    }

    #[test]
    fn scrubbing_shows_a_frame_and_resuming_drops_the_later_ones() {
        let (mut sim, mut t) = sim_and_timeline(10);
        assert_eq!(t.recording().len(), 11);
        t.scrub(3, &mut sim).unwrap();
        assert_eq!((sim.steps(), t.cursor()), (3, Some(3)));
        assert_eq!(sim.positions(), t.recording().get(3).unwrap().positions);
        // Past the end clamps to the newest frame.
        t.scrub(99, &mut sim).unwrap();
        assert_eq!(sim.steps(), 10);
        t.scrub(3, &mut sim).unwrap();
        assert_eq!(t.resume(), 7, "steps 4 to 10 belong to the old future");
        assert_eq!((t.recording().len(), t.cursor()), (4, None));
        sim.step().unwrap();
        t.record(&sim);
        assert_eq!(t.recording().frames().back().unwrap().step, 4);
    }

    #[test]
    fn playback_follows_simulated_time_and_stops_at_the_end() {
        // Steps of h = 0.05 s: frame k is at 0.05 k s.
        let (mut sim, mut t) = sim_and_timeline(10);
        t.play(&mut sim).unwrap();
        assert_eq!(t.cursor(), Some(0), "from the newest frame, playback starts at the first");
        // 0.12 s of wall time later the frame at 0.10 s is shown.
        assert!(t.play_for(0.12, &mut sim).unwrap());
        assert_eq!((t.cursor(), sim.steps()), (Some(2), 2));
        // Less than a step later nothing changes.
        assert!(!t.play_for(0.01, &mut sim).unwrap());
        // Long after, the last frame, and playback ends there.
        assert!(t.play_for(5.0, &mut sim).unwrap());
        assert_eq!((t.cursor(), t.playing()), (Some(10), false));
    }
}
