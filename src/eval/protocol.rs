//! The forecast-scoring loop of the evaluation protocol (docs/contracts.md section 4), shared by
//! `shipcast eval` and by the held-out error (sigma) of `shipcast train`.

use crate::predict::{PredictError, Predictor};
use std::time::Instant;

/// Why an evaluation could not run or a method failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EvalError {
    #[error(transparent)]
    Predict(#[from] PredictError),
    #[error("{what} must be at least 1")]
    Zero { what: &'static str },
    #[error("series of {len} samples is too short: train {train} + order {order} + horizon {horizon} = {needed} samples are needed for one forecast")]
    TooShort {
        len: usize,
        train: usize,
        order: usize,
        horizon: usize,
        needed: usize,
    },
    #[error("non-finite forecast at origin {origin}, step {step}")]
    NonFiniteForecast { origin: usize, step: usize },
    #[error("noise of {0} % of the peak amplitude: must be finite and not negative")]
    BadNoise(f64),
}

/// Forecast origins for a test segment starting at `first`: `first + order`,
/// `first + order + stride`, ... while `origin + horizon <= len`.
pub fn origins(
    len: usize,
    first: usize,
    order: usize,
    horizon: usize,
    stride: usize,
) -> Result<std::iter::StepBy<std::ops::RangeInclusive<usize>>, EvalError> {
    if order == 0 {
        return Err(EvalError::Zero { what: "order" });
    }
    if horizon == 0 {
        return Err(EvalError::Zero { what: "horizon" });
    }
    if stride == 0 {
        return Err(EvalError::Zero { what: "stride" });
    }
    // Checked: absurd flags (e.g. --order 18446744073709551615) must be an error, not a wrap.
    let needed = first
        .checked_add(order)
        .and_then(|v| v.checked_add(horizon))
        .unwrap_or(usize::MAX);
    if len < needed {
        return Err(EvalError::TooShort {
            len,
            train: first,
            order,
            horizon,
            needed,
        });
    }
    Ok((first + order..=len - horizon).step_by(stride))
}

/// Per-step errors of a fitted predictor over the forecast origins of one test segment.
#[derive(Clone, Debug, PartialEq)]
pub struct Scores {
    /// Number of forecasts scored.
    pub origins: usize,
    /// RMS error per step h = 1..H against the series.
    pub rms: Vec<f64>,
    /// RMS error per step against the clean series, when one was given.
    pub rms_clean: Option<Vec<f64>>,
    /// RMS error per step of persistence (last observed value) at the same origins.
    pub persistence_rms: Vec<f64>,
    /// Mean wall time of one `forecast` call [s].
    pub predict_seconds: f64,
    /// Total wall time of the online `update` calls [s] (0 for offline methods).
    pub update_seconds: f64,
}

/// Score `predictor` (already fitted) on the test segment `series[first..]`.
///
/// At origin `o` the forecast sees `series[o - order .. o)` and is scored against
/// `series[o .. o + H)` (and `clean[o .. o + H)` if given). An online predictor is first updated
/// with every value `series[t]`, `first <= t < o`, not yet given, in time order, each update
/// seeing `series[t + 1 - order - H ..= t]` (values before the test segment are history it may
/// use; a value with fewer than `order + H` values up to it is not given). So no update ever
/// sees a value at or after the origin it precedes.
///
/// `progress` is called with the number of origins done since its last call.
pub fn score_forecasts(
    predictor: &mut dyn Predictor,
    series: &[f64],
    first: usize,
    stride: usize,
    clean: Option<&[f64]>,
    progress: &dyn Fn(u64),
) -> Result<Scores, EvalError> {
    let order = predictor.order();
    let horizon = predictor.horizon();
    let origins = origins(series.len(), first, order, horizon, stride)?;
    let online = predictor.is_online();
    let history = order + horizon;

    let mut forecast = vec![0.0; horizon];
    let mut sum_sq = vec![0.0; horizon];
    let mut sum_sq_clean = vec![0.0; horizon];
    let mut sum_sq_persistence = vec![0.0; horizon];
    let mut next_update = first;
    let mut count = 0usize;
    let mut predict_time = 0.0;
    let mut update_time = 0.0;
    let mut unreported = 0u64;

    for origin in origins {
        if online {
            let start = Instant::now();
            while next_update < origin {
                let t = next_update;
                if t + 1 >= history {
                    predictor.update(&series[t + 1 - history..=t])?;
                }
                next_update += 1;
            }
            update_time += start.elapsed().as_secs_f64();
        }
        let start = Instant::now();
        predictor.forecast(&series[origin - order..origin], &mut forecast)?;
        predict_time += start.elapsed().as_secs_f64();

        let last = series[origin - 1];
        for (step, &f) in forecast.iter().enumerate() {
            if !f.is_finite() {
                return Err(EvalError::NonFiniteForecast {
                    origin,
                    step: step + 1,
                });
            }
            let truth = series[origin + step];
            sum_sq[step] += (f - truth).powi(2);
            sum_sq_persistence[step] += (last - truth).powi(2);
            if let Some(clean) = clean {
                sum_sq_clean[step] += (f - clean[origin + step]).powi(2);
            }
        }
        count += 1;
        unreported += 1;
        if unreported == 256 {
            progress(unreported);
            unreported = 0;
        }
    }
    progress(unreported);

    let rms = |sums: Vec<f64>| -> Vec<f64> {
        sums.into_iter()
            .map(|s| (s / count as f64).sqrt())
            .collect()
    };
    Ok(Scores {
        origins: count,
        rms: rms(sum_sq),
        rms_clean: clean.map(|_| rms(sum_sq_clean)),
        persistence_rms: rms(sum_sq_persistence),
        predict_seconds: predict_time / count as f64,
        update_seconds: update_time,
    })
}

/// Expected RMS error per step (sigma) of a fitted predictor, measured on the held-out values
/// `series[first..]` with the protocol's origins (stride `stride`); the values before `first`
/// are only history for online updates. The predictor service publishes this with every forecast.
pub fn forecast_sigma(
    predictor: &mut dyn Predictor,
    series: &[f64],
    first: usize,
    stride: usize,
) -> Result<Vec<f64>, EvalError> {
    Ok(score_forecasts(predictor, series, first, stride, None, &|_| {})?.rms)
}
