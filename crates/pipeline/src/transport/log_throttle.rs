//! Warnings about what peers send, rate-limited: a peer can send thousands of bad messages a
//! second, and a line for each filled 310 MB of log in 3 s (review). Every rejection is still
//! counted (status and stop lines); the log shows the first ones one by one, then at most one
//! a second, each saying how many were held back before it.

use std::time::Instant;

/// Lines let through at once before the rate applies.
pub const BURST_LINES: f64 = 20.0;
/// Lines per second once the burst is spent.
pub const LINES_PER_S: f64 = 1.0;

/// A token bucket of log lines.
#[derive(Debug, Clone)]
pub struct LogThrottle {
    tokens: f64,
    last: Option<Instant>,
    held: u64,
}

impl Default for LogThrottle {
    fn default() -> Self {
        Self {
            tokens: BURST_LINES,
            last: None,
            held: 0,
        }
    }
}

impl LogThrottle {
    /// Whether a line about an event at `now` is written; if so, how many lines were held
    /// back since the last one written.
    pub fn admit(&mut self, now: Instant) -> Option<u64> {
        if let Some(last) = self.last {
            let refill = now.saturating_duration_since(last).as_secs_f64() * LINES_PER_S;
            self.tokens = (self.tokens + refill).min(BURST_LINES);
        }
        self.last = Some(now);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            Some(std::mem::take(&mut self.held))
        } else {
            self.held += 1;
            None
        }
    }

    /// Warn of one rejection (`what`, with its service's name) now, if a line is admitted;
    /// `rejected` is the count so far, which the line carries with those held back.
    pub fn warn_rejected(&mut self, rejected: u64, what: std::fmt::Arguments<'_>) {
        if let Some(held_back) = self.admit(Instant::now()) {
            tracing::warn!(rejected, held_back, "{what}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_burst_passes_then_one_line_a_second_with_what_was_held_back() {
        let mut t = LogThrottle::default();
        let start = Instant::now();
        // 1000 events a second for 3 s.
        let mut written = Vec::new();
        for i in 0..3000u64 {
            if let Some(held) = t.admit(start + Duration::from_millis(i)) {
                written.push((i, held));
            }
        }
        let burst = BURST_LINES as usize;
        // The burst, one after another, nothing held back.
        assert!(written[..burst].iter().all(|&(_, held)| held == 0));
        assert_eq!(written[burst - 1].0, burst as u64 - 1);
        // Then one a second (the bucket refills 0.02 lines during the burst's 20 ms).
        let after: Vec<_> = written[burst..].to_vec();
        assert_eq!(after.len(), 2, "{after:?}");
        // Every event is either written or counted as held back.
        let held: u64 = written.iter().map(|&(_, h)| h).sum();
        assert_eq!(written.len() as u64 + held + t.held, 3000);
        // A quiet spell refills the burst.
        let later = start + Duration::from_secs(60);
        for i in 0..burst as u64 {
            assert!(t.admit(later + Duration::from_millis(i)).is_some());
        }
    }

    #[test]
    fn a_clock_that_goes_back_refills_nothing() {
        let mut t = LogThrottle::default();
        let start = Instant::now() + Duration::from_secs(10);
        for _ in 0..BURST_LINES as usize {
            assert!(t.admit(start).is_some());
        }
        assert_eq!(t.admit(start - Duration::from_secs(5)), None);
        assert_eq!(t.admit(start + Duration::from_secs(1)), Some(1));
    }
}
