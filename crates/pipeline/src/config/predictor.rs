//! `[predictor]`: the forecasting service, its method and the engine's settings.

use serde::{Deserialize, Serialize};
use shipcast_predict::{McaWeighting, Method, PredictorConfig, WienerFit};
use std::path::PathBuf;

/// The forecasting service.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PredictorServiceConfig {
    pub method: Method,
    /// Past values per forecast (MCA window length n, of which n - horizon are past values).
    pub order: usize,
    /// Forecast steps (at most 128).
    pub horizon: usize,
    /// Rate the motion is decimated to before forecasting [Hz]; must divide the input rate.
    pub sample_rate_hz: f64,
    /// Start from this model file (`shipcast train`) instead of training on simulated history.
    pub model: Option<PathBuf>,
    /// Simulated history used for the start-up model [s of record time].
    pub warmup_s: f64,
    /// Anti-alias filter of the decimation: "minimum" (default: the same magnitude as the
    /// evaluation's linear-phase filter with half its delay, so forecasts reach 0.5 s further
    /// ahead of the newest sample; docs/results/filter_delay.md) or "linear" (the evaluation
    /// protocol's, delay 1.0 s at 8 -> 2 Hz).
    pub filter: shipcast_series::FilterPhase,
    /// Fit the first model on live data once this much live history is held [s of record
    /// time]; until a model has been verified on this sea, forecasts say "no skill".
    pub first_fit_s: f64,
    /// Retrain from live data every this many seconds of record time (0 = never, including
    /// the first live fit).
    pub retrain_every_s: f64,
    /// Live history kept for retraining [values at sample_rate_hz]; the newest `holdout`
    /// values (at most a third of what is held) score the candidates and are not trained on.
    pub retrain_window: usize,
    pub holdout: usize,
    /// Orders tried at every fit (those up to `order` that the data allow); the best on the
    /// held-out values wins, per DOF.
    pub candidate_orders: Vec<usize>,
    /// Rolling window of record time over which forecasts are verified and recalibrated [s].
    pub verification_window_s: f64,
    /// A forecast mean beyond this many times the live RMS of the motion is never delivered.
    pub plausible_rms_factor: f64,
    /// Live squared errors this many times what sigma claims (or 1 / this) mean the sea has
    /// changed: recalibrate and retrain at once.
    pub change_ratio: f64,
    /// Report the producer as stale after this much record time without samples [s].
    pub stale_after_s: f64,
    /// Spin on the subscriber instead of sleeping until woken (lowest latency, one core busy).
    pub busy_poll: bool,
    /// `[predictor.mca]`: settings of the MCA method; only with `method = "mca"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mca: Option<McaSettings>,
    /// `[predictor.ar]`: settings of the AR-LMS method; only with `method = "ar"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ar: Option<ArSettings>,
    /// `[predictor.mlp]`: settings of the MLP method; only with `method = "mlp"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mlp: Option<MlpSettings>,
    /// `[predictor.wiener]`: settings of the Wiener method; only with `method = "wiener"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wiener: Option<WienerSettings>,
}

/// `[predictor.wiener]`: the Wiener method's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WienerSettings {
    /// How the weights are estimated: "guarded" (default: least squares over the training
    /// window's forecast origins, each forecast held within a band around the paper's
    /// estimate's), "autocorrelation" (the paper's Yule-Walker estimate) or "least-squares"
    /// (unguarded: sharper on a steady sea, but wild for a while after a change of sea).
    /// docs/forecasting.md, "How the weights are estimated".
    pub fit: WienerFit,
}

impl Default for WienerSettings {
    /// The service's Wiener: guarded least squares, better than the paper's estimate out of
    /// sample on every record measured and no less safe after a change of sea.
    fn default() -> Self {
        Self {
            fit: WienerFit::Guarded,
        }
    }
}

/// `[predictor.mca]`: the MCA method's settings (the `shipcast eval` MCA options).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct McaSettings {
    /// Eigen-direction weights: "inverse" (all, 1/(lambda + eps): the conditional mean) or
    /// "paper" (the minor components, unweighted).
    pub weighting: McaWeighting,
    /// Shift between consecutive training windows.
    pub shift: usize,
    /// Energy fraction of the minor components (paper weighting).
    pub energy: f64,
    /// Ridge (inverse weighting: eps relative to the mean eigenvalue; 0 = default).
    pub ridge: f64,
    /// Choose the energy threshold (inverse weighting: the ridge) on held-out training data.
    pub validate_energy: bool,
}

