//! shipcast: predicts the six motions of a ship 5 to 25 seconds ahead and delivers the forecasts
//! over iceoryx2 (local, zero-copy) and zenoh (remote).
//!
//! The library holds everything; the `shipcast` binary (in `services/`) is thin wiring.
//! - [`dof`]: the six degrees of freedom and their names.
//! - [`motion_csv`]: the motion CSV format (docs/contracts.md section 2.3).
//! - [`signal`]: resampling (anti-alias low-pass, decimation).
//! - [`predict`]: the [`predict::Predictor`] trait and MCA, Wiener, AR-LMS, MLP and baselines.
//! - [`eval`]: the evaluation protocol (docs/contracts.md section 4).
//! - [`engine`]: the forecasting engine the predictor service and `shipcast replay` drive.
//! - [`model`]: model files (per-DOF fitted predictors and held-out sigma).
//! - [`sim`]: the ship-motion simulator (sea spectra, RAOs, time series).
//! - [`paper`]: the paper study (`shipcast paper`).
//! - [`payload`]: the wire payloads `MotionSample` and `Forecast`.
//! - [`transport`]: service names, iceoryx2 and zenoh plumbing.
//! - [`config`]: the pipeline TOML configuration.
//! - [`deck`], [`crane`]: ship-point geometry, landing advisory, crane-tip forecast.
//! - [`decision`]: landing go/no-go over a minimum operation time, with the joint probability
//!   that every limit holds, and its scoring against a record.
//! - [`bench`]: the latency harness (`shipcast bench latency`).
//!
//! # Example: fit a predictor and forecast
//!
//! Every method sits behind one trait; `forecast` writes into a caller's buffer and never
//! allocates. A sum of a few sinusoids is extrapolated almost exactly by a linear predictor:
//!
//! ```
//! use shipcast::predict::{AnyPredictor, Method, Predictor, PredictorConfig};
//!
//! let x: Vec<f64> = (0..3000)
//!     .map(|t| {
//!         let t = t as f64 * 0.5; // 2 Hz
//!         (0.6 * t).sin() + 0.5 * (0.9 * t + 1.0).sin()
//!     })
//!     .collect();
//! let config = PredictorConfig { order: 100, horizon: 20, ..PredictorConfig::default() };
//! let mut wiener = AnyPredictor::new(Method::Wiener, &config).unwrap();
//! wiener.fit(&x[..2000]).unwrap();
//!
//! let mut out = [0.0; 20];
//! wiener.forecast(&x[..2500], &mut out).unwrap();
//! for (h, predicted) in out.iter().enumerate() {
//!     assert!((predicted - x[2500 + h]).abs() < 0.05, "step {}", h + 1);
//! }
//! ```

pub mod bench;
pub mod config;
pub mod crane;
pub mod decision;
pub mod deck;
pub mod dof;
pub mod engine;
pub mod eval;
pub mod model;
pub mod motion_csv;
pub mod paper;
pub mod payload;
pub mod payload_json;
pub mod predict;
pub mod progress;
pub mod signal;
pub mod sim;
pub mod transport;

pub use dof::Dof;
