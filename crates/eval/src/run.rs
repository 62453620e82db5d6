//! Evaluating methods on DOFs of a motion record: one [`Entry`] per (dof, method), failures
//! included, so one infeasible method never hides the results of the others.

use super::noise::add_noise;
use super::protocol::{origins, score_with_average, EvalError};
use serde::{Deserialize, Serialize};
use shipcast_predict::averaging::Averaging;
use shipcast_predict::{AnyPredictor, McaWeighting, Method, Predictor, PredictorConfig};
use shipcast_series::motion_csv::{MotionCsvError, MotionData};
use shipcast_wire::dof::Dof;
use std::time::Instant;

/// The protocol's settings other than the predictor configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalSettings {
    /// Length T of the training segment `x[0..T)`.
    pub train: usize,
    /// Spacing of forecast origins.
    pub stride: usize,
    /// Sample rate of the series [Hz] (reported; the series is already at this rate).
    pub sample_rate: f64,
    /// Gaussian noise added before training and testing, % of the peak |x| (0 = none).
    pub noise_pct: f64,
    /// Seed of the noise (and of the methods, through `PredictorConfig::seed`).
    pub seed: u64,
    /// Combination of the forecasts of the same instant from consecutive origins (k = 1: none).
    #[serde(default)]
    pub average: Averaging,
}

/// The result of one method on one DOF (one line of `shipcast eval --json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalResult {
    pub dof: Dof,
    pub method: Method,
    pub order: usize,
    pub horizon: usize,
    pub train: usize,
    pub stride: usize,
    pub sample_rate: f64,
    pub noise_pct: f64,
    pub seed: u64,
    /// Number of forecasts scored.
    pub origins: usize,
    /// RMS error per step h = 1..H (against the series scored, noisy if noise was added).
    pub rms: Vec<f64>,
    /// `rms` divided by the standard deviation of the test segment.
    pub nrmse: Vec<f64>,
    /// RMS error per step of persistence at the same origins.
    pub persistence_rms: Vec<f64>,
    /// With noise: RMS error per step against the clean series.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rms_clean: Option<Vec<f64>>,
    /// Standard deviation of the test segment `x[T..)`.
    pub test_std: f64,
    /// Wall time of `fit` [s].
    pub train_seconds: f64,
    /// Mean wall time of one forecast [s].
    pub predict_seconds: f64,
    /// Total wall time of online updates [s].
    pub update_seconds: f64,
    /// MCA: number of minor components used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub minor_components: Option<usize>,
    /// MCA with validated energy: the threshold chosen.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub energy: Option<f64>,
    /// MCA: the ridge used (inverse weighting with validation: the one chosen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ridge: Option<f64>,
    /// MCA: weights of the eigen-directions (paper or inverse).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mca_weighting: Option<McaWeighting>,
    /// How the scored forecasts combine the forecasts of the same instant (k = 1: the newest
    /// alone, the protocol without averaging).
    #[serde(default)]
    pub average: Averaging,
    /// Weighted averaging: per step, the fitted weights of the forecasts made 0, 1, ... steps
    /// before the origin (fitted on the training segment only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub average_weights: Option<Vec<Vec<f64>>>,
}

/// A (dof, method) pair that could not be evaluated, and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalFailure {
    pub dof: Dof,
    pub method: Method,
    pub error: String,
}

/// One (dof, method) outcome.
// One entry per (dof, method) pair, a few dozen per run at most: boxing the result would
// save nothing measurable and make every construction site noisier.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Entry {
    Done(EvalResult),
    Failed(EvalFailure),
}

impl Entry {
    pub fn dof(&self) -> Dof {
        match self {
            Entry::Done(r) => r.dof,
            Entry::Failed(f) => f.dof,
        }
    }
    pub fn method(&self) -> Method {
        match self {
            Entry::Done(r) => r.method,
            Entry::Failed(f) => f.method,
        }
    }
}

