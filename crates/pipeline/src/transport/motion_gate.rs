//! What a remote consumer checks before it verifies anything against a vessel's observed
//! motion (zenoh `.../motion`, published by that vessel's predictor): it comes from the one
//! live publisher of the key, its seq and record time move forward within the producer run
//! ([`MotionHistory`] judges that, and starts afresh on a new run or a new publisher), and
//! every value is a finite number. As with forecasts (`forecast_check`), these checks stop
//! accidents and naive injection; access control stops a sender that imitates the publisher.

use crate::observed::MotionHistory;
use crate::transport::counters::{SeqCheck, SeqTracker};
use crate::transport::forecast_check::{check_source, LivePublishers, Rejection};
use crate::transport::zenoh::Received;
use shipcast_wire::payload::MotionSample;

/// Why a motion sample was rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MotionRejection {
    #[error("{0}")]
    Source(Rejection),
    #[error("motion JSON: {0}")]
    Json(String),
    #[error("motion seq {seq} at {time_s} s does not follow the last accepted sample of this run")]
    NotForward { seq: u64, time_s: f64 },
}

/// What an accepted sample did to the history.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Admitted {
    /// It continues the record kept so far.
    Continues,
    /// It starts a new record: the vessel's producer started a new run (seq 0 after a run),
    /// or another predictor took over the key. What was kept is forgotten, and anything
    /// waiting to be verified on the old record's clock must be dropped.
    Restarted,
}

/// Accepts motion samples from the one live publisher of a `.../motion` key into that
/// vessel's [`MotionHistory`]; counts what it accepts and rejects.
#[derive(Debug, Default)]
pub struct MotionGate {
    pub live: LivePublishers,
    /// Publisher of the last accepted sample.
    last_publisher: Option<String>,
    pub accepted: u64,
    pub rejected: u64,
    /// Lines logged about rejections; every one is counted in `rejected`.
    pub log: crate::transport::log_throttle::LogThrottle,
}

impl MotionGate {
    pub fn new() -> Self {
        Self::default()
    }

    /// Parse and check one received payload and, if it is accepted, keep it in `history`.
    pub fn check(
        &mut self,
        received: &Received,
        history: &mut MotionHistory,
    ) -> Result<Admitted, MotionRejection> {
        let result = self.check_uncounted(received, history);
        match result {
            Ok(_) => self.accepted += 1,
            Err(_) => self.rejected += 1,
        }
        result
    }

