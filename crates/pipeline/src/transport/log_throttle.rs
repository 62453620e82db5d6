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
}

/// Warn of one rejection through a [`LogThrottle`], if a line is admitted now:
/// `warn_rejected!(throttle, rejected, "format", args...)`, `rejected` being the count so far,
/// which the line carries with those held back. A macro so that the line's target is the
/// module that rejected (`RUST_LOG=shipcast::deck=warn` finds it), not this one.
#[macro_export]
macro_rules! warn_rejected {
    ($throttle:expr, $rejected:expr, $($what:tt)+) => {
        if let Some(held_back) = $throttle.admit(::std::time::Instant::now()) {
            ::tracing::warn!(rejected = $rejected, held_back, $($what)+);
        }
    };
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

    /// Records the target of every event.
    struct Targets(std::sync::Mutex<Vec<String>>);

    impl tracing::Subscriber for Targets {
        fn enabled(&self, _: &tracing::Metadata<'_>) -> bool {
            true
        }
        fn new_span(&self, _: &tracing::span::Attributes<'_>) -> tracing::span::Id {
            tracing::span::Id::from_u64(1)
        }
        fn record(&self, _: &tracing::span::Id, _: &tracing::span::Record<'_>) {}
        fn record_follows_from(&self, _: &tracing::span::Id, _: &tracing::span::Id) {}
        fn event(&self, event: &tracing::Event<'_>) {
            let target = event.metadata().target().to_string();
            self.0.lock().unwrap().push(target);
        }
        fn enter(&self, _: &tracing::span::Id) {}
        fn exit(&self, _: &tracing::span::Id) {}
    }

    #[test]
    fn a_rejection_is_logged_under_the_module_that_rejected() {
        // Regression: every rejection logged under this module's target, so a filter on the
        // service that rejected (RUST_LOG=shipcast::deck=warn) hid them.
        let targets = std::sync::Arc::new(Targets(Default::default()));
        let mut throttle = LogThrottle::default();
        tracing::subscriber::with_default(targets.clone(), || {
            for rejected in 1..=BURST_LINES as u64 + 5 {
                crate::warn_rejected!(throttle, rejected, "test: rejected {}", rejected);
            }
        });
        let seen = targets.0.lock().unwrap();
        // The burst is written, the rest held back within the same instant.
        assert_eq!(seen.len(), BURST_LINES as usize);
        assert!(seen.iter().all(|t| t == module_path!()), "{seen:?}");
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
