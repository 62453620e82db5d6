//! AR predictor with LMS-learned coefficients (docs/contracts.md section 4), updated online.
//!
//! One linear predictor per step h = 1..H maps the last `order` values to the value h steps
//! ahead. The coefficients start at zero and are learned with least mean squares over the
//! training segment (one pass, in time order), then keep learning online from every value
//! observed after training.
//!
//! The update is `w += mu * e * x` with `e = target - prediction`. The paper prints it with the
//! opposite sign (`e = prediction - target`), which climbs the error surface instead of descending
//! it; the sign here is the one that converges.
//!
//! Plain LMS needs `mu` well below `2 / (order * power)`, where power is the mean square of the
//! signal (mean-square stability of Gaussian signals is guaranteed below `2 / (3 order power)`):
//! with the paper's gain 0.005 an order-800 predictor diverges on heave of about 0.7 m standard
//! deviation, and on anything larger. Divergence is detected (a non-finite prediction or one far
//! beyond anything observed) and reported as [`PredictError::Numerical`] with the safe gain,
//! instead of producing NaN forecasts. Normalised LMS (`lms_normalized`: step
//! `mu / (eps + |x|^2)`, stable for 0 < mu < 2, where about 0.1 is a good choice) avoids it.

use super::linear_map::dot;
use super::vector_state::clear_upper_vector_state;
use super::{
    check_forecast_buffers, check_training, Method, PredictError, Predictor, PredictorConfig,
};
use serde::{Deserialize, Serialize};

/// A prediction larger than this many times the largest value observed so far means the filter
/// has left any sensible range: LMS instability grows geometrically, so this triggers long before
/// the weights overflow, yet is far beyond what a converging filter ever predicts.
const DIVERGENCE_FACTOR: f64 = 1e6;

/// Largest LMS step size accepted, in a configuration or a model file: far beyond any stable
/// value (the paper's is 0.005; NLMS is stable below 2).
pub const MAX_GAIN: f64 = 100.0;

/// A gain as written, in exponent form only where plain digits would run long (1e300): the
/// rule of `shipcast_wire::shown::number`, which serves every other crate's messages. This
/// crate of algorithms does not depend on the transport's crate for it.
fn shown(gain: f64) -> String {
    if gain != 0.0 && !(1e-6..1e15).contains(&gain.abs()) {
        format!("{gain:e}")
    } else {
        format!("{gain}")
    }
}

/// Regularises NLMS on a (near-)zero window, relative to the scale of the data.
const NLMS_EPS: f64 = 1e-12;

/// AR predictor with one LMS-adapted coefficient vector per forecast step.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(remote = "Self", deny_unknown_fields)]
pub struct ArLmsPredictor {
    order: usize,
    horizon: usize,
    gain: f64,
    normalized: bool,
    /// `horizon` rows of `order` coefficients; row h-1 predicts h steps ahead from the window
    /// ordered oldest first.
    weights: Vec<f64>,
    /// Largest |value| observed (training and online); the divergence test is relative to it.
    peak: f64,
    /// Mean square of the training segment, for the stability limit in error messages.
    power: f64,
    fitted: bool,
    /// Set when an online update diverged: the weights are no longer usable until the next fit.
    diverged: Option<String>,
}

serde_validated!(ArLmsPredictor);

