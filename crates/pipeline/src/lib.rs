//! The running system: what the `shipcast` services are made of.
//!
//! - [`config`]: the pipeline TOML configuration (schema, defaults, validation).
//! - [`transport`]: service names, iceoryx2 and zenoh plumbing, security, receive checks.
//! - [`engine`]: the forecasting engine the predictor service, `shipcast replay` and the latency
//!   bench drive (ingest, model set, retraining, verification, calibration).
//! - [`deck`], [`crane`]: ship-point geometry, landing advisory, crane-tip forecast.
//! - [`relative`]: ship-to-ship relative motion (crane tip against a landing spot), its
//!   calibrated sigma, the lift go/no-go and the two-ship study.
//! - [`observed`]: a vessel's observed motion kept by time, which live verification looks
//!   outcomes up in (the deck, the relative service), and its new-run reset.
//! - [`limits`]: range checks of numeric command-line values and configuration keys.
//! - [`pending`]: forecasts waiting for their outcome, the queue the crane's and the relative
//!   service's verifiers keep.
//! - [`sigma_scale`]: a sigma's scale per axis and step from verified standardised errors.
//! - [`child`], [`pacing`]: child processes that are always stopped and reaped, and paced loops.
//! - [`certs`]: the CA and certificates of a secure setup (`shipcast certs`).

pub mod certs;
pub mod child;
pub mod config;
pub mod crane;
pub mod decision;
pub mod deck;
pub mod engine;
pub mod limits;
pub mod observed;
pub mod pacing;
pub mod pending;
pub mod relative;
pub mod sigma_scale;
pub mod transport;
