//! The zenoh subscriptions that fill the board: one key expression per kind of message covers
//! every vessel (`[instance/]shipcast/*/forecast`, `.../verification`, `.../advisory/*`).
//!
//! A message is shown only if it comes from the one live publisher of its key (the liveliness
//! tokens followed in [`LiveSources`]), like the deck and the crane check their forecasts.
//!
//! Callbacks run on zenoh's threads and only parse, check and assign under the board's lock,
//! so the display never holds up zenoh, and a page that reads slowly never reaches back here.

use crate::board::{AdvisoryView, Board, VerificationIn};
use crate::sources::{parse_token, LiveSources};
use shipcast_pipeline::transport::forecast_check::check_content;
use shipcast_pipeline::transport::naming::check_segment;
use shipcast_wire::payload::Forecast;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::pubsub::Subscriber;
use zenoh::sample::{Sample, SampleKind};
use zenoh::{Session, Wait};

/// Why the feed could not start.
#[derive(Debug, thiserror::Error)]
#[error("subscribe to {key}: {reason}")]
pub struct FeedError {
    key: String,
    reason: String,
}

/// The running subscriptions; dropping it unsubscribes and stops the token resync.
pub struct Feed {
    _subscribers: Vec<Subscriber<()>>,
    stop: Arc<AtomicBool>,
    resync: Option<std::thread::JoinHandle<()>>,
}

impl Drop for Feed {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.resync.take() {
            let _ = t.join();
        }
    }
}

/// How often the feed asks for every live token again after one was refused for lack of
/// room ([`LiveSources::take_overflowed`]).
pub const RESYNC_EVERY: Duration = Duration::from_secs(5);

/// The kinds of message the display reads, as key tails after `<prefix><vessel>/`: one list
/// for the messages and for their publishers' tokens.
const TAILS: [&str; 3] = ["forecast", "verification", "advisory/*"];

/// The token key expressions under `prefix`, one per kind of message the display reads.
fn token_keys(prefix: &str) -> [String; 3] {
    TAILS.map(|tail| format!("{prefix}*/{tail}/publisher/*"))
}

/// What a key names after the fleet prefix (`[<instance>/]shipcast/`):
/// `<vessel>/<kind>[/<station>]`.
#[derive(Debug, PartialEq, Eq)]
pub enum Topic<'a> {
    Forecast { vessel: &'a str },
    Verification { vessel: &'a str },
    Advisory { vessel: &'a str, station: &'a str },
}

/// The topic of `key` under `prefix` (`Names::fleet_prefix`), or None for any other key and
/// for a vessel or station name that breaks the rule every shipcast name keeps (at most 64
/// letters, digits, '-', '_' and '.': `check_segment`). Regression (review): a forged
/// 30 000-character name was kept on the board and sent in every snapshot.
pub fn topic<'a>(prefix: &str, key: &'a str) -> Option<Topic<'a>> {
    let rest = key.strip_prefix(prefix)?;
    let mut parts = rest.split('/');
    let name = |n: &'a str| check_segment("name", n).is_ok().then_some(n);
    let vessel = parts.next().and_then(name)?;
    let topic = match (parts.next()?, parts.next(), parts.next()) {
        ("forecast", None, None) => Topic::Forecast { vessel },
        ("verification", None, None) => Topic::Verification { vessel },
        ("advisory", Some(station), None) => Topic::Advisory {
            vessel,
            station: name(station)?,
        },
        _ => return None,
    };
    Some(topic)
}

/// Parse and check one forecast message: the JSON's own shape (`Forecast::from_json`) and the
/// content checks every consumer applies (finite values, non-negative sigma, the expected step).
pub fn parse_forecast(bytes: &[u8], expected_dt_s: f64) -> Result<Forecast, String> {
    let forecast = Forecast::from_json(bytes).map_err(|e| e.to_string())?;
    check_content(&forecast, expected_dt_s).map_err(|e| e.to_string())?;
    Ok(forecast)
}

