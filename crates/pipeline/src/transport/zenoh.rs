//! zenoh plumbing with the synchronous `.wait()` API (no async runtime in our code): a session
//! with explicit endpoints (and, when configured, zenoh's TLS, authentication and access
//! control: see `zenoh_security`), JSON publishers that name themselves, liveliness tokens, and
//! "latest value" subscribers backed by a ring channel so a slow consumer never blocks zenoh's
//! receive thread.

use crate::transport::zenoh_security::{self as security, AccessRules, TlsSettings, UserPassword};
use crate::transport::zenoh_tls_files::check_tls_files;
use serde::{Deserialize, Serialize};
use shipcast_wire::payload::limits;
use std::time::Duration;
use zenoh::bytes::{Encoding, ZBytes};
use zenoh::handlers::{FifoChannelHandler, RingChannel, RingChannelHandler};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::sample::{Sample, SampleKind};
use zenoh::{Session, Wait};

/// A zenoh failure, with what was being done; the underlying error is the `source`.
#[derive(Debug, thiserror::Error)]
#[error("zenoh: {context}")]
pub struct ZenohError {
    pub context: String,
    #[source]
    pub source: ZenohCause,
}

impl ZenohError {
    /// The error of a failed call; `context` becomes a `String` only then (a put that
    /// succeeds formats nothing).
    pub fn on<E>(context: impl Into<String>) -> impl FnOnce(E) -> ZenohError
    where
        E: Into<Box<dyn std::error::Error + Send + Sync + 'static>>,
    {
        move |e| ZenohError {
            context: context.into(),
            source: ZenohCause(e.into()),
        }
    }
}

/// The error zenoh (or the JSON encoder, or the OS) returned, kept whole for callers that
/// inspect it. zenoh's errors write their own causes into their message ("... - Caused by
/// ...") and also return them as `source`, so the chain ends here: with `{:#}` every cause
/// prints once.
#[derive(Debug)]
pub struct ZenohCause(pub Box<dyn std::error::Error + Send + Sync + 'static>);

impl std::fmt::Display for ZenohCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for ZenohCause {}

pub(super) fn err<E>(context: impl Into<String>) -> impl FnOnce(E) -> ZenohError
where
    E: Into<Box<dyn std::error::Error + Send + Sync + 'static>>,
{
    ZenohError::on(context)
}

/// zenoh's role for a session: a peer (the predictor, plain-TCP consumers), a client that
/// reaches everything through the one node it connects to (secure consumers), or a router
/// (`shipcast router`, the hub of a fleet).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    #[default]
    Peer,
    Client,
    Router,
}

impl Mode {
    fn as_str(self) -> &'static str {
        match self {
            Mode::Peer => "peer",
            Mode::Client => "client",
            Mode::Router => "router",
        }
    }
}