impl ArLmsPredictor {
    /// What a model file must satisfy (see `serde_validated!`): a positive finite gain,
    /// order x horizon finite weights, a finite peak and power.
    fn validate(&self) -> Result<(), String> {
        // Regression (review): a gain of 1e300 loaded, and its failure was logged with
        // 300-digit numbers.
        if !(self.gain > 0.0 && self.gain <= MAX_GAIN) {
            return Err(format!(
                "AR gain must be in (0, {MAX_GAIN}], got {}",
                shown(self.gain)
            ));
        }
        if self.order.checked_mul(self.horizon) != Some(self.weights.len()) {
            return Err(format!(
                "AR weights hold {} coefficients; order {} x horizon {} needed",
                self.weights.len(),
                self.order,
                self.horizon
            ));
        }
        if self.weights.iter().any(|w| !w.is_finite()) {
            return Err("AR weights hold a non-finite value".into());
        }
        for (name, value) in [("peak", self.peak), ("power", self.power)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(format!(
                    "AR {name} must be finite and non-negative, got {value}"
                ));
            }
        }
        Ok(())
    }

    /// An unfitted predictor; fails if the gain is not a positive finite number.
    pub fn new(config: &PredictorConfig) -> Result<Self, PredictError> {
        if !(config.lms_gain > 0.0 && config.lms_gain <= MAX_GAIN) {
            return Err(PredictError::Infeasible(format!(
                "LMS gain must be in (0, {MAX_GAIN}], got {}",
                shown(config.lms_gain)
            )));
        }
        Ok(Self {
            order: config.order,
            horizon: config.horizon,
            gain: config.lms_gain,
            normalized: config.lms_normalized,
            weights: vec![0.0; config.order * config.horizon],
            peak: 0.0,
            power: 0.0,
            fitted: false,
            diverged: None,
        })
    }

    /// Coefficients of the h-step predictor (h = 1..=horizon), oldest lag first.
    pub fn coefficients(&self, h: usize) -> &[f64] {
        &self.weights[(h - 1) * self.order..h * self.order]
    }

    /// One LMS correction of `w` towards predicting `target` from `x`. Returns an error message
    /// if the prediction shows the filter has diverged.
    fn lms_step(&self, w: &mut [f64], x: &[f64], target: f64) -> Result<(), String> {
        let prediction = dot(w, x);
        let limit = DIVERGENCE_FACTOR * self.peak.max(f64::MIN_POSITIVE);
        if !prediction.is_finite() || prediction.abs() > limit {
            return Err(self.divergence_message(prediction));
        }
        let error = target - prediction;
        let step = if self.normalized {
            let power = dot(x, x) + NLMS_EPS * self.peak * self.peak * x.len() as f64;
            if power < f64::MIN_POSITIVE {
                // An all-zero window carries nothing to learn from.
                return Ok(());
            }
            self.gain / power
        } else {
            self.gain
        };
        axpy(step * error, x, w);
        Ok(())
    }

    fn divergence_message(&self, prediction: f64) -> String {
        if self.normalized {
            format!(
                "AR LMS diverged (prediction {prediction:e}): normalised gain {} must lie in (0, 2)",
                self.gain
            )
        } else {
            let safe = 2.0 / (3.0 * self.order as f64 * self.power.max(f64::MIN_POSITIVE));
            format!(
                "AR LMS diverged (prediction {prediction:e}): gain {} is too large for order {} on \
                 a signal of power {:.3e}; plain LMS is safe below 2/(3*order*power) = {safe:.3e}; \
                 use a smaller gain or normalised LMS",
                self.gain, self.order, self.power
            )
        }
    }

    fn require_usable(&self) -> Result<(), PredictError> {
        if !self.fitted {
            return Err(PredictError::NotFitted(Method::Ar));
        }
        if let Some(reason) = &self.diverged {
            return Err(PredictError::Numerical(reason.clone()));
        }
        // A model file edited by hand must not make forecasts silently short.
        if self.weights.len() != self.order * self.horizon {
            return Err(PredictError::Numerical(format!(
                "AR model holds {} coefficients, order {} x horizon {} needs {}",
                self.weights.len(),
                self.order,
                self.horizon,
                self.order * self.horizon
            )));
        }
        Ok(())
    }
}

impl Predictor for ArLmsPredictor {
    fn method(&self) -> Method {
        Method::Ar
    }

    fn order(&self) -> usize {
        self.order
    }

    fn horizon(&self) -> usize {
        self.horizon
    }

    fn is_online(&self) -> bool {
        true
    }

