//! Minor Component Analysis predictor (Zhao, Xu, Kwan; docs/contracts.md section 4).
//!
//! Windows of n = order consecutive values of the training segment, taken every `shift` values,
//! span (almost) a subspace of R^n. The eigenvectors of R = sum X X^T with the smallest
//! eigenvalues, the minor components B, are (almost) orthogonal to every window: B x ~ 0.
//! Splitting a window into its n1 = n - H past values x1 and H future values x2, the future is
//! the least-squares solution of B1 x1 + B2 x2 = 0, so x2 = P x1 with
//! P = -(B2^T B2)^-1 B2^T B1, computed once at fit time. A forecast is one H x n1 product.
//!
//! `McaWeighting::Inverse` (not in the paper) weighs every eigen-direction v_i of R by
//! 1/(lambda_i + eps) instead of keeping the minor ones with weight 1: the future then minimises
//! x^T M x with M = V diag(w) V^T = (R + eps I)^-1, so P = -(M22)^-1 M21 = R21 (R11 + eps I)^-1,
//! the conditional mean E[x2 | x1] of a Gaussian with the sample covariance R (ridge-regularised):
//! the best linear predictor the training windows can estimate. The unweighted paper rule gives
//! a strong signal direction that happens to fall among the minor components the same weight as
//! pure noise, which is why it loses to predicting zero at long horizons on a dense sea.

use super::linear_map::LinearMap;
use super::{
    check_forecast_buffers, check_training, Diagnostics, Method, PredictError, Predictor,
    PredictorConfig,
};
use serde::{Deserialize, Serialize};
use spectrum::{Spectrum, SpectrumModel};

#[path = "mca_spectrum.rs"]
mod spectrum;

/// Energy thresholds tried when `mca_validate_energy` is on: from "only the null space" to
/// "a tenth of the signal".
pub const ENERGY_GRID: [f64; 8] = [0.001, 0.002, 0.005, 0.01, 0.015, 0.02, 0.05, 0.1];

/// Ridges (eps relative to the mean eigenvalue) tried when `mca_validate_energy` is on with
/// inverse weighting, where the energy threshold plays no part.
/// Measurement noise needs the large end (10 % noise, shift 10: 1.0 is best), a clean dense
/// sea with full-rank R the small end.
pub const RIDGE_GRID: [f64; 9] = [1e-12, 1e-9, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0];

/// Fraction of the training segment held out at its end to choose the energy threshold.
const VALIDATION_FRACTION_INV: usize = 5;

/// Inverse weighting: eps relative to the mean eigenvalue when `mca_ridge` is 0. Chosen for the
/// paper's shift 10, where 420 windows leave R of rank < 800: on the simulated paper sea
/// (heave, order 800, H 50) 1e-3 gave the lowest mean RMS over the 50 steps of the ridges
/// 1e-12..1e-2 (0.257 m; 1e-6: 0.309 m, 1e-9: 0.652 m). With shift 1 or 2 R has full rank and
/// smaller is better (1e-12: 0.133 m against Wiener's 0.212 m); validation picks it from
/// `RIDGE_GRID`.
pub const INVERSE_DEFAULT_RIDGE: f64 = 1e-3;

/// How the eigen-directions of R enter the completion of a window.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum McaWeighting {
    /// The paper: the minor components chosen by the energy rule, each with weight 1.
    #[default]
    Paper,
    /// Every eigenvector, weighted by 1/(lambda + eps) with eps = ridge * mean eigenvalue
    /// (`INVERSE_DEFAULT_RIDGE` when `mca_ridge` is 0): the Gaussian conditional mean.
    Inverse,
}

impl McaWeighting {
    /// CLI / config name.
    pub const fn name(self) -> &'static str {
        match self {
            McaWeighting::Paper => "paper",
            McaWeighting::Inverse => "inverse",
        }
    }
}

impl std::fmt::Display for McaWeighting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for McaWeighting {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "paper" => Ok(McaWeighting::Paper),
            "inverse" => Ok(McaWeighting::Inverse),
            _ => Err(format!(
                "unknown MCA weighting '{s}' (expected paper or inverse)"
            )),
        }
    }
}