/// The vessel a topic belongs to.
fn vessel_of<'a>(topic: &Topic<'a>) -> &'a str {
    match topic {
        Topic::Forecast { vessel }
        | Topic::Verification { vessel }
        | Topic::Advisory { vessel, .. } => vessel,
    }
}

fn on_sample(
    board: &Board,
    sources: &LiveSources,
    prefix: &str,
    expected_dt_s: f64,
    sample: &Sample,
) {
    let key = sample.key_expr().as_str();
    let Some(topic) = topic(prefix, key) else {
        // Every key the subscriptions deliver names a topic unless a name breaks the rule.
        board.reject_unheard();
        tracing::debug!("display: {key}: refused: not a topic with valid names");
        return;
    };
    let publisher = sample
        .attachment()
        .and_then(|a| a.try_to_string().ok().map(|t| t.into_owned()));
    if let Err(e) = sources.admits(key, publisher.as_deref()) {
        let vessel = vessel_of(&topic);
        board.reject(vessel);
        tracing::debug!("display: {key}: refused: {e}");
        return;
    }
    let bytes = sample.payload().to_bytes();
    match topic {
        Topic::Forecast { vessel } => match parse_forecast(&bytes, expected_dt_s) {
            Ok(f) => {
                if let Err(e) =
                    board.forecast_from(vessel, &f, publisher.as_deref(), Instant::now())
                {
                    tracing::debug!("display: {vessel}: {e}");
                }
            }
            Err(e) => {
                board.reject(vessel);
                tracing::debug!("display: {vessel}: refused forecast: {e}");
            }
        },
        Topic::Verification { vessel } => match serde_json::from_slice::<VerificationIn>(&bytes) {
            Ok(report) => {
                board.verification(vessel, &report, Instant::now());
            }
            Err(e) => {
                board.reject(vessel);
                tracing::debug!("display: {vessel}: refused verification: {e}");
            }
        },
        Topic::Advisory { vessel, station } => {
            match serde_json::from_slice::<AdvisoryView>(&bytes) {
                Ok(a) => {
                    board.advisory(vessel, station, a, Instant::now());
                }
                Err(e) => {
                    board.reject(vessel);
                    tracing::debug!("display: {vessel}/{station}: refused advisory: {e}");
                }
            }
        }
    }
}

/// Follow one publisher token appearing or vanishing, for keys the display reads.
fn on_token(sources: &LiveSources, prefix: &str, sample: &Sample) {
    let Some((key, zid)) = parse_token(sample.key_expr().as_str()) else {
        return;
    };
    if topic(prefix, key).is_none() {
        return;
    }
    match sample.kind() {
        SampleKind::Put => {
            if !sources.appeared(key, zid) {
                tracing::debug!("display: {key}: publisher token {zid} not followed (no room)");
            }
        }
        SampleKind::Delete => sources.vanished(key, zid),
    }
}

/// While tokens are refused for lack of room, ask zenoh for every live token again each
/// [`RESYNC_EVERY`]: a refused token is never announced again, so without this a publisher
/// that came while junk tokens filled the map would stay unheard after they went.
fn resync_tokens(
    session: Session,
    sources: Arc<LiveSources>,
    prefix: String,
    stop: Arc<AtomicBool>,
) {
    let mut last = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(100));
        if last.elapsed() < RESYNC_EVERY || !sources.take_overflowed() {
            continue;
        }
        last = Instant::now();
        // At most one line per RESYNC_EVERY, however many tokens were refused.
        tracing::warn!(
            "display: publisher tokens refused for lack of room ({} keys, {} publishers per key at most): asking for every live token again",
            crate::sources::MAX_KEYS,
            crate::sources::MAX_IDS_PER_KEY
        );
        for key in token_keys(&prefix) {
            let (sources, prefix) = (sources.clone(), prefix.clone());
            let asked = session
                .liveliness()
                .get(key.clone())
                .callback(move |reply| {
                    if let Ok(sample) = reply.result() {
                        on_token(&sources, &prefix, sample);
                    }
                })
                .wait();
            if let Err(e) = asked {
                tracing::debug!("display: ask for the tokens on {key}: {e}");
            }
        }
    }
}