    fn fit(&mut self, train: &[f64]) -> Result<(), PredictError> {
        let (order, horizon) = (self.order, self.horizon);
        check_training(Method::Ar, order, order + horizon, train)?;
        self.fitted = false;
        self.diverged = None;
        self.peak = train.iter().fold(0.0, |m, v| m.max(v.abs()));
        self.power = train.iter().map(|v| v * v).sum::<f64>() / train.len() as f64;
        clear_upper_vector_state();
        let mut weights = std::mem::take(&mut self.weights);
        weights.clear();
        weights.resize(order * horizon, 0.0);
        // The step predictors are independent, so each learns in its own pass over time; this
        // keeps one coefficient row hot in cache instead of cycling through all of them.
        let mut result = Ok(());
        'steps: for (step, w) in weights.chunks_exact_mut(order).enumerate() {
            let h = step + 1;
            for origin in order..=train.len() - h {
                let target = train[origin + h - 1];
                if let Err(reason) = self.lms_step(w, &train[origin - order..origin], target) {
                    result = Err(PredictError::Numerical(format!(
                        "{reason} (training, step {h})"
                    )));
                    break 'steps;
                }
            }
        }
        self.weights = weights;
        result?;
        self.fitted = true;
        tracing::debug!(
            order,
            horizon,
            gain = self.gain,
            normalized = self.normalized,
            "AR LMS fitted"
        );
        Ok(())
    }

    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        self.require_usable()?;
        check_forecast_buffers(self.order, self.horizon, past, out)?;
        let window = &past[past.len() - self.order..];
        if window.iter().any(|v| !v.is_finite()) {
            return Err(PredictError::NonFinite("AR forecast window"));
        }
        // Earlier faer code on this thread may have left the vector state dirty.
        clear_upper_vector_state();
        for (slot, w) in out.iter_mut().zip(self.weights.chunks_exact(self.order)) {
            *slot = dot(w, window);
        }
        Ok(())
    }

    /// Corrects the h-step predictor with the window that ended h steps before the newest value
    /// (`recent[len-h-order .. len-h]`), whose target is the newest value: only values already
    /// observed are used.
    fn update(&mut self, recent: &[f64]) -> Result<(), PredictError> {
        self.require_usable()?;
        let (order, horizon) = (self.order, self.horizon);
        let len = recent.len();
        if len < order + horizon {
            return Err(PredictError::Length(format!(
                "AR update needs the last {} values, got {len}",
                order + horizon
            )));
        }
        let used = &recent[len - order - horizon..];
        if used.iter().any(|v| !v.is_finite()) {
            return Err(PredictError::NonFinite("AR update window"));
        }
        let target = recent[len - 1];
        self.peak = self.peak.max(target.abs());
        clear_upper_vector_state();
        let mut weights = std::mem::take(&mut self.weights);
        let mut result = Ok(());
        for (step, w) in weights.chunks_exact_mut(order).enumerate() {
            let h = step + 1;
            let end = len - h;
            if let Err(reason) = self.lms_step(w, &recent[end - order..end], target) {
                result = Err(format!("{reason} (online update, step {h})"));
                break;
            }
        }
        self.weights = weights;
        if let Err(reason) = result {
            tracing::warn!(%reason, "AR predictor diverged; it needs a refit");
            self.diverged = Some(reason.clone());
            return Err(PredictError::Numerical(reason));
        }
        Ok(())
    }
}

