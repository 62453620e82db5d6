//! Wiener-Hopf multi-step linear predictor (docs/contracts.md section 4).
//!
//! For each step h the predictor `x(t+h) ~ sum_l w_h(l) x(t-l)`, l = 0..order, minimises the
//! mean squared error under the autocorrelation `r`: the normal equations
//! `sum_l w_h(l) r(k-l) = r(k+h)`, k = 0..order, form a symmetric Toeplitz system solved by
//! Levinson recursion. `fit` uses the biased autocorrelation of the training segment
//! (positive definite by construction); `from_autocorrelation` takes an exact one, e.g. from a
//! wave spectrum, to compute the optimal linear predictor the other methods are measured against.
//! With `wiener_fit = least-squares` the same predictor is fitted by least squares over the
//! training segment's origins instead, and with `guarded` each forecast of that fit is held
//! near the autocorrelation fit's (`wiener_ls.rs`; neither is the paper's).

use super::levinson::{solve_toeplitz, workspace_len};
use super::linear_map::LinearMap;
use super::wiener_ls::{least_squares_from, FitGram, Guard, WienerFit};
use super::{
    check_forecast_buffers, check_training, Method, PredictError, Predictor, PredictorConfig,
};
use serde::{Deserialize, Serialize};

/// Wiener predictor: an `horizon x order` coefficient matrix applied to the last `order`
/// values (oldest first).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(remote = "Self", deny_unknown_fields)]
pub struct WienerPredictor {
    order: usize,
    horizon: usize,
    /// How `fit` estimates the weights (model files written before it existed: the paper's).
    #[serde(default)]
    fit: WienerFit,
    /// `None` until fitted.
    coefficients: Option<LinearMap>,
    /// `fit = guarded`: the band around the autocorrelation fit that forecasts are held in.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    guard: Option<Guard>,
}

impl WienerPredictor {
    /// An unfitted predictor with the order and horizon of `config`.
    pub fn new(config: &PredictorConfig) -> Result<Self, PredictError> {
        check_shape(config.order, config.horizon)?;
        Ok(Self {
            order: config.order,
            horizon: config.horizon,
            fit: config.wiener_fit,
            coefficients: None,
            guard: None,
        })
    }

    /// A fitted predictor from a given autocorrelation sequence `r[0], r[1], ...`, which must
    /// hold at least `order + horizon` lags (lag `order - 1 + horizon` is the last one used).
    pub fn from_autocorrelation(
        r: &[f64],
        order: usize,
        horizon: usize,
    ) -> Result<Self, PredictError> {
        check_shape(order, horizon)?;
        let needed = order + horizon;
        if r.len() < needed {
            return Err(PredictError::Length(format!(
                "Wiener order {order}, horizon {horizon} needs {needed} autocorrelation lags, got {}",
                r.len()
            )));
        }
        if r.iter().any(|v| !v.is_finite()) {
            return Err(PredictError::NonFinite("autocorrelation"));
        }
        Ok(Self {
            order,
            horizon,
            fit: WienerFit::Autocorrelation,
            coefficients: Some(solve_coefficients(r, order, horizon)?),
            guard: None,
        })
    }

    /// The coefficients, row h-1 for step h, column j multiplying the j-th of the last
    /// `order` values (oldest first). `None` before fitting.
    pub fn coefficients(&self) -> Option<&LinearMap> {
        self.coefficients.as_ref()
    }
}

serde_validated!(WienerPredictor);

impl WienerPredictor {
    /// What a model file must satisfy (see `serde_validated!`): order and horizon of at least
    /// 1 and, once fitted, a horizon x order coefficient matrix.
    fn validate(&self) -> Result<(), String> {
        check_shape(self.order, self.horizon).map_err(|e| e.to_string())?;
        match &self.coefficients {
            Some(c) if (c.rows(), c.cols()) != (self.horizon, self.order) => Err(format!(
                "Wiener coefficients are {} x {}; horizon {} and order {} need {} x {}",
                c.rows(),
                c.cols(),
                self.horizon,
                self.order,
                self.horizon,
                self.order
            )),
            _ => match (&self.guard, &self.coefficients) {
                (Some(guard), _) => guard.validate(self.order, self.horizon),
                // Regression (review): a fitted guarded model whose guard was deleted loaded
                // and forecast unguarded, the fit that failed worst after a course change.
                (None, Some(_)) if self.fit == WienerFit::Guarded => {
                    Err("a guarded Wiener fit has coefficients but no guard".into())
                }
                (None, _) => Ok(()),
            },
        }
    }
}

fn check_shape(order: usize, horizon: usize) -> Result<(), PredictError> {
    if order == 0 || horizon == 0 {
        return Err(PredictError::Infeasible(format!(
            "Wiener needs order and horizon of at least 1, got order {order}, horizon {horizon}"
        )));
    }
    Ok(())
}