    fn check_uncounted(
        &mut self,
        received: &Received,
        history: &mut MotionHistory,
    ) -> Result<Admitted, MotionRejection> {
        let publisher = check_source(&self.live, received).map_err(MotionRejection::Source)?;
        let sample = MotionSample::from_json(&received.payload)
            .map_err(|e| MotionRejection::Json(e.to_string()))?;
        // Every value is finite here: JSON has no NaN or infinity, and serde_json refuses a
        // number beyond f64's range (1e999) as malformed.
        let not_forward = || MotionRejection::NotForward {
            seq: sample.seq,
            time_s: sample.time_s,
        };
        let mut admitted = Admitted::Continues;
        if self.last_publisher.as_ref() != Some(publisher) {
            // A restarted predictor is a new publisher: its stream may start anywhere. The
            // sample is judged as the first of a fresh record before the kept one is given up
            // for it, so a sample that the new record would refuse leaves the history alone.
            if !SeqTracker::new().check(&sample).is_accepted() {
                return Err(not_forward());
            }
            if self.last_publisher.is_some() {
                admitted = Admitted::Restarted;
            }
            history.clear();
            self.last_publisher = Some(publisher.clone());
        }
        match history.push(&sample) {
            SeqCheck::Accepted { .. } => Ok(admitted),
            SeqCheck::NewRun => Ok(Admitted::Restarted),
            SeqCheck::BadValue | SeqCheck::OutOfOrder => Err(not_forward()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observed::ObservedMotion;
    use shipcast_wire::payload_json::MotionJsonEncoder;

    fn sent(by: Option<&str>, seq: u64, time_s: f64, heave: f64) -> Received {
        let m = MotionSample {
            seq,
            stamp_ns: 0,
            time_s,
            dof: [0.0, 0.0, heave, 0.0, 0.0, 0.0],
        };
        Received {
            payload: MotionJsonEncoder::new().encode_shared(&m).unwrap().to_vec(),
            publisher: by.map(str::to_string),
        }
    }

    #[test]
    fn only_the_live_publisher_moving_forward_is_accepted() {
        let mut gate = MotionGate::new();
        let mut h = MotionHistory::new(8.0, 60.0);
        // Nobody alive yet: even a well-formed sample is refused.
        assert!(matches!(
            gate.check(&sent(Some("a"), 1, 0.125, 0.5), &mut h),
            Err(MotionRejection::Source(Rejection::NotLivePublisher { .. }))
        ));
        gate.live.appeared("a");
        assert_eq!(
            gate.check(&sent(Some("a"), 1, 0.125, 0.5), &mut h),
            Ok(Admitted::Continues)
        );
        assert_eq!(h.dof_at(0.125).map(|d| d[2]), Some(0.5));
        assert!(gate.check(&sent(Some("a"), 2, 0.25, 0.4), &mut h).is_ok());
        // A replayed or reordered sample, and one whose time goes back, are refused.
        for (seq, t) in [(2, 0.375), (3, 0.25)] {
            assert!(
                matches!(
                    gate.check(&sent(Some("a"), seq, t, 0.0), &mut h),
                    Err(MotionRejection::NotForward { .. })
                ),
                "{seq} {t}"
            );
        }
        // A forger without the publisher's id, or without any, is refused.
        assert!(gate.check(&sent(Some("b"), 9, 9.0, 0.0), &mut h).is_err());
        assert_eq!(
            gate.check(&sent(None, 9, 9.0, 0.0), &mut h),
            Err(MotionRejection::Source(Rejection::NoPublisherId))
        );
        // Malformed and non-finite content from the live publisher.
        let mut bad = sent(Some("a"), 5, 1.0, 0.0);
        bad.payload.truncate(10);
        assert!(matches!(
            gate.check(&bad, &mut h),
            Err(MotionRejection::Json(_))
        ));
        let mut huge = sent(Some("a"), 5, 1.0, 0.0);
        huge.payload = br#"{"seq":5,"stamp_ns":0,"time_s":1.0,"dof":[0,0,1e999,0,0,0]}"#.to_vec();
        assert!(matches!(
            gate.check(&huge, &mut h),
            Err(MotionRejection::Json(_))
        ));
        assert_eq!((gate.accepted, gate.rejected), (2, 7));
        // Nothing refused reached the history.
        assert_eq!((h.len(), h.newest_s()), (2, Some(0.25)));
    }

    /// Regression: the producer restarted under a running predictor, which republishes its
    /// samples under the same zenoh id from seq 0 and time 0. The gate used to refuse them
    /// until seq and time passed the old run's, and live verification stopped.
    #[test]
    fn a_new_run_or_a_new_predictor_starts_the_record_afresh() {
        let mut gate = MotionGate::new();
        let mut h = MotionHistory::new(8.0, 60.0);
        gate.live.appeared("a");
        for i in 1..100 {
            let t = i as f64 / 8.0;
            assert_eq!(
                gate.check(&sent(Some("a"), i, t, 1.0), &mut h),
                Ok(Admitted::Continues)
            );
        }
        assert_eq!(
            gate.check(&sent(Some("a"), 0, 0.0, 2.0), &mut h),
            Ok(Admitted::Restarted)
        );
        assert_eq!(
            gate.check(&sent(Some("a"), 1, 0.125, 2.0), &mut h),
            Ok(Admitted::Continues)
        );
        assert_eq!(h.len(), 2);
        assert_eq!(h.dof_at(0.125).map(|d| d[2]), Some(2.0));
        assert_eq!(h.dof_at(10.0), None);
        // The predictor restarts under a new id, its producer already some way into a run.
        gate.live.vanished("a");
        gate.live.appeared("c");
        assert_eq!(
            gate.check(&sent(Some("c"), 40, 5.0, 3.0), &mut h),
            Ok(Admitted::Restarted)
        );
        assert_eq!((h.len(), h.dof_at(5.0).map(|d| d[2])), (1, Some(3.0)));
        assert_eq!(gate.rejected, 0);
    }
}
