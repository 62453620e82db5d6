//! The paper's averaged forecasts: every forecast origin predicts the same future instant at a
//! different lead, so the forecast of an instant can combine the last K forecasts that cover it
//! (Zhao, Xu and Kwan: "the mean value of several predictions for the same future point").
//!
//! Forecasts arrive one per sample step (origins o, o+1, ...). Of the K newest, the one made j
//! steps ago predicts step s (0-based) of the newest forecast at its own index s + j, so step s
//! is covered by `min(K, H - s)` forecasts, fewer until K forecasts have arrived. Two
//! combinations:
//! - uniform: the mean of the forecasts that cover the instant (the paper's);
//! - weighted: per step and per number of covering forecasts, least-squares weights fitted on
//!   forecasts made inside the training segment and scored against it ([`fit_weights`]). The
//!   newest forecast carries the most information, so a uniform mean can be worse than it.
//!
//! [`ForecastAverager`] does the combination as a stream, without allocating after construction.

use super::{PredictError, Predictor};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Ridge added to the normal equations of the weights, relative to their mean diagonal.
/// Forecasts from neighbouring origins are nearly collinear; without it the weights can grow
/// into large cancelling pairs that fit the training segment and fail outside it.
pub const WEIGHT_RIDGE: f64 = 1e-6;

/// How the K forecasts of one instant are combined.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AverageMode {
    /// The mean of the forecasts that cover the instant (the paper's).
    #[default]
    Uniform,
    /// Least-squares weights per step, fitted on the training segment.
    Weighted,
}

impl AverageMode {
    pub const fn name(self) -> &'static str {
        match self {
            AverageMode::Uniform => "uniform",
            AverageMode::Weighted => "weighted",
        }
    }
}

impl fmt::Display for AverageMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for AverageMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "uniform" => Ok(AverageMode::Uniform),
            "weighted" => Ok(AverageMode::Weighted),
            _ => Err(format!(
                "unknown averaging mode '{s}' (expected uniform or weighted)"
            )),
        }
    }
}

/// How many forecasts are combined, and how. `k = 1` is the newest forecast alone, unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Averaging {
    pub k: usize,
    pub mode: AverageMode,
}

impl Default for Averaging {
    fn default() -> Self {
        Self::NONE
    }
}

impl Averaging {
    /// The newest forecast alone.
    pub const NONE: Averaging = Averaging {
        k: 1,
        mode: AverageMode::Uniform,
    };

    /// True if forecasts are used as they are (`k = 1`, either mode).
    pub fn is_none(&self) -> bool {
        self.k == 1
    }

    /// Check `k` against the horizon: at least 1, and at most `horizon` (a forecast made
    /// `horizon` or more steps ago covers no step of the newest one).
    pub fn validate(&self, horizon: usize) -> Result<(), PredictError> {
        if self.k == 0 || self.k > horizon.max(1) {
            return Err(PredictError::Infeasible(format!(
                "averaging over {} forecasts: must be between 1 and the horizon {horizon}",
                self.k
            )));
        }
        Ok(())
    }

    /// "newest forecast", "uniform mean of 5", "weighted combination of 5".
    pub fn describe(&self) -> String {
        match (self.k, self.mode) {
            (1, _) => "newest forecast".to_string(),
            (k, AverageMode::Uniform) => format!("uniform mean of {k}"),
            (k, AverageMode::Weighted) => format!("weighted combination of {k}"),
        }
    }
}

/// Weights per step (0-based), each the weights of the forecasts made 0, 1, ... steps ago.
pub type StepWeights = Vec<Vec<f64>>;

/// Combination weights for K forecasts over a horizon H: for every number m = 1..K of
/// forecasts available and every step s, the weights of the m newest forecasts that cover s.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AveragingWeights {
    k: usize,
    horizon: usize,
    /// `weights[((m - 1) * horizon + s) * k + j]`: weight of the forecast made j steps ago at
    /// step s when m forecasts are available (zero for j >= the number covering s).
    weights: Vec<f64>,
}

impl AveragingWeights {
    /// The uniform mean of the forecasts covering each step.
    pub fn uniform(k: usize, horizon: usize) -> Result<Self, PredictError> {
        let mut w = Self::zeros(k, horizon)?;
        for m in 1..=k {
            for s in 0..horizon {
                let n = covering(m, horizon, s);
                for j in 0..n {
                    *w.at_mut(m, s, j) = 1.0 / n as f64;
                }
            }
        }
        Ok(w)
    }

