//! The forecast-scoring loop of the evaluation protocol (docs/contracts.md section 4), shared by
//! `shipcast eval` and by the held-out error (sigma) of `shipcast train`.

use shipcast_predict::averaging::{
    averager_for, AverageMode, Averaging, ForecastAverager, StepWeights,
};
use shipcast_predict::{PredictError, Predictor};
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
    let mut feed = OnlineFeed::new(predictor, first);
    let mut forecast = vec![0.0; horizon];
    let mut sums = ErrorSums::new(horizon);
    let mut predict_time = 0.0;
    let mut unreported = 0u64;

    for origin in origins {
        feed.catch_up(predictor, series, origin)?;
        let start = Instant::now();
        predictor.forecast(&series[origin - order..origin], &mut forecast)?;
        predict_time += start.elapsed().as_secs_f64();
        sums.add(series, clean, origin, &forecast)?;
        unreported += 1;
        if unreported == 256 {
            progress(unreported);
            unreported = 0;
        }
    }
    progress(unreported);
    let forecasts = sums.count;
    Ok(sums.into_scores(clean.is_some(), predict_time, forecasts, feed.seconds))
}

/// Like [`score_forecasts`], but each scored forecast is the combination `averager` makes of
/// the forecasts of the same instants from the origins before it (docs/contracts.md section 4
/// origins; the combination of [`shipcast_predict::averaging`]). Forecasts are made at every
/// origin (stride 1) from `K - 1` steps before the first scored one, so every scored origin has
/// its K forecasts whatever `stride` is; only the protocol's origins (every `stride`-th) are
/// scored. An online predictor sees the same updates before each forecast as in
/// [`score_forecasts`]. `predict_seconds` is the mean time of one forecast plus its
/// combination, over every forecast made.
pub fn score_averaged_forecasts(
    predictor: &mut dyn Predictor,
    series: &[f64],
    first: usize,
    stride: usize,
    clean: Option<&[f64]>,
    averager: &mut ForecastAverager,
    progress: &dyn Fn(u64),
) -> Result<Scores, EvalError> {
    let order = predictor.order();
    let horizon = predictor.horizon();
    // Checks the lengths; the scored origins are `first + order`, then every `stride`-th.
    let _ = origins(series.len(), first, order, horizon, stride)?;
    let first_scored = first + order;
    let last = series.len() - horizon;
    averager.reset();
    let k = averager.weights().k();
    let start_origin = first_scored.saturating_sub(k - 1).max(order);
    let mut feed = OnlineFeed::new(predictor, first);
    let mut forecast = vec![0.0; horizon];
    let mut combined = vec![0.0; horizon];
    let mut sums = ErrorSums::new(horizon);
    let mut predict_time = 0.0;
    let mut forecasts = 0usize;
    let mut unreported = 0u64;

    for origin in start_origin..=last {
        feed.catch_up(predictor, series, origin)?;
        let start = Instant::now();
        predictor.forecast(&series[origin - order..origin], &mut forecast)?;
        averager.push(&forecast, &mut combined)?;
        predict_time += start.elapsed().as_secs_f64();
        forecasts += 1;
        if origin < first_scored || !(origin - first_scored).is_multiple_of(stride) {
            continue;
        }
        sums.add(series, clean, origin, &combined)?;
        unreported += 1;
        if unreported == 256 {
            progress(unreported);
            unreported = 0;
        }
    }
    progress(unreported);
    Ok(sums.into_scores(clean.is_some(), predict_time, forecasts, feed.seconds))
}

