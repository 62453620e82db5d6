//! zenoh plumbing with the synchronous `.wait()` API (no async runtime in our code): a peer
//! session with explicit endpoints, JSON publishers, liveliness tokens, and "latest value"
//! subscribers backed by a ring channel so a slow consumer never blocks zenoh's receive thread.

use crate::payload::limits;
use serde::{Deserialize, Serialize};
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::handlers::{FifoChannelHandler, RingChannel, RingChannelHandler};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::sample::{Sample, SampleKind};
use zenoh::{Session, Wait};

/// A zenoh failure, with what was being done.
#[derive(Debug, thiserror::Error)]
#[error("zenoh: {context}: {detail}")]
pub struct ZenohError {
    pub context: String,
    pub detail: String,
}

fn err<E: std::fmt::Display>(context: impl Into<String>) -> impl FnOnce(E) -> ZenohError {
    move |e| ZenohError {
        context: context.into(),
        detail: e.to_string(),
    }
}

/// How a process joins the zenoh network.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZenohSettings {
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:17447`. Empty: do not listen.
    pub listen: Vec<String>,
    /// Endpoints of peers or routers to connect to.
    pub connect: Vec<String>,
    /// Find peers by UDP multicast scouting (off: only the explicit endpoints are used).
    pub multicast_scouting: bool,
}

impl ZenohSettings {
    /// Listen on `endpoint` only, scouting off (the bench and tests on loopback).
    pub fn listen_on(endpoint: &str) -> Self {
        Self {
            listen: vec![endpoint.to_string()],
            ..Self::default()
        }
    }

    /// Connect to `endpoint` only, scouting off.
    pub fn connect_to(endpoint: &str) -> Self {
        Self {
            connect: vec![endpoint.to_string()],
            ..Self::default()
        }
    }
}

/// A TCP endpoint on 127.0.0.1 with a port that is free now (the OS picks it; it is released
/// before zenoh binds it), e.g. `tcp/127.0.0.1:40123`.
pub fn free_loopback_endpoint() -> Result<String, ZenohError> {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map_err(err("find a free TCP port on 127.0.0.1"))?
        .port();
    Ok(format!("tcp/127.0.0.1:{port}"))
}

/// Open a peer session with exactly the configured endpoints.
pub fn open(settings: &ZenohSettings) -> Result<Session, ZenohError> {
    let mut config = zenoh::Config::default();
    let json = |v: &Vec<String>| serde_json::to_string(v).unwrap_or_else(|_| "[]".into());
    let entries = [
        ("mode", "\"peer\"".to_string()),
        ("listen/endpoints", json(&settings.listen)),
        ("connect/endpoints", json(&settings.connect)),
        (
            "scouting/multicast/enabled",
            settings.multicast_scouting.to_string(),
        ),
        // Return from open once the explicit endpoints are connected instead of waiting for
        // every peer learnt by gossip (a 500 ms wait and a warning when one is slow to
        // answer). Declarations propagate asynchronously either way.
        (
            "open/return_conditions/connect_scouted",
            "false".to_string(),
        ),
    ];
    for (key, value) in entries {
        config
            .insert_json5(key, &value)
            .map_err(err(format!("config {key} = {value}")))?;
    }
    zenoh::open(config).wait().map_err(err(format!(
        "open session (listen {:?}, connect {:?})",
        settings.listen, settings.connect
    )))
}

/// Publishes JSON payloads (encoding `application/json`) on one key.
///
/// Publishers are express: each put is written to the link from the calling thread instead of
/// waiting in zenoh's batching queue for its transmit task. Our messages are few (a forecast
/// every 0.5 s) and latency is what consumers pay for, so batching only adds a thread hop (about
/// 40 µs at the median on two cores, where that task shares the predictor's core).
pub struct JsonPublisher {
    publisher: Publisher<'static>,
}

impl JsonPublisher {
    pub fn new(session: &Session, key: &str) -> Result<Self, ZenohError> {
        let publisher = session
            .declare_publisher(key.to_string())
            .encoding(Encoding::APPLICATION_JSON)
            .express(true)
            .wait()
            .map_err(err(format!("declare publisher on '{key}'")))?;
        Ok(Self { publisher })
    }

    /// Publish one JSON document.
    pub fn put(&self, json: &[u8]) -> Result<(), ZenohError> {
        self.publisher
            .put(json.to_vec())
            .wait()
            .map_err(err(format!("put on '{}'", self.publisher.key_expr())))
    }

    /// Serialise `value` as JSON and publish it.
    pub fn put_serialize<T: Serialize>(&self, value: &T) -> Result<(), ZenohError> {
        let bytes = serde_json::to_vec(value).map_err(err("serialise JSON"))?;
        self.put(&bytes)
    }

    /// True once at least one subscriber matches (declarations propagate asynchronously).
    pub fn has_subscribers(&self) -> bool {
        self.publisher
            .matching_status()
            .wait()
            .map(|s| s.matching())
            .unwrap_or(false)
    }
}

/// Declare the liveliness token of a service; it stays alive while the returned value lives.
pub fn liveliness_token(session: &Session, key: &str) -> Result<LivelinessToken, ZenohError> {
    session
        .liveliness()
        .declare_token(key.to_string())
        .wait()
        .map_err(err(format!("declare liveliness token '{key}'")))
}

/// Keeps the newest few payloads of one key; older ones are dropped, never queued without bound.
pub struct LatestSubscriber {
    subscriber: Subscriber<RingChannelHandler<Sample>>,
}

impl LatestSubscriber {
    pub fn new(session: &Session, key: &str) -> Result<Self, ZenohError> {
        let subscriber = session
            .declare_subscriber(key.to_string())
            .with(RingChannel::new(limits::ZENOH_RING))
            .wait()
            .map_err(err(format!("declare subscriber on '{key}'")))?;
        Ok(Self { subscriber })
    }

    /// Wait up to `timeout` for the next payload.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<Vec<u8>>, ZenohError> {
        let sample = self
            .subscriber
            .recv_timeout(timeout)
            .map_err(err("receive"))?;
        Ok(sample.map(|s| s.payload().to_bytes().into_owned()))
    }

    /// The newest payload waiting, if any, discarding older ones.
    pub fn latest(&self) -> Result<Option<Vec<u8>>, ZenohError> {
        let mut newest = None;
        while let Some(s) = self.subscriber.try_recv().map_err(err("receive"))? {
            newest = Some(s);
        }
        Ok(newest.map(|s| s.payload().to_bytes().into_owned()))
    }
}

/// Follows the liveliness token of a service: reports when it appears and disappears.
pub struct LivelinessWatch {
    subscriber: Subscriber<FifoChannelHandler<Sample>>,
}

impl LivelinessWatch {
    pub fn new(session: &Session, key: &str) -> Result<Self, ZenohError> {
        let subscriber = session
            .liveliness()
            .declare_subscriber(key.to_string())
            .history(true)
            .wait()
            .map_err(err(format!("watch liveliness of '{key}'")))?;
        Ok(Self { subscriber })
    }

    /// The latest change since the last call: Some(true) alive, Some(false) gone.
    pub fn poll(&self) -> Option<bool> {
        let mut state = None;
        while let Ok(Some(s)) = self.subscriber.try_recv() {
            state = Some(s.kind() == SampleKind::Put);
        }
        state
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    #[test]
    fn json_flows_between_two_peers_on_explicit_endpoints() {
        let endpoint = free_loopback_endpoint().unwrap();
        let a = open(&ZenohSettings::listen_on(&endpoint)).unwrap();
        let b = open(&ZenohSettings::connect_to(&endpoint)).unwrap();
        let key = format!("unit-{}/shipcast/x/forecast", std::process::id());
        let sub = LatestSubscriber::new(&b, &key).unwrap();
        let watch = LivelinessWatch::new(&b, &format!("{key}/alive")).unwrap();
        let publisher = JsonPublisher::new(&a, &key).unwrap();
        let token = liveliness_token(&a, &format!("{key}/alive")).unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        while !publisher.has_subscribers() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(10));
        }
        publisher.put(br#"{"x":1}"#).unwrap();
        let got = sub.recv_timeout(Duration::from_secs(5)).unwrap();
        assert_eq!(got.as_deref(), Some(&br#"{"x":1}"#[..]));
        let mut alive = None;
        while alive.is_none() && Instant::now() < deadline {
            alive = watch.poll();
            std::thread::sleep(Duration::from_millis(10));
        }
        assert_eq!(alive, Some(true));
        drop(token);
        let mut alive = None;
        while alive != Some(false) && Instant::now() < deadline {
            alive = watch.poll().or(alive);
            std::thread::sleep(Duration::from_millis(10));
        }
        assert_eq!(alive, Some(false));
    }

    #[test]
    fn bad_endpoint_is_a_clear_error() {
        let e = open(&ZenohSettings {
            listen: vec!["nonsense".into()],
            ..ZenohSettings::default()
        })
        .err()
        .unwrap();
        assert!(e.to_string().starts_with("zenoh: "), "{e}");
    }
}
