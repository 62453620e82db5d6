//! What a consumer checks before it acts on a forecast: it comes from the live predictor, its
//! seq moves forward, and it passes the payload's own checks. These checks hold even where
//! access control is off, but without access control a determined sender can imitate the
//! predictor's id; they stop accidents and naive injection, the ACL stops the rest
//! (docs/security.md).

use crate::transport::log_throttle::LogThrottle;
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
    // The three source reasons name no payload: motion samples share them (`motion_gate`).
    #[error("sent without a publisher id (not from a shipcast publisher)")]
    NoPublisherId,
    // Forecasts and motion samples share it: "publisher", not "predictor" (review).
    #[error("sent by publisher {got}, which is not the live publisher of its key ({live})")]
    NotLivePublisher { got: String, live: String },
    #[error("sent while {0} publishers are alive on the key; cannot tell which is the predictor")]
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

/// Rejection counts by reason, for the consumer's closing log line and status.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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

/// The largest magnitude of a mean or sigma a forecast may carry (m or rad). No ship's motion
/// comes near it; it keeps a forged value that f32 still holds (3e38) from overflowing a
/// consumer's arithmetic. Regression (review): a roll of 3e38 rad became infinity in degrees
/// on the display, was sent as null and drawn as a calm 0.
pub const MAX_ABS_VALUE: f32 = 1.0e6;

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
        let beyond = |v: &f32| v.abs() > MAX_ABS_VALUE;
        if let Some(k) = mean.iter().chain(sigma).position(beyond) {
            let (what, k) = if k < steps {
                ("mean", k)
            } else {
                ("sigma", k - steps)
            };
            return bad(format!(
                "{what} of DOF {d} step {k} is beyond {MAX_ABS_VALUE:e}, no ship's motion"
            ));
        }
    }
    Ok(())
}

/// A zenoh id as publishers attach it to their puts and name it in their tokens: 1 to 32
/// lowercase hex digits. Anything else is no id: it came from a peer that is not ours, and its
/// text, of any length and with newlines, was echoed into the warnings (review: forged log
/// lines and 300 MB of log in 3 s).
pub fn is_publisher_id(text: &str) -> bool {
    (1..=32).contains(&text.len())
        && text
            .bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
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

    /// True when no publisher of the key is alive.
    pub fn is_empty(&self) -> bool {
        self.zids.is_empty()
    }

    /// How many publishers of the key are alive.
    pub fn len(&self) -> usize {
        self.zids.len()
    }

    pub fn contains(&self, zid: &str) -> bool {
        self.zids.contains(zid)
    }

    /// The one live publisher, or why there is not exactly one.
    fn the_one(&self) -> Result<&str, usize> {
        let mut it = self.zids.iter();
        match (it.next(), it.next()) {
            (Some(z), None) => Ok(z),
            _ => Err(self.zids.len()),
        }
    }

    /// Ok if `publisher` (the id a payload carried, if any) is the one live publisher.
    pub fn admits(&self, publisher: Option<&str>) -> Result<(), Rejection> {
        let Some(publisher) = publisher else {
            return Err(Rejection::NoPublisherId);
        };
        match self.the_one() {
            Ok(z) if z == publisher => Ok(()),
            Ok(z) => Err(Rejection::NotLivePublisher {
                got: publisher.to_string(),
                live: z.to_string(),
            }),
            Err(0) => Err(Rejection::NotLivePublisher {
                got: publisher.to_string(),
                live: "none".into(),
            }),
            Err(n) => Err(Rejection::SeveralPublishers(n)),
        }
    }
}

/// The checks every consumer makes whatever its transport: the payload's own checks, and seq
/// moving forward within one publisher's stream (`P` names the publisher as the transport
/// does); counts what it accepts and rejects.
#[derive(Debug)]
pub struct StreamChecks<P> {
    expected_dt_s: f64,
    /// Publisher and seq of the last accepted forecast.
    last: Option<(P, u64)>,
    pub rejected: RejectionCounts,
    pub accepted: u64,
    /// Lines logged about rejections ([`LogThrottle`]); every one is counted in `rejected`.
    pub log: LogThrottle,
}

impl<P: PartialEq + Clone> StreamChecks<P> {
    pub fn new(expected_dt_s: f64) -> Self {
        Self {
            expected_dt_s,
            last: None,
            rejected: RejectionCounts::default(),
            accepted: 0,
            log: LogThrottle::default(),
        }
    }

    /// Content and seq of a forecast from `publisher`, whose source the caller has checked.
    fn follows(&mut self, publisher: &P, forecast: &Forecast) -> Result<(), Rejection> {
        check_content(forecast, self.expected_dt_s)?;
        // seq restarts with a new predictor; it must increase within one publisher's stream.
        match &mut self.last {
            Some((last_publisher, last_seq)) if last_publisher == publisher => {
                if forecast.seq <= *last_seq {
                    return Err(Rejection::SeqNotIncreasing {
                        seq: forecast.seq,
                        last: *last_seq,
                    });
                }
                *last_seq = forecast.seq;
            }
            last => *last = Some((publisher.clone(), forecast.seq)),
        }
        Ok(())
    }