/// Biased autocorrelation `r(k) = (1/T) sum_t x(t) x(t+k)` for lags `0..lags`; lags at or
/// beyond `T` are zero.
pub fn biased_autocorrelation(x: &[f64], lags: usize) -> Vec<f64> {
    let t = x.len();
    (0..lags)
        .map(|k| {
            if k >= t {
                return 0.0;
            }
            let s: f64 = x[..t - k].iter().zip(&x[k..]).map(|(a, b)| a * b).sum();
            s / t as f64
        })
        .collect()
}

/// Solve the Toeplitz normal equations for every step and store them as a matrix over the past
/// window in chronological order.
fn solve_coefficients(r: &[f64], order: usize, horizon: usize) -> Result<LinearMap, PredictError> {
    let mut w = vec![0.0; order];
    let mut work = vec![0.0; workspace_len(order)];
    let mut coef = vec![0.0; horizon * order];
    for h in 1..=horizon {
        solve_toeplitz(&r[..order], &r[h..h + order], &mut w, &mut work)
            .map_err(|e| PredictError::Numerical(e.to_string()))?;
        // w(l) multiplies x(t-l), the value l steps before the newest: column order-1-l.
        let row = &mut coef[(h - 1) * order..h * order];
        for (dst, &src) in row.iter_mut().rev().zip(&w) {
            *dst = src;
        }
    }
    LinearMap::from_row_major(horizon, order, coef).map_err(PredictError::Numerical)
}

impl Predictor for WienerPredictor {
    fn method(&self) -> Method {
        Method::Wiener
    }
    fn order(&self) -> usize {
        self.order
    }
    fn horizon(&self) -> usize {
        self.horizon
    }

