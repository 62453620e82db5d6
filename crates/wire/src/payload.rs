//! Wire payloads (docs/contracts.md section 2.1): `MotionSample` and `Forecast` as fixed-layout
//! `#[repr(C)]` structs shared over iceoryx2, and the JSON form of `Forecast` sent over zenoh
//! (section 2.2).
//!
//! The layouts are part of the contract with C, C++ and Python readers: field order, types and
//! sizes must not change. Every limit of the transports (buffers, history, number of ports) lives
//! in [`limits`], so that all processes of a pipeline agree on them.

use crate::forecast_rows::Rows;
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};

/// Number of degrees of freedom carried in every payload.
pub const NUM_DOF: usize = 6;

/// Capacity of the forecast arrays; `Forecast::steps` says how many are valid.
pub const MAX_STEPS: usize = 128;

/// Transport limits, in one place. The process that creates a service sets them; every opener
/// asks for the same values so that whichever process starts first creates a compatible service.
pub mod limits {
    /// Samples a motion subscriber can hold before the oldest is overwritten. At 8 Hz this is
    /// 32 s of motion: a predictor that stalls briefly loses nothing, a dead one never blocks
    /// the producer (safe overflow).
    pub const MOTION_BUFFER: usize = 256;
    /// Motion samples replayed to a late subscriber (iceoryx2 connects ports lazily).
    pub const MOTION_HISTORY: usize = 16;
    /// Forecasts a subscriber can hold; consumers only need the newest.
    pub const FORECAST_BUFFER: usize = 8;
    /// Forecasts replayed to a late subscriber, so a consumer starts with the latest one.
    pub const FORECAST_HISTORY: usize = 1;
    /// Publishers per service: one live producer/predictor plus one not yet cleaned after a crash.
    pub const MAX_PUBLISHERS: usize = 4;
    /// Subscribers per service (predictor, deck, monitors, tests, external readers).
    pub const MAX_SUBSCRIBERS: usize = 16;
    /// Processes that may hold a service open at once.
    pub const MAX_NODES: usize = 32;
    /// Notifiers and listeners of each wake-up event service.
    pub const MAX_NOTIFIERS: usize = 4;
    pub const MAX_LISTENERS: usize = 16;
    /// Ring channel of a zenoh "latest forecast" subscriber: older forecasts are dropped
    /// instead of blocking zenoh's receive thread.
    pub const ZENOH_RING: usize = 4;
}

/// One motion measurement of the six degrees of freedom (72 bytes). Its zenoh JSON form
/// (`.../motion`, docs/contracts.md section 2.2) has the same field names.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend, Serialize, Deserialize)]
#[type_name("shipcast::MotionSample")]
#[repr(C)]
pub struct MotionSample {
    /// 0, 1, 2, ... per producer run; a gap means a lost sample.
    pub seq: u64,
    /// CLOCK_MONOTONIC when the sample was taken or published.
    pub stamp_ns: u64,
    /// Time on the record's own clock (simulation or file time).
    pub time_s: f64,
    /// Surge, sway, heave [m]; roll, pitch, yaw [rad].
    pub dof: [f64; NUM_DOF],
}

/// Largest magnitude of a motion value a sample may carry [m or rad]. No ship moves a thousand
/// kilometres or turns a million radians from its mean: a value beyond is a fault (a sensor,
/// a unit, a corrupt file), and its square would swamp every running mean square and sum of
/// squares the predictor keeps (1e200 squares to infinity and leaves NaN behind for the rest
/// of the run). Time is not bounded: a record may keep epoch seconds.
pub const MAX_ABS_MOTION: f64 = 1.0e6;

impl MotionSample {
    /// True if the time and every DOF value are finite.
    pub fn is_finite(&self) -> bool {
        self.time_s.is_finite() && self.dof.iter().all(|v| v.is_finite())
    }

    /// True if the sample can be used: finite, and every DOF value within
    /// [`MAX_ABS_MOTION`].
    pub fn is_sound(&self) -> bool {
        self.is_finite() && self.dof.iter().all(|v| v.abs() <= MAX_ABS_MOTION)
    }

