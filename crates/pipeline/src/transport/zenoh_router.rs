//! The hub of a fleet: a zenoh router (zenoh's own router mode) that vessels' predictors connect
//! to and shore consumers subscribe through, with the latest forecast of every vessel kept and
//! served to queries so a late joiner has one at once.

use crate::transport::zenoh::{zenoh_config, Mode, ZenohError, ZenohSettings};
use shipcast_wire::payload_json::MAX_JSON_LEN;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use zenoh::bytes::{Encoding, ZBytes};
use zenoh::key_expr::KeyExpr;
use zenoh::pubsub::Subscriber;
use zenoh::query::Queryable;
use zenoh::{Session, Wait};

/// Batches in the queue of each of the router's links for data-priority messages.
const ROUTER_DATA_QUEUE_BATCHES: usize = 16;

/// Default key expression of every vessel's forecast.
pub const FLEET_FORECASTS: &str = "shipcast/*/forecast";

/// Keys whose latest forecast the router keeps (a fleet of vessels, with room to spare): any
/// peer that may put on the forecast keys can make up vessel names, and without a bound each
/// would be kept for good.
pub const MAX_LATEST_KEYS: usize = 4096;

type Latest = Arc<Mutex<BTreeMap<String, (ZBytes, Encoding)>>>;

/// A running router; it stops when dropped.
pub struct FleetRouter {
    pub session: Session,
    latest: Latest,
    /// Samples not kept (forwarded all the same): on a new key with the map full, or longer
    /// than any forecast.
    refused: Arc<AtomicU64>,
    _subscriber: Subscriber<()>,
    _queryable: Queryable<()>,
}

impl FleetRouter {
    /// Open a router with `settings` (its mode is forced to router) that keeps and serves the
    /// latest sample of every key matching `forecasts`.
    pub fn start(settings: &ZenohSettings, forecasts: &str) -> Result<Self, ZenohError> {
        Self::start_keeping(settings, forecasts, MAX_LATEST_KEYS)
    }

    /// [`FleetRouter::start`], keeping the latest sample of at most `max_keys` keys.
    pub fn start_keeping(
        settings: &ZenohSettings,
        forecasts: &str,
        max_keys: usize,
    ) -> Result<Self, ZenohError> {
        let settings = ZenohSettings {
            mode: Mode::Router,
            ..settings.clone()
        };
        let err = |context: String| ZenohError::on::<zenoh::Error>(context);
        let mut config = zenoh_config(&settings)?;
        // Forecasts are express puts, and zenoh sends each express message in a batch of its
        // own, so a link's queue of 2 batches (zenoh's default) holds only 2 forecasts. On the
        // router's link to a shore that carries every vessel (400 forecasts/s for 200 vessels)
        // a stall of a few milliseconds then dropped forecasts; 16 batches (zenoh's maximum)
        // ride out about 40 ms. Memory is a batch per slot and link, taken as needed.
        config
            .insert_json5(
                "transport/link/tx/queue/size/data",
                &ROUTER_DATA_QUEUE_BATCHES.to_string(),
            )
            .map_err(err(
                "router: config transport/link/tx/queue/size/data".into()
            ))?;
        let session = zenoh::open(config)
            .wait()
            .map_err(err(format!("router: open on {:?}", settings.listen)))?;
        let latest: Latest = Arc::default();
        let refused = Arc::new(AtomicU64::new(0));
        let store = latest.clone();
        let refusals = refused.clone();
        let subscriber = session
            .declare_subscriber(forecasts.to_string())
            .callback(move |sample| {
                let key = sample.key_expr().as_str();
                // No forecast is this long: a stranger's large put would be kept and served
                // to every late joiner (review).
                if sample.payload().len() > MAX_JSON_LEN {
                    let n = refusals.fetch_add(1, Ordering::Relaxed) + 1;
                    if n == 1 || n.is_multiple_of(1000) {
                        tracing::warn!(
                            key,
                            refused = n,
                            len = sample.payload().len(),
                            "router: a sample longer than any forecast is not kept (still forwarded)"
                        );
                    }
                    return;
                }
                let Ok(mut map) = store.lock() else { return };
                let value = (sample.payload().clone(), sample.encoding().clone());
                if let Some(slot) = map.get_mut(key) {
                    *slot = value;
                } else if map.len() < max_keys {
                    map.insert(key.to_string(), value);
                } else {
                    let n = refusals.fetch_add(1, Ordering::Relaxed) + 1;
                    if n == 1 || n.is_multiple_of(1000) {
                        tracing::warn!(
                            key,
                            refused = n,
                            "router: {max_keys} forecast keys kept already: a new key's latest sample is not kept (still forwarded)"
                        );
                    }
                }
            })
            .wait()
            .map_err(err(format!("router: subscribe to '{forecasts}'")))?;
        let serve = latest.clone();
        let queryable = session
            .declare_queryable(forecasts.to_string())
            .callback(move |query| {
                let Ok(map) = serve.lock() else { return };
                for (key, (payload, encoding)) in map.iter() {
                    let Ok(k) = KeyExpr::try_from(key.as_str()) else {
                        continue;
                    };
                    if query.key_expr().intersects(&k) {
                        if let Err(e) = query
                            .reply(k, payload.clone())
                            .encoding(encoding.clone())
                            .wait()
                        {
                            tracing::debug!("router: reply on {key}: {e}");
                        }
                    }
                }
            })
            .wait()
            .map_err(err(format!("router: serve queries on '{forecasts}'")))?;
        Ok(Self {
            session,
            latest,
            refused,
            _subscriber: subscriber,
            _queryable: queryable,
        })
    }

