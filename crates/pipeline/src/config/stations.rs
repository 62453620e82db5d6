//! `[deck]`, `[crane]` and `[relative]`: the stations that act on the forecasts.

use super::MAX_LEVER_M;
use crate::limits;
use crate::transport::naming::Names;
use serde::{Deserialize, Serialize};

/// A fixed-size array that must be given whole: serde's own takes the first N values of a
/// longer one and drops the rest (review: `point_m = [1.0, 2.0, 3.0, 4.0]` was accepted).
fn exact_array<'de, D, const N: usize>(d: D) -> Result<[f64; N], D::Error>
where
    D: serde::Deserializer<'de>,
{
    let values = Vec::<f64>::deserialize(d)?;
    let got = values.len();
    values.try_into().map_err(|_| {
        serde::de::Error::invalid_length(got, &format!("an array of length {N}").as_str())
    })
}

/// Helideck landing advisory.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeckConfig {
    /// Helideck point from the centre of gravity [m], ship axes x forward, y starboard, z down.
    #[serde(deserialize_with = "exact_array")]
    pub point_m: [f64; 3],
    pub roll_limit_deg: f64,
    pub pitch_limit_deg: f64,
    /// Limit of the deck point's vertical velocity [m/s].
    pub vertical_velocity_limit_mps: f64,
    /// Shortest window worth reporting [s].
    pub min_window_s: f64,
    /// Limit of the deck point's vertical displacement from its rest position [m].
    pub vertical_displacement_limit_m: f64,
    /// Minimum operation time: the go/no-go is about a window this long [s].
    pub mot_s: f64,
    /// Go when the probability that every limit holds over the whole window is at least this.
    pub go_probability: f64,
    /// Correlation of the standardised forecast errors between neighbouring steps, used before
    /// enough verified forecasts estimate it (roll, pitch, deck vertical displacement, deck
    /// vertical velocity); docs/decisions.md says where the defaults come from.
    #[serde(deserialize_with = "exact_array")]
    pub error_correlation: [f64; 4],
    /// Go (now or a next window) only once the probability comes from verified forecast
    /// errors (the error ensemble, docs/decisions.md); before that the Gaussian model's
    /// probability is stated but never says go. False lets the model decide from the start.
    pub go_needs_verified_errors: bool,
    /// Publish the advisory on zenoh `.../advisory/deck`.
    pub publish: bool,
    /// Keep the verified statements, which correct new ones, in this file across runs: read
    /// at start (a missing file is a first run), written every minute and at the end
    /// (docs/decisions.md). None: every run starts from nothing.
    pub statements_file: Option<std::path::PathBuf>,
}

impl Default for DeckConfig {
    fn default() -> Self {
        Self {
            // Flight deck of a DDG-51: near the stern, on the centre line, about 5 m above CG.
            point_m: [-62.0, 0.0, -5.0],
            roll_limit_deg: 2.5,
            pitch_limit_deg: 1.5,
            vertical_velocity_limit_mps: 1.0,
            min_window_s: 2.0,
            vertical_displacement_limit_m: 2.0,
            mot_s: 10.0,
            go_probability: 0.95,
            error_correlation: [0.95, 0.95, 0.95, 0.8],
            go_needs_verified_errors: true,
            publish: true,
            statements_file: None,
        }
    }
}

/// Crane-tip forecast.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CraneConfig {
    /// Crane tip from the centre of gravity [m], ship axes x forward, y starboard, z down.
    #[serde(deserialize_with = "exact_array")]
    pub tip_m: [f64; 3],
    /// Print one line every this many forecasts (10: one each 5 s at 2 Hz; at every forecast a
    /// service's log grew by 30 MB a day, soak review).
    pub print_every: u64,
    /// Half-life, in verified tip forecasts, of the scale on the tip's sigma (`crane::verify`);
    /// shorter while fewer than four times as many are verified (`SigmaScale::adaptive`).
    pub calibration_halflife: f64,
    /// Verified tip forecasts behind a step before its sigma is scaled.
    pub calibration_min_verified: f64,
}

impl Default for CraneConfig {
    fn default() -> Self {
        Self {
            // An alongside transfer rig: amidships, 15 m outboard to starboard, 20 m up.
            tip_m: [10.0, 15.0, -20.0],
            print_every: 10,
            // As the relative sigma's: 10 minutes of forecasts at 2 Hz.
            calibration_halflife: 1200.0,
            calibration_min_verified: 100.0,
        }
    }
}