/// How a process joins the zenoh network.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZenohSettings {
    pub mode: Mode,
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:17447`. Empty: do not listen.
    pub listen: Vec<String>,
    /// Endpoints of peers or routers to connect to.
    pub connect: Vec<String>,
    /// Find peers by UDP multicast scouting (off: only the explicit endpoints are used).
    pub multicast_scouting: bool,
    /// Mutual TLS (used by `tls/` endpoints).
    pub tls: Option<TlsSettings>,
    /// User/password authentication.
    pub auth: Option<UserPassword>,
    /// Access control enforced by this node on its links.
    pub access: Option<AccessRules>,
    /// zenoh downsampling of puts sent out of this node (a router towards the shore).
    pub downsample_egress: Option<Downsampling>,
    /// A client keeps trying its endpoints this long when opening (a consumer started before
    /// the predictor); none: zenoh's default, one attempt.
    pub client_connect_patience_ms: Option<u64>,
}

/// At most `max_hz` puts per second per key on `key_exprs`, towards every link of the node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Downsampling {
    pub key_exprs: Vec<String>,
    pub max_hz: f64,
}

impl Eq for Downsampling {}

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

/// A TCP endpoint on 127.0.0.1 with a port that is free now (it is released before zenoh binds
/// it), e.g. `tcp/127.0.0.1:24123`.
///
/// The port is drawn at random from outside the kernel's ephemeral range. A port the OS hands
/// out for `bind(0)` lies inside that range, where any outgoing connection made in between
/// (a test beside this one, a zenoh session dialling out) can take it before zenoh binds it:
/// that happened in CI ("Address already in use"). Outside the range only another explicit
/// bind can, and a random draw makes that unlikely. Where the range leaves no room (1024-65535),
/// the OS picks, as before.
pub fn free_loopback_endpoint() -> Result<String, ZenohError> {
    let port = free_port(std::net::Ipv4Addr::LOCALHOST.into())?;
    Ok(format!("tcp/127.0.0.1:{port}"))
}

/// A TCP port on `ip` that is free now, drawn from outside the ephemeral range as
/// [`free_loopback_endpoint`] explains (the display `shipcast run` starts takes one too).
pub fn free_port(ip: std::net::IpAddr) -> Result<u16, ZenohError> {
    const TRIES: usize = 64;
    if let Some(band) = ports_outside_ephemeral_range() {
        for _ in 0..TRIES {
            let port = rand::random_range(band.clone());
            if std::net::TcpListener::bind((ip, port)).is_ok() {
                return Ok(port);
            }
        }
    }
    Ok(std::net::TcpListener::bind((ip, 0))
        .and_then(|l| l.local_addr())
        .map_err(err(format!("find a free TCP port on {ip}")))?
        .port())
}

/// Ports to draw from outside the ephemeral range: below it from 10000 (1024 if it starts
/// lower), else above it, whichever holds at least 1000 ports first; None if neither does.
fn ports_outside_ephemeral_range() -> Option<std::ops::RangeInclusive<u16>> {
    const ROOM: u32 = 1000;
    let (lo, hi) = ephemeral_port_range();
    let start = if lo >= 10_000 + ROOM { 10_000 } else { 1024 };
    if lo >= start + ROOM {
        return Some(start as u16..=(lo - 1) as u16);
    }
    (hi + ROOM <= u32::from(u16::MAX)).then(|| (hi + 1) as u16..=u16::MAX)
}

/// The ports the kernel hands out for outgoing connections and `bind(0)`, inclusive: Linux's
/// `ip_local_port_range`; where it cannot be read, Linux's default (32768-60999) on Linux and
/// the IANA dynamic range (49152-65535), which most other systems use, elsewhere.
fn ephemeral_port_range() -> (u32, u32) {
    let default = if cfg!(target_os = "linux") {
        (32_768, 60_999)
    } else {
        (49_152, 65_535)
    };
    let read = std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range")
        .ok()
        .and_then(|text| {
            let mut bounds = text.split_whitespace().map(|b| b.parse::<u32>().ok());
            Some((bounds.next()??, bounds.next()??))
        })
        .filter(|&(lo, hi)| 0 < lo && lo <= hi && hi <= u32::from(u16::MAX));
    read.unwrap_or(default)
}

/// The largest zenoh message a session of ours takes in; larger ones are dropped by zenoh on
/// arrival. The largest we send is the live verification, about 170 kB at the most steps.
pub const MAX_MESSAGE_BYTES: usize = 1 << 20;

/// The zenoh configuration entries (key path, JSON value) of `settings`.
pub fn config_entries(settings: &ZenohSettings) -> Vec<(String, serde_json::Value)> {
    use serde_json::json;
    let mut entries: Vec<(String, serde_json::Value)> = vec![
        ("mode".into(), settings.mode.as_str().into()),
        ("listen/endpoints".into(), json!(settings.listen)),
        ("connect/endpoints".into(), json!(settings.connect)),
        (
            "scouting/multicast/enabled".into(),
            settings.multicast_scouting.into(),
        ),
        // Peers learn of other peers by gossip and connect to them directly; off for clients
        // and routers, so nothing goes around the node that holds the access rules.
        (
            "scouting/gossip/enabled".into(),
            (settings.mode == Mode::Peer).into(),
        ),
    ];
    // zenoh reassembles a message of up to 1 GiB from any peer before anything of ours (or
    // its access control) sees it, and keeps the buffer: two puts of 300 MB by a stranger held
    // 550 MB in the predictor (review). Our largest message is well under this.
    entries.push((
        "transport/link/rx/max_message_size".into(),
        json!(MAX_MESSAGE_BYTES),
    ));
    if settings.mode == Mode::Peer {
        // Return from open once the explicit endpoints are connected instead of waiting for
        // every peer learnt by gossip (a 500 ms wait and a warning when one is slow to
        // answer). Declarations propagate asynchronously either way.
        entries.push((
            "open/return_conditions/connect_scouted".into(),
            false.into(),
        ));
    }
    if let (Mode::Client, Some(ms)) = (settings.mode, settings.client_connect_patience_ms) {
        entries.push(("connect/timeout_ms".into(), json!(ms)));
    }
    if let Some(tls) = &settings.tls {
        entries.extend(security::tls_entries(tls, !settings.listen.is_empty()));
    }
    if let Some(auth) = &settings.auth {
        entries.extend(security::usrpwd_entries(auth));
    }
    if let Some(access) = &settings.access {
        entries.push(("access_control".into(), access.to_zenoh_json()));
    }
    if let Some(d) = &settings.downsample_egress {
        entries.push((
            "downsampling".into(),
            json!([{
                "id": "towards-consumers",
                "messages": ["put"],
                "flows": ["egress"],
                "rules": d.key_exprs.iter().map(|k| json!({"key_expr": k, "freq": d.max_hz})).collect::<Vec<_>>(),
            }]),
        ));
    }
    entries
}

/// `settings` as one nested zenoh configuration document (JSON, which is also JSON5), as a
/// zenoh client in any language loads it (`zenoh.Config.from_file` in Python).
pub fn config_document(settings: &ZenohSettings) -> serde_json::Value {
    fn insert(
        map: &mut serde_json::Map<String, serde_json::Value>,
        path: &[&str],
        value: serde_json::Value,
    ) {
        match path {
            [] => {}
            [last] => {
                map.insert(last.to_string(), value);
            }
            [first, rest @ ..] => {
                let child = map
                    .entry(first.to_string())
                    .or_insert_with(|| serde_json::Value::Object(Default::default()));
                // Entries never put a value where another one has a section.
                if let Some(section) = child.as_object_mut() {
                    insert(section, rest, value);
                }
            }
        }
    }
    let mut root = serde_json::Map::new();
    for (key, value) in config_entries(settings) {
        let path: Vec<&str> = key.split('/').collect();
        insert(&mut root, &path, value);
    }
    serde_json::Value::Object(root)
}

/// The zenoh configuration of `settings`.
pub fn zenoh_config(settings: &ZenohSettings) -> Result<zenoh::Config, ZenohError> {
    if let Some(tls) = &settings.tls {
        check_tls_files(tls)?;
    }
    let mut config = zenoh::Config::default();
    for (key, value) in config_entries(settings) {
        let text = value.to_string();
        config.insert_json5(&key, &text).map_err(err(format!(
            "config {key} = {}",
            // Keys may be inline; never print them.
            if key.contains("private_key") || key.contains("password") {
                "<secret>"
            } else {
                &text
            }
        )))?;
    }
    Ok(config)
}

/// Open a session with exactly the configured endpoints.
pub fn open(settings: &ZenohSettings) -> Result<Session, ZenohError> {
    let config = zenoh_config(settings)?;
    zenoh::open(config).wait().map_err(err(format!(
        "open {} session (listen {:?}, connect {:?}{})",
        settings.mode.as_str(),
        settings.listen,
        settings.connect,
        if settings.tls.is_some() { ", TLS" } else { "" }
    )))
}

/// How long an open may take before [`open_unless`] says it is still waiting, and how often
/// it says so again.
const OPEN_NOTICE_AFTER: Duration = Duration::from_secs(10);
const OPEN_NOTICE_EVERY: Duration = Duration::from_secs(15);

/// [`open`], given up (`Ok(None)`) when `limit` is reached first: a client keeps trying to
/// reach its router or predictor for up to `client_connect_patience_ms`, and a stop request
/// or the `--duration` limit must not wait for that.
pub fn open_until(
    settings: &ZenohSettings,
    limit: &crate::transport::shutdown::RunLimit,
) -> Result<Option<Session>, ZenohError> {
    open_unless(settings, || limit.reached())
}

/// [`open`], given up (`Ok(None)`) as soon as `give_up` says so (asked every 50 ms): `shipcast
/// run` also gives up when one of its services exits while its view waits.
pub fn open_unless(
    settings: &ZenohSettings,
    mut give_up: impl FnMut() -> bool,
) -> Result<Option<Session>, ZenohError> {
    let (done, opened) = std::sync::mpsc::channel();
    let for_thread = settings.clone();
    // The thread owns nothing of ours: given up on, it ends with the open (or the process).
    std::thread::Builder::new()
        .name("zenoh-open".into())
        .spawn(move || {
            let _ = done.send(open(&for_thread));
        })
        .map_err(ZenohError::on("start a thread to open the zenoh session"))?;
    // A client keeps trying for up to a minute and zenoh says nothing meanwhile: say what it
    // waits for, so an operator whose certificate is refused is not left looking at silence
    // (the reason is in the other side's log).
    let started = std::time::Instant::now();
    let mut next_notice = OPEN_NOTICE_AFTER;
    loop {
        if started.elapsed() >= next_notice {
            tracing::warn!(
                "zenoh: still opening a {} session to {:?}{} after {} s: is the predictor (or \
                 router) running there? A refused certificate or name shows as 'refused zenoh \
                 client' in its log (docs/FAQ.md)",
                settings.mode.as_str(),
                settings.connect,
                if settings.tls.is_some() {
                    " over TLS"
                } else {
                    ""
                },
                next_notice.as_secs()
            );
            next_notice += OPEN_NOTICE_EVERY;
        }
        match opened.recv_timeout(Duration::from_millis(50)) {
            Ok(result) => return result.map(Some),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) if give_up() => return Ok(None),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            Err(e @ std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(ZenohError::on("open the zenoh session")(e))
            }
        }
    }
}