/// Subscribe to every vessel's forecasts, verification and advisories under `prefix`
/// (`Names::fleet_prefix`), and to their publishers' liveliness tokens.
pub fn start(
    session: &Session,
    prefix: &str,
    board: Arc<Board>,
    expected_dt_s: f64,
) -> Result<Feed, FeedError> {
    start_with(
        session,
        prefix,
        board,
        expected_dt_s,
        Arc::new(LiveSources::default()),
    )
}

/// [`start`] following the publishers in `sources` (a test looks at them).
fn start_with(
    session: &Session,
    prefix: &str,
    board: Arc<Board>,
    expected_dt_s: f64,
    sources: Arc<LiveSources>,
) -> Result<Feed, FeedError> {
    let mut subscribers = Vec::new();
    // The tokens first, with those already alive: a message is checked against them.
    for key in token_keys(prefix) {
        let (sources, prefix) = (sources.clone(), prefix.to_string());
        let subscriber = session
            .liveliness()
            .declare_subscriber(key.clone())
            .history(true)
            .callback(move |sample| on_token(&sources, &prefix, &sample))
            .wait()
            .map_err(|e| FeedError {
                key,
                reason: e.to_string(),
            })?;
        subscribers.push(subscriber);
    }
    for tail in TAILS {
        let key = format!("{prefix}*/{tail}");
        let (board, sources, prefix) = (board.clone(), sources.clone(), prefix.to_string());
        let subscriber = session
            .declare_subscriber(key.clone())
            .callback(move |sample| on_sample(&board, &sources, &prefix, expected_dt_s, &sample))
            .wait()
            .map_err(|e| FeedError {
                key,
                reason: e.to_string(),
            })?;
        subscribers.push(subscriber);
    }
    let stop = Arc::new(AtomicBool::new(false));
    let resync = {
        let (session, sources, prefix, stop) =
            (session.clone(), sources, prefix.to_string(), stop.clone());
        std::thread::Builder::new()
            .name("display-tokens".into())
            .spawn(move || resync_tokens(session, sources, prefix, stop))
            .map_err(|e| FeedError {
                key: "(token resync thread)".into(),
                reason: e.to_string(),
            })?
    };
    Ok(Feed {
        _subscribers: subscribers,
        stop,
        resync: Some(resync),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression (review): any name a key carried was kept, 30 000 characters long or
    /// with markup in it.
    #[test]
    fn names_that_break_the_naming_rule_make_no_topic() {
        let long = "v".repeat(65);
        let longest = "v".repeat(64);
        for key in [
            format!("shipcast/{long}/forecast"),
            format!("shipcast/a/advisory/{long}"),
            "shipcast/<img src=x>/forecast".to_string(),
            "shipcast/a/advisory/de\"ck".to_string(),
        ] {
            assert_eq!(topic("shipcast/", &key), None, "{key}");
        }
        assert_eq!(
            topic("shipcast/", &format!("shipcast/{longest}/advisory/lift.2")),
            Some(Topic::Advisory {
                vessel: &longest,
                station: "lift.2"
            })
        );
    }

    #[test]
    fn keys_name_their_vessel_station_and_kind() {
        assert_eq!(
            topic("shipcast/", "shipcast/ddg51/forecast"),
            Some(Topic::Forecast { vessel: "ddg51" })
        );
        assert_eq!(
            topic("t1/shipcast/", "t1/shipcast/ffg7/advisory/deck"),
            Some(Topic::Advisory {
                vessel: "ffg7",
                station: "deck"
            })
        );
        assert_eq!(
            topic("t1/shipcast/", "t1/shipcast/a/verification"),
            Some(Topic::Verification { vessel: "a" })
        );
        for other in [
            "shipcast/ddg51/forecast/alive",
            "shipcast//forecast",
            "t2/shipcast/a/forecast",
            "shipcast/a/status/predictor",
            "shipcast/a/advisory/",
        ] {
            assert_eq!(
                topic(
                    if other.starts_with("t2") {
                        "t1/shipcast/"
                    } else {
                        "shipcast/"
                    },
                    other
                ),
                None,
                "{other}"
            );
        }
    }

    fn forecast_json(seq: u64) -> Vec<u8> {
        let mut f = Forecast {
            seq,
            time_s: 10.0,
            dt_s: 0.5,
            steps: 2,
            ..Forecast::default()
        };
        for d in 0..6 {
            f.sigma[d][..2].copy_from_slice(&[0.1, 0.2]);
        }
        let mut json = Vec::new();
        f.write_json(&mut json).unwrap();
        json
    }

    /// Regression: the display showed whatever any peer put on a vessel's key; now only the
    /// key's live publisher (its liveliness token) reaches the page, as for the deck.
    #[test]
    fn the_page_shows_only_the_live_publisher_of_a_vessels_key() {
        use shipcast_pipeline::transport::naming::unique_instance;
        use shipcast_pipeline::transport::zenoh::{
            free_loopback_endpoint, open, JsonPublisher, ZenohSettings,
        };

        let endpoint = free_loopback_endpoint().unwrap();
        let display = open(&ZenohSettings::listen_on(&endpoint)).unwrap();
        let vessel_side = open(&ZenohSettings::connect_to(&endpoint)).unwrap();
        let intruder = open(&ZenohSettings::connect_to(&endpoint)).unwrap();
        let prefix = format!("{}/shipcast/", unique_instance("feed"));
        let key = format!("{prefix}v1/forecast");
        let board = Arc::new(Board::new(
            crate::board::Limits {
                roll_deg: 5.0,
                pitch_deg: 3.0,
            },
            Duration::from_secs(60),
        ));
        let _feed = start(&display, &prefix, board.clone(), 0.5).unwrap();
        let shown = |board: &Board| {
            let s = board.snapshot(Instant::now());
            let v = s.vessels.first();
            (
                v.and_then(|v| v.forecast.as_ref().map(|f| f.seq)),
                v.map_or(0, |v| v.rejected),
            )
        };
        let wait_until = |what: &str, ok: &dyn Fn((Option<u64>, u64)) -> bool| {
            let deadline = Instant::now() + Duration::from_secs(20);
            while !ok(shown(&board)) {
                assert!(Instant::now() < deadline, "{what}: {:?}", shown(&board));
                std::thread::sleep(Duration::from_millis(20));
            }
        };

        let predictor = JsonPublisher::new(&vessel_side, &key).unwrap();
        // Until the display has the token and the subscription, puts may be refused or lost:
        // repeat with rising seq until one is shown.
        let mut seq = 10;
        let deadline = Instant::now() + Duration::from_secs(20);
        while shown(&board).0.is_none() {
            assert!(Instant::now() < deadline, "no forecast shown");
            predictor.put(&forecast_json(seq)).unwrap();
            seq += 1;
            std::thread::sleep(Duration::from_millis(50));
        }
        let rejected_before = shown(&board).1;

        // Naive injection: a put with no publisher id, and one that names the intruder itself.
        let forged = forecast_json(999_999);
        intruder.put(&key, forged.clone()).wait().unwrap();
        intruder
            .put(&key, forged.clone())
            .attachment(intruder.zid().to_string())
            .wait()
            .unwrap();
        wait_until("both forgeries refused", &|(_, r)| r >= rejected_before + 2);
        predictor.put(&forecast_json(seq)).unwrap();
        wait_until("the next real forecast shown", &|(s, _)| s == Some(seq));
        assert_eq!(shown(&board).1, rejected_before + 2);

        // The predictor's session stops publishing (its token goes): what it still puts under
        // its id is no longer shown.
        let predictor_id = vessel_side.zid().to_string();
        drop(predictor);
        let rejected_before = shown(&board).1;
        let deadline = Instant::now() + Duration::from_secs(20);
        while shown(&board).1 == rejected_before {
            assert!(
                Instant::now() < deadline,
                "a put after the token went was shown"
            );
            vessel_side
                .put(&key, forecast_json(seq + 100))
                .attachment(predictor_id.clone())
                .wait()
                .unwrap();
            std::thread::sleep(Duration::from_millis(50));
        }
        assert_eq!(shown(&board).0, Some(seq));
    }

    /// Regression: tokens on made-up keys filled the map of followed publishers, and a real
    /// publisher whose token came then was never followed, even after they went (zenoh
    /// announces a token once). Now the feed asks for every live token again until all fit.
    #[test]
    fn a_publisher_refused_while_junk_tokens_filled_the_map_is_heard_once_they_go() {
        use shipcast_pipeline::transport::naming::unique_instance;
        use shipcast_pipeline::transport::zenoh::{
            free_loopback_endpoint, liveliness_token, open, JsonPublisher, ZenohSettings,
        };

        let endpoint = free_loopback_endpoint().unwrap();
        let display = open(&ZenohSettings::listen_on(&endpoint)).unwrap();
        let vessel_side = open(&ZenohSettings::connect_to(&endpoint)).unwrap();
        let flooder = open(&ZenohSettings::connect_to(&endpoint)).unwrap();
        let prefix = format!("{}/shipcast/", unique_instance("flood"));
        let board = Arc::new(Board::new(
            crate::board::Limits {
                roll_deg: 5.0,
                pitch_deg: 3.0,
            },
            Duration::from_secs(60),
        ));
        let sources = Arc::new(LiveSources::default());
        let _feed = start_with(&display, &prefix, board.clone(), 0.5, sources.clone()).unwrap();
        let flood: Vec<_> = (0..crate::sources::MAX_KEYS)
            .map(|i| {
                let key = format!("{prefix}junk{i}/forecast/publisher/abc");
                liveliness_token(&flooder, &key).unwrap()
            })
            .collect();
        let wait = |what: &str, ok: &dyn Fn() -> bool| {
            let deadline = Instant::now() + Duration::from_secs(30);
            while !ok() {
                assert!(Instant::now() < deadline, "{what}");
                std::thread::sleep(Duration::from_millis(20));
            }
        };
        wait("the junk tokens fill the map", &|| {
            sources.len() == crate::sources::MAX_KEYS
        });
        let shown = || {
            let s = board.snapshot(Instant::now());
            let vessel = s.vessels.iter().find(|v| v.vessel == "v1").cloned();
            (
                vessel
                    .as_ref()
                    .and_then(|v| v.forecast.as_ref().map(|f| f.seq)),
                s.rejected_unheard + vessel.map_or(0, |v| v.rejected),
            )
        };
        let predictor = JsonPublisher::new(&vessel_side, &format!("{prefix}v1/forecast")).unwrap();
        let mut seq = 1;
        while shown().1 < 3 {
            predictor.put(&forecast_json(seq)).unwrap();
            seq += 1;
            std::thread::sleep(Duration::from_millis(50));
            assert!(seq < 600, "no put refused: {:?}", shown());
        }
        assert_eq!(shown().0, None, "a publisher with no room was followed");
        drop(flood);
        wait("the junk tokens go", &|| sources.is_empty());
        // At a resync the real publisher is followed and its forecasts shown (the deadline
        // is a hang guard, not a measure of how soon: test-quality review).
        let deadline = Instant::now() + Duration::from_secs(60);
        while shown().0.is_none() {
            assert!(Instant::now() < deadline, "still refused: {:?}", shown());
            predictor.put(&forecast_json(seq)).unwrap();
            seq += 1;
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    #[test]
    fn a_forecast_message_must_be_sound_json_with_the_expected_step() {
        let json = forecast_json(3);
        assert_eq!(parse_forecast(&json, 0.5).unwrap().seq, 3);
        assert!(parse_forecast(&json, 1.0).is_err(), "wrong step accepted");
        assert!(parse_forecast(b"{\"seq\":1}", 0.5).is_err());
        assert!(parse_forecast(&json[..json.len() / 2], 0.5).is_err());
    }
}
