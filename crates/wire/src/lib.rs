//! The types every shipcast process agrees on, and nothing else: an integrator who only reads
//! forecasts depends on this crate alone (no zenoh, faer or plotters).
//!
//! - [`dof`]: the six degrees of freedom and their names.
//! - [`payload`]: the iceoryx2 payloads [`payload::MotionSample`] and [`payload::Forecast`]
//!   (`#[repr(C)]`, type names `shipcast::MotionSample` / `shipcast::Forecast`), their limits
//!   and the owned JSON form of a forecast (docs/contracts.md section 2).
//! - [`payload_json`]: the allocation-free forecast JSON encoder used on the zenoh path.
//! - [`forecast_rows`]: the allocation-free parse of a received forecast's rows.
//! - [`shown`]: numbers as one-line messages show them.

pub mod dof;
pub mod forecast_rows;
pub mod payload;
pub mod payload_json;
pub mod shown;

pub use dof::Dof;
