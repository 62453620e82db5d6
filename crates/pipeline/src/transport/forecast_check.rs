//! What a consumer checks before it acts on a forecast: it comes from the live predictor, its
//! seq moves forward, and it passes the payload's own checks. These checks hold even where
//! access control is off, but without access control a determined sender can imitate the
//! predictor's id; they stop accidents and naive injection, the ACL stops the rest
//! (docs/security.md).

use crate::transport::zenoh::{publisher_token, Received, ZenohError};
use shipcast_wire::payload::{Forecast, PayloadError};
use std::collections::BTreeSet;
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::Subscriber;
use zenoh::sample::{Sample, SampleKind};
use zenoh::{Session, Wait};

/// Why a forecast was rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum Rejection {
    #[error("forecast without a publisher id (not from a shipcast publisher)")]
    NoPublisherId,
    #[error("forecast from publisher {got}, which is not the live predictor ({live})")]
    NotLivePublisher { got: String, live: String },
    #[error(
        "forecast while {0} publishers are alive on the key; cannot tell which is the predictor"
    )]
    SeveralPublishers(usize),
    #[error("forecast seq {seq} does not follow the last accepted {last}")]
    SeqNotIncreasing { seq: u64, last: u64 },
    #[error("{0}")]
    Payload(String),
}

impl From<PayloadError> for Rejection {
    fn from(e: PayloadError) -> Self {
        Rejection::Payload(e.to_string())
    }
}

/// Rejection counts by reason, for the consumer's closing log line.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct RejectionCounts {
    pub source: u64,
    pub seq: u64,
    pub payload: u64,
}

impl RejectionCounts {
    pub fn total(&self) -> u64 {
        self.source + self.seq + self.payload
    }
}

/// Checks of a forecast's content that do not depend on who sent it.
pub fn check_content(f: &Forecast, expected_dt_s: f64) -> Result<(), Rejection> {
    let bad = |m: String| Err(Rejection::Payload(format!("forecast JSON: {m}")));
    if f.steps == 0 {
        return bad("steps is 0".into());
    }
    if !f.time_s.is_finite() {
        return bad(format!("time_s {} is not finite", f.time_s));
    }
    if !(f.dt_s.is_finite() && (f.dt_s - expected_dt_s).abs() <= 1e-9 * expected_dt_s.abs()) {
        return bad(format!(
            "dt_s {} differs from the predictor's {expected_dt_s}",
            f.dt_s
        ));
    }
    let steps = f.valid_steps();
    for d in 0..shipcast_wire::payload::NUM_DOF {
        let mean = &f.mean[d][..steps];
        let sigma = &f.sigma[d][..steps];
        if let Some(k) = mean.iter().position(|v| !v.is_finite()) {
            return bad(format!("mean of DOF {d} step {k} is not finite"));
        }
        if let Some(k) = sigma.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            return bad(format!(
                "sigma of DOF {d} step {k} is not a finite non-negative number"
            ));
        }
    }
    Ok(())
}

/// The publishers of one key that are alive now, from their liveliness tokens.
#[derive(Debug, Default, Clone)]
pub struct LivePublishers {
    zids: BTreeSet<String>,
}

impl LivePublishers {
    pub fn appeared(&mut self, zid: &str) {
        self.zids.insert(zid.to_string());
    }

    pub fn vanished(&mut self, zid: &str) {
        self.zids.remove(zid);
    }

    /// The one live publisher, or why there is not exactly one.
    fn the_one(&self) -> Result<&str, usize> {
        let mut it = self.zids.iter();
        match (it.next(), it.next()) {
            (Some(z), None) => Ok(z),
            _ => Err(self.zids.len()),
        }
    }
}

/// Accepts forecasts from the one live predictor, with increasing seq, that pass the content
/// checks; counts what it rejects by reason.
#[derive(Debug)]
pub struct ForecastGate {
    expected_dt_s: f64,
    pub live: LivePublishers,
    /// Publisher and seq of the last accepted forecast.
    last: Option<(String, u64)>,
    pub rejected: RejectionCounts,
    pub accepted: u64,
}

