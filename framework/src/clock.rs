//! Time as the processors see it.
//!
//! Processors never read a clock themselves: the runtime passes `now` in and
//! tells them how long each step took. The threads runtime uses the wall clock;
//! the simulator supplies virtual time.

use std::time::Instant;

/// Nanoseconds since the start of the run (wall or virtual).
pub type Time = u64;

/// A source of [`Time`].
pub trait Clock: Send + Sync {
    /// The current time.
    fn now(&self) -> Time;
}

/// Wall-clock time since construction.
#[derive(Clone, Copy, Debug)]
pub struct WallClock {
    start: Instant,
}

impl WallClock {
    /// Starts counting now.
    pub fn new() -> Self {
        WallClock {
            start: Instant::now(),
        }
    }
}

impl Default for WallClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for WallClock {
    fn now(&self) -> Time {
        u64::try_from(self.start.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }
}
