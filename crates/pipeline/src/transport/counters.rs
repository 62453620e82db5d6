//! Message accounting: nothing is dropped silently. Every received sample is either accepted,
//! or rejected and counted by reason; gaps in `seq` are counted as lost.

use serde::{Deserialize, Serialize};
use shipcast_wire::payload::MotionSample;

/// Counters of one service process, logged periodically and published as status.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// Samples taken off the transport (accepted or not).
    pub received: u64,
    /// Samples missing according to gaps in `seq` (in the predictor also gaps in record time
    /// that `seq` does not show: a recorded file with a hole, sent with consecutive seq).
    pub lost: u64,
    /// Samples with a NaN or infinite value, or a DOF value beyond
    /// [`MAX_ABS_MOTION`](shipcast_wire::payload::MAX_ABS_MOTION) (the status keeps the
    /// field's first name).
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
    /// Times the predictor found the motion's time stamps off `producer.rate_hz` (checked
    /// over 64 slots at a time); each restarted its history.
    #[serde(default)]
    pub rate_mismatches: u64,
}

impl Counters {
    /// Account for one received sample as judged by `check`.
    pub fn count(&mut self, check: SeqCheck) {
        self.received += 1;
        match check {
            SeqCheck::Accepted { lost } => self.lost = self.lost.saturating_add(lost),
            SeqCheck::NewRun => self.restarts += 1,
            SeqCheck::BadValue => self.rejected_nonfinite += 1,
            SeqCheck::OutOfOrder => self.rejected_order += 1,
        }
    }

    /// Samples rejected, for whatever reason.
    pub fn rejected(&self) -> u64 {
        self.rejected_nonfinite + self.rejected_order + self.rejected_source
    }

