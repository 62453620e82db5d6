//! What the predictor reports about itself on zenoh `.../status/predictor`, once a second: one
//! type for the predictor that writes it and for `shipcast run`'s live view that reads it, so a
//! renamed field fails to compile instead of showing nothing (review: the view looked fields
//! up by name in untyped JSON).

use crate::engine::EngineCounts;
use crate::transport::counters::Counters;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PredictorStatus {
    pub counters: Counters,
    pub engine: EngineCounts,
    /// No motion sample for longer than the stale limit.
    pub stale: bool,
    pub model_version: u32,
    /// Forecasts published.
    pub forecasts: u64,
    /// Values of live history held.
    pub history: usize,
    /// The running models' order (0 without models).
    pub order: usize,
    /// The running models, described (`none` without).
    pub models: String,
    /// Record time of the newest sample taken in.
    pub last_time_s: f64,
    /// Delay of a forecast's `time_s` behind the newest sample (the decimation filter's): the
    /// lead of step k after the newest sample is `k * dt_s - delay_s`.
    pub delay_s: f64,
    /// zenoh clients refused by this process, per reason (TLS or user/password;
    /// `transport::zenoh_refusals`).
    #[serde(default)]
    pub refused_clients: BTreeMap<String, u64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the predictor writes is what the view reads back, every field.
    #[test]
    fn a_status_round_trips_through_its_json() {
        let mut status = PredictorStatus {
            stale: true,
            model_version: 3,
            forecasts: 120,
            history: 800,
            order: 200,
            models: "wiener-200".into(),
            last_time_s: 61.5,
            delay_s: 0.5,
            ..PredictorStatus::default()
        };
        status.counters.received = 9;
        status.counters.rejected_source = 2;
        status.engine.swaps = 4;
        status.engine.implausible[2] = 7;
        status.refused_clients.insert("tls".into(), 1);
        let text = serde_json::to_string(&status).unwrap();
        let back: PredictorStatus = serde_json::from_str(&text).unwrap();
        assert_eq!(back, status);
    }
}