    /// Parse the JSON form: exactly the four fields, `dof` six numbers. A non-finite value
    /// cannot be written in JSON (serde_json writes `null`), so it fails here too.
    pub fn from_json(bytes: &[u8]) -> Result<Self, serde_json::Error> {
        serde_json::from_slice(bytes)
    }
}

/// A forecast of all six DOF, `steps` values each, spaced `dt_s` after `time_s`.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("shipcast::Forecast")]
#[repr(C)]
pub struct Forecast {
    /// Forecast counter.
    pub seq: u64,
    /// seq of the newest MotionSample used.
    pub source_seq: u64,
    /// Its stamp_ns, copied, for end-to-end latency.
    pub source_stamp_ns: u64,
    /// CLOCK_MONOTONIC when the forecast was computed, just before it is sent (the path
    /// `sample-to-forecast-published` of `shipcast bench latency` ends there).
    pub issued_stamp_ns: u64,
    /// Record time of the newest decimated value used (the decimation filter's delay before the
    /// newest sample); step k (1-based) is at time_s + k * dt_s.
    pub time_s: f64,
    /// Spacing of the forecast steps.
    pub dt_s: f64,
    /// Valid steps, at most MAX_STEPS.
    pub steps: u32,
    /// One more at every model put in use (a retrained model that the running one outscores
    /// takes no number).
    pub model_version: u32,
    /// Predicted motion per DOF, same units as MotionSample.
    pub mean: [[f32; MAX_STEPS]; NUM_DOF],
    /// Expected RMS error per DOF and step: from the errors verified live (held-out data until
    /// there are enough of them), times the shape factor that matches +-1 and +-2 sigma
    /// coverage (docs/forecasting.md).
    pub sigma: [[f32; MAX_STEPS]; NUM_DOF],
}

impl Default for Forecast {
    fn default() -> Self {
        Self {
            seq: 0,
            source_seq: 0,
            source_stamp_ns: 0,
            issued_stamp_ns: 0,
            time_s: 0.0,
            dt_s: 0.0,
            steps: 0,
            model_version: 0,
            mean: [[0.0; MAX_STEPS]; NUM_DOF],
            sigma: [[0.0; MAX_STEPS]; NUM_DOF],
        }
    }
}

impl Forecast {
    /// Valid steps, clamped to the array capacity so a corrupt `steps` cannot index out of
    /// bounds.
    pub fn valid_steps(&self) -> usize {
        (self.steps as usize).min(MAX_STEPS)
    }

    /// The valid part of the mean forecast of one DOF.
    pub fn mean_of(&self, dof: usize) -> &[f32] {
        &self.mean[dof][..self.valid_steps()]
    }

    /// The valid part of the sigma of one DOF.
    pub fn sigma_of(&self, dof: usize) -> &[f32] {
        &self.sigma[dof][..self.valid_steps()]
    }

    /// The JSON view of this forecast (arrays cut to `steps`); serialising it does not copy
    /// the arrays.
    pub fn json_view(&self) -> ForecastJsonView<'_> {
        let steps = self.valid_steps();
        ForecastJsonView {
            seq: self.seq,
            source_seq: self.source_seq,
            source_stamp_ns: self.source_stamp_ns,
            issued_stamp_ns: self.issued_stamp_ns,
            time_s: self.time_s,
            dt_s: self.dt_s,
            steps: steps as u32,
            model_version: self.model_version,
            mean: std::array::from_fn(|d| &self.mean[d][..steps]),
            sigma: std::array::from_fn(|d| &self.sigma[d][..steps]),
        }
    }

    /// Serialise the JSON form into `out` (cleared first), reusing its allocation.
    pub fn write_json(&self, out: &mut Vec<u8>) -> Result<(), serde_json::Error> {
        out.clear();
        serde_json::to_writer(out, &self.json_view())
    }

    /// Parse the JSON form. Fails with a one-line reason on malformed JSON, more than
    /// MAX_STEPS steps, arrays whose length differs from `steps`, or a DOF count other than 6.
    pub fn from_json(bytes: &[u8]) -> Result<Self, PayloadError> {
        let json: ForecastJson = serde_json::from_slice(bytes)?;
        json.try_into()
    }
}

