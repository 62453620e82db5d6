//! `[producer]`: where motion comes from and how fast it is published.

use serde::{Deserialize, Serialize};
use shipcast_sim::{Scenario, Station};
use std::path::PathBuf;

/// Where motion comes from and how fast it is published.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProducerConfig {
    /// Replay this motion CSV instead of simulating.
    pub input: Option<PathBuf>,
    /// Simulated sea and ship.
    pub scenario: Scenario,
    pub seed: u64,
    /// Sample rate of the simulator [Hz].
    pub rate_hz: f64,
    /// Pacing: 1 = real time, 100 = a hundred times faster, 0 = as fast as possible.
    pub speed: f64,
    /// Stop after this much record time [s]; none = endless (simulator) or end of file.
    pub record_s: Option<f64>,
    /// Publish the first this-many seconds of record at `backfill_speed` before pacing at
    /// `speed`: a sensor handing over its recent log, so forecasts can start without waiting
    /// for `order` values of history in real time.
    pub backfill_s: f64,
    pub backfill_speed: f64,
    /// Where the simulated vessel keeps station in the sea of `scenario` and `seed`, relative
    /// to the reference vessel (x_m forward, y_m starboard, heading_offset_deg to starboard);
    /// the default is the reference vessel itself.
    pub station: Station,
}

impl Default for ProducerConfig {
    fn default() -> Self {
        Self {
            input: None,
            scenario: Scenario::Paper,
            seed: 1,
            rate_hz: 8.0,
            speed: 1.0,
            record_s: None,
            backfill_s: 240.0,
            backfill_speed: 50.0,
            station: Station::REFERENCE,
        }
    }
}