impl Default for McaSettings {
    /// The service's MCA: eigenvalue-weighted, validated (not the paper's settings, which
    /// are worse than predicting zero on a realistic sea; README "Honest accuracy").
    fn default() -> Self {
        let paper = PredictorConfig::default();
        Self {
            weighting: McaWeighting::Inverse,
            shift: 2,
            energy: paper.mca_energy,
            ridge: paper.mca_ridge,
            validate_energy: true,
        }
    }
}

/// `[predictor.ar]`: the AR method's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArSettings {
    /// LMS step size.
    pub lms_gain: f64,
    /// Normalised LMS (step divided by the input power).
    pub normalized: bool,
}

impl Default for ArSettings {
    fn default() -> Self {
        let paper = PredictorConfig::default();
        Self {
            lms_gain: paper.lms_gain,
            normalized: paper.lms_normalized,
        }
    }
}

/// `[predictor.mlp]`: the MLP method's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MlpSettings {
    /// Hidden tanh units.
    pub hidden: usize,
    /// Rprop epochs per fit.
    pub epochs: usize,
    /// Seed of the initial weights.
    pub seed: u64,
}

impl Default for MlpSettings {
    fn default() -> Self {
        let paper = PredictorConfig::default();
        Self {
            hidden: paper.mlp_hidden,
            epochs: paper.mlp_epochs,
            seed: paper.seed,
        }
    }
}

impl Default for PredictorServiceConfig {
    fn default() -> Self {
        Self {
            // Chosen out of sample (train on one stretch or realisation, score on another, at
            // every origin; README "Honest accuracy"): the Wiener predictor with its order
            // validated per DOF is the most robust on measured seas, where the
            // eigenvalue-weighted MCA learns one realisation's wave components and fails on
            // band-limited records.
            method: Method::Wiener,
            order: 200,
            horizon: 50,
            sample_rate_hz: 2.0,
            model: None,
            warmup_s: 3000.0,
            filter: shipcast_series::FilterPhase::Minimum,
            first_fit_s: 240.0,
            retrain_every_s: 300.0,
            retrain_window: 20000,
            holdout: 1000,
            candidate_orders: vec![25, 50, 100, 200],
            verification_window_s: 1200.0,
            plausible_rms_factor: 8.0,
            change_ratio: 3.0,
            stale_after_s: 2.0,
            busy_poll: false,
            mca: None,
            ar: None,
            mlp: None,
            wiener: None,
        }
    }
}

impl PredictorServiceConfig {
    /// Values of history the engine keeps per DOF: the retrain window, or at least one
    /// forecast's input (a model of a larger order, from a file, raises it further).
    pub fn history_values(&self) -> usize {
        self.retrain_window.max(self.order + self.horizon)
    }

    /// The predictor settings: this section's order and horizon, and the chosen method's
    /// section (its defaults when left out).
    pub fn predictor_config(&self) -> PredictorConfig {
        let mca = self.mca.clone().unwrap_or_default();
        let ar = self.ar.clone().unwrap_or_default();
        let mlp = self.mlp.clone().unwrap_or_default();
        PredictorConfig {
            order: self.order,
            horizon: self.horizon,
            mca_shift: mca.shift,
            mca_energy: mca.energy,
            mca_ridge: mca.ridge,
            mca_validate_energy: mca.validate_energy,
            mca_weighting: mca.weighting,
            lms_gain: ar.lms_gain,
            lms_normalized: ar.normalized,
            wiener_fit: self.wiener_fit(),
            mlp_hidden: mlp.hidden,
            mlp_epochs: mlp.epochs,
            seed: mlp.seed,
        }
    }

    /// How a Wiener fit estimates its weights: `[predictor.wiener] fit`, or its default.
    pub fn wiener_fit(&self) -> WienerFit {
        self.wiener
            .as_ref()
            .map_or_else(|| WienerSettings::default().fit, |w| w.fit)
    }

    /// A method section is refused unless it is the chosen method's: a key that does nothing
    /// is an error, not a silent no-op.
    pub(super) fn check_method_sections(&self) -> Result<(), String> {
        for (section, present, method) in [
            ("mca", self.mca.is_some(), Method::Mca),
            ("ar", self.ar.is_some(), Method::Ar),
            ("mlp", self.mlp.is_some(), Method::Mlp),
            ("wiener", self.wiener.is_some(), Method::Wiener),
        ] {
            if present && self.method != method {
                return Err(format!(
                    "[predictor.{section}] applies to method = \"{}\" only, but method is \"{}\"",
                    method.name(),
                    self.method.name()
                ));
            }
        }
        self.check_method_settings()
    }