/// MCA predictor for one degree of freedom.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(remote = "Self", deny_unknown_fields)]
pub struct McaPredictor {
    order: usize,
    horizon: usize,
    shift: usize,
    energy: f64,
    ridge: f64,
    validate_energy: bool,
    /// Absent from model files written before the option existed: those are the paper's.
    #[serde(default)]
    weighting: McaWeighting,
    /// `None` until fitted.
    model: Option<McaModel>,
}

/// What `fit` learns.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct McaModel {
    /// P, H x n1.
    prediction: LinearMap,
    minor_components: usize,
    energy: f64,
    /// The ridge used (inverse weighting: the one chosen when validation is on).
    #[serde(default)]
    ridge: f64,
}

serde_validated!(McaPredictor);

impl McaModel {
    fn new(
        spectrum: &Spectrum,
        weighting: McaWeighting,
        energy: f64,
        horizon: usize,
        ridge: f64,
    ) -> Result<Self, PredictError> {
        let SpectrumModel {
            prediction,
            minor_components,
        } = spectrum.model(weighting, energy, horizon, ridge)?;
        Ok(Self {
            prediction,
            minor_components,
            energy,
            ridge,
        })
    }
}

impl McaPredictor {
    /// An unfitted MCA predictor. Horizon >= order (no past values left in the window), a zero
    /// shift, an energy outside [0, 1) or a negative ridge are infeasible.
    pub fn new(config: &PredictorConfig) -> Result<Self, PredictError> {
        let (order, horizon) = (config.order, config.horizon);
        check_options(
            order,
            horizon,
            config.mca_shift,
            config.mca_energy,
            config.mca_ridge,
        )?;
        Ok(Self {
            order,
            horizon,
            shift: config.mca_shift,
            energy: config.mca_energy,
            ridge: config.mca_ridge,
            validate_energy: config.mca_validate_energy,
            weighting: config.mca_weighting,
            model: None,
        })
    }

    /// Number of past values the prediction matrix multiplies (n1 = order - horizon).
    pub fn past_len(&self) -> usize {
        self.order - self.horizon
    }

    /// The prediction matrix P (horizon x past_len, row-major), once fitted.
    pub fn prediction_matrix(&self) -> Option<&LinearMap> {
        self.model.as_ref().map(|m| &m.prediction)
    }

    /// Like `forecast`, with the f32 copy of P: about half the memory traffic. Accurate only
    /// for a well-conditioned P: with eigenvalue weighting and the small ridge validation
    /// picks on a clean sea (1e-12), P's rows reach an L1 norm of 1e6 with cancelling terms,
    /// and f32 rounding moves the forecast by about 2.5 % of the motion's std (1e-2 m of
    /// heave at order 400), so the services' `forecast` keeps f64 arithmetic and reads the f32
    /// coefficients only where their rounding provably does not matter
    /// (`linear_map::MIXED_MAX_ROUNDING`). Never allocates.
    pub fn forecast_f32(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        let n1 = self.past_len();
        let model = self
            .model
            .as_mut()
            .ok_or(PredictError::NotFitted(Method::Mca))?;
        check_forecast_buffers(self.order, self.horizon, past, out)?;
        model.prediction.apply_f32(&past[past.len() - n1..], out);
        Ok(())
    }

