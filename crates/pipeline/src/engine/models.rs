//! The six fitted predictors the engine forecasts with, how they are chosen, and what they
//! scored on held-out data.
//!
//! Fitting on live data is judged out of sample: each candidate (method, order) is fitted on
//! the older part of the window and scored on the newest `holdout` values at every origin
//! (stride 1, so no origin is aligned with the training windows by construction). The
//! candidate whose recalibrated error over all steps is lowest wins, per DOF. Its held-out
//! pair sums become the calibrator's prior, so sigma starts from errors it really had.

use super::calibrate::PairSums;
use crate::config::PredictorServiceConfig;
use anyhow::Context;
use shipcast_eval::model::ModelFile;
use shipcast_eval::{EvalError, OnlineFeed};
use shipcast_predict::{AnyPredictor, Method, Predictor};
use shipcast_wire::payload::{MAX_STEPS, NUM_DOF};
use shipcast_wire::Dof;
use std::path::Path;

/// Fewest held-out forecast origins a candidate is scored on.
pub const MIN_HOLDOUT_ORIGINS: usize = 60;

/// Training values per model order at least (fewer over-fit the autocorrelation).
pub const TRAIN_PER_ORDER: usize = 4;

/// One predictor per DOF plus what it is known to do.
#[derive(Clone)]
pub struct ModelSet {
    pub predictors: Vec<AnyPredictor>,
    /// Held-out (m, x) sums per DOF and step; empty for a model never scored on this sea.
    pub held_out: Vec<Vec<PairSums>>,
    /// Mean normalised recalibrated held-out error per DOF (NaN if unscored), for the logs and
    /// for deciding whether a new model replaces the running one.
    pub score: [f64; NUM_DOF],
    pub version: u32,
}

impl ModelSet {
    /// Values of history the longest of the six needs.
    pub fn order(&self) -> usize {
        self.predictors.iter().map(|p| p.order()).max().unwrap_or(0)
    }

    pub fn horizon(&self) -> usize {
        self.predictors[0].horizon()
    }

