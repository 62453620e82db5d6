//! The lift go/no-go on a relative forecast: the probability that the crane tip stays within
//! its limits relative to the landing spot over a window of MOT from now.
//!
//! The lift decides on the raw difference of the two forecasts and its own calibrated sigma
//! (`RelativeTrack::raw_mean`, `raw_sigma`), not on the issued mean shrunk towards no relative
//! motion (`relative::shrink`): the ensemble's regression of the errors on the mean does that
//! shrinking itself, and on the shrunk mean the one-hour paper-sea statements were over-stated
//! in 4-6 more bins (docs/two_ships.md, "The relative mean").
//!
//! Two estimates, as for the deck (docs/decisions.md), and for the same reason:
//! - **verified errors** (the default once they exist): the share of an ensemble of recent
//!   verified relative error paths (`decision::ensemble`, three quantities: the relative x, y
//!   and z) under which, put on the current forecast, every limit holds at every step of the
//!   window. It keeps what a Gaussian model assumes away: the errors' tails, their dependence
//!   across steps and across the three axes.
//!   Its statements are then corrected by what happened to earlier ones stated like them
//!   (`decision::recalibrate`, the deck's rule: never raised above the larger of p and 0.8).
//! - **before them, a Gaussian model**: each axis an AR(1) chain in lead
//!   (`relative.error_correlation`), the three axes multiplied as independent. Scored against
//!   two records (the two-ship study) it stated 6-14 points more than happened in most bins
//!   between 0.2 and 0.8 once the sigma was calibrated; in the first minutes, with the sigma
//!   of forecasts not yet verified, its go calls failed 42 % of the time on one sea. So by
//!   default (`relative.go_needs_verified_errors`) it states nothing and never says go.

use super::still::{FrozenSensor, Ship};
use super::RelativeTrack;
use crate::config::RelativeConfig;
use crate::decision::ensemble::{share_within, ErrorEnsemble};
use crate::decision::recalibrate::StatementRecord;
use crate::decision::window::{chain_within, Lattice};
use crate::decision::{standardised_error, LATTICE_POINTS};
use serde::{Deserialize, Serialize};
use shipcast_wire::payload::MAX_STEPS;
use shipcast_wire::Dof;

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
    /// No probability (so no go) before verified errors back it.
    pub needs_verified_errors: bool,
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
            needs_verified_errors: config.go_needs_verified_errors,
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
    /// the forecast is shorter than MOT, or `awaiting_verified_errors`).
    pub probability_now: Option<f64>,
    /// Start of the first window of MOT whose mean holds every limit and whose probability
    /// reaches `go_probability` (the time of its first step; the first step's own when go now),
    /// and that probability; None when no window within the horizon does, or no probability
    /// is stated. Absent in the advisories of a service older than this field.
    #[serde(default)]
    pub next_window_s: Option<f64>,
    #[serde(default)]
    pub next_window_probability: Option<f64>,
    /// First step at which the predicted mean breaks a limit.
    pub next_exceedance_s: Option<f64>,
    /// Verified error paths the probability comes from; 0: the Gaussian model (absent in the
    /// advisories of a service older than this field).
    #[serde(default)]
    pub ensemble_members: usize,
    /// No probability is stated yet: too few verified error paths (or none as long as the
    /// window), and the Gaussian model before them is not trusted
    /// (`relative.go_needs_verified_errors`).
    #[serde(default)]
    pub awaiting_verified_errors: bool,
    /// A sensor of this ship repeats its recorded value (`frozen_dof`, [`super::still`]): no
    /// probability and no go. Both absent in the advisories of a service older than this.
    #[serde(default)]
    pub frozen_ship: Option<Ship>,
    #[serde(default)]
    pub frozen_dof: Option<Dof>,
}

/// Per axis and step: a verified forecast's standardised errors or means.
type PerAxis = [[f64; MAX_STEPS]; 3];