    /// What a model file must satisfy (see `serde_validated!`): the constructor's checks, and a
    /// fitted model's prediction matrix of horizon x (order - horizon).
    fn validate(&self) -> Result<(), String> {
        check_options(
            self.order,
            self.horizon,
            self.shift,
            self.energy,
            self.ridge,
        )
        .map_err(|e| e.to_string())?;
        let Some(model) = &self.model else {
            return Ok(());
        };
        let (rows, cols) = (model.prediction.rows(), model.prediction.cols());
        if (rows, cols) != (self.horizon, self.past_len()) {
            return Err(format!(
                "MCA model.prediction is {rows} x {cols}; horizon {} and order {} need {} x {}",
                self.horizon,
                self.order,
                self.horizon,
                self.past_len()
            ));
        }
        if model.minor_components > self.order {
            return Err(format!(
                "MCA model.minor_components {} exceeds the order {}",
                model.minor_components, self.order
            ));
        }
        for (name, value) in [("energy", model.energy), ("ridge", model.ridge)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(format!(
                    "MCA model.{name} must be finite and non-negative, got {value}"
                ));
            }
        }
        Ok(())
    }

    /// The ridge as configured; 0 means `INVERSE_DEFAULT_RIDGE` with inverse weighting, where
    /// no ridge at all would let the null space of a rank-deficient R decide the forecast.
    fn configured_ridge(&self) -> f64 {
        match self.weighting {
            McaWeighting::Inverse if self.ridge == 0.0 => INVERSE_DEFAULT_RIDGE,
            _ => self.ridge,
        }
    }

    /// The (energy, ridge) pairs validation chooses from: the energy grid for the paper's
    /// weighting, the ridge grid for inverse weighting.
    fn candidates(&self) -> Vec<(f64, f64)> {
        match self.weighting {
            McaWeighting::Paper => ENERGY_GRID.iter().map(|&e| (e, self.ridge)).collect(),
            McaWeighting::Inverse => RIDGE_GRID.iter().map(|&r| (self.energy, r)).collect(),
        }
    }

    fn fit_with(&self, train: &[f64], energy: f64, ridge: f64) -> Result<McaModel, PredictError> {
        let spectrum = Spectrum::of_windows(train, self.order, self.shift)?;
        McaModel::new(&spectrum, self.weighting, energy, self.horizon, ridge)
    }

    /// Choose the energy threshold (inverse weighting: the ridge) on the last fifth of the
    /// training segment (fit on the rest, forecast every `shift` values, lowest RMS over all
    /// steps wins), then refit on all of it.
    fn fit_validated(&self, train: &[f64]) -> Result<McaModel, PredictError> {
        let needed = validation_needed(self.order, self.horizon);
        if train.len() < needed {
            return Err(PredictError::TooShort {
                method: Method::Mca,
                order: self.order,
                needed,
                got: train.len(),
            });
        }
        let cut = train.len() - train.len() / VALIDATION_FRACTION_INV;
        let spectrum = Spectrum::of_windows(&train[..cut], self.order, self.shift)?;
        let mut forecast = vec![0.0; self.horizon];
        let mut best: Option<(f64, f64, f64)> = None;
        let mut best_key: Option<(f64, f64)> = None;
        for (energy, ridge) in self.candidates() {
            let model = match McaModel::new(&spectrum, self.weighting, energy, self.horizon, ridge)
            {
                Ok(m) => m,
                Err(e) => {
                    tracing::debug!(energy, ridge, error = %e, "MCA candidate rejected");
                    continue;
                }
            };
            let gain = max_row_gain(&model.prediction);
            let bounded = gain <= MAX_ROW_GAIN;
            // Every origin, not only those aligned with the training windows: a map fitted on windows
            // at `shift` can exploit structure that exists only at those offsets (band-limited,
            // interpolated records), and would then fail at every other origin.
            let rms = validation_rms(&model.prediction, train, cut, 1, &mut forecast);
            tracing::debug!(
                energy,
                ridge,
                rms,
                minor_components = model.minor_components,
                "MCA candidate"
            );
            // A candidate within the gain bound beats any outside it; among those outside
            // (only when none is within), the smaller map wins.
            let key = if bounded { (0.0, rms) } else { (gain, rms) };
            if rms.is_finite() && best_key.is_none_or(|b: (f64, f64)| key < b) {
                best = Some((energy, ridge, rms));
                best_key = Some(key);
            }
        }
        let (energy, ridge, rms) = best.ok_or(PredictError::NoUsableCandidate(Method::Mca))?;
        tracing::debug!(energy, ridge, weighting = %self.weighting, validation_rms = rms, "MCA setting chosen");
        self.fit_with(train, energy, ridge)
    }
}

/// The constructor's checks: 1 <= horizon < order, shift >= 1, energy in [0, 1), ridge finite
/// and non-negative.
fn check_options(
    order: usize,
    horizon: usize,
    shift: usize,
    energy: f64,
    ridge: f64,
) -> Result<(), PredictError> {
    if horizon == 0 || horizon >= order {
        return Err(PredictError::Infeasible(format!(
            "MCA needs 1 <= horizon < order (the window of order values splits into \
             order - horizon past and horizon future values), got order {order}, horizon {horizon}"
        )));
    }
    if shift == 0 {
        return Err(PredictError::Infeasible(
            "MCA window shift must be at least 1".into(),
        ));
    }
    if !(0.0..1.0).contains(&energy) {
        return Err(PredictError::Infeasible(format!(
            "MCA energy threshold must be in [0, 1), got {energy}"
        )));
    }
    if !(ridge >= 0.0 && ridge.is_finite()) {
        return Err(PredictError::Infeasible(format!(
            "MCA ridge must be finite and non-negative, got {ridge}"
        )));
    }
    Ok(())
}

