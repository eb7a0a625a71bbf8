//! A run's frames, kept in memory.

use std::collections::VecDeque;
use std::sync::Arc;

use glam::Vec3;

use crate::sim::{ClothMesh, SimError, Simulation};

/// Why a recorded frame could not be restored.
#[derive(Debug, thiserror::Error)]
pub enum RestoreError {
    /// The index is past the frames kept.
    #[error("frame {index} is not recorded: the recording holds {frames} frames")]
    NoSuchFrame {
        /// The index asked for.
        index: usize,
        /// Frames held.
        frames: usize,
    },
    /// The recording kept positions only.
    #[error("this recording kept positions only, not the previous positions a resume needs")]
    NotResumable,
    /// The simulation refused the state (another mesh's frame).
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// One recorded state of the cloth.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Steps since the simulation started.
    pub step: u64,
    /// Simulated time, seconds.
    pub time: f64,
    /// Positions x, metres, in the mesh's particle order.
    pub positions: Vec<Vec3>,
    /// The previous positions x_{i−1} (Verlet's velocity), when the
    /// recording keeps them to resume from this frame; empty otherwise.
    pub previous: Vec<Vec3>,
}

/// Frames of one cloth, oldest first, bounded in memory: when a new frame
/// would pass the limit, the oldest ones are dropped.
///
/// A frame costs 12 bytes per particle (24 when resumable: positions and
/// previous positions) plus a few dozen bytes; the seed's 20 × 30 cloth is
/// 14.4 KB a resumable frame, a 256 × 256 one 1.57 MB.
#[derive(Clone, Debug)]
pub struct Recording {
    mesh: Arc<ClothMesh>,
    frames: VecDeque<Frame>,
    resumable: bool,
    limit_bytes: usize,
}

impl Recording {
    /// An unbounded recording of positions only (for export).
    pub fn new(mesh: Arc<ClothMesh>) -> Self {
        Recording { mesh, frames: VecDeque::new(), resumable: false, limit_bytes: usize::MAX }
    }

    /// A recording that keeps each frame's previous positions too, so that
    /// the simulation can resume from any frame, holding at most
    /// `limit_bytes` of frames (always at least one frame).
    pub fn resumable(mesh: Arc<ClothMesh>, limit_bytes: usize) -> Self {
        Recording { mesh, frames: VecDeque::new(), resumable: true, limit_bytes }
    }

    /// The mesh the frames belong to.
    pub fn mesh(&self) -> &Arc<ClothMesh> {
        &self.mesh
    }

    /// Bytes one frame takes.
    pub fn frame_bytes(&self) -> usize {
        let per_particle = if self.resumable { 24 } else { 12 };
        std::mem::size_of::<Frame>() + per_particle * self.mesh.particle_count()
    }

    /// The most frames the memory limit allows (at least 1).
    pub fn capacity(&self) -> usize {
        (self.limit_bytes / self.frame_bytes()).max(1)
    }

    /// Bytes the frames take now.
    pub fn bytes(&self) -> usize {
        self.frames.len() * self.frame_bytes()
    }

