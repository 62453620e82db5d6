//! What a remote consumer checks before it verifies anything against a vessel's observed
//! motion (zenoh `.../motion`, published by that vessel's predictor): it comes from the one
//! live publisher of the key, its seq and record time move forward within that publisher's
//! stream, and every value is a finite number. As with forecasts (`forecast_check`), these checks stop
//! accidents and naive injection; access control stops a sender that imitates the publisher.

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
    #[error("motion seq {seq} at {time_s} s does not follow the last accepted {last} at {last_time_s} s")]
    NotForward {
        seq: u64,
        time_s: f64,
        last: u64,
        last_time_s: f64,
    },
}

/// Accepts motion samples from the one live publisher of a `.../motion` key; counts what it
/// accepts and rejects.
#[derive(Debug, Default)]
pub struct MotionGate {
    pub live: LivePublishers,
    /// Publisher, seq and record time of the last accepted sample.
    last: Option<(String, u64, f64)>,
    pub accepted: u64,
    pub rejected: u64,
}

impl MotionGate {
    pub fn new() -> Self {
        Self::default()
    }

    /// Parse and check one received payload.
    pub fn check(&mut self, received: &Received) -> Result<MotionSample, MotionRejection> {
        let result = self.check_uncounted(received);
        match result {
            Ok(_) => self.accepted += 1,
            Err(_) => self.rejected += 1,
        }
        result
    }

    fn check_uncounted(&mut self, received: &Received) -> Result<MotionSample, MotionRejection> {
        let publisher = check_source(&self.live, received).map_err(MotionRejection::Source)?;
        let sample = MotionSample::from_json(&received.payload)
            .map_err(|e| MotionRejection::Json(e.to_string()))?;
        // Every value is finite here: JSON has no NaN or infinity, and serde_json refuses a
        // number beyond f64's range (1e999) as malformed.
        match &mut self.last {
            // A restarted predictor is a new publisher: its seq and record time start over.
            Some((p, seq, time_s)) if p == publisher => {
                if sample.seq <= *seq || sample.time_s <= *time_s {
                    return Err(MotionRejection::NotForward {
                        seq: sample.seq,
                        time_s: sample.time_s,
                        last: *seq,
                        last_time_s: *time_s,
                    });
                }
                (*seq, *time_s) = (sample.seq, sample.time_s);
            }
            last => *last = Some((publisher.clone(), sample.seq, sample.time_s)),
        }
        Ok(sample)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
        // Nobody alive yet: even a well-formed sample is refused.
        assert!(matches!(
            gate.check(&sent(Some("a"), 1, 0.125, 0.5)),
            Err(MotionRejection::Source(Rejection::NotLivePublisher { .. }))
        ));
        gate.live.appeared("a");
        assert_eq!(
            gate.check(&sent(Some("a"), 1, 0.125, 0.5)).unwrap().dof[2],
            0.5
        );
        assert_eq!(gate.check(&sent(Some("a"), 2, 0.25, 0.4)).unwrap().seq, 2);
        // A replayed or reordered sample, and one whose time goes back, are refused.
        for (seq, t) in [(2, 0.375), (3, 0.25)] {
            assert!(
                matches!(
                    gate.check(&sent(Some("a"), seq, t, 0.0)),
                    Err(MotionRejection::NotForward { .. })
                ),
                "{seq} {t}"
            );
        }
        // A forger without the publisher's id, or without any, is refused.
        assert!(gate.check(&sent(Some("b"), 9, 9.0, 0.0)).is_err());
        assert_eq!(
            gate.check(&sent(None, 9, 9.0, 0.0)),
            Err(MotionRejection::Source(Rejection::NoPublisherId))
        );
        // Malformed and non-finite content from the live publisher.
        let mut bad = sent(Some("a"), 5, 1.0, 0.0);
        bad.payload.truncate(10);
        assert!(matches!(gate.check(&bad), Err(MotionRejection::Json(_))));
        let mut huge = sent(Some("a"), 5, 1.0, 0.0);
        huge.payload = br#"{"seq":5,"stamp_ns":0,"time_s":1.0,"dof":[0,0,1e999,0,0,0]}"#.to_vec();
        assert!(matches!(gate.check(&huge), Err(MotionRejection::Json(_))));
        assert_eq!((gate.accepted, gate.rejected), (2, 7));
        // The predictor restarts under a new id: its stream starts over.
        gate.live.vanished("a");
        gate.live.appeared("c");
        assert!(gate.check(&sent(Some("c"), 0, 0.125, 0.1)).is_ok());
    }
}