/// What verification has taught the lift decision: the verified relative error paths, and
/// the outcomes of the statements made from them.
#[derive(Debug, Clone)]
pub struct LiftEvidence {
    limits: LiftLimits,
    pub ensemble: LiftEnsemble,
    /// The uncorrected statements from the ensemble and whether their windows held.
    pub statements: StatementRecord,
    /// A sensor of either ship that repeats its value now ([`super::still`]): set by the
    /// verifier's watch before each decision.
    pub frozen: Option<FrozenSensor>,
    u: Box<PerAxis>,
    z: Box<PerAxis>,
}

impl LiftEvidence {
    pub fn new(limits: LiftLimits) -> Self {
        Self {
            limits,
            ensemble: LiftEnsemble::default(),
            statements: StatementRecord::default(),
            frozen: None,
            u: Box::new([[0.0; MAX_STEPS]; 3]),
            z: Box::new([[0.0; MAX_STEPS]; 3]),
        }
    }

    /// Learns from a verified forecast, `actual[k]` its true relative displacement at step k:
    /// its standardised errors u = (actual - mean) / sigma and means z = mean / sigma (sigma as
    /// issued; a miss at sigma 0 is an error beyond any limit, [`standardised_error`])
    /// join the ensemble, and its statement, if it made one from verified errors, is recorded
    /// against whether its window held.
    pub fn learn(&mut self, track: &RelativeTrack, actual: &[[f64; 3]]) {
        let steps = track.steps().min(MAX_STEPS).min(actual.len());
        for (k, value) in actual.iter().enumerate().take(steps) {
            for (axis, &v) in value.iter().enumerate() {
                let (mean, sigma) = (track.raw_mean[axis][k], track.raw_sigma[axis][k]);
                self.u[axis][k] = standardised_error(v, mean, sigma);
                self.z[axis][k] = mean / sigma;
            }
        }
        self.ensemble.offer(&self.u, &self.z, steps);
        if let Some(p) = track.lift_statement {
            let window = self.limits.window_steps(track.dt_s);
            if window <= steps {
                let held = self.limits.window_holds(window, |k| actual[k]);
                self.statements.add(p, held);
            }
        }
    }
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

    /// The Gaussian model's probability that the window of MOT holds (None: the forecast is
    /// shorter than MOT).
    pub fn gaussian_probability(&self, track: &RelativeTrack) -> Option<f64> {
        let limits = &self.limits;
        let window = limits.window_steps(track.dt_s);
        (window <= track.steps() && window <= self.lattice.dims())
            .then(|| self.gaussian_window(track, 0, window))
    }

    /// The Gaussian model's probability that every limit holds over steps [start, end).
    fn gaussian_window(&self, track: &RelativeTrack, start: usize, end: usize) -> f64 {
        let limits = &self.limits;
        (0..3)
            .map(|axis| {
                chain_within(
                    &track.raw_mean[axis][start..end],
                    &track.raw_sigma[axis][start..end],
                    limits.limit(axis),
                    limits.error_correlation,
                    &self.lattice,
                )
            })
            .product::<f64>()
    }

