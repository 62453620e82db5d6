//! The decision for one forecast as a station publishes it: the advisory JSON's `decision`,
//! the iceoryx2 payload for local readers, and the console line.

use serde::{Deserialize, Serialize};
use shipcast_wire::payload::DecisionSample;
use shipcast_wire::Dof;

use super::NUM_QUANTITIES;

/// The decision for one forecast (inside the advisory JSON on `.../advisory/<station>`).
/// Times are seconds after the forecast's `time_s`; step k of a forecast is at (k + 1) dt.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    pub mot_s: f64,
    /// Go threshold on the window probability.
    pub go_probability: f64,
    /// Go now: the window of MOT starting at the first step holds with at least
    /// `go_probability`.
    pub go: bool,
    /// Probability that every limit holds over the window of MOT from the first step; None
    /// when the forecast horizon is shorter than MOT (nothing can be decided), or before
    /// verified forecast errors back a probability (`ensemble_members` 0, with
    /// `deck.go_needs_verified_errors`).
    pub probability_now: Option<f64>,
    /// Start of the first window of MOT whose probability reaches `go_probability`.
    pub next_window_s: Option<f64>,
    pub next_window_probability: Option<f64>,
    /// First step at which the predicted mean breaks a limit (None: not within the horizon).
    pub next_exceedance_s: Option<f64>,
    /// Step-to-step error correlation used, per quantity ([`QUANTITIES`]).
    pub error_correlation: [f64; NUM_QUANTITIES],
    /// Verified error paths the probabilities come from (0: the Gaussian model).
    #[serde(default)]
    pub ensemble_members: usize,
    /// No probability is stated yet because no verified errors back one
    /// (`deck.go_needs_verified_errors`).
    #[serde(default)]
    pub awaiting_verified_errors: bool,
    /// A DOF the deck's quantities are made of has repeated its recorded value for
    /// [`super::still::STILL_AFTER_S`] after moving: a frozen sensor, so no probability and no go.
    #[serde(default)]
    pub frozen_dof: Option<Dof>,
}

/// The NO-GO a station publishes for its local readers when its forecasts stop: no
/// probability, no window, nothing verified behind it, tied to the last forecast decided on
/// (`forecast_seq`, `time_s`) and stamped now. Local readers keep the newest decision; without
/// it they kept the last GO for as long as the silence lasted (review).
pub fn withdrawn_sample(
    mot_s: f64,
    go_probability: f64,
    forecast_seq: u64,
    time_s: f64,
    stamp_ns: u64,
) -> DecisionSample {
    DecisionSample {
        forecast_seq,
        stamp_ns,
        time_s,
        mot_s,
        go_probability,
        probability_now: f64::NAN,
        next_window_s: f64::NAN,
        next_window_probability: f64::NAN,
        next_exceedance_s: f64::NAN,
        go: 0,
        ensemble_members: 0,
    }
}

impl Decision {
    /// The decision as the iceoryx2 payload for local readers (NaN for absent values).
    pub fn sample(&self, forecast_seq: u64, time_s: f64, stamp_ns: u64) -> DecisionSample {
        let nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
        DecisionSample {
            forecast_seq,
            stamp_ns,
            time_s,
            mot_s: self.mot_s,
            go_probability: self.go_probability,
            probability_now: nan(self.probability_now),
            next_window_s: nan(self.next_window_s),
            next_window_probability: nan(self.next_window_probability),
            next_exceedance_s: nan(self.next_exceedance_s),
            go: u32::from(self.go),
            ensemble_members: u32::try_from(self.ensemble_members).unwrap_or(u32::MAX),
        }
    }

    pub fn summary(&self) -> String {
        let next = match (self.next_window_s, self.next_window_probability) {
            (Some(s), Some(p)) => format!("next go window in {s:.1}s ({:.0}%)", 100.0 * p),
            _ => "no go window in the horizon".into(),
        };
        let exceed = self
            .next_exceedance_s
            .map_or("no exceedance predicted".into(), |s| {
                format!("exceedance in {s:.1}s")
            });
        let now = match self.probability_now {
            Some(p) => format!("{:.0}%", 100.0 * p),
            None if self.frozen_dof.is_some() => format!(
                "{} sensor repeats its value",
                self.frozen_dof.map_or("a", Dof::name)
            ),
            None if self.awaiting_verified_errors => "no probability before verified errors".into(),
            None => "MOT beyond the horizon".into(),
        };
        format!(
            "{} (MOT {:.0}s, {now}), {next}, {exceed}",
            if self.go { "GO" } else { "NO-GO" },
            self.mot_s
        )
    }
}
