//! The zenoh subscriptions that fill the board: one key expression per kind of message covers
//! every vessel (`[instance/]shipcast/*/forecast`, `.../verification`, `.../advisory/*`).
//!
//! Callbacks run on zenoh's threads and only parse, check and assign under the board's lock,
//! so the display never holds up zenoh, and a page that reads slowly never reaches back here.

use crate::board::{AdvisoryView, Board, VerificationIn};
use shipcast_pipeline::transport::forecast_check::check_content;
use shipcast_wire::payload::Forecast;
use std::sync::Arc;
use std::time::Instant;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;
use zenoh::{Session, Wait};

/// Why the feed could not start.
#[derive(Debug, thiserror::Error)]
#[error("subscribe to {key}: {reason}")]
pub struct FeedError {
    key: String,
    reason: String,
}

/// The running subscriptions; dropping it unsubscribes.
pub struct Feed {
    _subscribers: Vec<Subscriber<()>>,
}

/// What a key names after the fleet prefix (`[<instance>/]shipcast/`):
/// `<vessel>/<kind>[/<station>]`.
#[derive(Debug, PartialEq, Eq)]
pub enum Topic<'a> {
    Forecast { vessel: &'a str },
    Verification { vessel: &'a str },
    Advisory { vessel: &'a str, station: &'a str },
}

/// The topic of `key` under `prefix` (`Names::fleet_prefix`), or None for any other key.
pub fn topic<'a>(prefix: &str, key: &'a str) -> Option<Topic<'a>> {
    let rest = key.strip_prefix(prefix)?;
    let mut parts = rest.split('/');
    let vessel = parts.next().filter(|v| !v.is_empty())?;
    let topic = match (parts.next()?, parts.next(), parts.next()) {
        ("forecast", None, None) => Topic::Forecast { vessel },
        ("verification", None, None) => Topic::Verification { vessel },
        ("advisory", Some(station), None) if !station.is_empty() => {
            Topic::Advisory { vessel, station }
        }
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

fn on_sample(board: &Board, prefix: &str, expected_dt_s: f64, sample: &Sample) {
    let key = sample.key_expr().as_str();
    let Some(topic) = topic(prefix, key) else {
        return;
    };
    let bytes = sample.payload().to_bytes();
    match topic {
        Topic::Forecast { vessel } => match parse_forecast(&bytes, expected_dt_s) {
            Ok(f) => {
                let publisher = sample
                    .attachment()
                    .and_then(|a| a.try_to_string().ok().map(|t| t.into_owned()));
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
                board.verification(vessel, &report);
            }
            Err(e) => {
                board.reject(vessel);
                tracing::debug!("display: {vessel}: refused verification: {e}");
            }
        },
        Topic::Advisory { vessel, station } => {
            match serde_json::from_slice::<AdvisoryView>(&bytes) {
                Ok(a) => board.advisory(vessel, station, a, Instant::now()),
                Err(e) => {
                    board.reject(vessel);
                    tracing::debug!("display: {vessel}/{station}: refused advisory: {e}");
                }
            }
        }
    }
}

/// Subscribe to every vessel's forecasts, verification and advisories under `prefix`
/// (`Names::fleet_prefix`).
pub fn start(
    session: &Session,
    prefix: &str,
    board: Arc<Board>,
    expected_dt_s: f64,
) -> Result<Feed, FeedError> {
    let mut subscribers = Vec::new();
    for tail in ["forecast", "verification", "advisory/*"] {
        let key = format!("{prefix}*/{tail}");
        let (board, prefix) = (board.clone(), prefix.to_string());
        let subscriber = session
            .declare_subscriber(key.clone())
            .callback(move |sample| on_sample(&board, &prefix, expected_dt_s, &sample))
            .wait()
            .map_err(|e| FeedError {
                key,
                reason: e.to_string(),
            })?;
        subscribers.push(subscriber);
    }
    Ok(Feed {
        _subscribers: subscribers,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn a_forecast_message_must_be_sound_json_with_the_expected_step() {
        let mut f = Forecast {
            seq: 3,
            time_s: 10.0,
            dt_s: 0.5,
            steps: 2,
            model_version: 1,
            ..Forecast::default()
        };
        for d in 0..6 {
            f.sigma[d][..2].copy_from_slice(&[0.1, 0.2]);
        }
        let mut json = Vec::new();
        f.write_json(&mut json).unwrap();
        assert_eq!(parse_forecast(&json, 0.5).unwrap().seq, 3);
        assert!(parse_forecast(&json, 1.0).is_err(), "wrong step accepted");
        assert!(parse_forecast(b"{\"seq\":1}", 0.5).is_err());
        assert!(parse_forecast(&json[..json.len() / 2], 0.5).is_err());
    }
}
