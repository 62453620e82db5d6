//! The bound: the Wiener predictor of a given order computed from the EXACT autocorrelation of
//! the simulated sea, i.e. the best any linear predictor of that order can do on that record.
//!
//! The study evaluates every method on the series decimated 8 -> 2 Hz by the evaluation's
//! anti-alias filter, so the bound must describe that filtered series, not the raw motion. For a
//! FIR filter h the filtered autocorrelation is `R_y(L) = sum_d g(d) R_x(L + d)` with
//! `g(d) = sum_n h(n) h(n + d)` (the autocorrelation of the taps), and decimation by `F` keeps
//! every `F`-th lag. This is exact given `R_x` at the input rate, so the bound and the methods
//! see the same signal.

use shipcast_predict::{PredictError, Predictor, WienerPredictor};

/// Relative white-noise floor added to `r(0)` before solving: a sea of few lines has a rank-
/// deficient Toeplitz matrix (each line adds rank two) and Levinson would fail on it. The floor
/// is the variance of a measurement noise of 1e-4 of the signal's standard deviation, far below
/// every error the study reports, and the report states it.
pub const NUGGET: f64 = 1e-8;

/// Autocorrelation of the series filtered by `taps` and decimated by `factor`, for output lags
/// `0..lags`, from the autocorrelation `r_in` of the input at input-rate lags. `r_in` must hold
/// at least `(lags - 1) * factor + taps.len()` lags (it is even in the lag, so negative lags are
/// read mirrored).
pub fn filtered_autocorrelation(
    r_in: &[f64],
    taps: &[f64],
    factor: usize,
    lags: usize,
) -> Result<Vec<f64>, String> {
    let m = taps.len();
    if m == 0 || factor == 0 {
        return Err("filter needs at least one tap and a factor of at least 1".into());
    }
    let needed = lags.saturating_sub(1) * factor + m;
    if r_in.len() < needed {
        return Err(format!(
            "filtered autocorrelation of {lags} lags needs {needed} input lags, got {}",
            r_in.len()
        ));
    }
    // g(d) for d = 0..m-1; g is even.
    let g: Vec<f64> = (0..m)
        .map(|d| {
            taps[..m - d]
                .iter()
                .zip(&taps[d..])
                .map(|(a, b)| a * b)
                .sum()
        })
        .collect();
    let r_at = |lag: i64| r_in[lag.unsigned_abs() as usize];
    Ok((0..lags)
        .map(|k| {
            let l = (k * factor) as i64;
            let mut s = g[0] * r_at(l);
            for (d, &gd) in g.iter().enumerate().skip(1) {
                s += gd * (r_at(l + d as i64) + r_at(l - d as i64));
            }
            s
        })
        .collect())
}

/// The optimal linear predictor of `order` past values for `horizon` steps under the
/// autocorrelation `r`, with its exact mean squared error per step.
#[derive(Clone, Debug)]
pub struct Bound {
    pub predictor: WienerPredictor,
    /// Exact RMS error per step 1..=horizon under `r` (with the nugget).
    pub rms: Vec<f64>,
}

impl Bound {
    /// Solve with the [`NUGGET`] floor. `r` holds at least `order + horizon` lags.
    pub fn from_autocorrelation(
        r: &[f64],
        order: usize,
        horizon: usize,
    ) -> Result<Self, PredictError> {
        let mut r = r.to_vec();
        if let Some(r0) = r.first_mut() {
            *r0 *= 1.0 + NUGGET;
        }
        let predictor = WienerPredictor::from_autocorrelation(&r, order, horizon)?;
        let map = predictor
            .coefficients()
            .ok_or_else(|| PredictError::Numerical("bound predictor has no coefficients".into()))?;
        // mse_h = r(0) - sum_l w_h(l) r(h + l); row entry j multiplies x(t - (order-1-j)).
        let rms = (1..=horizon)
            .map(|h| {
                let row = map.row(h - 1);
                let explained: f64 = row
                    .iter()
                    .enumerate()
                    .map(|(j, w)| w * r[h + order - 1 - j])
                    .sum();
                (r[0] - explained).max(0.0).sqrt()
            })
            .collect();
        debug_assert_eq!(predictor.order(), order);
        Ok(Self { predictor, rms })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_through_the_filter_gives_the_taps_autocorrelation() {
        let taps = [0.25, 0.5, 0.25];
        let mut r_in = vec![0.0; 20];
        r_in[0] = 1.0;
        let r = filtered_autocorrelation(&r_in, &taps, 2, 3).unwrap();
        // Lag 0: sum h^2; decimated lag 1 = input lag 2: h0 h2; lag 2 = input lag 4: none.
        assert!((r[0] - 0.375).abs() < 1e-15, "{r:?}");
        assert!((r[1] - 0.0625).abs() < 1e-15, "{r:?}");
        assert_eq!(r[2], 0.0);
    }

    /// A sinusoid's autocorrelation is a cosine; through the filter it is scaled by |H|^2.
    #[test]
    fn a_sinusoid_is_scaled_by_the_squared_gain() {
        let taps = shipcast_series::fir::design_lowpass(4);
        let w = 0.3; // rad per input sample
        let r_in: Vec<f64> = (0..200).map(|k| 0.5 * (w * k as f64).cos()).collect();
        let r = filtered_autocorrelation(&r_in, &taps, 4, 10).unwrap();
        let gain = shipcast_series::fir::magnitude(&taps, w / std::f64::consts::TAU);
        for (k, v) in r.iter().enumerate() {
            let expected = 0.5 * gain * gain * (w * 4.0 * k as f64).cos();
            assert!((v - expected).abs() < 1e-12, "lag {k}: {v} vs {expected}");
        }
    }

    #[test]
    fn too_few_input_lags_is_an_error() {
        let err = filtered_autocorrelation(&[1.0; 5], &[0.5, 0.5], 2, 4).unwrap_err();
        assert!(err.contains("needs 8 input lags"), "{err}");
    }

    #[test]
    fn ar1_bound_has_the_analytic_error() {
        // r(k) = a^k: the best h-step predictor is a^h x(t), error variance 1 - a^(2h).
        let a: f64 = 0.9;
        let r: Vec<f64> = (0..20).map(|k| a.powi(k)).collect();
        let b = Bound::from_autocorrelation(&r, 3, 5).unwrap();
        for (h, rms) in b.rms.iter().enumerate() {
            let expected = (1.0 + NUGGET - a.powi(2 * (h as i32 + 1))).sqrt();
            assert!(
                (rms - expected).abs() < 1e-6,
                "step {}: {rms} vs {expected}",
                h + 1
            );
        }
    }

    #[test]
    fn a_few_lines_are_predicted_almost_exactly() {
        // Three sinusoids: rank 6, singular without the nugget, near-perfectly predictable.
        let r: Vec<f64> = (0..80)
            .map(|k| {
                let k = k as f64;
                0.5 * (0.3 * k).cos() + 0.2 * (0.71 * k).cos() + 0.1 * (1.3 * k).cos()
            })
            .collect();
        let b = Bound::from_autocorrelation(&r, 40, 30).unwrap();
        let worst = b.rms.iter().fold(0.0f64, |m, v| m.max(*v));
        assert!(worst < 0.01 * r[0].sqrt(), "worst rms {worst}");
    }
}