/// Smallest training length for which validation leaves at least one window to fit on
/// (`order` values) and one forecast to score (`horizon` values).
fn validation_needed(order: usize, horizon: usize) -> usize {
    let mut t = order.max(VALIDATION_FRACTION_INV * horizon);
    while t - t / VALIDATION_FRACTION_INV < order {
        t += 1;
    }
    t
}

/// Largest Euclidean norm of a row of the prediction map: how much a forecast step can amplify
/// white noise on the past values. Validation prefers candidates within `MAX_ROW_GAIN`: a map that
/// large reaches its validation score by cancelling big coefficients against each other, which
/// holds only on data with the exact structure it was fitted to. When every candidate is above
/// it, the one with the smallest map is taken.
fn max_row_gain(map: &LinearMap) -> f64 {
    (0..map.rows())
        .map(|r| map.row(r).iter().map(|c| c * c).sum::<f64>().sqrt())
        .fold(0.0, f64::max)
}

/// See [`max_row_gain`]. A step's noise gain of 10 turns 1 % sensor noise into 10 %.
const MAX_ROW_GAIN: f64 = 10.0;

/// RMS error of the forecasts issued at origins `cut, cut + stride, ...` of `series`.
fn validation_rms(
    map: &LinearMap,
    series: &[f64],
    cut: usize,
    stride: usize,
    forecast: &mut [f64],
) -> f64 {
    let (h, n1) = (map.rows(), map.cols());
    let (mut sum, mut count) = (0.0, 0usize);
    let mut origin = cut;
    while origin + h <= series.len() {
        map.apply(&series[origin - n1..origin], forecast);
        for (p, x) in forecast.iter().zip(&series[origin..origin + h]) {
            sum += (p - x) * (p - x);
        }
        count += h;
        origin += stride;
    }
    (sum / count.max(1) as f64).sqrt()
}

impl Predictor for McaPredictor {
    fn method(&self) -> Method {
        Method::Mca
    }
    fn order(&self) -> usize {
        self.order
    }
    fn horizon(&self) -> usize {
        self.horizon
    }

    fn fit(&mut self, train: &[f64]) -> Result<(), PredictError> {
        check_training(Method::Mca, self.order, self.order, train)?;
        let model = if self.validate_energy {
            self.fit_validated(train)?
        } else {
            self.fit_with(train, self.energy, self.configured_ridge())?
        };
        tracing::debug!(
            order = self.order,
            horizon = self.horizon,
            minor_components = model.minor_components,
            energy = model.energy,
            ridge = model.ridge,
            weighting = %self.weighting,
            "MCA fitted"
        );
        self.model = Some(model);
        Ok(())
    }

    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        let model = self
            .model
            .as_mut()
            .ok_or(PredictError::NotFitted(Method::Mca))?;
        check_forecast_buffers(self.order, self.horizon, past, out)?;
        let n1 = self.order - self.horizon;
        model
            .prediction
            .apply_prepared(&past[past.len() - n1..], out);
        Ok(())
    }

    fn prepare(&mut self, known: &[f64]) -> Result<(), PredictError> {
        if let Some(model) = self.model.as_mut() {
            model.prediction.prepare(known);
        }
        Ok(())
    }

    fn diagnostics(&self) -> Diagnostics {
        Diagnostics {
            minor_components: self.model.as_ref().map(|m| m.minor_components),
            // Inverse weighting uses every eigenvector: no energy threshold to report.
            energy: self
                .model
                .as_ref()
                .filter(|_| self.weighting == McaWeighting::Paper)
                .map(|m| m.energy),
            ridge: self.model.as_ref().map(|m| m.ridge),
            mca_weighting: Some(self.weighting),
        }
    }
}

#[cfg(test)]
#[path = "mca_tests.rs"]
mod tests;