impl ForecastGate {
    pub fn new(expected_dt_s: f64) -> Self {
        Self {
            expected_dt_s,
            live: LivePublishers::default(),
            last: None,
            rejected: RejectionCounts::default(),
            accepted: 0,
        }
    }

    /// Parse and check one received payload.
    pub fn check(&mut self, received: &Received) -> Result<Forecast, Rejection> {
        let result = self.check_uncounted(received);
        match &result {
            Ok(_) => self.accepted += 1,
            Err(
                Rejection::NoPublisherId
                | Rejection::NotLivePublisher { .. }
                | Rejection::SeveralPublishers(_),
            ) => self.rejected.source += 1,
            Err(Rejection::SeqNotIncreasing { .. }) => self.rejected.seq += 1,
            Err(Rejection::Payload(_)) => self.rejected.payload += 1,
        }
        result
    }

    fn check_uncounted(&mut self, received: &Received) -> Result<Forecast, Rejection> {
        let Some(publisher) = received.publisher.as_deref() else {
            return Err(Rejection::NoPublisherId);
        };
        let live = match self.live.the_one() {
            Ok(z) => z,
            Err(0) => {
                return Err(Rejection::NotLivePublisher {
                    got: publisher.to_string(),
                    live: "none".into(),
                })
            }
            Err(n) => return Err(Rejection::SeveralPublishers(n)),
        };
        if publisher != live {
            return Err(Rejection::NotLivePublisher {
                got: publisher.to_string(),
                live: live.to_string(),
            });
        }
        let forecast = Forecast::from_json(&received.payload)?;
        check_content(&forecast, self.expected_dt_s)?;
        // seq restarts with a new predictor; it must increase within one publisher's stream.
        if let Some((last_publisher, last_seq)) = &self.last {
            if last_publisher == publisher && forecast.seq <= *last_seq {
                return Err(Rejection::SeqNotIncreasing {
                    seq: forecast.seq,
                    last: *last_seq,
                });
            }
        }
        self.last = Some((publisher.to_string(), forecast.seq));
        Ok(forecast)
    }
}

/// Follows the publisher tokens of one key (`JsonPublisher` declares them).
pub struct PublisherWatch {
    prefix: String,
    subscriber: Subscriber<FifoChannelHandler<Sample>>,
}

impl PublisherWatch {
    pub fn new(session: &Session, key: &str) -> Result<Self, ZenohError> {
        let prefix = publisher_token(key, "");
        let subscriber = session
            .liveliness()
            .declare_subscriber(format!("{prefix}*"))
            .history(true)
            .wait()
            .map_err(|e| ZenohError {
                context: format!("watch publishers of '{key}'"),
                detail: e.to_string(),
            })?;
        Ok(Self { prefix, subscriber })
    }

