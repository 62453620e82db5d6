//! How a consumer notices that forecasts stopped coming while their predictor still looks
//! alive (its producer died, its forecasting loop hangs, the link drops forecasts but keeps the
//! session): by wall time since the last accepted forecast, said once when it passes the limit
//! and once when forecasts come again. The predictor's liveliness token alone tells only when
//! its session ends, up to the zenoh lease (10 s) after it stops, and never while a live
//! session sends nothing.

use std::time::{Duration, Instant};

/// Wall time without a forecast after which a consumer says so (10 forecast periods at 2 Hz).
pub const NO_FORECAST_AFTER: Duration = Duration::from_secs(5);

/// Time since the last accepted forecast, and whether the silence was reported.
#[derive(Debug)]
pub struct ForecastSilence {
    service: &'static str,
    after: Duration,
    last: Instant,
    reported: bool,
}

impl ForecastSilence {
    /// Silence measured from `now` (a consumer starting counts from its start).
    pub fn new(service: &'static str, after: Duration, now: Instant) -> Self {
        ForecastSilence {
            service,
            after,
            last: now,
            reported: false,
        }
    }

    /// A forecast was accepted at `now`; true when it ends a reported silence (also logged).
    pub fn heard(&mut self, now: Instant) -> bool {
        let ended = self.reported;
        if ended {
            tracing::info!(
                "{}: forecasts again after {:.0} s without one",
                self.service,
                now.saturating_duration_since(self.last).as_secs_f64()
            );
        }
        self.last = now;
        self.reported = false;
        ended
    }

    /// No forecast at `now`; true (and one warning) when the silence has just passed the limit.
    pub fn check(&mut self, now: Instant) -> bool {
        if self.reported || now.saturating_duration_since(self.last) < self.after {
            return false;
        }
        self.reported = true;
        tracing::warn!(
            "{}: no forecast for {:.0} s (the producer, the predictor or the link stopped)",
            self.service,
            self.after.as_secs_f64()
        );
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_silence_is_reported_once_past_the_limit_and_its_end_once() {
        let t0 = Instant::now();
        let s = Duration::from_secs;
        let mut silence = ForecastSilence::new("crane", s(5), t0);
        assert!(!silence.check(t0 + s(4)));
        assert!(silence.check(t0 + s(5)), "reported at the limit");
        assert!(!silence.check(t0 + s(9)), "once");
        assert!(silence.heard(t0 + s(12)), "its end is reported");
        assert!(
            !silence.heard(t0 + s(13)),
            "a forecast in time is nothing to report"
        );
        assert!(!silence.check(t0 + s(17)));
        assert!(silence.check(t0 + s(18)), "measured from the last forecast");
    }
}
