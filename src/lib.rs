//! shipcast: predicts the six motions of a ship 5 to 25 seconds ahead and delivers the forecasts
//! over iceoryx2 (local, zero-copy) and zenoh (remote).
//!
//! The library holds everything; the `shipcast` binary (in `services/`) is thin wiring.
//! - [`dof`]: the six degrees of freedom and their names.
//! - [`motion_csv`]: the motion CSV format (DESIGN.md 2.3).
//! - [`signal`]: resampling (anti-alias low-pass, decimation).
//! - [`predict`]: the [`predict::Predictor`] trait and MCA, Wiener, AR-LMS, MLP and baselines.
//! - [`eval`]: the evaluation protocol (DESIGN.md 4).
//! - [`model`]: model files (per-DOF fitted predictors and held-out sigma).
//! - [`sim`]: the ship-motion simulator (sea spectra, RAOs, time series).
//! - [`paper`]: the paper study (`shipcast paper`).
//! - [`payload`]: the wire payloads `MotionSample` and `Forecast`.
//! - [`transport`]: service names, iceoryx2 and zenoh plumbing.
//! - [`config`]: the pipeline TOML configuration.
//! - [`deck`], [`crane`]: ship-point geometry, landing advisory, crane-tip forecast.

pub mod bench;
pub mod config;
pub mod crane;
pub mod deck;
pub mod dof;
pub mod eval;
pub mod model;
pub mod motion_csv;
pub mod paper;
pub mod payload;
pub mod predict;
pub mod signal;
pub mod sim;
pub mod transport;

pub use dof::Dof;
