//! [`Clock`]: where the viewer reads the time, so tests can fix it.

use std::time::{Duration, Instant};

/// A source of monotonic time since some origin.
pub trait Clock: Send {
    /// Time since the clock's origin.
    fn now(&mut self) -> Duration;
}

/// The real monotonic clock.
#[derive(Clone, Copy, Debug)]
pub struct WallClock(Instant);

impl Default for WallClock {
    fn default() -> Self {
        Self(Instant::now())
    }
}

impl Clock for WallClock {
    fn now(&mut self) -> Duration {
        self.0.elapsed()
    }
}

/// A clock that advances by a fixed tick each time it is read: timings it
/// yields are the same on every run (for golden images of the panel).
#[derive(Clone, Copy, Debug)]
pub struct TickingClock {
    /// The time it will report next.
    pub next: Duration,
    /// How much each reading adds.
    pub tick: Duration,
}

impl Clock for TickingClock {
    fn now(&mut self) -> Duration {
        let t = self.next;
        self.next += self.tick;
        t
    }
}