/// Errors that stop a whole evaluation (bad input rather than a failing method).
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error(transparent)]
    Csv(#[from] MotionCsvError),
    #[error(transparent)]
    Eval(#[from] EvalError),
}

/// A DOF series as the protocol scores it: with noise added if asked, and the clean original.
pub struct PreparedSeries {
    pub series: Vec<f64>,
    /// The series before noise, present only when noise was added.
    pub clean: Option<Vec<f64>>,
}

/// Add the settings' noise to `clean` (stream = DOF index).
pub fn prepare_series(
    clean: &[f64],
    dof: Dof,
    settings: &EvalSettings,
) -> Result<PreparedSeries, EvalError> {
    if settings.noise_pct == 0.0 {
        return Ok(PreparedSeries {
            series: clean.to_vec(),
            clean: None,
        });
    }
    let series = add_noise(clean, settings.noise_pct, settings.seed, dof.index() as u64)?;
    Ok(PreparedSeries {
        series,
        clean: Some(clean.to_vec()),
    })
}

/// Run the protocol for one method on one prepared series: fit on `x[0..T)`, score the test
/// segment.
pub fn evaluate_method(
    prepared: &PreparedSeries,
    dof: Dof,
    method: Method,
    config: &PredictorConfig,
    settings: &EvalSettings,
    progress: &dyn Fn(u64),
) -> Result<EvalResult, EvalError> {
    let series = &prepared.series;
    // Reject a series too short for one forecast before a possibly slow fit.
    let _ = origins(
        series.len(),
        settings.train,
        config.order,
        config.horizon,
        settings.stride,
    )?;
    settings.average.validate(config.horizon)?;
    let mut predictor = AnyPredictor::new(method, config)?;
    let start = Instant::now();
    predictor.fit(&series[..settings.train])?;
    let train_seconds = start.elapsed().as_secs_f64();
    let (scores, average_weights) = score_with_average(
        &mut predictor,
        &series[..settings.train],
        series,
        settings.train,
        settings.stride,
        prepared.clean.as_deref(),
        settings.average,
        progress,
    )?;
    let test_std = std_dev(&series[settings.train..]);
    let diagnostics = predictor.diagnostics();
    Ok(EvalResult {
        dof,
        method,
        order: config.order,
        horizon: config.horizon,
        train: settings.train,
        stride: settings.stride,
        sample_rate: settings.sample_rate,
        noise_pct: settings.noise_pct,
        seed: settings.seed,
        origins: scores.origins,
        nrmse: scores.rms.iter().map(|r| r / test_std).collect(),
        rms: scores.rms,
        persistence_rms: scores.persistence_rms,
        rms_clean: scores.rms_clean,
        test_std,
        train_seconds,
        predict_seconds: scores.predict_seconds,
        update_seconds: scores.update_seconds,
        minor_components: diagnostics.minor_components,
        energy: diagnostics.energy,
        ridge: diagnostics.ridge,
        mca_weighting: diagnostics.mca_weighting,
        average: settings.average,
        average_weights,
    })
}

/// Number of forecasts each (dof, method) will score on a record of `len` samples, or the
/// reason none fits (checked before any method runs, so bad input gives one error).
pub fn origin_count(
    len: usize,
    config: &PredictorConfig,
    settings: &EvalSettings,
) -> Result<usize, EvalError> {
    settings.average.validate(config.horizon)?;
    Ok(origins(
        len,
        settings.train,
        config.order,
        config.horizon,
        settings.stride,
    )?
    .count())
}

/// Evaluate every method on every DOF of `data` (already at `settings.sample_rate`).
/// Input errors (absent DOF, record too short, bad noise) stop everything; a method that fails
/// becomes an [`Entry::Failed`]. `on_entry` sees each entry as soon as it is done.
pub fn evaluate_record(
    data: &MotionData,
    dofs: &[Dof],
    methods: &[Method],
    config: &PredictorConfig,
    settings: &EvalSettings,
    progress: &dyn Fn(u64),
    on_entry: &mut dyn FnMut(&Entry),
) -> Result<Vec<Entry>, RecordError> {
    let mut columns = Vec::with_capacity(dofs.len());
    for &dof in dofs {
        columns.push(data.dof(dof)?);
    }
    origin_count(data.len(), config, settings)?;
    let mut entries = Vec::with_capacity(dofs.len() * methods.len());
    for (&dof, column) in dofs.iter().zip(columns) {
        let prepared = prepare_series(column, dof, settings)?;
        for &method in methods {
            let entry = match evaluate_method(&prepared, dof, method, config, settings, progress) {
                Ok(result) => Entry::Done(result),
                Err(e) => Entry::Failed(EvalFailure {
                    dof,
                    method,
                    error: e.to_string(),
                }),
            };
            on_entry(&entry);
            entries.push(entry);
        }
    }
    Ok(entries)
}

/// Population standard deviation (about the mean).
pub fn std_dev(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt()
}