/// Why a JSON payload was rejected. The parser's error is in the message, not chained as a
/// `source`, so `{:#}` prints it once.
#[derive(Debug, thiserror::Error)]
pub enum PayloadError {
    #[error("forecast JSON: {0}")]
    Json(serde_json::Error),
    #[error("forecast JSON: {0}")]
    Shape(String),
}

impl From<serde_json::Error> for PayloadError {
    fn from(error: serde_json::Error) -> Self {
        PayloadError::Json(error)
    }
}

/// Borrowed JSON form of a forecast, for serialising without copies.
#[derive(Debug, Serialize)]
pub struct ForecastJsonView<'a> {
    pub seq: u64,
    pub source_seq: u64,
    pub source_stamp_ns: u64,
    pub issued_stamp_ns: u64,
    pub time_s: f64,
    pub dt_s: f64,
    pub steps: u32,
    pub model_version: u32,
    pub mean: [&'a [f32]; NUM_DOF],
    pub sigma: [&'a [f32]; NUM_DOF],
}

/// JSON form of a forecast, as received over zenoh (its rows parsed in place, no heap
/// allocation: [`crate::forecast_rows`]).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForecastJson {
    pub seq: u64,
    pub source_seq: u64,
    pub source_stamp_ns: u64,
    pub issued_stamp_ns: u64,
    pub time_s: f64,
    pub dt_s: f64,
    pub steps: u32,
    pub model_version: u32,
    pub mean: Rows,
    pub sigma: Rows,
}

impl TryFrom<ForecastJson> for Forecast {
    type Error = PayloadError;

    fn try_from(json: ForecastJson) -> Result<Self, PayloadError> {
        let steps = json.steps as usize;
        if steps > MAX_STEPS {
            return Err(PayloadError::Shape(format!(
                "steps {steps} exceeds the maximum {MAX_STEPS}"
            )));
        }
        let mut f = Forecast {
            seq: json.seq,
            source_seq: json.source_seq,
            source_stamp_ns: json.source_stamp_ns,
            issued_stamp_ns: json.issued_stamp_ns,
            time_s: json.time_s,
            dt_s: json.dt_s,
            steps: json.steps,
            model_version: json.model_version,
            ..Forecast::default()
        };
        for (name, rows, dst) in [
            ("mean", &json.mean, &mut f.mean),
            ("sigma", &json.sigma, &mut f.sigma),
        ] {
            if rows.count != NUM_DOF {
                return Err(PayloadError::Shape(format!(
                    "'{name}' has {} rows, expected {NUM_DOF}",
                    rows.count
                )));
            }
            for (d, (row, &len)) in rows.values.iter().zip(&rows.lens).enumerate() {
                if len != steps {
                    return Err(PayloadError::Shape(format!(
                        "'{name}' row {d} has {len} values, expected steps = {steps}"
                    )));
                }
                dst[d][..steps].copy_from_slice(&row[..steps]);
            }
        }
        Ok(f)
    }
}

/// A station's go/no-go decision on one forecast (docs/decisions.md), for local readers over
/// iceoryx2 on `shipcast/<vessel>/advisory/<station>` (80 bytes): the `decision` of the JSON
/// advisory, with NaN where that has `null`. Times are seconds after the forecast's `time_s`.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("shipcast::DecisionSample")]
#[repr(C)]
pub struct DecisionSample {
    /// seq of the forecast decided on.
    pub forecast_seq: u64,
    /// CLOCK_MONOTONIC when the decision was published.
    pub stamp_ns: u64,
    /// The forecast's `time_s` (record time).
    pub time_s: f64,
    /// Minimum operation time [s] and the go threshold.
    pub mot_s: f64,
    pub go_probability: f64,
    /// Probability that every limit holds over the window of MOT from the first step (NaN:
    /// the horizon is shorter than MOT).
    pub probability_now: f64,
    /// Start of the first window of MOT reaching the threshold, and its probability.
    pub next_window_s: f64,
    pub next_window_probability: f64,
    /// First predicted exceedance of a limit.
    pub next_exceedance_s: f64,
    /// 1: go now, 0: no-go.
    pub go: u32,
    /// Verified error paths behind the probabilities (0: the Gaussian model, no go).
    pub ensemble_members: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payload_sizes_and_type_names_are_the_contract() {
        assert_eq!(std::mem::size_of::<DecisionSample>(), 80);
        assert_eq!(std::mem::offset_of!(DecisionSample, go), 72);
        assert_eq!(std::mem::offset_of!(DecisionSample, ensemble_members), 76);
        assert_eq!(std::mem::size_of::<MotionSample>(), 72);
        assert_eq!(std::mem::align_of::<MotionSample>(), 8);
        assert_eq!(
            std::mem::size_of::<Forecast>(),
            4 * 8 + 2 * 8 + 2 * 4 + 2 * NUM_DOF * MAX_STEPS * 4
        );
        assert_eq!(std::mem::offset_of!(MotionSample, dof), 24);
        assert_eq!(std::mem::offset_of!(Forecast, steps), 48);
        assert_eq!(std::mem::offset_of!(Forecast, mean), 56);
        // SAFETY: type_name only returns the static string given in the attribute.
        unsafe {
            assert_eq!(MotionSample::type_name(), "shipcast::MotionSample");
            assert_eq!(Forecast::type_name(), "shipcast::Forecast");
            assert_eq!(DecisionSample::type_name(), "shipcast::DecisionSample");
        }
    }

