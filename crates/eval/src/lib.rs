//! The evaluation protocol of docs/contracts.md section 4, exactly: fit on the training segment
//! `x[0..T)`, forecast from `x[o - order .. o)` at origins `o = T + order, T + order + stride, ...`
//! while `o + H <= len`, RMS error per step, normalised by the standard deviation of the test
//! segment, next to persistence at the same origins.
//!
//! - [`protocol`]: the scoring loop (also gives the held-out sigma for model files), plain or
//!   with the forecasts of the same instant averaged.
//! - [`run`]: one [`Entry`] per (dof, method), with noise and the JSON record.
//! - [`noise`]: seeded Gaussian measurement noise.
//! - [`report`]: the human-readable table.
//! - [`model`]: model files (per-DOF fitted predictors and held-out sigma).
//! - [`progress`]: how long jobs report progress (the CLI draws the bar).

pub mod model;
pub mod noise;
pub mod progress;
pub mod protocol;
pub mod report;
pub mod run;

pub use noise::add_noise;
pub use protocol::{
    forecast_sigma, origins, score_averaged_forecasts, score_forecasts, score_with_average,
    EvalError, OnlineFeed, Scores,
};
pub use run::{
    evaluate_method, evaluate_record, origin_count, prepare_series, std_dev, Entry, EvalFailure,
    EvalResult, EvalSettings, PreparedSeries, RecordError,
};

#[cfg(test)]
mod average_tests;
#[cfg(test)]
mod tests;
