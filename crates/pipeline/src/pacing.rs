//! Pacing and waiting: one place for "send at a steady rate" and "wait until something holds".
//!
//! - [`Pacer`]: a fixed-period schedule that never bursts to catch up after falling behind.
//! - [`sleep_until`]: sleep to a deadline in short naps, so a stop request is noticed.
//! - [`poll_until`]: look at a condition every interval until it gives a value or time runs out.

use std::time::{Duration, Instant};

/// Sends at a fixed period: [`Pacer::wait`] sleeps until the next send is due.
#[derive(Debug)]
pub struct Pacer {
    period: Duration,
    next: Instant,
}

impl Pacer {
    /// A schedule of one send every `period`, starting now.
    pub fn new(period: Duration) -> Self {
        Self {
            period,
            next: Instant::now(),
        }
    }

    /// A schedule of `rate_hz` sends per second (a positive, finite rate; see
    /// `limits::rate`).
    pub fn at_rate(rate_hz: f64) -> Self {
        Self::new(Duration::from_secs_f64(1.0 / rate_hz))
    }

    pub fn period(&self) -> Duration {
        self.period
    }

    /// Sleep until the next send is due.
    pub fn wait(&mut self) {
        self.next += self.period;
        let now = Instant::now();
        if self.next > now {
            std::thread::sleep(self.next - now);
        } else {
            // Fell behind (slow transport, busy core): restart the schedule, never burst.
            self.next = now;
        }
    }
}

/// Sleep until `deadline` (none: until stopped) in naps of at most `nap`, returning early (false)
/// as soon as `stop()` is true; true when the deadline was reached.
pub fn sleep_until(deadline: Option<Instant>, nap: Duration, stop: impl Fn() -> bool) -> bool {
    loop {
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) {
            return true;
        }
        if stop() {
            return false;
        }
        let left = deadline.map_or(nap, |d| d - now);
        std::thread::sleep(left.min(nap));
    }
}

/// Call `probe` every `interval` until it returns `Some` (returned) or `timeout` has passed
/// (`None`). `probe` is called at least once, and once more at the end of the time.
pub fn poll_until<T>(
    timeout: Duration,
    interval: Duration,
    mut probe: impl FnMut() -> Option<T>,
) -> Option<T> {
    let deadline = Instant::now().checked_add(timeout);
    loop {
        if let Some(v) = probe() {
            return Some(v);
        }
        let now = Instant::now();
        match deadline {
            Some(d) if now >= d => return None,
            Some(d) => std::thread::sleep(interval.min(d - now)),
            None => std::thread::sleep(interval),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poll_until_returns_the_first_value_and_counts_its_calls() {
        let mut calls = 0;
        let got = poll_until(Duration::from_secs(60), Duration::ZERO, || {
            calls += 1;
            (calls == 3).then_some(calls * 10)
        });
        assert_eq!(got, Some(30));
        assert_eq!(calls, 3);
    }

    #[test]
    fn poll_until_gives_up_after_the_timeout_having_tried() {
        let mut calls = 0;
        let got: Option<()> = poll_until(Duration::ZERO, Duration::from_millis(1), || {
            calls += 1;
            None
        });
        assert_eq!(got, None);
        assert!(calls >= 1);
    }

    #[test]
    fn sleep_until_reaches_a_past_deadline_and_stops_when_asked() {
        assert!(sleep_until(
            Some(Instant::now()),
            Duration::from_millis(1),
            || true
        ));
        // No deadline: only the stop request ends it.
        assert!(!sleep_until(None, Duration::from_millis(1), || true));
    }

    #[test]
    fn the_pacer_never_schedules_in_the_past() {
        let mut p = Pacer::at_rate(4.0);
        assert_eq!(p.period(), Duration::from_millis(250));
        // Fallen behind: the schedule restarts from now instead of bursting.
        let before = Instant::now();
        p.next = before - Duration::from_secs(10);
        p.wait();
        assert!(p.next >= before, "scheduled in the past");
    }
}