    fn fit(&mut self, train: &[f64]) -> Result<(), PredictError> {
        let lags = self.order + self.horizon;
        let autocorrelation_fit = || -> Result<LinearMap, PredictError> {
            let r = biased_autocorrelation(train, lags);
            // A series of zeros (a column without that motion): said as such, not as the
            // Levinson recursion's "leading minor of size 1 is not positive" (review).
            if !(r.first().is_some_and(|&r0| r0 > 0.0)) {
                return Err(PredictError::Numerical(
                    "Wiener fit: the training segment has no power (all zeros)".into(),
                ));
            }
            solve_coefficients(&r, self.order, self.horizon)
        };
        let needed = self.fit.training_values(self.order, self.horizon);
        check_training(Method::Wiener, self.order, needed, train)?;
        let (coefficients, guard) = match self.fit {
            WienerFit::Autocorrelation => (autocorrelation_fit()?, None),
            WienerFit::LeastSquares | WienerFit::Guarded => {
                let gram = FitGram::new(train, self.order, self.horizon)?;
                let sharp = least_squares_from(&gram)?;
                let guard = (self.fit == WienerFit::Guarded)
                    .then(|| Guard::fit(&gram, &sharp, autocorrelation_fit()?))
                    .transpose()?;
                (sharp, guard)
            }
        };
        self.coefficients = Some(coefficients);
        self.guard = guard;
        Ok(())
    }

    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        let map = self
            .coefficients
            .as_mut()
            .ok_or(PredictError::NotFitted(Method::Wiener))?;
        check_forecast_buffers(self.order, self.horizon, past, out)?;
        let window = &past[past.len() - self.order..];
        map.apply_prepared(window, out);
        if let Some(guard) = self.guard.as_mut() {
            guard.hold(window, out);
        }
        Ok(())
    }

    fn prepare(&mut self, known: &[f64]) -> Result<(), PredictError> {
        if let Some(map) = self.coefficients.as_mut() {
            map.prepare(known);
        }
        if let Some(guard) = self.guard.as_mut() {
            guard.prepare(known);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conformance::{nrmse_over_test, sum_of_sinusoids, LINES, RATE_HZ};
    use faer::linalg::solvers::Solve;
    use faer::Mat;

    #[test]
    fn wiener_800_predicts_sinusoids_50_steps() {
        // The biased autocorrelation tapers lag k by (1 - k/T), which costs accuracy of the
        // order of order/T: on 5000 points Wiener-800 reaches nrmse 9e-3 (2e-3 on 20000,
        // 9e-4 on 50000), so this check trains on 80000 points (11 hours at 2 Hz).
        const TRAIN: usize = 80_000;
        let x = sum_of_sinusoids(TRAIN + 1000);
        let config = PredictorConfig {
            order: 800,
            horizon: 50,
            ..PredictorConfig::default()
        };
        let mut p = WienerPredictor::new(&config).unwrap();
        p.fit(&x[..TRAIN]).unwrap();
        let nrmse = nrmse_over_test(&mut p, &x, TRAIN, 25);
        assert!(nrmse < 1e-3, "Wiener-800 nrmse {nrmse}");
    }

    #[test]
    fn exact_autocorrelation_of_a_line_spectrum_predicts_it() {
        // r(k) = sum A^2/2 cos(w k) for the lines, plus a white-noise floor of 1e-8 of the
        // power that keeps the Toeplitz matrix positive definite.
        let (order, horizon) = (200, 50);
        let power: f64 = LINES.iter().map(|&(a, _, _)| a * a / 2.0).sum();
        let r: Vec<f64> = (0..order + horizon)
            .map(|k| {
                let lines: f64 = LINES
                    .iter()
                    .map(|&(a, period, _)| {
                        let w = 2.0 * std::f64::consts::PI / (period * RATE_HZ);
                        a * a / 2.0 * (w * k as f64).cos()
                    })
                    .sum();
                lines + if k == 0 { 1e-8 * power } else { 0.0 }
            })
            .collect();
        let mut p = WienerPredictor::from_autocorrelation(&r, order, horizon).unwrap();
        let x = sum_of_sinusoids(2000);
        let nrmse = nrmse_over_test(&mut p, &x, 1000, 7);
        assert!(nrmse < 1e-3, "exact Wiener-200 nrmse {nrmse}");
    }

    /// Independent path: autocorrelation by explicit double loop, Toeplitz matrix built in full
    /// and solved densely with faer for all steps at once.
    #[test]
    fn agrees_with_dense_reference_solve() {
        let (order, horizon, t) = (24, 6, 600);
        let x = crate::conformance::noisy_oscillation(t, 7);
        let mut r = vec![0.0; order + horizon];
        for (k, rk) in r.iter_mut().enumerate() {
            for i in 0..t - k {
                *rk += x[i] * x[i + k];
            }
            *rk /= t as f64;
        }
        let toeplitz = Mat::from_fn(order, order, |i, j| r[i.abs_diff(j)]);
        let rhs = Mat::from_fn(order, horizon, |k, h| r[k + h + 1]);
        let w = toeplitz.partial_piv_lu().solve(&rhs);

        let config = PredictorConfig {
            order,
            horizon,
            ..PredictorConfig::default()
        };
        let mut p = WienerPredictor::new(&config).unwrap();
        p.fit(&x).unwrap();
        let map = p.coefficients().unwrap();
        let scale = (0..horizon)
            .flat_map(|h| (0..order).map(move |l| (h, l)))
            .fold(0.0f64, |m, (h, l)| m.max(w[(l, h)].abs()));
        for h in 0..horizon {
            for l in 0..order {
                let got = map.row(h)[order - 1 - l];
                let diff = (got - w[(l, h)]).abs() / scale;
                assert!(
                    diff < 1e-6,
                    "step {} lag {l}: {got} vs {}",
                    h + 1,
                    w[(l, h)]
                );
            }
        }
        let from_r = WienerPredictor::from_autocorrelation(&r, order, horizon).unwrap();
        let diff = max_abs_diff(
            from_r.coefficients().unwrap().coefficients(),
            map.coefficients(),
        );
        assert!(
            diff <= 1e-12 * scale,
            "from_autocorrelation differs by {diff}"
        );
    }

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
    }

    #[test]
    fn exact_ar1_autocorrelation_gives_powers_of_the_pole() {
        // AR(1) with pole a: r(k) = a^k, the optimal h-step predictor is a^h x(t).
        let a: f64 = 0.8;
        let r: Vec<f64> = (0..12).map(|k| a.powi(k)).collect();
        let mut p = WienerPredictor::from_autocorrelation(&r, 5, 4).unwrap();
        let past = [0.3, -1.0, 0.2, 0.7, 2.0];
        let mut out = [0.0; 4];
        p.forecast(&past, &mut out).unwrap();
        for (h, o) in out.iter().enumerate() {
            let expected = a.powi(h as i32 + 1) * 2.0;
            assert!((o - expected).abs() < 1e-12, "step {}: {o}", h + 1);
        }
    }

    #[test]
    fn bad_autocorrelation_is_an_error() {
        let err = WienerPredictor::from_autocorrelation(&[1.0, 0.5], 2, 1).unwrap_err();
        assert!(matches!(err, PredictError::Length(_)), "{err}");
        let err = WienerPredictor::from_autocorrelation(&[1.0, 2.0, 0.0, 0.0], 2, 2).unwrap_err();
        assert!(err.to_string().contains("not positive definite"), "{err}");
        let err = WienerPredictor::from_autocorrelation(&[1.0, f64::NAN, 0.0], 2, 1).unwrap_err();
        assert_eq!(err, PredictError::NonFinite("autocorrelation"));
        let err = WienerPredictor::from_autocorrelation(&[1.0; 4], 0, 1).unwrap_err();
        assert!(matches!(err, PredictError::Infeasible(_)), "{err}");
    }

    #[test]
    fn constant_zero_training_is_a_numerical_error() {
        let mut p = WienerPredictor::new(&PredictorConfig {
            order: 4,
            horizon: 2,
            ..PredictorConfig::default()
        })
        .unwrap();
        let err = p.fit(&[0.0; 50]).unwrap_err();
        assert!(matches!(err, PredictError::Numerical(_)), "{err}");
        // Said as what it is (review: "Levinson: Toeplitz matrix is not positive definite").
        assert!(err.to_string().contains("no power (all zeros)"), "{err}");
    }
}
