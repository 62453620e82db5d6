//! Message accounting: nothing is dropped silently. Every received sample is either accepted,
//! or rejected and counted by reason; gaps in `seq` are counted as lost.

use serde::{Deserialize, Serialize};
use shipcast_wire::payload::MotionSample;

/// Counters of one service process, logged periodically and published as status.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// Samples taken off the transport (accepted or not).
    pub received: u64,
    /// Samples missing according to gaps in `seq`.
    pub lost: u64,
    /// Samples with a NaN or infinite value.
    pub rejected_nonfinite: u64,
    /// Samples older than one already accepted (seq or record time going back).
    pub rejected_order: u64,
    /// Samples from a publisher port other than the one followed (a second producer).
    #[serde(default)]
    pub rejected_source: u64,
    /// Messages published by this process.
    pub published: u64,
    /// Producer runs seen start again at seq 0.
    pub restarts: u64,
}

impl Counters {
    /// Account for one received sample as judged by `check`.
    pub fn count(&mut self, check: SeqCheck) {
        self.received += 1;
        match check {
            SeqCheck::Accepted { lost } => self.lost += lost,
            SeqCheck::NewRun => self.restarts += 1,
            SeqCheck::NonFinite => self.rejected_nonfinite += 1,
            SeqCheck::OutOfOrder => self.rejected_order += 1,
        }
    }

    /// One-line summary for logs and the live view.
    pub fn summary(&self) -> String {
        format!(
            "received {} lost {} rejected {} (non-finite {}, out-of-order {}, foreign {}) published {} restarts {}",
            self.received,
            self.lost,
            self.rejected_nonfinite + self.rejected_order + self.rejected_source,
            self.rejected_nonfinite,
            self.rejected_order,
            self.rejected_source,
            self.published,
            self.restarts
        )
    }
}

/// What to do with a received sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeqCheck {
    /// In order; `lost` samples were skipped before it.
    Accepted { lost: u64 },
    /// seq 0 after a run: a new producer started. The sample is accepted and starts a new,
    /// discontinuous record.
    NewRun,
    /// Rejected: a value is NaN or infinite.
    NonFinite,
    /// Rejected: seq or record time is not after the last accepted sample.
    OutOfOrder,
}

impl SeqCheck {
    /// True if the sample should be used.
    pub fn is_accepted(self) -> bool {
        matches!(self, SeqCheck::Accepted { .. } | SeqCheck::NewRun)
    }
}

/// Judges each sample against the last accepted one of the current producer run.
#[derive(Debug, Clone, Default)]
pub struct SeqTracker {
    last: Option<(u64, f64)>,
}

impl SeqTracker {
    pub fn new() -> Self {
        Self::default()
    }

    /// Judge `sample` and, if accepted, remember it as the newest.
    pub fn check(&mut self, sample: &MotionSample) -> SeqCheck {
        if !sample.is_finite() {
            // The sample arrived, so it is not lost: advance seq (not time, which may be NaN)
            // so the next good sample does not count it again as a gap.
            if let Some((last_seq, last_time)) = self.last {
                if sample.seq > last_seq {
                    self.last = Some((sample.seq, last_time));
                }
            }
            return SeqCheck::NonFinite;
        }
        let verdict = match self.last {
            None => SeqCheck::Accepted { lost: 0 },
            Some((last_seq, _)) if sample.seq == 0 && last_seq > 0 => SeqCheck::NewRun,
            Some((last_seq, last_time)) => {
                if sample.seq <= last_seq || sample.time_s <= last_time {
                    SeqCheck::OutOfOrder
                } else {
                    SeqCheck::Accepted {
                        lost: sample.seq - last_seq - 1,
                    }
                }
            }
        };
        if verdict.is_accepted() {
            self.last = Some((sample.seq, sample.time_s));
        }
        verdict
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(seq: u64, time_s: f64) -> MotionSample {
        MotionSample {
            seq,
            time_s,
            ..MotionSample::default()
        }
    }

    #[test]
    fn gaps_reorders_restarts_and_nan_are_told_apart() {
        let mut t = SeqTracker::new();
        let mut c = Counters::default();
        let mut feed = |smp: MotionSample| {
            let v = t.check(&smp);
            c.count(v);
            v
        };
        assert_eq!(feed(s(0, 0.0)), SeqCheck::Accepted { lost: 0 });
        assert_eq!(feed(s(1, 0.125)), SeqCheck::Accepted { lost: 0 });
        assert_eq!(feed(s(4, 0.5)), SeqCheck::Accepted { lost: 2 });
        assert_eq!(feed(s(3, 0.375)), SeqCheck::OutOfOrder);
        // Same seq again, or time not advancing: out of order too.
        assert_eq!(feed(s(4, 0.5)), SeqCheck::OutOfOrder);
        assert_eq!(feed(s(5, 0.5)), SeqCheck::OutOfOrder);
        let mut nan = s(5, 0.625);
        nan.dof[2] = f64::NAN;
        assert_eq!(feed(nan), SeqCheck::NonFinite);
        // The rejected seq 5 arrived: it is counted as rejected, not again as lost.
        assert_eq!(feed(s(6, 0.75)), SeqCheck::Accepted { lost: 0 });
        assert_eq!(feed(s(0, 0.0)), SeqCheck::NewRun);
        assert_eq!(feed(s(1, 0.125)), SeqCheck::Accepted { lost: 0 });
        assert_eq!(
            c,
            Counters {
                received: 10,
                lost: 2,
                rejected_nonfinite: 1,
                rejected_order: 3,
                rejected_source: 0,
                published: 0,
                restarts: 1,
            }
        );
        assert!(c.summary().contains("lost 2"));
    }
}