    /// Count the outcome of one check and pass it on.
    fn count<T>(&mut self, result: Result<T, Rejection>) -> Result<T, Rejection> {
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
}

/// Accepts forecasts received over zenoh from the one live predictor (its publisher token),
/// with increasing seq, that pass the content checks; counts what it rejects by reason.
#[derive(Debug)]
pub struct ForecastGate {
    pub live: LivePublishers,
    pub stream: StreamChecks<String>,
}

impl ForecastGate {
    pub fn new(expected_dt_s: f64) -> Self {
        Self {
            live: LivePublishers::default(),
            stream: StreamChecks::new(expected_dt_s),
        }
    }

    /// Parse and check one received payload.
    pub fn check(&mut self, received: &Received) -> Result<Forecast, Rejection> {
        let result = self.check_uncounted(received);
        self.stream.count(result)
    }

    fn check_uncounted(&mut self, received: &Received) -> Result<Forecast, Rejection> {
        let publisher = check_source(&self.live, received)?;
        let forecast = Forecast::from_json(&received.payload)?;
        self.stream.follows(publisher, &forecast)?;
        Ok(forecast)
    }
}

/// The publisher id of `received` if it is the one live publisher of its key.
pub fn check_source<'a>(
    live: &LivePublishers,
    received: &'a Received,
) -> Result<&'a String, Rejection> {
    live.admits(received.publisher.as_deref())?;
    // admits refuses a payload without an id, so there is one here.
    received.publisher.as_ref().ok_or(Rejection::NoPublisherId)
}

/// The iceoryx2 publisher port a consumer follows. The sender is the port that iceoryx2 itself
/// records in each sample, which a sender cannot choose. The followed port is the one the
/// consumer has been following for as long as it stays connected; when it goes and exactly
/// one port is connected, that one is followed. Samples of any other port are refused, so a
/// second publisher on the service cannot interrupt the stream. The deck follows the
/// predictor's forecasts and the producer's motion this way.
#[derive(Debug, Default)]
pub struct IoxFollowedPort {
    followed: Option<u128>,
}

impl IoxFollowedPort {
    /// True if `origin` is the port followed now: a sample from it is admitted without asking
    /// iceoryx2 which ports are connected (the hot path of the predictor's input).
    #[inline]
    pub fn is_followed(&self, origin: u128) -> bool {
        self.followed == Some(origin)
    }

    /// [`admit`](Self::admit), asking for the connected ports (`list` fills `connected`) only
    /// when `origin` is not the port followed now.
    pub fn admit_listing(
        &mut self,
        origin: u128,
        connected: &mut Vec<u128>,
        list: impl FnOnce(&mut Vec<u128>),
    ) -> Result<(), Rejection> {
        if self.is_followed(origin) {
            return Ok(());
        }
        list(connected);
        self.admit(origin, connected)
    }

    /// Is `origin` the followed port, while `connected` are the service's publishers?
    pub fn admit(&mut self, origin: u128, connected: &[u128]) -> Result<(), Rejection> {
        if self.followed.is_some_and(|f| !connected.contains(&f)) {
            self.followed = None;
        }
        let followed = match (self.followed, connected) {
            (Some(f), _) => f,
            (None, [only]) => *self.followed.insert(*only),
            (None, []) => {
                return Err(Rejection::NotLivePublisher {
                    got: format!("{origin:032x}"),
                    live: "none".into(),
                })
            }
            (None, several) => return Err(Rejection::SeveralPublishers(several.len())),
        };
        if origin != followed {
            return Err(Rejection::NotLivePublisher {
                got: format!("{origin:032x}"),
                live: format!("{followed:032x}"),
            });
        }
        Ok(())
    }
}

/// Accepts forecasts received over iceoryx2 (the deck) from the followed publisher port
/// ([`IoxFollowedPort`]), with increasing seq, that pass the content checks.
#[derive(Debug)]
pub struct IoxForecastGate {
    port: IoxFollowedPort,
    pub stream: StreamChecks<u128>,
}

impl IoxForecastGate {
    pub fn new(expected_dt_s: f64) -> Self {
        Self {
            port: IoxFollowedPort::default(),
            stream: StreamChecks::new(expected_dt_s),
        }
    }

    /// Check `forecast` sent by publisher `origin` while `connected` are the publishers of
    /// the service.
    pub fn check(
        &mut self,
        origin: u128,
        connected: &[u128],
        forecast: &Forecast,
    ) -> Result<(), Rejection> {
        let result = self
            .port
            .admit(origin, connected)
            .and_then(|()| self.stream.follows(&origin, forecast));
        self.stream.count(result)
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
            .map_err(ZenohError::on(format!("watch publishers of '{key}'")))?;
        Ok(Self { prefix, subscriber })
    }