/// Publishes JSON payloads (encoding `application/json`) on one key.
///
/// Publishers are express: each put is written to the link from the calling thread instead of
/// waiting in zenoh's batching queue for its transmit task. Our messages are few (a forecast
/// every 0.5 s) and latency is what consumers pay for, so batching only adds a thread hop (about
/// 40 µs at the median on two cores, where that task shares the predictor's core).
///
/// Each put carries the publishing session's zenoh id as its attachment, and the publisher
/// holds the liveliness token `Names::publisher_token(key, zid)`: a consumer accepts a payload
/// only from the publisher whose token is alive (`SourceCheck`).
pub struct JsonPublisher {
    publisher: Publisher<'static>,
    publisher_id: ZBytes,
    _token: LivelinessToken,
    /// [`Self::put_serialize`]'s document, kept across calls.
    json_buffer: std::sync::Mutex<Vec<u8>>,
}

impl JsonPublisher {
    pub fn new(session: &Session, key: &str) -> Result<Self, ZenohError> {
        let publisher = session
            .declare_publisher(key.to_string())
            .encoding(Encoding::APPLICATION_JSON)
            // A slow, full or vanished remote link drops forecasts instead of blocking the
            // publishing thread (zenoh's default for puts, stated because it matters).
            .congestion_control(CongestionControl::Drop)
            .express(true)
            .wait()
            .map_err(err(format!("declare publisher on '{key}'")))?;
        let zid = session.zid().to_string();
        let token = liveliness_token(session, &publisher_token(key, &zid))?;
        Ok(Self {
            publisher,
            publisher_id: ZBytes::from(zid.into_bytes()),
            _token: token,
            json_buffer: std::sync::Mutex::new(Vec::new()),
        })
    }