    /// The method sections' values, in the ranges `shipcast eval` accepts for the same
    /// options: unchecked, a huge `epochs` hung start-up training and an `energy` above 1
    /// made every retrain fail.
    fn check_method_settings(&self) -> Result<(), String> {
        use crate::limits::{self, MAX_EPOCHS, MAX_GAIN, MAX_HIDDEN, MAX_RIDGE};
        if let Some(m) = &self.mca {
            limits::count("predictor.mca.shift", m.shift, 1, super::MAX_ORDER)?;
            limits::fraction_below_one("predictor.mca.energy", m.energy)?;
            limits::non_negative("predictor.mca.ridge", m.ridge, MAX_RIDGE)?;
        }
        if let Some(a) = &self.ar {
            limits::positive("predictor.ar.lms_gain", a.lms_gain, MAX_GAIN)?;
        }
        if let Some(m) = &self.mlp {
            limits::count("predictor.mlp.hidden", m.hidden, 1, MAX_HIDDEN)?;
            limits::count("predictor.mlp.epochs", m.epochs, 1, MAX_EPOCHS)?;
        }
        Ok(())
    }
}

/// A stretch of values the engine fits on: the live retrain window, or the simulated start-up
/// history. `shown` names it as the user configured it ("predictor.retrain_window = 6000
/// values"); `raise` is the key to raise when it is too short.
pub(super) struct FitSpan<'a> {
    pub len: usize,
    pub shown: String,
    pub raise: &'a str,
    /// For a span set in seconds (`warmup_s`): the seconds a span of n values takes.
    pub seconds_for: Option<&'a dyn Fn(usize) -> f64>,
}

impl FitSpan<'_> {
    /// "raise retrain_window to hold at least N values", in the span's own unit.
    fn raise_to(&self, values: usize) -> String {
        match self.seconds_for {
            Some(seconds) => format!(
                "raise {} to at least {} s ({values} values)",
                self.raise,
                seconds(values).ceil()
            ),
            None => format!("raise {} to at least {values} values", self.raise),
        }
    }
}

impl PredictorServiceConfig {
    /// Why a fit on `span` could fit and score no candidate order, if it could not: the same
    /// rule the engine fits by (`models::window_fits`: the held-out part is at most a third of
    /// the span). Unchecked, retraining silently
    /// never happened, or the start-up fit failed after simulating the whole history.
    pub(super) fn fit_span_problem(&self, span: &FitSpan) -> Option<String> {
        use crate::engine::models::{self, MIN_HOLDOUT_ORIGINS, TRAIN_PER_ORDER};
        if models::window_fits(self, span.len) {
            return None;
        }
        let held_out = models::holdout_for(self, span.len);
        let Some(smallest) = models::candidate_orders(self).min() else {
            return Some(format!(
                "predictor: no candidate order is above the horizon ({}), and MCA needs one: raise predictor.order or add such an order to candidate_orders",
                self.horizon
            ));
        };
        let needed = smallest + self.horizon + MIN_HOLDOUT_ORIGINS;
        if self.holdout < needed {
            return Some(format!(
                "predictor.holdout = {} values is too short to score any candidate: the smallest order ({smallest}) with the horizon ({}) and {MIN_HOLDOUT_ORIGINS} origins needs {needed}; raise holdout",
                self.holdout, self.horizon
            ));
        }
        // The shortest span that fits and scores the smallest candidate: feasibility only
        // grows with the span (both the held-out and the training part do), so a bisection.
        let (mut lo, mut hi) = (span.len, span.len.max(1));
        while !models::window_fits(self, hi) {
            hi = hi.saturating_mul(2);
        }
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if models::window_fits(self, mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        if held_out < needed {
            return Some(format!(
                "{} holds out at most a third of itself ({held_out} values), too short to score any candidate: the smallest order ({smallest}) with the horizon ({}) and {MIN_HOLDOUT_ORIGINS} origins needs {needed}; {}",
                span.shown,
                self.horizon,
                span.raise_to(hi)
            ));
        }
        let train = span.len - held_out;
        Some(format!(
            "{} leaves {train} values to train on beside the {held_out} held out: the smallest order ({smallest}) needs {TRAIN_PER_ORDER} x {smallest} = {}; {}",
            span.shown,
            TRAIN_PER_ORDER * smallest,
            span.raise_to(hi)
        ))
    }
}