    fn zeros(k: usize, horizon: usize) -> Result<Self, PredictError> {
        Averaging {
            k,
            mode: AverageMode::Uniform,
        }
        .validate(horizon)?;
        Ok(Self {
            k,
            horizon,
            weights: vec![0.0; k * horizon * k],
        })
    }

    pub fn k(&self) -> usize {
        self.k
    }

    pub fn horizon(&self) -> usize {
        self.horizon
    }

    /// The weights of the forecasts made 0, 1, ... steps ago at step `s` (0-based) when all K
    /// are available; as many as cover that step.
    pub fn at_step(&self, s: usize) -> &[f64] {
        let n = covering(self.k, self.horizon, s);
        let start = ((self.k - 1) * self.horizon + s) * self.k;
        &self.weights[start..start + n]
    }

    /// [`AveragingWeights::at_step`] for every step.
    pub fn per_step(&self) -> StepWeights {
        (0..self.horizon)
            .map(|s| self.at_step(s).to_vec())
            .collect()
    }

    fn at(&self, m: usize, s: usize, j: usize) -> f64 {
        self.weights[((m - 1) * self.horizon + s) * self.k + j]
    }

    fn at_mut(&mut self, m: usize, s: usize, j: usize) -> &mut f64 {
        &mut self.weights[((m - 1) * self.horizon + s) * self.k + j]
    }
}

/// Number of the `m` newest forecasts that cover step `s` of the newest one.
fn covering(m: usize, horizon: usize, s: usize) -> usize {
    m.min(horizon - s)
}

/// Combines each new forecast with the ones before it. Push one forecast per sample step
/// (consecutive origins); after a gap in the origins call [`ForecastAverager::reset`].
/// Allocation-free after construction.
#[derive(Clone, Debug)]
pub struct ForecastAverager {
    weights: AveragingWeights,
    /// The K newest forecasts, slot `newest` the latest, `(newest + j) % K` the one j steps older.
    history: Vec<f64>,
    newest: usize,
    available: usize,
}

impl ForecastAverager {
    pub fn new(weights: AveragingWeights) -> Self {
        let history = vec![0.0; weights.k * weights.horizon];
        Self {
            newest: 0,
            available: 0,
            weights,
            history,
        }
    }

    pub fn weights(&self) -> &AveragingWeights {
        &self.weights
    }

    /// Forget every forecast (the next one is combined with nothing).
    pub fn reset(&mut self) {
        self.available = 0;
    }

    /// Add the forecast of the next origin and write the combined forecast to `out`
    /// (`forecast` and `out` hold at least H values; only the first H are used).
    pub fn push(&mut self, forecast: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        let (k, h) = (self.weights.k, self.weights.horizon);
        if forecast.len() < h || out.len() < h {
            return Err(PredictError::Length(format!(
                "averaging needs forecasts of {h} steps, got {} in and {} out",
                forecast.len(),
                out.len()
            )));
        }
        self.newest = (self.newest + k - 1) % k;
        self.history[self.newest * h..(self.newest + 1) * h].copy_from_slice(&forecast[..h]);
        self.available = (self.available + 1).min(k);
        let m = self.available;
        for (s, o) in out[..h].iter_mut().enumerate() {
            // Start from the newest term so that a weight of exactly 1 returns it bit for bit.
            let mut acc = self.weights.at(m, s, 0) * self.history[self.newest * h + s];
            for j in 1..covering(m, h, s) {
                let slot = (self.newest + j) % k;
                acc += self.weights.at(m, s, j) * self.history[slot * h + s + j];
            }
            *o = acc;
        }
        Ok(())
    }
}