/// Ship-to-ship relative motion (`shipcast relative`, docs/two_ships.md): the crane tip
/// (`crane.tip_m`) on the crane vessel against a landing spot on the target vessel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RelativeConfig {
    /// `shipcast run` also runs the target vessel (its own producer and predictor, simulated
    /// in the same sea at `target_position_m`, `target_heading_offset_deg`) and the relative
    /// service.
    pub two_ship: bool,
    /// The vessel carrying the crane; none = the pipeline's `vessel`.
    pub crane_vessel: Option<String>,
    /// The vessel the load goes to.
    pub target_vessel: String,
    /// The target's centre of gravity forward and to starboard of the crane vessel's [m].
    #[serde(deserialize_with = "exact_array")]
    pub target_position_m: [f64; 2],
    /// The target's bow turned this far to starboard of the crane vessel's heading [deg].
    pub target_heading_offset_deg: f64,
    /// Landing spot from the target's centre of gravity [m], its axes x forward, y starboard,
    /// z down.
    #[serde(deserialize_with = "exact_array")]
    pub landing_spot_m: [f64; 3],
    /// Limits of the tip's motion relative to the spot [m]: vertical, and each horizontal axis.
    pub vertical_limit_m: f64,
    pub horizontal_limit_m: f64,
    /// Minimum operation time of the lift [s].
    pub mot_s: f64,
    /// Go when the window probability reaches this.
    pub go_probability: f64,
    /// State a probability, and so say go, only once it comes from verified relative errors;
    /// false lets the Gaussian model decide from the first forecast.
    pub go_needs_verified_errors: bool,
    /// Step-to-step correlation of the standardised relative errors (AR(1) in lead).
    pub error_correlation: f64,
    /// Half-life of the sigma calibration and the mean's shrinkage, in verified forecasts (the
    /// issued sigma's shorter while fewer than four times as many are verified:
    /// `SigmaScale::adaptive`).
    pub calibration_halflife: f64,
    /// Verified forecasts behind a step before its sigma is calibrated and its mean shrunk
    /// (weighted by the half-life for the shrinkage and the lift's raw sigma).
    pub calibration_min_verified: f64,
    /// Shrink the relative mean per axis and step towards no relative motion by the
    /// least-squares factor of verified forecasts (false: the raw difference of the two
    /// ships' forecasts).
    pub shrink_mean: bool,
    /// Publish the relative forecast on zenoh `.../<crane vessel>/advisory/relative`.
    pub publish: bool,
    /// Print one line every this many relative forecasts (10, as the crane's).
    pub print_every: u64,
}

impl Default for RelativeConfig {
    fn default() -> Self {
        Self {
            two_ship: false,
            crane_vessel: None,
            target_vessel: "supply".to_string(),
            // Alongside to starboard, 40 m between the centres of gravity, its bow 10 deg to
            // starboard of the crane vessel's: two headings, one sea (docs/two_ships.md).
            target_position_m: [0.0, 40.0],
            target_heading_offset_deg: 10.0,
            // On the target's deck, port side (facing the crane vessel), 6 m above its CG.
            landing_spot_m: [10.0, -8.0, -6.0],
            vertical_limit_m: 1.0,
            horizontal_limit_m: 1.0,
            mot_s: 10.0,
            go_probability: 0.9,
            // Before verified errors the Gaussian model's go calls failed 42 % of the time on
            // a paper sea (docs/two_ships.md).
            go_needs_verified_errors: true,
            error_correlation: 0.95,
            calibration_halflife: 1200.0,
            calibration_min_verified: 100.0,
            shrink_mean: true,
            publish: true,
            print_every: 10,
        }
    }
}

impl RelativeConfig {
    /// The crane vessel's name: `crane_vessel`, else the pipeline's `vessel`.
    pub fn crane_vessel<'a>(&'a self, vessel: &'a str) -> &'a str {
        self.crane_vessel.as_deref().unwrap_or(vessel)
    }

    pub(super) fn validate(&self, vessel: &str) -> Result<(), String> {
        let r = self;
        Names::new(None, &r.target_vessel).map_err(|e| format!("relative.target_vessel: {e}"))?;
        if let Some(c) = &r.crane_vessel {
            Names::new(None, c).map_err(|e| format!("relative.crane_vessel: {e}"))?;
        }
        if r.crane_vessel(vessel) == r.target_vessel {
            return Err(format!(
                "relative.target_vessel '{}' is the crane vessel itself",
                r.target_vessel
            ));
        }
        let position = [r.target_position_m[0], r.target_position_m[1]];
        for (name, values) in [
            ("relative.target_position_m", &position[..]),
            ("relative.landing_spot_m", &r.landing_spot_m[..]),
        ] {
            if !values
                .iter()
                .all(|v| v.is_finite() && v.abs() <= MAX_LEVER_M)
            {
                return Err(format!(
                    "{name} must be finite numbers within +-{MAX_LEVER_M} m, got {values:?}"
                ));
            }
        }
        if !r.target_heading_offset_deg.is_finite() {
            return Err("relative.target_heading_offset_deg must be finite".into());
        }
        for (name, v) in [
            ("relative.vertical_limit_m", r.vertical_limit_m),
            ("relative.horizontal_limit_m", r.horizontal_limit_m),
            ("relative.mot_s", r.mot_s),
            ("relative.calibration_halflife", r.calibration_halflife),
            (
                "relative.calibration_min_verified",
                r.calibration_min_verified,
            ),
        ] {
            limits::positive(name, v, 1e9)?;
        }
        if !(r.go_probability > 0.0 && r.go_probability < 1.0) {
            return Err(format!(
                "relative.go_probability must be between 0 and 1, got {}",
                r.go_probability
            ));
        }
        if !(0.0..1.0).contains(&r.error_correlation) {
            return Err(format!(
                "relative.error_correlation must be in [0, 1), got {}",
                r.error_correlation
            ));
        }
        // The lift's sums forget: their weight tends to 1 / (1 - decay), about 1.44 half-lives.
        // A minimum beyond it is never reached, and the lift's sigma and shrinkage would stay
        // uncalibrated for good while the issued sigma said calibrated (review, 2026-12-06).
        let decay = crate::sigma_scale::decay_per_forecast(r.calibration_halflife);
        let reachable = 1.0 / (1.0 - decay);
        if r.calibration_min_verified >= reachable {
            return Err(format!(
                "relative.calibration_min_verified ({}) must be below the weight a half-life \
                 of {} verified forecasts reaches ({reachable:.0}): raise the half-life or \
                 lower the minimum",
                r.calibration_min_verified, r.calibration_halflife
            ));
        }
        limits::count("relative.print_every", r.print_every, 1, u64::MAX)?;
        Ok(())
    }
}