    /// Decides on `track`: no probability while a sensor of either ship is frozen
    /// (`evidence.frozen`), else from the evidence's ensemble once it is ready (corrected by
    /// the earlier statements' outcomes), else from the Gaussian model. The uncorrected statement
    /// from verified errors is noted in `track.lift_statement`, so that verification records
    /// its outcome.
    pub fn decide(&mut self, track: &mut RelativeTrack, evidence: &LiftEvidence) -> LiftDecision {
        let limits = self.limits;
        let steps = track.steps();
        let window = limits.window_steps(track.dt_s);
        let ensemble = &evidence.ensemble;
        let from_ensemble = ensemble.ready();
        let mut usable = 0;
        track.lift_statement = None;
        let frozen = evidence.frozen.filter(|_| window <= steps);
        let probability_now = if window > steps || frozen.is_some() {
            None
        } else if from_ensemble {
            usable = ensemble.failures(
                &track.raw_mean,
                &track.raw_sigma,
                &std::array::from_fn(|axis| limits.limit(axis)),
                window,
                &mut self.fail_before,
                &mut self.usable,
            );
            // As many paths must cover the window as make the ensemble ready: a probability
            // from a handful of long paths (the horizon grew) would be a guess.
            let raw = ensemble
                .enough(usable)
                .then(|| share_within(&self.fail_before, &self.usable, 0, window))
                .flatten();
            track.lift_statement = raw;
            raw.map(|p| evidence.statements.correct(p, limits.go_probability))
        } else if limits.needs_verified_errors {
            None
        } else {
            self.gaussian_probability(track)
        };
        let next_exceedance_s = (0..steps)
            .find(|&k| (0..3).any(|axis| track.mean[axis][k].abs() > limits.limit(axis)))
            .map(|k| (k + 1) as f64 * track.dt_s);
        let go = probability_now.is_some_and(|p| p >= limits.go_probability);
        let next_window = match probability_now {
            Some(p) if go => Some((0, p)),
            Some(_) => self.later_window(track, evidence, from_ensemble),
            None => None,
        };
        LiftDecision {
            mot_s: limits.mot_s,
            go_probability: limits.go_probability,
            go,
            probability_now,
            next_window_s: next_window.map(|(s, _)| (s + 1) as f64 * track.dt_s),
            next_window_probability: next_window.map(|(_, p)| p),
            next_exceedance_s,
            // The paths the probability comes from: those as long as the window.
            frozen_ship: frozen.map(|f| f.ship),
            frozen_dof: frozen.map(|f| f.dof),
            ensemble_members: if from_ensemble && probability_now.is_some() {
                usable
            } else {
                0
            },
            // No member long enough for the window (the horizon grew) is no verified errors
            // for it either.
            awaiting_verified_errors: window <= steps
                && frozen.is_none()
                && probability_now.is_none()
                && (from_ensemble || limits.needs_verified_errors),
        }
    }

    /// The first window of MOT after the first step whose mean (as published) holds every
    /// limit and whose probability, from the same source as the decision's (the verified
    /// paths, as far ahead as enough of them reach, corrected as the decision's; else the
    /// Gaussian model),
    /// reaches `go_probability`: its start step and probability. As the deck's
    /// (`Decider::next_window`): a window whose mean breaks a limit holds with less than even
    /// odds and is no candidate.
    fn later_window(
        &mut self,
        track: &RelativeTrack,
        evidence: &LiftEvidence,
        from_ensemble: bool,
    ) -> Option<(usize, f64)> {
        let limits = self.limits;
        let steps = track.steps();
        let window = limits.window_steps(track.dt_s);
        let mean_holds = |s: usize| {
            (s..s + window)
                .all(|k| (0..3).all(|axis| track.mean[axis][k].abs() <= limits.limit(axis)))
        };
        if from_ensemble {
            // As far ahead as enough verified paths reach (review: paths one step shorter
            // than this track, enough for the decision's window, gave no later window at all).
            let reach = evidence.ensemble.covered_steps(steps);
            let usable = evidence.ensemble.failures(
                &track.raw_mean,
                &track.raw_sigma,
                &std::array::from_fn(|axis| limits.limit(axis)),
                reach,
                &mut self.fail_before,
                &mut self.usable,
            );
            if !evidence.ensemble.enough(usable) {
                return None;
            }
            (1..=reach.checked_sub(window)?)
                .filter(|&s| mean_holds(s))
                .find_map(|s| {
                    let raw = share_within(&self.fail_before, &self.usable, s, s + window)?;
                    let p = evidence.statements.correct(raw, limits.go_probability);
                    (p >= limits.go_probability).then_some((s, p))
                })
        } else {
            let dims = self.lattice.dims();
            (1..=steps.checked_sub(window)?)
                .filter(|&s| window <= dims && mean_holds(s))
                .find_map(|s| {
                    let p = self.gaussian_window(track, s, s + window);
                    (p >= limits.go_probability).then_some((s, p))
                })
        }
    }
}