/// Least-squares weights of K forecasts per step, from forecasts of `predictor` (already
/// fitted) made at every origin inside `train` and scored against `train` only. Online
/// predictors are used as they are (no updates). For each step s the normal equations of the
/// K(s) covering forecasts are accumulated once; the weights for m available forecasts solve
/// their leading m x m block (the forecasts are ordered newest first).
pub fn fit_weights(
    predictor: &mut dyn Predictor,
    train: &[f64],
    k: usize,
) -> Result<AveragingWeights, PredictError> {
    let (order, horizon) = (predictor.order(), predictor.horizon());
    let mut weights = AveragingWeights::zeros(k, horizon)?;
    // Origins o with K forecasts behind them (o - K + 1 >= order) and every step scored
    // inside the training segment (o + H <= len).
    let first = order + k - 1;
    if train.len() < first + horizon + k {
        // Regression (review): this was the method's own "too short", which a user could only
        // read as the method needing more than it does.
        return Err(PredictError::TooShortToWeigh {
            method: predictor.method(),
            order,
            k,
            needed: first + horizon + k,
            got: train.len(),
        });
    }
    let mut gram = vec![0.0; horizon * k * k];
    let mut rhs = vec![0.0; horizon * k];
    let mut history = vec![0.0; k * horizon];
    let mut forecast = vec![0.0; horizon];
    for origin in order..=train.len() - horizon {
        predictor.forecast(&train[origin - order..origin], &mut forecast)?;
        if forecast.iter().any(|v| !v.is_finite()) {
            return Err(PredictError::NonFinite("forecast on the training segment"));
        }
        // Slot of the forecast made j steps ago: (origin - j) % k.
        let slot = origin % k;
        history[slot * horizon..(slot + 1) * horizon].copy_from_slice(&forecast);
        if origin < first {
            continue;
        }
        for s in 0..horizon {
            let n = covering(k, horizon, s);
            let value = |j: usize| history[((origin - j) % k) * horizon + s + j];
            let truth = train[origin + s];
            for a in 0..n {
                let fa = value(a);
                rhs[s * k + a] += fa * truth;
                for b in 0..=a {
                    gram[(s * k + a) * k + b] += fa * value(b);
                }
            }
        }
    }
    let mut block = vec![0.0; k * k];
    let mut solution = vec![0.0; k];
    for s in 0..horizon {
        for m in 1..=k {
            let n = covering(m, horizon, s);
            for a in 0..n {
                for b in 0..=a {
                    block[a * n + b] = gram[(s * k + a) * k + b];
                }
            }
            let mean_diag = (0..n).map(|a| block[a * n + a]).sum::<f64>() / n as f64;
            let ridge = WEIGHT_RIDGE * mean_diag.max(f64::MIN_POSITIVE);
            solution[..n].copy_from_slice(&rhs[s * k..s * k + n]);
            solve_spd_lower(&mut block[..n * n], n, ridge, &mut solution[..n])?;
            for (j, &w) in solution[..n].iter().enumerate() {
                *weights.at_mut(m, s, j) = w;
            }
        }
    }
    Ok(weights)
}

/// Solve (A + ridge I) x = b for a symmetric positive definite A given by its lower triangle
/// (row-major, n x n), by Cholesky in place; `x` holds b on entry.
fn solve_spd_lower(a: &mut [f64], n: usize, ridge: f64, x: &mut [f64]) -> Result<(), PredictError> {
    for i in 0..n {
        a[i * n + i] += ridge;
    }
    for j in 0..n {
        let mut d = a[j * n + j];
        for p in 0..j {
            d -= a[j * n + p] * a[j * n + p];
        }
        if d.is_nan() || d <= 0.0 || d.is_infinite() {
            return Err(PredictError::Numerical(
                "averaging weights: normal equations not positive definite".into(),
            ));
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut v = a[i * n + j];
            for p in 0..j {
                v -= a[i * n + p] * a[j * n + p];
            }
            a[i * n + j] = v / d;
        }
    }
    for i in 0..n {
        let mut v = x[i];
        for p in 0..i {
            v -= a[i * n + p] * x[p];
        }
        x[i] = v / a[i * n + i];
    }
    for i in (0..n).rev() {
        let mut v = x[i];
        for p in i + 1..n {
            v -= a[p * n + i] * x[p];
        }
        x[i] = v / a[i * n + i];
    }
    Ok(())
}

/// The averager for `averaging`: uniform weights, or weights fitted on `train` with
/// `predictor` (already fitted). With `k = 1` either mode passes each forecast on unchanged.
pub fn averager_for(
    averaging: Averaging,
    predictor: &mut dyn Predictor,
    train: &[f64],
) -> Result<ForecastAverager, PredictError> {
    let weights = match averaging.mode {
        AverageMode::Weighted if !averaging.is_none() => {
            fit_weights(predictor, train, averaging.k)?
        }
        _ => AveragingWeights::uniform(averaging.k, predictor.horizon())?,
    };
    Ok(ForecastAverager::new(weights))
}

#[cfg(test)]
#[path = "averaging_tests.rs"]
mod tests;