    /// Apply the token changes since the last call to `live`; returns how many there were.
    pub fn update(&self, live: &mut LivePublishers) -> usize {
        let mut changes = 0;
        while let Ok(Some(s)) = self.subscriber.try_recv() {
            let key = s.key_expr().as_str();
            let Some(zid) = key
                .strip_prefix(&self.prefix)
                .filter(|z| is_publisher_id(z))
            else {
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
        assert_eq!(gate.stream.accepted, 3);
        assert_eq!(
            gate.stream.rejected,
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
        // Finite in f32 but beyond any motion: a consumer's degrees would overflow.
        let mut huge_roll = forecast(6);
        huge_roll.mean[3][2] = 3e38;
        let mut huge_sigma = forecast(7);
        huge_sigma.sigma[1][0] = 2.0e6;
        let mut largest = forecast(8);
        largest.mean[3][2] = -MAX_ABS_VALUE;
        largest.sigma[1][0] = MAX_ABS_VALUE;
        assert!(check_content(&largest, 0.5).is_ok());
        assert!(matches!(
            check_content(&huge_roll, 0.5),
            Err(Rejection::Payload(ref m)) if m.contains("mean of DOF 3 step 2 is beyond")
        ));
        assert!(matches!(
            check_content(&huge_sigma, 0.5),
            Err(Rejection::Payload(ref m)) if m.contains("sigma of DOF 1 step 0 is beyond")
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
        assert_eq!(gate.stream.rejected.payload, 5);
        assert_eq!(gate.stream.accepted, 0);
    }

    #[test]
    fn iceoryx2_gate_follows_its_publisher_and_ignores_a_second_one() {
        let mut gate = IoxForecastGate::new(0.5);
        // Two publishers before any was followed: nobody can tell which is the predictor.
        assert_eq!(
            gate.check(1, &[1, 2], &forecast(1)),
            Err(Rejection::SeveralPublishers(2))
        );
        assert!(gate.check(1, &[1], &forecast(1)).is_ok());
        // A second publisher joins: its samples are rejected, the followed stream goes on.
        assert!(matches!(
            gate.check(2, &[1, 2], &forecast(987654321)),
            Err(Rejection::NotLivePublisher { .. })
        ));
        assert!(gate.check(1, &[1, 2], &forecast(2)).is_ok());
        assert_eq!(
            gate.check(1, &[1, 2], &forecast(2)),
            Err(Rejection::SeqNotIncreasing { seq: 2, last: 2 })
        );
        let mut nan = forecast(3);
        nan.sigma[2][0] = f32::NAN;
        assert!(matches!(
            gate.check(1, &[1, 2], &nan),
            Err(Rejection::Payload(_))
        ));
        // The predictor restarts as publisher 3 while 2 is still there: nothing is followed
        // until one of them is alone.
        assert_eq!(
            gate.check(3, &[2, 3], &forecast(0)),
            Err(Rejection::SeveralPublishers(2))
        );
        assert!(gate.check(3, &[3], &forecast(0)).is_ok());
        // A sample still queued from a publisher that has gone.
        assert!(matches!(
            gate.check(4, &[], &forecast(5)),
            Err(Rejection::NotLivePublisher { ref got, .. }) if got.ends_with('4')
        ));
        assert_eq!(gate.stream.accepted, 3);
        assert_eq!(
            gate.stream.rejected,
            RejectionCounts {
                source: 4,
                seq: 1,
                payload: 1
            }
        );
    }

    #[test]
    fn a_followed_port_is_admitted_without_listing_the_ports_and_another_only_after() {
        let mut port = IoxFollowedPort::default();
        let mut connected = Vec::new();
        let list = |ports: &[u128]| {
            let ports = ports.to_vec();
            move |c: &mut Vec<u128>| {
                c.clear();
                c.extend(ports);
            }
        };
        // Nothing followed yet: the ports are listed, and the one alone is followed.
        assert!(port.admit_listing(7, &mut connected, list(&[7])).is_ok());
        assert!(port.is_followed(7));
        // The followed port again: admitted without asking (this list, empty, would refuse
        // it).
        let mut asked = false;
        let empty = |c: &mut Vec<u128>| {
            asked = true;
            c.clear();
        };
        assert!(port.admit_listing(7, &mut connected, empty).is_ok());
        assert!(!asked);
        // Another port: the ports are listed, and it is refused while the followed one is
        // still connected.
        assert!(matches!(
            port.admit_listing(8, &mut connected, list(&[7, 8])),
            Err(Rejection::NotLivePublisher { .. })
        ));
        assert_eq!(connected, vec![7, 8]);
        // The followed port gone: the other one alone is followed from then on.
        assert!(port.admit_listing(8, &mut connected, list(&[8])).is_ok());
        assert!(port.is_followed(8) && !port.is_followed(7));
    }
}
