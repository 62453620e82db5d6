//! Events counted and reported at most once per period: the first at once, then how many came
//! since the previous report. A flood of connections must not become a flood of log lines.

use std::time::Duration;
use tokio::time::Instant;

/// A count of one kind of event, with what has not been reported yet.
#[derive(Debug)]
pub(crate) struct Tally {
    period: Duration,
    total: u64,
    unreported: u64,
    last_report: Option<Instant>,
}

/// One report: events since the previous one, and since the count started.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Report {
    pub since_last: u64,
    pub total: u64,
}

impl Tally {
    pub(crate) fn new(period: Duration) -> Self {
        Tally {
            period,
            total: 0,
            unreported: 0,
            last_report: None,
        }
    }

    /// Count one event; the report to log, if one is due.
    pub(crate) fn count(&mut self, now: Instant) -> Option<Report> {
        self.total += 1;
        self.unreported += 1;
        self.report_if_due(now)
    }

    /// The report of the events not reported yet, if there are any and the period since the
    /// last report has passed.
    pub(crate) fn report_if_due(&mut self, now: Instant) -> Option<Report> {
        if self.unreported == 0 {
            return None;
        }
        if self
            .last_report
            .is_some_and(|t| now.duration_since(t) < self.period)
        {
            return None;
        }
        self.last_report = Some(now);
        Some(Report {
            since_last: std::mem::take(&mut self.unreported),
            total: self.total,
        })
    }

    /// When the events not reported yet will be due (None: none are waiting).
    pub(crate) fn due_at(&self) -> Option<Instant> {
        match (self.unreported, self.last_report) {
            (0, _) => None,
            (_, Some(t)) => Some(t + self.period),
            (_, None) => Some(Instant::now()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_are_reported_at_once_then_at_most_once_per_period() {
        let period = Duration::from_secs(10);
        let mut tally = Tally::new(period);
        let t0 = Instant::now();
        assert_eq!(tally.due_at(), None);
        assert_eq!(
            tally.count(t0),
            Some(Report {
                since_last: 1,
                total: 1
            })
        );
        assert_eq!(tally.due_at(), None, "nothing waits after a report");
        for k in 1..=5 {
            assert_eq!(tally.count(t0 + Duration::from_secs(k)), None);
        }
        assert_eq!(tally.due_at(), Some(t0 + period));
        assert_eq!(tally.report_if_due(t0 + Duration::from_secs(9)), None);
        assert_eq!(
            tally.report_if_due(t0 + period),
            Some(Report {
                since_last: 5,
                total: 6
            })
        );
        assert_eq!(tally.report_if_due(t0 + period * 3), None);
        // After a quiet spell, the next event is reported at once again.
        assert_eq!(
            tally.count(t0 + period * 3),
            Some(Report {
                since_last: 1,
                total: 7
            })
        );
    }
}