    fn sample_forecast(steps: u32) -> Forecast {
        let mut f = Forecast {
            seq: 7,
            source_seq: 123,
            source_stamp_ns: 456,
            issued_stamp_ns: 789,
            time_s: 12.5,
            dt_s: 0.5,
            steps,
            model_version: 3,
            ..Forecast::default()
        };
        for d in 0..NUM_DOF {
            for k in 0..steps as usize {
                f.mean[d][k] = (d * 1000 + k) as f32 * 0.25;
                f.sigma[d][k] = 0.01 * (k + 1) as f32;
            }
        }
        f
    }

    #[test]
    fn forecast_json_round_trip_cuts_arrays_to_steps() {
        let f = sample_forecast(5);
        let mut buf = Vec::new();
        f.write_json(&mut buf).unwrap();
        let value: serde_json::Value = serde_json::from_slice(&buf).unwrap();
        assert_eq!(value["mean"].as_array().unwrap().len(), NUM_DOF);
        assert_eq!(value["mean"][2].as_array().unwrap().len(), 5);
        assert_eq!(value["source_seq"], 123);
        let back = Forecast::from_json(&buf).unwrap();
        assert_eq!(back, f);
    }

    #[test]
    fn forecast_json_rejects_bad_shapes() {
        let f = sample_forecast(3);
        let mut buf = Vec::new();
        f.write_json(&mut buf).unwrap();
        let mut v: serde_json::Value = serde_json::from_slice(&buf).unwrap();
        v["steps"] = 4.into();
        let err = Forecast::from_json(v.to_string().as_bytes()).unwrap_err();
        assert!(err.to_string().contains("expected steps = 4"), "{err}");
        v["steps"] = 200.into();
        let err = Forecast::from_json(v.to_string().as_bytes()).unwrap_err();
        assert!(err.to_string().contains("exceeds"), "{err}");
        assert!(Forecast::from_json(b"{not json").is_err());
        // A forged row of a million values is counted, not kept, and refused by its length.
        let mut v: serde_json::Value = serde_json::from_slice(&buf).unwrap();
        v["sigma"][1] = serde_json::Value::Array(vec![0.5.into(); 1_000_000]);
        let err = Forecast::from_json(v.to_string().as_bytes()).unwrap_err();
        assert!(
            err.to_string()
                .contains("'sigma' row 1 has 1000000 values, expected steps = 3"),
            "{err}"
        );
        v["sigma"]
            .as_array_mut()
            .unwrap()
            .push(serde_json::json!([1, 2, 3]));
        let err = Forecast::from_json(v.to_string().as_bytes()).unwrap_err();
        assert!(
            err.to_string().contains("'sigma' has 7 rows, expected 6"),
            "{err}"
        );
    }

    #[test]
    fn corrupt_steps_never_index_out_of_bounds() {
        let f = Forecast {
            steps: 10_000,
            ..Forecast::default()
        };
        assert_eq!(f.mean_of(0).len(), MAX_STEPS);
        let g = MotionSample {
            dof: [0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0],
            ..MotionSample::default()
        };
        assert!(!g.is_finite());
        assert!(MotionSample::default().is_finite());
    }
}