    /// How many keys have a latest sample.
    pub fn keys_seen(&self) -> usize {
        self.latest.lock().map(|m| m.len()).unwrap_or(0)
    }

    /// Samples not kept: on a new key with `max_keys` keys kept already, or longer than any
    /// forecast.
    pub fn keys_refused(&self) -> u64 {
        self.refused.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pacing::poll_until;
    use crate::transport::zenoh::{self as zn, free_loopback_endpoint};
    use std::time::Duration;

    /// A router keeping `max_keys` keys under a prefix of its own, a client of it, its
    /// forecast keys' expression, and the forecast key of vessel `v`.
    fn router_and_client(
        tag: &str,
        max_keys: usize,
    ) -> (FleetRouter, Session, String, impl Fn(&str) -> String) {
        let endpoint = free_loopback_endpoint().unwrap();
        let prefix = format!("{tag}-{}", std::process::id());
        let forecasts = format!("{prefix}/shipcast/*/forecast");
        let router =
            FleetRouter::start_keeping(&ZenohSettings::listen_on(&endpoint), &forecasts, max_keys)
                .unwrap();
        let client = zn::open(&ZenohSettings {
            mode: Mode::Client,
            ..ZenohSettings::connect_to(&endpoint)
        })
        .unwrap();
        let key = move |v: &str| format!("{prefix}/shipcast/{v}/forecast");
        (router, client, forecasts, key)
    }

    #[test]
    fn the_router_keeps_at_most_max_keys_latest_forecasts() {
        let (router, client, forecasts, key) = router_and_client("router-cap", 2);
        // Puts are asynchronous: send until the router has seen what it should.
        let settled = poll_until(Duration::from_secs(20), Duration::from_millis(50), || {
            for v in ["a", "b", "c"] {
                client.put(key(v), v).wait().ok()?;
            }
            (router.keys_seen() == 2 && router.keys_refused() > 0).then_some(())
        });
        assert!(
            settled.is_some(),
            "{} {}",
            router.keys_seen(),
            router.keys_refused()
        );
        // Two vessels' latest forecasts are served, the third's is not kept.
        let replies = client.get(forecasts.clone()).wait().unwrap();
        let mut served = Vec::new();
        while let Ok(Some(reply)) = replies.recv_timeout(Duration::from_secs(5)) {
            if let Ok(sample) = reply.result() {
                served.push(sample.key_expr().as_str().to_string());
            }
        }
        served.sort();
        served.dedup();
        assert_eq!(served.len(), 2, "{served:?}");
        assert_eq!(router.keys_seen(), 2);
    }

    /// Regression (review): the router kept the latest put of any length on every forecast
    /// key and served it to each late joiner.
    #[test]
    fn a_sample_longer_than_any_forecast_is_not_kept() {
        let (router, client, _, key) = router_and_client("router-long", MAX_LATEST_KEYS);
        let settled = poll_until(Duration::from_secs(20), Duration::from_millis(50), || {
            client
                .put(key("long"), vec![b'x'; MAX_JSON_LEN + 1])
                .wait()
                .ok()?;
            client
                .put(key("short"), vec![b'x'; MAX_JSON_LEN])
                .wait()
                .ok()?;
            (router.keys_seen() == 1 && router.keys_refused() > 0).then_some(())
        });
        assert!(
            settled.is_some(),
            "{} {}",
            router.keys_seen(),
            router.keys_refused()
        );
        let kept = router.latest.lock().unwrap();
        assert_eq!(kept.keys().collect::<Vec<_>>(), [&key("short")]);
    }
}