    /// Apply the token changes since the last call to `live`; returns how many there were.
    pub fn update(&self, live: &mut LivePublishers) -> usize {
        let mut changes = 0;
        while let Ok(Some(s)) = self.subscriber.try_recv() {
            let key = s.key_expr().as_str();
            let Some(zid) = key.strip_prefix(&self.prefix) else {
                continue;
            };
            match s.kind() {
                SampleKind::Put => live.appeared(zid),
                SampleKind::Delete => live.vanished(zid),
            }
            changes += 1;
        }
        changes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn forecast(seq: u64) -> Forecast {
        let mut f = Forecast {
            seq,
            time_s: 100.0,
            dt_s: 0.5,
            steps: 4,
            ..Forecast::default()
        };
        f.sigma[2][..4].copy_from_slice(&[0.1, 0.2, 0.3, 0.4]);
        f
    }

    fn received(f: &Forecast, publisher: Option<&str>) -> Received {
        let mut payload = Vec::new();
        f.write_json(&mut payload).unwrap();
        Received {
            payload,
            publisher: publisher.map(str::to_string),
        }
    }

    #[test]
    fn only_the_live_publisher_with_increasing_seq_is_accepted() {
        let mut gate = ForecastGate::new(0.5);
        gate.live.appeared("aaa");
        assert_eq!(
            gate.check(&received(&forecast(5), Some("aaa")))
                .unwrap()
                .seq,
            5
        );
        assert!(gate.check(&received(&forecast(6), Some("aaa"))).is_ok());
        // The injection of issue 14: another publisher, then repeats of one high seq.
        assert_eq!(
            gate.check(&received(&forecast(987654321), Some("bbb"))),
            Err(Rejection::NotLivePublisher {
                got: "bbb".into(),
                live: "aaa".into()
            })
        );
        assert_eq!(
            gate.check(&received(&forecast(7), None)),
            Err(Rejection::NoPublisherId)
        );
        assert_eq!(
            gate.check(&received(&forecast(6), Some("aaa"))),
            Err(Rejection::SeqNotIncreasing { seq: 6, last: 6 })
        );
        assert_eq!(
            gate.check(&received(&forecast(2), Some("aaa"))),
            Err(Rejection::SeqNotIncreasing { seq: 2, last: 6 })
        );
        assert!(gate.check(&received(&forecast(7), Some("aaa"))).is_ok());
        assert_eq!(gate.accepted, 3);
        assert_eq!(
            gate.rejected,
            RejectionCounts {
                source: 2,
                seq: 2,
                payload: 0
            }
        );
    }

    #[test]
    fn a_restarted_predictor_starts_its_seq_again() {
        let mut gate = ForecastGate::new(0.5);
        gate.live.appeared("old");
        assert!(gate.check(&received(&forecast(900), Some("old"))).is_ok());
        gate.live.vanished("old");
        assert!(matches!(
            gate.check(&received(&forecast(901), Some("old"))),
            Err(Rejection::NotLivePublisher { .. })
        ));
        gate.live.appeared("new");
        assert!(gate.check(&received(&forecast(0), Some("new"))).is_ok());
    }

    #[test]
    fn two_live_publishers_reject_everything() {
        let mut gate = ForecastGate::new(0.5);
        gate.live.appeared("aaa");
        gate.live.appeared("bbb");
        assert_eq!(
            gate.check(&received(&forecast(1), Some("aaa"))),
            Err(Rejection::SeveralPublishers(2))
        );
    }

    #[test]
    fn content_checks_reject_bad_payloads() {
        let mut gate = ForecastGate::new(0.5);
        gate.live.appeared("aaa");
        let mut wrong_dt = forecast(1);
        wrong_dt.dt_s = 0.25;
        let mut infinite = forecast(2);
        infinite.mean[2][1] = f32::INFINITY;
        let mut negative_sigma = forecast(3);
        negative_sigma.sigma[0][0] = -1.0;
        for f in [wrong_dt, negative_sigma] {
            let r = gate.check(&received(&f, Some("aaa")));
            assert!(matches!(r, Err(Rejection::Payload(_))), "{r:?}");
        }
        // JSON cannot carry infinity: serde writes null, which fails to parse.
        let r = gate.check(&received(&infinite, Some("aaa")));
        assert!(matches!(r, Err(Rejection::Payload(_))), "{r:?}");
        // A value beyond f32 range is refused by the parser, not turned into infinity.
        let text = String::from_utf8(received(&forecast(4), Some("aaa")).payload).unwrap();
        let huge = text.replacen("\"mean\":[[0.0", "\"mean\":[[1e39", 1);
        assert_ne!(huge, text);
        let r = gate.check(&Received {
            payload: huge.into_bytes(),
            publisher: Some("aaa".into()),
        });
        assert!(
            matches!(r, Err(Rejection::Payload(ref m)) if m.contains("out of range")),
            "{r:?}"
        );
        // Non-finite values arrive only through a binary path (iceoryx2); the content check
        // catches them there.
        assert!(matches!(
            check_content(&infinite, 0.5),
            Err(Rejection::Payload(ref m)) if m.contains("mean of DOF 2 step 1 is not finite")
        ));
        // steps above the maximum.
        let text = String::from_utf8(received(&forecast(5), Some("aaa")).payload).unwrap();
        let many = text.replacen("\"steps\":4", "\"steps\":129", 1);
        let r = gate.check(&Received {
            payload: many.into_bytes(),
            publisher: Some("aaa".into()),
        });
        assert!(
            matches!(r, Err(Rejection::Payload(ref m)) if m.contains("129")),
            "{r:?}"
        );
        assert_eq!(gate.rejected.payload, 5);
        assert_eq!(gate.accepted, 0);
    }
}