    /// One-line summary for logs and the live view.
    pub fn summary(&self) -> String {
        format!(
            "received {} lost {} rejected {} (non-finite or out of range {}, out-of-order {}, foreign {}) published {} restarts {}{}",
            self.received,
            self.lost,
            self.rejected(),
            self.rejected_nonfinite,
            self.rejected_order,
            self.rejected_source,
            self.published,
            self.restarts,
            if self.rate_mismatches > 0 {
                format!(" off producer.rate_hz {}", self.rate_mismatches)
            } else {
                String::new()
            }
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
    /// Rejected: a value is NaN or infinite, or a DOF value is beyond
    /// [`MAX_ABS_MOTION`](shipcast_wire::payload::MAX_ABS_MOTION).
    BadValue,
    /// Rejected: seq or record time is not after the last accepted sample.
    OutOfOrder,
}

impl SeqCheck {
    /// True if the sample should be used.
    pub fn is_accepted(self) -> bool {
        matches!(self, SeqCheck::Accepted { .. } | SeqCheck::NewRun)
    }
}

/// Out-of-order samples, each following the one before it, after which the stream counts as
/// restarted (2 s at 8 Hz): the accepted sample they fall behind was a glitch.
pub const RESYNC_AFTER: u32 = 16;

/// Judges each sample against the last accepted one of the current producer run.
#[derive(Debug, Clone, Default)]
pub struct SeqTracker {
    last: Option<(u64, f64)>,
    /// The newest rejected-as-out-of-order sample and how many in a row, each after the one
    /// before, have been rejected. One sample whose seq or time jumped far ahead (a corrupt
    /// or forged value) would otherwise put every later genuine sample "out of order" until
    /// the producer restarts at seq 0.
    behind: Option<(u64, f64, u32)>,
    /// Samples the newest accepted one claimed lost (its seq gap).
    claimed_lost: u64,
    /// Set by a resynchronisation: what the abandoned sample had claimed lost. Those samples
    /// were not lost, the abandoned sample's seq was wrong: the counts take them back.
    abandoned: Option<u64>,
}

impl SeqTracker {
    pub fn new() -> Self {
        Self::default()
    }

    /// Judge `sample` and, if accepted, remember it as the newest.
    pub fn check(&mut self, sample: &MotionSample) -> SeqCheck {
        if !sample.is_sound() {
            // The sample arrived, so it is not lost: advance seq (not time, which may be NaN)
            // so the next good sample does not count it again as a gap.
            if let Some((last_seq, last_time)) = self.last {
                if sample.seq > last_seq {
                    self.last = Some((sample.seq, last_time));
                }
            }
            return SeqCheck::BadValue;
        }
        let verdict = match self.last {
            None => SeqCheck::Accepted { lost: 0 },
            Some((last_seq, _)) if sample.seq == 0 && last_seq > 0 => SeqCheck::NewRun,
            Some((last_seq, last_time)) => {
                if sample.seq <= last_seq || sample.time_s <= last_time {
                    self.out_of_order(sample)
                } else {
                    SeqCheck::Accepted {
                        lost: sample.seq - last_seq - 1,
                    }
                }
            }
        };
        if verdict.is_accepted() {
            self.last = Some((sample.seq, sample.time_s));
            self.behind = None;
            self.claimed_lost = match verdict {
                SeqCheck::Accepted { lost } => lost,
                _ => 0,
            };
        }
        verdict
    }

    /// After a [`SeqCheck::NewRun`]: `Some(n)` if it was a resynchronisation, whose abandoned
    /// sample had claimed `n` samples lost (to be taken back from the counts); `None` for a
    /// genuine new producer run. Reading it clears it.
    pub fn take_abandoned(&mut self) -> Option<u64> {
        self.abandoned.take()
    }

    /// A sample behind the last accepted one: rejected, unless it completes a run of
    /// `RESYNC_AFTER` that follow each other, which restarts the stream from it.
    fn out_of_order(&mut self, sample: &MotionSample) -> SeqCheck {
        let run = match self.behind {
            Some((seq, time, n)) if sample.seq > seq && sample.time_s > time => n + 1,
            _ => 1,
        };
        self.behind = Some((sample.seq, sample.time_s, run));
        if run >= RESYNC_AFTER {
            self.abandoned = Some(self.claimed_lost);
            tracing::warn!(
                seq = sample.seq,
                time_s = sample.time_s,
                "{RESYNC_AFTER} samples in order among themselves fell behind the last accepted one: the stream restarts from them"
            );
            SeqCheck::NewRun
        } else {
            SeqCheck::OutOfOrder
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shipcast_wire::payload::MAX_ABS_MOTION;

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
        assert_eq!(feed(nan), SeqCheck::BadValue);
        // A finite value no ship's motion can have: refused the same way.
        let mut absurd = s(5, 0.625);
        absurd.dof[2] = 1e200;
        assert_eq!(feed(absurd), SeqCheck::BadValue);
        let mut edge = s(5, 0.625);
        edge.dof[3] = -MAX_ABS_MOTION;
        edge.seq = 6;
        edge.time_s = 0.75;
        // The rejected seq 5 arrived: it is counted as rejected, not again as lost. A value
        // at the bound is still a value.
        assert_eq!(feed(edge), SeqCheck::Accepted { lost: 0 });
        assert_eq!(feed(s(0, 0.0)), SeqCheck::NewRun);
        assert_eq!(feed(s(1, 0.125)), SeqCheck::Accepted { lost: 0 });
        assert_eq!(
            c,
            Counters {
                received: 11,
                lost: 2,
                rejected_nonfinite: 2,
                rejected_order: 3,
                rejected_source: 0,
                published: 0,
                restarts: 1,
                rate_mismatches: 0,
            }
        );
        assert!(c.summary().contains("lost 2"));
    }

    #[test]
    fn a_sample_far_ahead_is_followed_by_a_restart_not_by_rejecting_the_stream() {
        // Regression: one sample with a seq and time far ahead was accepted, and every genuine
        // sample after it was rejected as out of order until the producer restarted at seq 0.
        let mut t = SeqTracker::new();
        for i in 0..10 {
            assert!(t.check(&s(i, i as f64 * 0.125)).is_accepted());
        }
        assert!(t.check(&s(1 << 40, 1e9)).is_accepted());
        assert_eq!(t.take_abandoned(), None);
        for i in 10..10 + u64::from(RESYNC_AFTER) - 1 {
            assert_eq!(
                t.check(&s(i, i as f64 * 0.125)),
                SeqCheck::OutOfOrder,
                "{i}"
            );
        }
        let i = 10 + u64::from(RESYNC_AFTER) - 1;
        assert_eq!(t.check(&s(i, i as f64 * 0.125)), SeqCheck::NewRun);
        // The far sample's seq gap was never lost data: it is handed back once.
        assert_eq!(t.take_abandoned(), Some((1 << 40) - 10));
        assert_eq!(t.take_abandoned(), None);
        assert_eq!(
            t.check(&s(i + 1, (i + 1) as f64 * 0.125)),
            SeqCheck::Accepted { lost: 0 }
        );
        // Late or repeated samples do not add up to a restart: they do not follow each other.
        for _ in 0..3 * RESYNC_AFTER {
            assert_eq!(t.check(&s(i, i as f64 * 0.125)), SeqCheck::OutOfOrder);
            assert_eq!(
                t.check(&s(i - 5, (i - 5) as f64 * 0.125)),
                SeqCheck::OutOfOrder
            );
        }
    }
}
