//! The running system: what the `shipcast` services are made of.
//!
//! - [`config`]: the pipeline TOML configuration (schema, defaults, validation).
//! - [`transport`]: service names, iceoryx2 and zenoh plumbing, security, receive checks.
//! - [`engine`]: the forecasting engine the predictor service, `shipcast replay` and the latency
//!   bench drive (ingest, model set, retraining, verification, calibration).
//! - [`deck`], [`crane`]: ship-point geometry, landing advisory, crane-tip forecast.
//! - [`limits`]: range checks of numeric command-line values and configuration keys.
//! - [`child`], [`pacing`]: child processes that are always stopped and reaped, and paced loops.
//! - [`certs`]: the CA and certificates of a secure setup (`shipcast certs`).

pub mod certs;
pub mod child;
pub mod config;
pub mod crane;
pub mod deck;
pub mod decision;
pub mod engine;
pub mod limits;
pub mod pacing;
pub mod transport;