    /// The frames, oldest first.
    pub fn frames(&self) -> &VecDeque<Frame> {
        &self.frames
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether there is no frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frame `index`, 0 the oldest.
    pub fn get(&self, index: usize) -> Option<&Frame> {
        self.frames.get(index)
    }

    /// Appends the simulation's current state, dropping the oldest frames
    /// past the limit. Returns how many were dropped.
    pub fn record(&mut self, sim: &Simulation) -> usize {
        let previous = if self.resumable { sim.previous_positions().to_vec() } else { Vec::new() };
        self.frames.push_back(Frame {
            step: sim.steps(),
            time: sim.time(),
            positions: sim.positions().to_vec(),
            previous,
        });
        let mut dropped = 0;
        while self.frames.len() > self.capacity() {
            self.frames.pop_front();
            dropped += 1;
        }
        dropped
    }

    /// Drops every frame after `index` (resuming from it makes them stale).
    pub fn truncate_after(&mut self, index: usize) {
        self.frames.truncate(index + 1);
    }

    /// Drops every frame.
    pub fn clear(&mut self) {
        self.frames.clear();
    }

    /// Puts `sim` in frame `index`'s state (positions, previous positions,
    /// step and time): it steps on from there as it did the first time,
    /// bit for bit with the reference solver; the fast solver keeps the
    /// displacement x − x_prev, which the round trip through x_prev can
    /// change by a rounding of x (≤ 1 ulp). Only a resumable recording can.
    pub fn restore(&self, index: usize, sim: &mut Simulation) -> Result<(), RestoreError> {
        let frame = self.frames.get(index).ok_or(RestoreError::NoSuchFrame { index, frames: self.frames.len() })?;
        if frame.previous.is_empty() {
            return Err(RestoreError::NotResumable);
        }
        sim.set_state(&frame.positions, &frame.previous)?;
        sim.set_clock(frame.step, frame.time)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, SolverKind, SolverParams};

    fn sim() -> Simulation {
        let mesh = Grid { columns: 4, rows: 3, ..Grid::default() }.build().unwrap();
        Simulation::new(mesh, SolverParams::default()).unwrap()
    }

    #[test]
    fn the_limit_drops_the_oldest_frames() {
        let mut sim = sim();
        let one = Recording::resumable(sim.mesh().clone(), usize::MAX).frame_bytes();
        // 12 particles: 288 bytes of positions per resumable frame, plus
        // the Frame itself; room for exactly three.
        assert_eq!(one, std::mem::size_of::<Frame>() + 24 * 12);
        let mut rec = Recording::resumable(sim.mesh().clone(), 3 * one + one / 2);
        assert_eq!(rec.capacity(), 3);
        for _ in 0..5 {
            rec.record(&sim);
            sim.step().unwrap();
        }
        assert_eq!(rec.len(), 3);
        assert_eq!(rec.frames().iter().map(|f| f.step).collect::<Vec<_>>(), [2, 3, 4]);
        assert!(rec.bytes() <= 3 * one + one / 2);
    }

    /// Records 10 steps, goes back to step 4 and steps again; returns the
    /// largest distance between the two runs' positions at steps 5 to 9.
    fn resume_gap(solver: SolverKind) -> (f32, Simulation, Recording) {
        let mesh = Grid { columns: 4, rows: 3, ..Grid::default() }.build().unwrap();
        let mut sim = Simulation::with_solver(mesh, SolverParams::default(), solver).unwrap();
        let mut rec = Recording::resumable(sim.mesh().clone(), usize::MAX);
        for _ in 0..10 {
            rec.record(&sim);
            sim.step().unwrap();
        }
        rec.restore(4, &mut sim).unwrap();
        assert_eq!((sim.steps(), sim.time()), (rec.get(4).unwrap().step, rec.get(4).unwrap().time));
        let mut gap = 0f32;
        for i in 5..10 {
            sim.step().unwrap();
            for (a, b) in sim.positions().iter().zip(&rec.get(i).unwrap().positions) {
                gap = gap.max(a.distance(*b));
            }
        }
        (gap, sim, rec)
    }

    #[test]
    fn resuming_from_a_frame_repeats_the_run() {
        // The reference solver keeps x and x_prev as given: the same bits
        // as the first time (the solver is deterministic; only the state it
        // starts from could differ).
        assert_eq!(resume_gap(SolverKind::Reference).0, 0.0);
        // The fast solver keeps the displacement d = x − x_prev, and
        // x − (x − d) can differ from d by a rounding of x (0.5 ulp of 1 m,
        // 6e-8 m); 5 steps carry it on without growth beyond a few ulp.
        let (gap, mut sim, rec) = resume_gap(SolverKind::Fast);
        assert!(gap < 1e-6, "{gap}");
        // A positions-only recording cannot resume.
        let mut flat = Recording::new(sim.mesh().clone());
        flat.record(&sim);
        assert!(flat.restore(0, &mut sim).is_err());
        assert!(rec.restore(99, &mut sim).is_err());
    }
}