    /// "wiener-100" per DOF, for logs.
    pub fn describe(&self) -> String {
        self.predictors
            .iter()
            .zip(Dof::ALL)
            .map(|(p, d)| format!("{} {}-{}", d.name(), p.method(), p.order()))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Held-out pair sums of a fitted predictor on `series[split..]`, origins at every value from
/// `split` on (values before `split` are only the forecasts' input, never scored; an online
/// method learns from each held-out value before the origins after it, as in the evaluation),
/// and the mean over steps of the recalibrated error relative to the held-out variance.
pub fn held_out_pairs(
    p: &mut AnyPredictor,
    series: &[f64],
    split: usize,
) -> Result<(Vec<PairSums>, f64), EvalError> {
    let (order, horizon) = (p.order(), p.horizon());
    let mut sums = vec![PairSums::default(); horizon];
    let mut out = vec![0.0; horizon];
    let mut feed = OnlineFeed::new(p, split);
    let first = split.max(order);
    for origin in first..=series.len().saturating_sub(horizon) {
        feed.catch_up(p, series, origin)?;
        p.forecast(&series[origin - order..origin], &mut out)?;
        for (k, (m, x)) in out.iter().zip(&series[origin..]).enumerate() {
            sums[k].add(*m, *x);
        }
    }
    let var = sums.first().map_or(f64::NAN, |s| s.mse(0.0));
    let score = sums.iter().map(|s| s.mse(s.beta()) / var).sum::<f64>() / horizon as f64;
    Ok((sums, score))
}

/// Orders worth trying on `len` values with `holdout` of them held out.
pub fn feasible_orders(config: &PredictorServiceConfig, len: usize, holdout: usize) -> Vec<usize> {
    let mut orders: Vec<usize> = feasible(config, len, holdout).collect();
    orders.sort_unstable();
    orders.dedup();
    orders
}

/// True if any order is worth trying (no allocation: the engine asks on the forecasting thread).
pub fn any_feasible_order(config: &PredictorServiceConfig, len: usize, holdout: usize) -> bool {
    feasible(config, len, holdout).next().is_some()
}

/// The candidate orders, unsorted and possibly repeated, that `len` values with `holdout` held
/// out allow.
fn feasible(
    config: &PredictorServiceConfig,
    len: usize,
    holdout: usize,
) -> impl Iterator<Item = usize> + '_ {
    let train = len.saturating_sub(holdout);
    config
        .candidate_orders
        .iter()
        .copied()
        .chain(std::iter::once(config.order))
        .filter(|&o| o >= 1 && o <= config.order)
        .filter(move |&o| {
            train >= TRAIN_PER_ORDER * o && holdout >= o + config.horizon + MIN_HOLDOUT_ORIGINS
        })
        .filter(|&o| config.method != Method::Mca || o > config.horizon)
}

/// The held-out part of a window of `len` values.
pub fn holdout_for(config: &PredictorServiceConfig, len: usize) -> usize {
    config.holdout.min(len / 3)
}

/// The held-out part of a window of `len` values of which the newest `recent` (if any) are from
/// the sea as it is now: scaled to those, so candidates are judged on the new sea only.
pub fn holdout_within(config: &PredictorServiceConfig, len: usize, recent: Option<usize>) -> usize {
    holdout_for(config, recent.map_or(len, |r| r.min(len)))
}

/// Fit six predictors on `series` (per DOF, oldest first): per DOF, every feasible order of the
/// configured method is fitted on all but the newest `holdout` values and scored on those; the
/// best is kept, with its held-out sums.
pub fn fit(
    series: &[Vec<f64>],
    config: &PredictorServiceConfig,
    version: u32,
) -> anyhow::Result<ModelSet> {
    fit_recent(series, config, version, None)
}

/// [`fit`] after a change of sea, when only the newest `recent` values (if any) are from the
/// sea as it is now: the held-out part is scaled to them, and every order is fitted twice, on
/// all the older values and on the recent ones before the held-out part only; the best of all
/// on the held-out (new-sea) values wins. Which window serves the new sea better is thus
/// decided on the new sea, not assumed.
pub fn fit_recent(
    series: &[Vec<f64>],
    config: &PredictorServiceConfig,
    version: u32,
    recent: Option<usize>,
) -> anyhow::Result<ModelSet> {
    let len = series.iter().map(Vec::len).min().unwrap_or(0);
    let holdout = holdout_within(config, len, recent);
    let split = len - holdout;
    // (first training value, orders) per training window, the whole window first.
    let mut windows = Vec::with_capacity(2);
    windows.push((0, feasible_orders(config, len, holdout)));
    if let Some(r) = recent.filter(|&r| r < len) {
        windows.push((len - r, feasible_orders(config, r, holdout)));
    }
    windows.retain(|w| !w.1.is_empty());
    if windows.is_empty() {
        anyhow::bail!(
            "{len} values are too few to fit and score any {} order up to {} (horizon {})",
            config.method,
            config.order,
            config.horizon
        );
    }
    let mut predictors = Vec::with_capacity(NUM_DOF);
    let mut held_out = Vec::with_capacity(NUM_DOF);
    let mut score = [f64::NAN; NUM_DOF];
    for (d, x) in series.iter().enumerate().take(NUM_DOF) {
        let x = &x[..len];
        let name = Dof::ALL[d].name();
        let mut best: Option<(AnyPredictor, Vec<PairSums>, f64)> = None;
        for (start, order) in windows
            .iter()
            .flat_map(|(start, orders)| orders.iter().map(move |&o| (*start, o)))
        {
            let pc = shipcast_predict::PredictorConfig {
                order,
                ..config.predictor_config()
            };
            let mut p = AnyPredictor::new(config.method, &pc)
                .with_context(|| format!("building the {} predictor", config.method))?;
            if let Err(e) = p.fit(&x[start..split]) {
                tracing::debug!(dof = name, order, "candidate not fitted: {e}");
                continue;
            }
            let (sums, s) = match held_out_pairs(&mut p, x, split) {
                Ok(r) => r,
                Err(e) => {
                    tracing::debug!(dof = name, order, "candidate failed on held-out data: {e}");
                    continue;
                }
            };
            tracing::debug!(dof = name, order, start, score = s, "candidate scored");
            if s.is_finite() && best.as_ref().is_none_or(|b| s < b.2) {
                best = Some((p, sums, s));
            }
        }
        // A DOF no candidate can fit (a constant column: a record without that motion) gets
        // the zero forecast: it has no skill to offer, and the other DOF still get models.
        let (p, sums, s) = match best {
            Some(b) => b,
            None => {
                tracing::debug!(
                    dof = name,
                    "no {} candidate fitted: zero forecast",
                    config.method
                );
                let pc = shipcast_predict::PredictorConfig {
                    order: 1,
                    ..config.predictor_config()
                };
                let mut p = AnyPredictor::new(Method::Zero, &pc)?;
                p.fit(&x[..split])?;
                let (sums, s) = held_out_pairs(&mut p, x, split)?;
                (p, sums, s)
            }
        };
        predictors.push(p);
        held_out.push(sums);
        score[d] = s;
    }
    Ok(ModelSet {
        predictors,
        held_out,
        score,
        version,
    })
}

/// The running model's score on the same held-out data as a new fit, to decide whether the new
/// one replaces it. NaN where it cannot be scored (too little history for its order).
pub fn score_on(
    models: &mut ModelSet,
    series: &[Vec<f64>],
    config: &PredictorServiceConfig,
    recent: Option<usize>,
) -> [f64; NUM_DOF] {
    let len = series.iter().map(Vec::len).min().unwrap_or(0);
    let split = len - holdout_within(config, len, recent);
    let mut out = [f64::NAN; NUM_DOF];
    for (d, p) in models.predictors.iter_mut().enumerate() {
        // Scoring a fitted model needs only origins, not `order` more values. After a change
        // the held-out part is short, and an unscored running model would be replaced by any
        // new fit; outside that the rule stays as it was (relaxing it everywhere changed the
        // start-up retrains and took the paper sea's max NRMSE to 1.0011).
        let needed = if recent.is_some() {
            MIN_HOLDOUT_ORIGINS
        } else {
            p.order()
        };
        if split >= p.order() && len >= split + needed + p.horizon() {
            if let Ok((_, s)) = held_out_pairs(p, &series[d][..len], split) {
                out[d] = s;
            }
        }
    }
    out
}

/// Load a model file from `shipcast train`; it must hold all six DOF and match the forecast
/// rate. Its sigma was measured on the data it was trained on, not on this sea, so it counts as
/// unscored here.
pub fn load(path: &Path, sample_rate_hz: f64) -> anyhow::Result<ModelSet> {
    let file = ModelFile::load(path)?;
    if (file.sample_rate - sample_rate_hz).abs() > 1e-9 {
        anyhow::bail!(
            "{}: model forecasts at {} Hz, the predictor runs at {sample_rate_hz} Hz",
            path.display(),
            file.sample_rate
        );
    }
    let mut predictors = Vec::with_capacity(NUM_DOF);
    for dof in Dof::ALL {
        let m = file
            .dofs
            .iter()
            .find(|m| m.dof == dof)
            .with_context(|| format!("{}: no model for {}", path.display(), dof.name()))?;
        if m.predictor.horizon() > MAX_STEPS {
            anyhow::bail!(
                "{}: horizon {} exceeds the forecast capacity {MAX_STEPS}",
                path.display(),
                m.predictor.horizon()
            );
        }
        predictors.push(m.predictor.clone());
    }
    let horizon = predictors[0].horizon();
    if predictors.iter().any(|p| p.horizon() != horizon) {
        anyhow::bail!("{}: the six DOF models differ in horizon", path.display());
    }
    Ok(ModelSet {
        predictors,
        held_out: Vec::new(),
        score: [f64::NAN; NUM_DOF],
        version: 1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(
        method: Method,
        order: usize,
        horizon: usize,
        holdout: usize,
    ) -> PredictorServiceConfig {
        PredictorServiceConfig {
            method,
            order,
            horizon,
            holdout,
            candidate_orders: vec![order],
            ..PredictorServiceConfig::default()
        }
    }

    #[test]
    fn held_out_sums_are_the_errors_at_every_origin() {
        // Persistence on a linear ramp: m = x - h * slope at every origin; the held-out sums
        // count one pair per origin and step.
        let series: Vec<Vec<f64>> = (0..NUM_DOF)
            .map(|d| (0..600).map(|i| i as f64 * 0.01 * (d + 1) as f64).collect())
            .collect();
        let set = fit(&series, &config(Method::Persistence, 10, 5, 150), 3).unwrap();
        assert_eq!(set.version, 3);
        for d in 0..NUM_DOF {
            let slope = 0.01 * (d + 1) as f64;
            for h in 0..5 {
                let s = set.held_out[d][h];
                // holdout min(150, 600 / 3) = 150: origins 450..=595.
                assert_eq!(s.count(), 146.0);
                let mut expect = PairSums::default();
                for o in 450..=595 {
                    let x = (o + h) as f64 * slope;
                    expect.add(x - (h + 1) as f64 * slope, x);
                }
                for i in 0..4 {
                    assert!((s.0[i] - expect.0[i]).abs() < 1e-9 * expect.0[i].abs().max(1.0));
                }
            }
        }
    }

    #[test]
    fn too_little_data_is_an_error() {
        let series = vec![vec![0.0; 20]; NUM_DOF];
        assert!(fit(&series, &config(Method::Persistence, 10, 5, 3), 0).is_err());
    }

    #[test]
    fn validation_picks_an_order_that_can_see_the_period() {
        // A sinusoid of period 40 values: a Wiener predictor of order 2 extrapolates a pure
        // sinusoid exactly, but with noise the longer order averages it out; any chosen order
        // must beat predicting zero by far.
        let series: Vec<Vec<f64>> = (0..NUM_DOF)
            .map(|_| {
                (0..3000)
                    .map(|i| (i as f64 * std::f64::consts::TAU / 40.0).sin())
                    .collect()
            })
            .collect();
        let mut c = config(Method::Wiener, 100, 20, 800);
        c.candidate_orders = vec![10, 50, 100];
        let set = fit(&series, &c, 1).unwrap();
        for d in 0..NUM_DOF {
            assert!(set.score[d] < 0.01, "{}", set.score[d]);
        }
    }
}
