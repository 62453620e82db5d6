//! The hub of a fleet: a zenoh router (zenoh's own router mode) that vessels' predictors connect
//! to and shore consumers subscribe through, with the latest forecast of every vessel kept and
//! served to queries so a late joiner has one at once.

use crate::transport::zenoh::{zenoh_config, Mode, ZenohError, ZenohSettings};
use std::collections::BTreeMap;
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

type Latest = Arc<Mutex<BTreeMap<String, (ZBytes, Encoding)>>>;

/// A running router; it stops when dropped.
pub struct FleetRouter {
    pub session: Session,
    latest: Latest,
    _subscriber: Subscriber<()>,
    _queryable: Queryable<()>,
}

impl FleetRouter {
    /// Open a router with `settings` (its mode is forced to router) that keeps and serves the
    /// latest sample of every key matching `forecasts`.
    pub fn start(settings: &ZenohSettings, forecasts: &str) -> Result<Self, ZenohError> {
        let settings = ZenohSettings {
            mode: Mode::Router,
            ..settings.clone()
        };
        let err = |context: String| {
            move |e: zenoh::Error| ZenohError {
                context,
                detail: e.to_string(),
            }
        };
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
        let store = latest.clone();
        let subscriber = session
            .declare_subscriber(forecasts.to_string())
            .callback(move |sample| {
                if let Ok(mut map) = store.lock() {
                    map.insert(
                        sample.key_expr().as_str().to_string(),
                        (sample.payload().clone(), sample.encoding().clone()),
                    );
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
            _subscriber: subscriber,
            _queryable: queryable,
        })
    }

    /// How many keys have a latest sample.
    pub fn keys_seen(&self) -> usize {
        self.latest.lock().map(|m| m.len()).unwrap_or(0)
    }
}