/// Score the fitted `predictor` on `series[first..]` with its forecasts combined as `average`
/// says ([`score_forecasts`] for K = 1, else [`score_averaged_forecasts`]); weighted
/// averaging fits its weights on `training` (the training segment, and nothing else) and
/// returns them per step (newest forecast first, all K available).
#[allow(clippy::too_many_arguments)]
pub fn score_with_average(
    predictor: &mut dyn Predictor,
    training: &[f64],
    series: &[f64],
    first: usize,
    stride: usize,
    clean: Option<&[f64]>,
    average: Averaging,
    progress: &dyn Fn(u64),
) -> Result<(Scores, Option<StepWeights>), EvalError> {
    if average.is_none() {
        let scores = score_forecasts(predictor, series, first, stride, clean, progress)?;
        return Ok((scores, None));
    }
    let mut averager = averager_for(average, predictor, training)?;
    let weights = (average.mode == AverageMode::Weighted).then(|| averager.weights().per_step());
    let scores = score_averaged_forecasts(
        predictor,
        series,
        first,
        stride,
        clean,
        &mut averager,
        progress,
    )?;
    Ok((scores, weights))
}

/// Feeds an online predictor every value of the test segment before each origin, in order.
/// Also used where the engine scores a fresh fit on held-out live data.
pub struct OnlineFeed {
    online: bool,
    next_update: usize,
    /// Total wall time of the updates [s].
    seconds: f64,
}

impl OnlineFeed {
    pub fn new(predictor: &dyn Predictor, first: usize) -> Self {
        Self {
            online: predictor.is_online(),
            next_update: first,
            seconds: 0.0,
        }
    }

    /// Update with every value `series[t]`, `t < origin`, not yet given.
    pub fn catch_up(
        &mut self,
        predictor: &mut dyn Predictor,
        series: &[f64],
        origin: usize,
    ) -> Result<(), EvalError> {
        if !self.online {
            return Ok(());
        }
        let history = predictor.order() + predictor.horizon();
        let start = Instant::now();
        while self.next_update < origin {
            let t = self.next_update;
            if t + 1 >= history {
                predictor.update(&series[t + 1 - history..=t])?;
            }
            self.next_update += 1;
        }
        self.seconds += start.elapsed().as_secs_f64();
        Ok(())
    }
}

/// Squared errors per step of the scored forecasts and of persistence at the same origins.
struct ErrorSums {
    sum_sq: Vec<f64>,
    sum_sq_clean: Vec<f64>,
    sum_sq_persistence: Vec<f64>,
    count: usize,
}

impl ErrorSums {
    fn new(horizon: usize) -> Self {
        Self {
            sum_sq: vec![0.0; horizon],
            sum_sq_clean: vec![0.0; horizon],
            sum_sq_persistence: vec![0.0; horizon],
            count: 0,
        }
    }

    /// Score the forecast made at `origin` against `series[origin..]` (and `clean[origin..]`).
    fn add(
        &mut self,
        series: &[f64],
        clean: Option<&[f64]>,
        origin: usize,
        forecast: &[f64],
    ) -> Result<(), EvalError> {
        let last = series[origin - 1];
        for (step, &f) in forecast.iter().enumerate() {
            if !f.is_finite() {
                return Err(EvalError::NonFiniteForecast {
                    origin,
                    step: step + 1,
                });
            }
            let truth = series[origin + step];
            self.sum_sq[step] += (f - truth).powi(2);
            self.sum_sq_persistence[step] += (last - truth).powi(2);
            if let Some(clean) = clean {
                self.sum_sq_clean[step] += (f - clean[origin + step]).powi(2);
            }
        }
        self.count += 1;
        Ok(())
    }

    /// RMS per step; `predict_time` is the total over `forecasts` forecast calls.
    fn into_scores(
        self,
        with_clean: bool,
        predict_time: f64,
        forecasts: usize,
        update_seconds: f64,
    ) -> Scores {
        let count = self.count;
        let rms = |sums: Vec<f64>| -> Vec<f64> {
            sums.into_iter()
                .map(|s| (s / count as f64).sqrt())
                .collect()
        };
        Scores {
            origins: count,
            rms: rms(self.sum_sq),
            rms_clean: with_clean.then(|| rms(self.sum_sq_clean)),
            persistence_rms: rms(self.sum_sq_persistence),
            predict_seconds: predict_time / forecasts as f64,
            update_seconds,
        }
    }
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