/// `y += alpha * x`.
fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn config(order: usize, horizon: usize, gain: f64, normalized: bool) -> PredictorConfig {
        PredictorConfig {
            order,
            horizon,
            lms_gain: gain,
            lms_normalized: normalized,
            ..PredictorConfig::default()
        }
    }

    /// x_t = a1 x_{t-1} + a2 x_{t-2} + e_t with unit Gaussian innovations.
    fn ar2(a1: f64, a2: f64, len: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut x = vec![0.0; len];
        for t in 2..len {
            let e: f64 = StandardNormal.sample(&mut rng);
            x[t] = a1 * x[t - 1] + a2 * x[t - 2] + e;
        }
        x
    }

    fn sines(len: usize, parts: &[(f64, f64, f64)]) -> Vec<f64> {
        (0..len)
            .map(|t| {
                parts
                    .iter()
                    .map(|&(amp, period, phase)| {
                        amp * (std::f64::consts::TAU * t as f64 / period + phase).sin()
                    })
                    .sum()
            })
            .collect()
    }

    #[test]
    fn lms_converges_to_true_ar2_coefficients() {
        let (a1, a2) = (1.2, -0.6);
        let x = ar2(a1, a2, 200_000, 7);
        for (gain, normalized) in [(0.0005, false), (0.001, true)] {
            let mut p = ArLmsPredictor::new(&config(2, 1, gain, normalized)).unwrap();
            p.fit(&x).unwrap();
            // The window is ordered oldest first: [x_{t-2}, x_{t-1}].
            let w = p.coefficients(1);
            assert!(
                (w[0] - a2).abs() < 0.06 && (w[1] - a1).abs() < 0.06,
                "normalized={normalized}: learned {w:?}, true [{a2}, {a1}]"
            );
        }
    }

    #[test]
    fn online_updates_reduce_error_after_the_signal_changes() {
        let (order, horizon) = (20, 5);
        let train = sines(3000, &[(1.0, 20.0, 0.0)]);
        // After training the sea "changes": a different period and a second component.
        let test = sines(4000, &[(0.8, 11.0, 0.3), (0.4, 31.0, 1.0)]);
        let series: Vec<f64> = train.iter().chain(&test).copied().collect();
        let mut online = ArLmsPredictor::new(&config(order, horizon, 0.005, false)).unwrap();
        online.fit(&train).unwrap();
        let mut frozen = online.clone();
        let (mut err_online, mut err_frozen) = (0.0, 0.0);
        let mut out = vec![0.0; horizon];
        let start = train.len() + order + horizon;
        for origin in start..series.len() - horizon {
            online.update(&series[..origin]).unwrap();
            if origin < series.len() - 1000 {
                continue;
            }
            let truth = &series[origin..origin + horizon];
            online.forecast(&series[..origin], &mut out).unwrap();
            err_online += out
                .iter()
                .zip(truth)
                .map(|(p, t)| (p - t).powi(2))
                .sum::<f64>();
            frozen.forecast(&series[..origin], &mut out).unwrap();
            err_frozen += out
                .iter()
                .zip(truth)
                .map(|(p, t)| (p - t).powi(2))
                .sum::<f64>();
        }
        assert!(
            err_online < 0.1 * err_frozen,
            "online squared error {err_online} vs frozen {err_frozen}"
        );
    }

    #[test]
    fn forecast_uses_no_value_after_the_origin() {
        let (order, horizon, train_len, origin) = (30, 8, 1000, 1300);
        let series = sines(1500, &[(1.0, 17.0, 0.2), (0.5, 7.3, 1.0)]);
        let mut altered = series.clone();
        for v in &mut altered[origin..] {
            *v = -3.0 * *v + 1.0;
        }
        let run = |x: &[f64]| {
            let mut p = ArLmsPredictor::new(&config(order, horizon, 0.005, false)).unwrap();
            p.fit(&x[..train_len]).unwrap();
            for t in train_len + order + horizon..=origin {
                p.update(&x[..t]).unwrap();
            }
            let mut out = vec![0.0; horizon];
            p.forecast(&x[..origin], &mut out).unwrap();
            out
        };
        let reference = run(&series);
        assert_eq!(reference, run(&altered));
        // The test can fail: the newest value before the origin does matter.
        let mut last_changed = series.clone();
        last_changed[origin - 1] += 1.0;
        assert_ne!(reference, run(&last_changed));
    }

    #[test]
    fn plain_lms_divergence_is_an_error_not_nan() {
        let order = 200;
        let x = sines(3000, &[(3.0, 20.0, 0.0), (1.5, 9.0, 0.5)]);
        // Power about 5.6, so 2/(order*power) is about 0.0018 < 0.005.
        let mut p = ArLmsPredictor::new(&config(order, 10, 0.005, false)).unwrap();
        match p.fit(&x) {
            Err(PredictError::Numerical(msg)) => assert!(msg.contains("smaller gain"), "{msg}"),
            other => panic!("expected a divergence error, got {other:?}"),
        }
        let mut out = vec![0.0; 10];
        assert!(matches!(
            p.forecast(&x, &mut out),
            Err(PredictError::NotFitted(Method::Ar))
        ));
        let mut nlms = ArLmsPredictor::new(&config(order, 10, 0.1, true)).unwrap();
        nlms.fit(&x).unwrap();
        nlms.forecast(&x, &mut out).unwrap();
        assert!(out.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn bad_inputs_give_errors() {
        assert!(ArLmsPredictor::new(&config(4, 2, 0.0, false)).is_err());
        assert!(ArLmsPredictor::new(&config(4, 2, f64::NAN, false)).is_err());
        let mut p = ArLmsPredictor::new(&config(4, 2, 0.01, false)).unwrap();
        let mut out = [0.0; 2];
        assert!(matches!(
            p.forecast(&[0.0; 4], &mut out),
            Err(PredictError::NotFitted(Method::Ar))
        ));
        assert!(matches!(
            p.fit(&[1.0; 5]),
            Err(PredictError::TooShort {
                needed: 6,
                got: 5,
                ..
            })
        ));
        let mut with_nan = sines(50, &[(1.0, 9.0, 0.0)]);
        with_nan[20] = f64::NAN;
        assert!(matches!(p.fit(&with_nan), Err(PredictError::NonFinite(_))));
        p.fit(&sines(50, &[(1.0, 9.0, 0.0)])).unwrap();
        assert!(matches!(p.update(&[0.0; 5]), Err(PredictError::Length(_))));
        assert!(matches!(
            p.update(&with_nan[..21]),
            Err(PredictError::NonFinite(_))
        ));
        assert!(matches!(
            p.forecast(&[0.0; 3], &mut out),
            Err(PredictError::Length(_))
        ));
        assert!(matches!(
            p.forecast(&[0.0; 4], &mut out[..1]),
            Err(PredictError::Length(_))
        ));
    }

    #[test]
    fn a_model_file_with_missing_coefficients_is_refused() {
        let mut p = ArLmsPredictor::new(&config(4, 2, 0.01, false)).unwrap();
        p.fit(&sines(50, &[(1.0, 9.0, 0.0)])).unwrap();
        let mut model: serde_json::Value = serde_json::to_value(&p).unwrap();
        model["weights"].as_array_mut().unwrap().truncate(5);
        let err = serde_json::from_value::<ArLmsPredictor>(model).unwrap_err();
        assert!(
            err.to_string()
                .contains("AR weights hold 5 coefficients; order 4 x horizon 2 needed"),
            "{err}"
        );
    }
}
