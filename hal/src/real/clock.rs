//! The real rig's clock: seconds since the backend started, on the host's monotonic clock.
//!
//! The device reader threads tell the clock when input arrives ([`RealClock::input_arrived`]),
//! so a runner waiting for its next control tick wakes as soon as a frame is there, not at
//! the tick: the reaction to a slipping frame leaves within the I/O time.

use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use crate::Clock;

/// How many inputs have arrived, and the condition a waiting runner sleeps on.
#[derive(Debug, Default)]
struct Arrivals {
    count: Mutex<u64>,
    changed: Condvar,
}

/// Clones share the start instant and the arrivals; each keeps its own count of the
/// arrivals it has seen, so only the clone that waits consumes them.
#[derive(Debug, Clone)]
pub struct RealClock {
    start: Instant,
    arrivals: Arc<Arrivals>,
    seen: u64,
}

impl RealClock {
    pub fn new() -> Self {
        Self {
            start: Instant::now(),
            arrivals: Arc::default(),
            seen: 0,
        }
    }

    /// Time `at` on this clock, s.
    pub fn at(&self, at: Instant) -> f64 {
        at.saturating_duration_since(self.start).as_secs_f64()
    }

    /// A device's reader thread has handed over new input: wakes a runner waiting in
    /// [`Clock::wait_for_input_until`].
    pub fn input_arrived(&self) {
        let mut count = self
            .arrivals
            .count
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        *count += 1;
        self.arrivals.changed.notify_all();
    }
}

impl Default for RealClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for RealClock {
    fn now_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }
    fn sleep_until(&mut self, time_s: f64) {
        let left = time_s - self.now_s();
        if left > 0.0 {
            std::thread::sleep(Duration::from_secs_f64(left));
        }
    }
    fn wait_for_input_until(&mut self, time_s: f64) {
        let mut count = self
            .arrivals
            .count
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        // Input that arrived since the last wait (while the runner was busy) ends this one
        // at once, so none is left waiting for a tick.
        while *count == self.seen {
            let left = time_s - self.now_s();
            if left <= 0.0 {
                return;
            }
            count = self
                .arrivals
                .changed
                .wait_timeout(count, Duration::from_secs_f64(left))
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
        self.seen = *count;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wait_ends_at_its_time_without_input() {
        let mut clock = RealClock::new();
        let t = clock.now_s() + 0.02;
        clock.wait_for_input_until(t);
        assert!(clock.now_s() >= t);
    }

    #[test]
    fn input_ends_a_wait_early_and_input_while_busy_ends_the_next_at_once() {
        let mut clock = RealClock::new();
        let reader = clock.clone();
        let thread = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            reader.input_arrived();
        });
        let start = clock.now_s();
        clock.wait_for_input_until(start + 10.0);
        let waited = clock.now_s() - start;
        thread.join().unwrap();
        assert!((0.015..5.0).contains(&waited), "{waited}");
        // consumed: the next wait runs to its time
        let t = clock.now_s() + 0.01;
        clock.wait_for_input_until(t);
        assert!(clock.now_s() >= t);
        // input that came while the runner was not waiting ends the next wait at once
        clock.input_arrived();
        let start = clock.now_s();
        clock.wait_for_input_until(start + 10.0);
        assert!(clock.now_s() - start < 5.0);
    }
}