    /// Publish one JSON document, copied into a buffer of zenoh's (for documents built once,
    /// such as the status; forecasts go through [`Self::put_shared`]).
    pub fn put(&self, json: &[u8]) -> Result<(), ZenohError> {
        self.put_payload(ZBytes::from(json))
    }

    /// Publish one JSON document without copying it: zenoh takes a reference-counted handle
    /// to `json`'s buffer. Once zenoh has written it to its links and dropped the handle, the
    /// writer of the buffer can reuse it (see `ForecastJsonEncoder::encode_shared`).
    pub fn put_shared(&self, json: bytes::Bytes) -> Result<(), ZenohError> {
        self.put_payload(ZBytes::from(json))
    }

    fn put_payload(&self, payload: ZBytes) -> Result<(), ZenohError> {
        self.publisher
            .put(payload)
            // A reference-counted copy of the id, no allocation of its bytes.
            .attachment(self.publisher_id.clone())
            .wait()
            // The context is formatted only on failure: a put that succeeds formats nothing.
            .map_err(|e| ZenohError::on(format!("put on '{}'", self.publisher.key_expr()))(e))
    }

    /// Serialise `value` as JSON and publish it. The document is written into a buffer kept
    /// across calls (an advisory or status goes out every forecast): only zenoh's own copy
    /// of it is allocated, not a buffer grown step by step each time.
    pub fn put_serialize<T: Serialize>(&self, value: &T) -> Result<(), ZenohError> {
        // A poisoned lock only means another put panicked mid-write: the buffer is cleared
        // before use anyway.
        let payload = {
            let mut buffer = self
                .json_buffer
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            reuse(&mut buffer);
            serde_json::to_writer(&mut *buffer, value).map_err(err("serialise JSON"))?;
            // zenoh's copy; the lock is not held across the put, which may wait.
            ZBytes::from(&buffer[..])
        };
        self.put_payload(payload)
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

/// Liveliness token that a publisher of `key` holds while it lives, naming its session.
pub fn publisher_token(key: &str, zid: &str) -> String {
    format!("{key}/publisher/{zid}")
}

/// Declare the liveliness token of a service; it stays alive while the returned value lives.
pub fn liveliness_token(session: &Session, key: &str) -> Result<LivelinessToken, ZenohError> {
    session
        .liveliness()
        .declare_token(key.to_string())
        .wait()
        .map_err(err(format!("declare liveliness token '{key}'")))
}

/// One payload and the publisher id it carried (`JsonPublisher` attaches its session's zenoh
/// id; other publishers may attach nothing, or anything).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Received {
    pub payload: Vec<u8>,
    pub publisher: Option<String>,
}

impl Received {
    /// An empty one, to be filled by [`LatestSubscriber::try_recv_into`].
    pub fn empty() -> Self {
        Self {
            payload: Vec::new(),
            publisher: None,
        }
    }
}

fn received(sample: &Sample) -> Received {
    let mut r = Received::empty();
    receive_into(sample, &mut r);
    r
}

/// The largest receive buffer kept from one message to the next [bytes].
const KEPT_PAYLOAD_BYTES: usize = 64 * 1024;

/// Empty `buffer` for the next message. A forecast's JSON is about 9 KB: a buffer grown past
/// [`KEPT_PAYLOAD_BYTES`] by one oversized (forged) message is given back, not kept for the
/// rest of the process; one within it is kept, so that steady traffic allocates nothing.
fn reuse(buffer: &mut Vec<u8>) {
    buffer.clear();
    buffer.shrink_to(KEPT_PAYLOAD_BYTES);
}

/// `sample` into `into`, reusing its buffers: once they have grown to the largest payload and
/// the publisher's id, receiving allocates nothing of ours (a motion sample arrives 8 times a
/// second per followed vessel).
fn receive_into(sample: &Sample, into: &mut Received) {
    reuse(&mut into.payload);
    into.payload.extend_from_slice(&sample.payload().to_bytes());
    let publisher = sample
        .attachment()
        .and_then(|a| a.try_to_string().ok())
        .filter(|p| crate::transport::forecast_check::is_publisher_id(p));
    match (publisher, &mut into.publisher) {
        (Some(p), Some(kept)) => {
            if kept.as_str() != p.as_ref() {
                kept.clear();
                kept.push_str(&p);
            }
        }
        (Some(p), slot) => *slot = Some(p.into_owned()),
        (None, slot) => *slot = None,
    }
}

/// Keeps the newest few payloads of one key; older ones are dropped, never queued without bound.
pub struct LatestSubscriber {
    subscriber: Subscriber<RingChannelHandler<Sample>>,
}

impl LatestSubscriber {
    pub fn new(session: &Session, key: &str) -> Result<Self, ZenohError> {
        Self::keeping(session, key, limits::ZENOH_RING)
    }

