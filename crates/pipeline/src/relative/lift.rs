//! The lift go/no-go on a relative forecast: the probability that the crane tip stays within
//! its limits relative to the landing spot over a window of MOT from now.
//!
//! Two estimates, as for the deck (docs/decisions.md), and for the same reason:
//! - **verified errors** (the default once they exist): the share of an ensemble of recent
//!   verified relative error paths (`decision::ensemble`, three quantities: the relative x, y
//!   and z) under which, put on the current forecast, every limit holds at every step of the
//!   window. It keeps what a Gaussian model assumes away: the errors' tails, their dependence
//!   across steps and across the three axes.
//! - **before them, a Gaussian model**: each axis an AR(1) chain in lead
//!   (`relative.error_correlation`), the three axes multiplied as independent. Scored against
//!   two records (the two-ship study) it stated 10-15 points more than happened in its middle
//!   bins.

use super::RelativeTrack;
use crate::config::RelativeConfig;
use crate::decision::ensemble::{share_within, ErrorEnsemble};
use crate::decision::window::{chain_within, Lattice};
use crate::decision::LATTICE_POINTS;
use serde::{Deserialize, Serialize};
use shipcast_wire::payload::MAX_STEPS;

/// The three relative axes (x, y, z of the crane vessel) are the ensemble's quantities.
pub type LiftEnsemble = ErrorEnsemble<3>;

/// The lift's limits: the tip's excursion relative to the spot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiftLimits {
    pub vertical_m: f64,
    /// Applied to each horizontal axis (along and across A): a box, not a circle.
    pub horizontal_m: f64,
    pub mot_s: f64,
    pub go_probability: f64,
    /// Step-to-step correlation of the standardised relative errors (AR(1) in lead).
    pub error_correlation: f64,
}

impl LiftLimits {
    pub fn new(config: &RelativeConfig) -> Self {
        Self {
            vertical_m: config.vertical_limit_m,
            horizontal_m: config.horizontal_limit_m,
            mot_s: config.mot_s,
            go_probability: config.go_probability,
            error_correlation: config.error_correlation,
        }
    }

    fn limit(&self, axis: usize) -> f64 {
        if axis == 2 {
            self.vertical_m
        } else {
            self.horizontal_m
        }
    }

    /// Steps in a window of MOT at step `dt_s` (at least one).
    pub fn window_steps(&self, dt_s: f64) -> usize {
        ((self.mot_s / dt_s).ceil() as usize).max(1)
    }

    /// Whether the relative displacement `at(k)` (per axis, A's axes) keeps every limit at every
    /// step of a window of `steps` steps from the first.
    pub fn window_holds(&self, steps: usize, at: impl Fn(usize) -> [f64; 3]) -> bool {
        (0..steps).all(|k| {
            let d = at(k);
            (0..3).all(|axis| d[axis].abs() <= self.limit(axis))
        })
    }
}

/// The lift go/no-go on one relative forecast (inside `RelativeAdvisory`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LiftDecision {
    pub mot_s: f64,
    pub go_probability: f64,
    pub go: bool,
    /// Probability that every limit holds over the window of MOT from the first step (None:
    /// the forecast is shorter than MOT).
    pub probability_now: Option<f64>,
    /// First step at which the predicted mean breaks a limit.
    pub next_exceedance_s: Option<f64>,
    /// Verified error paths the probability comes from; 0: the Gaussian model (absent in the
    /// advisories of a service older than this field).
    #[serde(default)]
    pub ensemble_members: usize,
}

/// Decides the lift on relative forecasts, with its work buffers (after the first decision it
/// does not allocate).
#[derive(Debug, Clone)]
pub struct LiftDecider {
    limits: LiftLimits,
    lattice: Lattice,
    fail_before: Vec<u16>,
    usable: Vec<bool>,
}

impl LiftDecider {
    pub fn new(limits: LiftLimits) -> Self {
        Self {
            limits,
            lattice: Lattice::new(LATTICE_POINTS, MAX_STEPS),
            fail_before: Vec::new(),
            usable: Vec::new(),
        }
    }

    pub fn limits(&self) -> &LiftLimits {
        &self.limits
    }

    /// Decides on `track`: from `ensemble` once it is ready, else from the Gaussian model.
    pub fn decide(&mut self, track: &RelativeTrack, ensemble: &LiftEnsemble) -> LiftDecision {
        let limits = self.limits;
        let steps = track.steps();
        let window = limits.window_steps(track.dt_s);
        let from_ensemble = ensemble.ready();
        let probability_now = if window > steps {
            None
        } else if from_ensemble {
            ensemble.failures(
                &track.mean,
                &track.sigma,
                &[limits.horizontal_m, limits.horizontal_m, limits.vertical_m],
                window,
                &mut self.fail_before,
                &mut self.usable,
            );
            share_within(&self.fail_before, &self.usable, 0, window)
        } else {
            (window <= self.lattice.dims()).then(|| {
                (0..3)
                    .map(|axis| {
                        chain_within(
                            &track.mean[axis][..window],
                            &track.sigma[axis][..window],
                            limits.limit(axis),
                            limits.error_correlation,
                            &self.lattice,
                        )
                    })
                    .product::<f64>()
            })
        };
        let next_exceedance_s = (0..steps)
            .find(|&k| (0..3).any(|axis| track.mean[axis][k].abs() > limits.limit(axis)))
            .map(|k| (k + 1) as f64 * track.dt_s);
        LiftDecision {
            mot_s: limits.mot_s,
            go_probability: limits.go_probability,
            go: probability_now.is_some_and(|p| p >= limits.go_probability),
            probability_now,
            next_exceedance_s,
            ensemble_members: if from_ensemble && probability_now.is_some() {
                ensemble.len()
            } else {
                0
            },
        }
    }
}