    /// Keeps the newest `capacity` payloads (a stream whose every message counts, such as
    /// motion samples, needs more than the newest few).
    pub fn keeping(session: &Session, key: &str, capacity: usize) -> Result<Self, ZenohError> {
        let subscriber = session
            .declare_subscriber(key.to_string())
            .with(RingChannel::new(capacity.max(1)))
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

    /// Wait up to `timeout` for the next payload, with the zenoh id its publisher attached,
    /// into `into`, reusing its buffers; false when nothing arrived within `timeout` (`into`
    /// is then left as it was).
    pub fn recv_into(&self, timeout: Duration, into: &mut Received) -> Result<bool, ZenohError> {
        let sample = self
            .subscriber
            .recv_timeout(timeout)
            .map_err(err("receive"))?;
        Ok(sample.map(|s| receive_into(&s, into)).is_some())
    }

    /// The next payload waiting, if any, with the zenoh id its publisher attached.
    pub fn try_recv_with_source(&self) -> Result<Option<Received>, ZenohError> {
        let sample = self.subscriber.try_recv().map_err(err("receive"))?;
        Ok(sample.map(|s| received(&s)))
    }

    /// [`Self::try_recv_with_source`] into `into`, reusing its buffers; false when nothing
    /// was waiting (`into` is then left as it was).
    pub fn try_recv_into(&self, into: &mut Received) -> Result<bool, ZenohError> {
        let sample = self.subscriber.try_recv().map_err(err("receive"))?;
        Ok(sample.map(|s| receive_into(&s, into)).is_some())
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

    /// Regression (review): one forged message of megabytes grew the receive buffer, and the
    /// buffer kept that size for the life of the process.
    #[test]
    fn a_buffer_grown_by_one_oversized_message_is_given_back_and_a_normal_one_kept() {
        let mut buffer = Vec::new();
        buffer.extend_from_slice(&[b'x'; 9000]);
        let normal = buffer.capacity();
        reuse(&mut buffer);
        assert!(buffer.is_empty() && buffer.capacity() == normal);
        buffer.extend_from_slice(&vec![b'x'; 8 << 20]);
        reuse(&mut buffer);
        assert!(buffer.is_empty());
        assert!(
            buffer.capacity() <= KEPT_PAYLOAD_BYTES,
            "{}",
            buffer.capacity()
        );
    }

    use super::*;

    /// Regression: a port from `bind(0)` lies in the ephemeral range, where an outgoing
    /// connection could take it before the predictor bound it (CI failed once this way).
    #[test]
    fn free_loopback_ports_lie_outside_the_ephemeral_range_and_are_bindable() {
        let (lo, hi) = ephemeral_port_range();
        let band = ports_outside_ephemeral_range();
        let mut ports = std::collections::BTreeSet::new();
        for _ in 0..20 {
            let endpoint = free_loopback_endpoint().unwrap();
            let port: u16 = endpoint
                .strip_prefix("tcp/127.0.0.1:")
                .and_then(|p| p.parse().ok())
                .unwrap_or_else(|| panic!("not a loopback TCP endpoint: {endpoint}"));
            // Where the range leaves no room the OS picks (inside it, as bind(0) does).
            let outside = u32::from(port) < lo || u32::from(port) > hi;
            assert_eq!(outside, band.is_some(), "{port} against {lo}-{hi}");
            assert!(std::net::TcpListener::bind(("127.0.0.1", port)).is_ok());
            ports.insert(port);
        }
        // Drawn at random, not one fixed port handed to every caller.
        assert!(ports.len() > 10, "{ports:?}");
    }

    #[test]
    fn the_band_outside_the_ephemeral_range_holds_room() {
        let (lo, hi) = ephemeral_port_range();
        assert!(0 < lo && lo <= hi && hi <= 65_535, "{lo}-{hi}");
        if let Some(band) = ports_outside_ephemeral_range() {
            let (a, b) = (u32::from(*band.start()), u32::from(*band.end()));
            assert!(b - a + 1 >= 1000 && a >= 1024, "{band:?}");
            assert!(b < lo || a > hi, "{band:?} against {lo}-{hi}");
        }
    }

    use std::time::Instant;

    /// A listening peer, a peer connected to it, and a forecast key of a unique instance.
    fn two_peers(tag: &str) -> (Session, Session, String) {
        let endpoint = free_loopback_endpoint().unwrap();
        let a = open(&ZenohSettings::listen_on(&endpoint)).unwrap();
        let b = open(&ZenohSettings::connect_to(&endpoint)).unwrap();
        let key = format!(
            "{}/shipcast/x/forecast",
            crate::transport::unique_instance(tag)
        );
        (a, b, key)
    }

    /// Wait (up to 10 s) until `publisher`'s puts have a subscriber to reach.
    fn wait_matched(publisher: &Publisher<'_>) {
        let deadline = Instant::now() + Duration::from_secs(10);
        while publisher
            .matching_status()
            .wait()
            .is_ok_and(|m| !m.matching())
            && Instant::now() < deadline
        {
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    #[test]
    fn json_flows_between_two_peers_on_explicit_endpoints() {
        let (a, b, key) = two_peers("unit");
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

    /// Regression (review): a stranger's put of any size up to zenoh's 1 GiB was reassembled,
    /// and its memory kept, by every session of ours.
    #[test]
    fn a_message_above_the_limit_is_dropped_on_arrival_and_the_link_goes_on() {
        let endpoint = free_loopback_endpoint().unwrap();
        let ours = open(&ZenohSettings::listen_on(&endpoint)).unwrap();
        // The sender is any zenoh peer, with zenoh's own limits.
        let mut config = zenoh::Config::default();
        for (key, value) in [
            ("mode", "\"peer\"".to_string()),
            ("scouting/multicast/enabled", "false".into()),
            ("connect/endpoints", format!("[\"{endpoint}\"]")),
        ] {
            config.insert_json5(key, &value).unwrap();
        }
        let stranger = zenoh::open(config).wait().unwrap();
        let key = format!(
            "{}/shipcast/x/forecast",
            crate::transport::unique_instance("big")
        );
        let sub = ours.declare_subscriber(key.clone()).wait().unwrap();
        let publisher = stranger.declare_publisher(key).wait().unwrap();
        wait_matched(&publisher);
        for len in [
            MAX_MESSAGE_BYTES + 1,
            4 * MAX_MESSAGE_BYTES,
            MAX_MESSAGE_BYTES / 2,
            3,
        ] {
            publisher.put(vec![b'x'; len]).wait().unwrap();
        }
        let mut got = Vec::new();
        while let Ok(Some(sample)) = sub.recv_timeout(Duration::from_secs(5)) {
            got.push(sample.payload().len());
            if got.len() == 2 {
                break;
            }
        }
        assert_eq!(got, [MAX_MESSAGE_BYTES / 2, 3]);
    }

    /// Regression (review): any attachment was taken as the publisher's id, and its text, of
    /// any length and with newlines, went into the consumers' warnings.
    #[test]
    fn an_attachment_that_is_no_zenoh_id_is_no_publisher_id() {
        let (a, b, key) = two_peers("att");
        let sub = LatestSubscriber::new(&b, &key).unwrap();
        let publisher = a.declare_publisher(key).wait().unwrap();
        wait_matched(&publisher);
        let forged = "ab\n2026-12-07T06:00:00Z  INFO crane: predictor alive";
        let real = a.zid().to_string();
        let mut got = Received::empty();
        for (attachment, expected) in [
            (forged.to_string(), None),
            ("x".repeat(200_000), None),
            (real.clone(), Some(real.as_str())),
        ] {
            publisher.put("{}").attachment(attachment).wait().unwrap();
            assert!(sub.recv_into(Duration::from_secs(5), &mut got).unwrap());
            assert_eq!(got.publisher.as_deref(), expected);
        }
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

    /// An error that, like zenoh's, writes its cause into its message and also returns it
    /// as `source`.
    #[derive(Debug)]
    struct SelfDescribing(std::io::Error);

    impl std::fmt::Display for SelfDescribing {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "link failed - Caused by {}", self.0)
        }
    }

    impl std::error::Error for SelfDescribing {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn a_cause_written_into_zenohs_message_prints_once() {
        let io = std::io::Error::other("refused by peer");
        let e = ZenohError::on("open session")(SelfDescribing(io));
        assert_eq!(
            format!("{:#}", anyhow::Error::from(e)),
            "zenoh: open session: link failed - Caused by refused by peer"
        );
    }

    #[test]
    fn an_invalid_certificate_file_prints_each_cause_once() {
        let dir = tempfile::tempdir().unwrap();
        let garbage = dir.path().join("pipeline.pem");
        // A PEM block (so our own check of the files passes) that holds no certificate: the
        // error comes from zenoh.
        std::fs::write(
            &garbage,
            "-----BEGIN CERTIFICATE-----\nnot a certificate\n-----END CERTIFICATE-----\n",
        )
        .unwrap();
        let garbage = garbage.display().to_string();
        let tcp = free_loopback_endpoint().unwrap();
        let listen = tcp.replacen("tcp/", "tls/", 1);
        let e = open(&ZenohSettings {
            listen: vec![listen.clone()],
            tls: Some(TlsSettings {
                root_ca: garbage.clone(),
                certificate: garbage.clone(),
                private_key: garbage,
            }),
            ..ZenohSettings::default()
        })
        .err()
        .unwrap();
        let e = anyhow::Error::from(e);
        let printed = format!("{e:#}");
        // zenoh's error is kept whole as the typed cause.
        let cause = e
            .chain()
            .nth(1)
            .and_then(|s| s.downcast_ref::<ZenohCause>())
            .expect("the zenoh error is the source");
        let head = format!("zenoh: open peer session (listen [\"{listen}\"], connect [], TLS): ");
        assert!(printed.starts_with(&head), "{printed}");
        assert_eq!(printed.lines().count(), 1, "{printed}");
        // zenoh writes its causes into its own message and also returns them as `source`:
        // chained naively, each would print twice.
        let mut inner = std::error::Error::source(cause.0.as_ref());
        while let Some(c) = inner {
            assert_eq!(
                printed.matches(&c.to_string()).count(),
                1,
                "{c} in {printed}"
            );
            inner = c.source();
        }
        assert_eq!(printed.matches(&cause.to_string()).count(), 1, "{printed}");
    }
}
