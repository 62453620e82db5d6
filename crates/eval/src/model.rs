//! Model files: per-DOF fitted predictors and their held-out error, written by `shipcast train`
//! and loaded by the predictor service.
//!
//! One JSON object: `format_version`, `method`, `sample_rate` [Hz], the `config`
//! (a [`PredictorConfig`]), `holdout_fraction`, and `dofs`, one [`DofModel`] per DOF with the
//! fitted `predictor` ([`AnyPredictor`], tagged by `method`) and `sigma`, the RMS error per step
//! measured on data the model measured did not see. Unknown keys are errors, so a typo or a file
//! from a newer shipcast is reported rather than half-read.

use crate::{forecast_sigma, origins, EvalError};
use serde::{Deserialize, Serialize};
use shipcast_predict::{AnyPredictor, Method, PredictError, Predictor, PredictorConfig};
use shipcast_series::motion_csv::{MotionCsvError, MotionData};
use shipcast_wire::dof::Dof;
use shipcast_wire::payload::MAX_ABS_MOTION;
use std::path::{Path, PathBuf};

/// Version of the model file format this build reads and writes.
pub const MODEL_FORMAT_VERSION: u32 = 1;

/// A model file.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    pub format_version: u32,
    pub method: Method,
    /// Rate of the series the models forecast [Hz]; one step is 1 / sample_rate seconds.
    pub sample_rate: f64,
    pub config: PredictorConfig,
    /// Fraction at the end of each series held out to measure sigma.
    pub holdout_fraction: f64,
    pub dofs: Vec<DofModel>,
}

/// The model of one DOF.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DofModel {
    pub dof: Dof,
    /// Samples the final model was fitted on (the whole series).
    pub samples: usize,
    /// Expected RMS error per step h = 1..H, from a model fitted on the series without its
    /// held-out end and scored on that end.
    pub sigma: Vec<f64>,
    /// Forecasts behind `sigma`.
    pub sigma_origins: usize,
    /// Fitted on the whole series.
    pub predictor: AnyPredictor,
}

/// Why a model could not be trained, saved or loaded.
///
/// Inner errors are fields named `error`, not `source`: the message already includes them, and
/// a `source` would make error-chain printers (`anyhow`'s `{:#}`) repeat them.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// "model file": the bare OS or parser error named no model (review: `error: m.json: EOF
    /// while parsing a list at line 1 column 5000`).
    #[error("model file {path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("model file {path}: {error}")]
    Json {
        path: PathBuf,
        error: serde_json::Error,
    },
    /// A value that does not fit its field, named by its path in the file (the file is one
    /// line of a megabyte: a column number alone does not find it).
    #[error("{path}: at {field}: {error} (the text there: '{near}')")]
    JsonAt {
        path: PathBuf,
        field: String,
        error: serde_json::Error,
        /// The text around the error's line and column.
        near: String,
    },
    #[error("{path}: not a shipcast model file (a JSON object with a 'format_version')")]
    NoVersion { path: PathBuf },
    #[error(
        "{path}: model format version {found}, this shipcast reads version {MODEL_FORMAT_VERSION}"
    )]
    /// `found` is the field as written (a number, or e.g. `"1"` when quoted).
    Version { path: PathBuf, found: String },
    #[error("{path}: {reason}")]
    Invalid { path: PathBuf, reason: String },
    #[error(transparent)]
    Csv(#[from] MotionCsvError),
    #[error("{dof}: {error}")]
    Eval { dof: Dof, error: EvalError },
    #[error("{dof}: {error}")]
    Predict { dof: Dof, error: PredictError },
    #[error("hold-out fraction {0} must lie strictly between 0 and 1")]
    BadHoldout(f64),
    /// The held-out error dwarfs the motion: a map that diverges (MCA whose minor components
    /// hold next to no future part), not a model to hand the engine.
    #[error("{dof}: the model's held-out error at step {step} ({sigma:.3e}) is over {MAX_SIGMA_OVER_STD} times the held-out motion's RMS about the training mean ({std:.3e}): it diverges; try another --method, a --ridge, or more data")]
    Diverges {
        dof: Dof,
        step: usize,
        sigma: f64,
        std: f64,
    },
    #[error("no DOF to train")]
    NoDof,
    #[error("every DOF to train is all zeros (dead channels): there is no motion to fit")]
    AllZero,
}

/// How `train_models` fits and measures.
#[derive(Clone, Debug)]
pub struct TrainOptions {
    pub method: Method,
    pub config: PredictorConfig,
    /// Rate of the record [Hz] (the record must already be at this rate).
    pub sample_rate: f64,
    /// Fraction at the end of each series held out to measure sigma (0.2: fit on the first
    /// 80 %, measure on the last 20 %, then refit on all).
    pub holdout_fraction: f64,
    /// Spacing of the forecast origins on the held-out part.
    pub sigma_stride: usize,
}

/// Of `len` values, how many `train_models` trains on before the held-out end (`holdout` of
/// them, rounded up): the rest are held out.
pub fn training_len(len: usize, holdout: f64) -> usize {
    ((1.0 - holdout) * len as f64).floor() as usize
}

/// Fit one model per DOF in `dofs`: measure sigma on the held-out end of the series with a model
/// fitted on the rest, then refit on the whole series.
pub fn train_models(
    data: &MotionData,
    dofs: &[Dof],
    options: &TrainOptions,
) -> Result<ModelFile, ModelError> {
    let holdout = options.holdout_fraction;
    if !(holdout > 0.0 && holdout < 1.0) {
        return Err(ModelError::BadHoldout(holdout));
    }
    if dofs.is_empty() {
        return Err(ModelError::NoDof);
    }
    let config = &options.config;
    let mut models = Vec::with_capacity(dofs.len());
    for &dof in dofs {
        let series = data.dof(dof)?;
        // Regression (review): one dead channel (all zeros) failed the whole file with "no
        // power". It gets no model: the service forecasts a DOF without one as no skill, and
        // takes a model of it from live data once it moves.
        if series.iter().all(|&v| v == 0.0) {
            tracing::warn!(
                %dof,
                "train: {dof} is all zeros (a dead channel?): no model for it; the service forecasts it as no skill until it moves"
            );
            continue;
        }
        let split = training_len(series.len(), holdout);
        let eval_err = |error| ModelError::Eval { dof, error };
        let predict_err = |error| ModelError::Predict { dof, error };
        let sigma_origins = origins(
            series.len(),
            split,
            config.order,
            config.horizon,
            options.sigma_stride,
        )
        .map_err(eval_err)?
        .count();

        // The engine fits and forecasts each value less its level (the list, a sensor's
        // zero; `engine::level`), so the model is fitted on values less their mean: fitted on
        // raw values, a heave offset of 1e4 m raised the first step's held-out sigma from
        // 0.5 mm to 0.14 m (the relative ridge grows with the offset squared), and the map
        // was then applied to other values than it was fitted on (review). The held-out part
        // is centred by the mean of the values before it: nothing from it is used to fit.
        // A constant series (a column held at 0.5) is fitted as it is: centred it is all
        // zeros, on which a Wiener fit has no power to work with (review), and the engine
        // forecasts its level anyway.
        let constant = |x: &[f64]| x.iter().all(|&v| v == x[0]);
        let fit_mean = if constant(&series[..split]) {
            0.0
        } else {
            mean(&series[..split])
        };
        let centred_by_fit: Vec<f64> = series.iter().map(|v| v - fit_mean).collect();
        let mut held_out = AnyPredictor::new(options.method, config).map_err(predict_err)?;
        held_out
            .fit(&centred_by_fit[..split])
            .map_err(predict_err)?;
        let sigma = forecast_sigma(&mut held_out, &centred_by_fit, split, options.sigma_stride)
            .map_err(eval_err)?;

        let held_out_rms = rms(&centred_by_fit[split..]);
        check_converges(dof, &sigma, held_out_rms)?;
        let whole_mean = if constant(series) { 0.0 } else { mean(series) };
        let centred: Vec<f64> = series.iter().map(|v| v - whole_mean).collect();
        let mut predictor = AnyPredictor::new(options.method, config).map_err(predict_err)?;
        predictor.fit(&centred).map_err(predict_err)?;
        tracing::debug!(%dof, sigma_first = sigma[0], sigma_last = sigma[sigma.len() - 1], "model fitted");
        models.push(DofModel {
            dof,
            samples: series.len(),
            sigma,
            sigma_origins,
            predictor,
        });
    }
    if models.is_empty() {
        return Err(ModelError::AllZero);
    }
    Ok(ModelFile {
        format_version: MODEL_FORMAT_VERSION,
        method: options.method,
        sample_rate: options.sample_rate,
        config: config.clone(),
        holdout_fraction: holdout,
        dofs: models,
    })
}

/// Largest held-out error of a model `train` writes, in standard deviations of the motion.
const MAX_SIGMA_OVER_STD: f64 = 100.0;

/// The smallest motion [m, rad] that [`MAX_SIGMA_OVER_STD`] is a multiple of.
const MOTION_FLOOR: f64 = 1e-6;

/// A model whose held-out error stays within [`MAX_SIGMA_OVER_STD`] times the motion's RMS
/// `motion_rms`, at every step. The engine would replace the forecasts of one beyond as
/// implausible, but a file that only ever forecasts "no skill" is no model (review: MCA wrote
/// one with sigma 1e17).
fn check_converges(dof: Dof, sigma: &[f64], motion_rms: f64) -> Result<(), ModelError> {
    match sigma
        .iter()
        .enumerate()
        // Floored: a motion of no size (a constant column) has no scale to diverge from.
        .find(|(_, s)| !s.is_finite() || **s > MAX_SIGMA_OVER_STD * motion_rms.max(MOTION_FLOOR))
    {
        Some((step, &sigma)) => Err(ModelError::Diverges {
            dof,
            step: step + 1,
            sigma,
            std: motion_rms,
        }),
        None => Ok(()),
    }
}

/// Root mean square of `values` (0 for none).
fn rms(values: &[f64]) -> f64 {
    mean(&values.iter().map(|v| v * v).collect::<Vec<_>>()).sqrt()
}

/// The mean of `values` (0 for none).
fn mean(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.iter().sum::<f64>() / values.len() as f64
}

/// Up to 30 characters either side of `line` and `column` (1-based, as serde_json counts) of
/// `text`: inside a field's path (an array of thousands of coefficients), what the bad value
/// looks like is what finds it.
fn text_near(text: &str, line: usize, column: usize) -> String {
    let Some(line_text) = text.lines().nth(line.saturating_sub(1)) else {
        return String::new();
    };
    let chars: Vec<char> = line_text.chars().collect();
    let at = column.saturating_sub(1).min(chars.len());
    let from = at.saturating_sub(30);
    let to = (at + 30).min(chars.len());
    chars[from..to].iter().collect()
}

/// Parse `text` as a `T`, naming an error by its field path in the file and the text there.
fn parse_locating<T: serde::de::DeserializeOwned>(
    text: &str,
    path: &Path,
) -> Result<T, ModelError> {
    let mut parser = serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(&mut parser).map_err(|e| {
        let field = e.path().to_string();
        let error = e.into_inner();
        // At the top level there is no field to name ("at ."): not JSON, or empty.
        if field == "." {
            return ModelError::Json {
                path: path.to_path_buf(),
                error,
            };
        }
        ModelError::JsonAt {
            path: path.to_path_buf(),
            field,
            near: text_near(text, error.line(), error.column()),
            error,
        }
    })
}

impl ModelFile {
    /// The model of `dof`, if the file has one.
    pub fn dof(&self, dof: Dof) -> Option<&DofModel> {
        self.dofs.iter().find(|m| m.dof == dof)
    }

    /// Write the file (compact JSON: prediction matrices are large), atomically: a write that
    /// fails leaves an existing model file as it was. Regression (review): it was written in
    /// place, and a retrain whose write failed (a full disk) left a truncated model that the
    /// predictor then refused.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), ModelError> {
        let path = path.as_ref();
        let json = serde_json::to_vec(self).map_err(|error| ModelError::Json {
            path: path.to_path_buf(),
            error,
        })?;
        shipcast_series::atomic_file::write_atomically(path, &json).map_err(|e| ModelError::Io {
            path: path.to_path_buf(),
            error: std::io::Error::other(e.to_string()),
        })
    }

    /// Read and check a model file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ModelError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|error| ModelError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        Self::from_json(&text, path)
    }

    /// Parse and check a model file's text; `path` only names it in errors.
    pub fn from_json(text: &str, path: &Path) -> Result<Self, ModelError> {
        // The version first, so that a file of another version says so instead of failing on
        // whichever field changed.
        #[derive(Deserialize)]
        struct VersionOnly {
            format_version: Option<serde_json::Value>,
        }
        let probe: VersionOnly = match serde_json::from_str(text) {
            Ok(probe) => probe,
            // Regression (review): text that is not JSON (a bare NaN written into a
            // coefficient) failed here with a column of a one-line megabyte file and no field:
            // the model's own parse names the field the text breaks.
            Err(error) => {
                return Err(match parse_locating::<ModelFile>(text, path) {
                    Err(located) => located,
                    Ok(_) => ModelError::Json {
                        path: path.to_path_buf(),
                        error,
                    },
                })
            }
        };
        // Regression (review): a file wrapped in [ ... ] passed as a sequence, its first
        // element taken for the version, and the error quoted the whole model.
        if !text.trim_start().starts_with('{') {
            return Err(ModelError::NoVersion {
                path: path.to_path_buf(),
            });
        }
        match probe.format_version {
            None => {
                return Err(ModelError::NoVersion {
                    path: path.to_path_buf(),
                })
            }
            Some(v) if v.as_u64() == Some(u64::from(MODEL_FORMAT_VERSION)) => {}
            // Shown as written: a quoted "1" was reported as version 0.
            Some(found) => {
                let mut found = found.to_string();
                if found.len() > 40 {
                    let end = (0..=37)
                        .rev()
                        .find(|&i| found.is_char_boundary(i))
                        .unwrap_or(0);
                    found = format!("{}...", &found[..end]);
                }
                return Err(ModelError::Version {
                    path: path.to_path_buf(),
                    found,
                });
            }
        }
        let model: ModelFile = parse_locating(text, path)?;
        model.check().map_err(|reason| ModelError::Invalid {
            path: path.to_path_buf(),
            reason,
        })?;
        Ok(model)
    }

    /// Consistency a hand-edited or corrupted file may lack.
    fn check(&self) -> Result<(), String> {
        if !(self.sample_rate > 0.0 && self.sample_rate.is_finite()) {
            return Err(format!("sample_rate {} must be positive", self.sample_rate));
        }
        if self.dofs.is_empty() {
            return Err("no DOF models".into());
        }
        // Regression (review): a hand-edited file with these out of range loaded silently.
        if !(self.holdout_fraction > 0.0 && self.holdout_fraction < 1.0) {
            return Err(format!(
                "holdout_fraction {} must be in (0, 1)",
                self.holdout_fraction
            ));
        }

        for (i, m) in self.dofs.iter().enumerate() {
            if self.dofs[..i].iter().any(|o| o.dof == m.dof) {
                return Err(format!("{} appears twice", m.dof));
            }
            let p = &m.predictor;
            if p.method() != self.method
                || p.order() != self.config.order
                || p.horizon() != self.config.horizon
            {
                return Err(format!(
                    "{}: predictor {} order {} horizon {} does not match the file's {} order {} horizon {}",
                    m.dof, p.method(), p.order(), p.horizon(),
                    self.method, self.config.order, self.config.horizon
                ));
            }
            if m.sigma.len() != self.config.horizon {
                return Err(format!(
                    "{}: {} sigma values for horizon {}",
                    m.dof,
                    m.sigma.len(),
                    self.config.horizon
                ));
            }
            if m.samples == 0 || m.sigma_origins == 0 {
                return Err(format!(
                    "{}: samples {} and sigma_origins {} must be at least 1",
                    m.dof, m.samples, m.sigma_origins
                ));
            }
            if m.sigma.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
                return Err(format!(
                    "{}: sigma holds a negative or non-finite value",
                    m.dof
                ));
            }
            check_forecasts(m, self.sample_rate)?;
        }
        // The file's own method must be buildable from its configuration (a negative LMS
        // gain, a hidden layer of 0 units, an MCA window shift of 0); after the models, whose
        // own errors name their DOF.
        AnyPredictor::new(self.method, &self.config).map_err(|e| format!("config: {e}"))?;
        Ok(())
    }
}

/// Largest order and horizon a model file may declare: far beyond any useful model, and small
/// enough that the trial forecast below cannot exhaust memory.
const MAX_MODEL_SIZE: usize = 1_000_000;

/// Period of the trial motion [s]: a wave.
const TRIAL_PERIOD_S: f64 = 10.0;

/// A model that loads must forecast: order and horizon of at least 1 (a hand-edited 0 would
/// make a baseline or AR predictor index out of bounds), fitted (an empty MLP or Wiener
/// predictor would fail only at the service's first forecast), finite on a quiet sea, and
/// within what any motion reaches (`MAX_ABS_MOTION`) from a wave of amplitude 1 sampled at
/// `sample_rate` (regression, review: coefficients edited to 1e300 forecast 0 from a quiet
/// sea and loaded; in service every forecast was then taken for a jump of the level).
fn check_forecasts(m: &DofModel, sample_rate: f64) -> Result<(), String> {
    let (order, horizon) = (m.predictor.order(), m.predictor.horizon());
    if !(1..=MAX_MODEL_SIZE).contains(&order) || !(1..=MAX_MODEL_SIZE).contains(&horizon) {
        return Err(format!(
            "{}: order {order} and horizon {horizon} must be in 1..={MAX_MODEL_SIZE}",
            m.dof
        ));
    }
    // Each trial on a fresh copy: a predictor that adapts must not carry one into the next.
    let trial = |input: &[f64], out: &mut [f64]| {
        m.predictor.clone().forecast(input, out).map_err(|e| {
            format!(
                "{}: the {} model cannot forecast: {e}",
                m.dof,
                m.predictor.method()
            )
        })
    };
    let mut out = vec![0.0; horizon];
    trial(&vec![0.0; order], &mut out)?;
    if out.iter().any(|v| !v.is_finite()) {
        return Err(format!(
            "{}: the {} model forecasts a non-finite value",
            m.dof,
            m.predictor.method()
        ));
    }
    let step = std::f64::consts::TAU / (TRIAL_PERIOD_S * sample_rate);
    let wave: Vec<f64> = (0..order).map(|i| (i as f64 * step).sin()).collect();
    trial(&wave, &mut out)?;
    // NaN as infinity: `f64::max` would pass it over.
    let largest = out
        .iter()
        .map(|v| if v.is_nan() { f64::INFINITY } else { v.abs() })
        .fold(0.0, f64::max);
    if largest > MAX_ABS_MOTION {
        return Err(format!(
            "{}: the {} model forecasts {largest:e} from a wave of amplitude 1 (beyond +-{MAX_ABS_MOTION:e}, which no motion reaches): its coefficients are corrupt",
            m.dof,
            m.predictor.method()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use shipcast_series::motion_csv::Column;

    fn record(len: usize) -> MotionData {
        let wave = |scale: f64| -> Vec<f64> {
            (0..len)
                .map(|i| scale * ((i as f64 * 0.3).sin() + 0.4 * (i as f64 * 0.17 + 1.0).cos()))
                .collect()
        };
        MotionData {
            ignored: Vec::new(),
            time: (0..len).map(|i| i as f64 * 0.5).collect(),
            columns: vec![
                Column {
                    name: "heave_m".into(),
                    values: wave(1.0),
                },
                Column {
                    name: "roll_rad".into(),
                    values: wave(0.05),
                },
            ],
        }
    }

    fn options(method: Method) -> TrainOptions {
        TrainOptions {
            method,
            config: PredictorConfig {
                order: 40,
                horizon: 6,
                ..PredictorConfig::default()
            },
            sample_rate: 2.0,
            holdout_fraction: 0.2,
            sigma_stride: 1,
        }
    }

    #[test]
    fn persistence_sigma_is_its_held_out_error_and_the_file_round_trips() {
        let data = record(500);
        let model = train_models(
            &data,
            &[Dof::Heave, Dof::Roll],
            &options(Method::Persistence),
        )
        .unwrap();
        let heave = data.dof(Dof::Heave).unwrap();
        // Held out: origins 400 + 40 ..= 494.
        let origins: Vec<usize> = (440..=494).collect();
        let m = model.dof(Dof::Heave).unwrap();
        assert_eq!(m.sigma_origins, origins.len());
        for h in 1..=6 {
            let expected = (origins
                .iter()
                .map(|&o| (heave[o - 1] - heave[o + h - 1]).powi(2))
                .sum::<f64>()
                / origins.len() as f64)
                .sqrt();
            assert!((m.sigma[h - 1] - expected).abs() < 1e-12);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.json");
        model.save(&path).unwrap();
        let loaded = ModelFile::load(&path).unwrap();
        assert_eq!(loaded.dofs.len(), 2);
        assert_eq!(loaded.config, model.config);
        assert_eq!(
            loaded.dof(Dof::Roll).unwrap().sigma,
            model.dof(Dof::Roll).unwrap().sigma
        );
    }

    /// Regression (review): `train` fitted raw values while the engine fits values less
    /// their level, and an offset raised the held-out sigma (0.5 mm without, 0.14 m with
    /// 1e4 m of heave offset). A model of a record with an offset is the model without it.
    #[test]
    fn an_offset_changes_neither_the_fitted_map_nor_its_sigma() {
        let data = record(600);
        let mut shifted = data.clone();
        for v in &mut shifted.columns[0].values {
            *v += 1e4;
        }
        let fit = |d: &MotionData| train_models(d, &[Dof::Heave], &options(Method::Wiener));
        let (mut plain, mut offset) = (fit(&data).unwrap(), fit(&shifted).unwrap());
        for (a, b) in plain.dofs[0].sigma.iter().zip(&offset.dofs[0].sigma) {
            assert!((a - b).abs() <= 1e-6 * a.max(1e-9), "sigma {a} and {b}");
        }
        // Both maps forecast the same deviation from the same centred past.
        let past: Vec<f64> = data.dof(Dof::Heave).unwrap()[500..540].to_vec();
        let (mut a, mut b) = (vec![0.0; 6], vec![0.0; 6]);
        plain.dofs[0].predictor.forecast(&past, &mut a).unwrap();
        offset.dofs[0].predictor.forecast(&past, &mut b).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-6, "{x} and {y}");
        }
    }

    /// Regression (review): centred, a constant column became all zeros and the Wiener fit
    /// failed for want of power, so `train` refused a record it used to take.
    #[test]
    fn a_constant_column_still_trains() {
        let mut data = record(600);
        data.columns[1].values.iter_mut().for_each(|v| *v = 0.5);
        let model =
            train_models(&data, &[Dof::Heave, Dof::Roll], &options(Method::Wiener)).unwrap();
        // The constant is forecast as itself, within the (small) sigma the held-out data gave:
        // the ridge shrinks the raw map's gain a little, and sigma says by how much.
        let mut roll = model.dof(Dof::Roll).unwrap().clone();
        assert!(
            roll.sigma.iter().all(|s| *s < 0.02 * 0.5),
            "{:?}",
            roll.sigma
        );
        let past = vec![0.5; roll.predictor.order()];
        let mut out = vec![0.0; roll.sigma.len()];
        roll.predictor.forecast(&past, &mut out).unwrap();
        for (v, s) in out.iter().zip(&roll.sigma) {
            assert!(
                (v - 0.5).abs() <= 2.0 * s + 1e-9,
                "{out:?} sigma {:?}",
                roll.sigma
            );
        }
    }

    /// Regression (review): one dead channel (all zeros) failed the whole file with "no
    /// power"; it is left out, and only a record of nothing but dead channels is refused.
    #[test]
    fn a_dead_channel_gets_no_model_and_the_others_still_train() {
        let mut data = record(600);
        data.columns[1].values.iter_mut().for_each(|v| *v = 0.0);
        let model =
            train_models(&data, &[Dof::Heave, Dof::Roll], &options(Method::Wiener)).unwrap();
        assert!(model.dof(Dof::Heave).is_some());
        assert!(model.dof(Dof::Roll).is_none());
        // What is written loads again.
        let text = serde_json::to_string(&model).unwrap();
        ModelFile::from_json(&text, Path::new("m.json")).unwrap();
        let e = train_models(&data, &[Dof::Roll], &options(Method::Wiener)).unwrap_err();
        assert!(matches!(e, ModelError::AllZero), "{e}");
    }

    #[test]
    fn a_diverging_model_is_refused_naming_its_dof_and_step() {
        assert!(check_converges(Dof::Heave, &[0.5, 1.0, 99.0], 1.0).is_ok());
        let e = check_converges(Dof::Roll, &[0.5, 101.0, 1e17], 1.0).unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::Diverges {
                    dof: Dof::Roll,
                    step: 2,
                    ..
                }
            ),
            "{e}"
        );
        let e = check_converges(Dof::Heave, &[f64::NAN], 1.0).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("heave: the model's held-out error at step 1"),
            "{e}"
        );
    }

    #[test]
    fn loaded_wiener_model_forecasts_like_the_saved_one() {
        let data = record(600);
        let mut model = train_models(&data, &[Dof::Heave], &options(Method::Wiener)).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("w.json");
        model.save(&path).unwrap();
        let mut loaded = ModelFile::load(&path).unwrap();
        let past = &data.dof(Dof::Heave).unwrap()[500..540];
        let (mut a, mut b) = (vec![0.0; 6], vec![0.0; 6]);
        model.dofs[0].predictor.forecast(past, &mut a).unwrap();
        loaded.dofs[0].predictor.forecast(past, &mut b).unwrap();
        assert_eq!(a, b);
        // A sum of two sinusoids is predictable: sigma far below the signal's size.
        assert!(
            model.dofs[0].sigma.iter().all(|s| *s < 0.05),
            "{:?}",
            model.dofs[0].sigma
        );
    }

    /// The error `from_json` gives for the file of a model trained with `method` after `edit`.
    fn load_error(method: Method, edit: impl Fn(&mut serde_json::Value)) -> String {
        let data = record(500);
        let model = train_models(&data, &[Dof::Heave], &options(method)).unwrap();
        let mut v = serde_json::to_value(&model).unwrap();
        edit(&mut v);
        let err = ModelFile::from_json(&v.to_string(), Path::new("m.json"))
            .expect_err("corrupted file loaded")
            .to_string();
        assert!(err.starts_with("m.json: ") && !err.contains('\n'), "{err}");
        err
    }

    /// Regression (review): a coefficient edited to null in a one-line file of a megabyte
    /// was "invalid type: null, expected f64 at line 1 column 658727", which finds nothing.
    #[test]
    fn a_value_of_the_wrong_type_is_named_by_its_field_and_shown_in_its_text() {
        let err = load_error(Method::Wiener, |v| {
            v["dofs"][0]["predictor"]["coefficients"]["coef"][5] = serde_json::Value::Null;
        });
        assert!(
            err.contains("at dofs[0].predictor: invalid type: null"),
            "{err}"
        );
        assert!(err.contains("null,"), "the text around it: {err}");
        let err = load_error(Method::Wiener, |v| v["dofs"][0]["sigma"][2] = "x".into());
        assert!(
            err.contains("at dofs[0].sigma[2]: invalid type: string"),
            "{err}"
        );
        assert!(err.contains("\"x\""), "{err}");
    }

    /// Regression (review): coefficients edited to 1e300 forecast 0 from the quiet sea the
    /// load check tried, so the file loaded, and in service every forecast was taken for a
    /// jump of the level. A trained model of each method passes the same trial.
    #[test]
    fn a_model_that_blows_a_wave_up_beyond_any_motion_is_refused() {
        for method in [Method::Wiener, Method::Mca, Method::Ar] {
            let err = load_error(method, |v| {
                let p = &mut v["dofs"][0]["predictor"];
                let coef = match method {
                    Method::Wiener => &mut p["coefficients"]["coef"],
                    Method::Mca => &mut p["model"]["prediction"]["coef"],
                    _ => &mut p["weights"],
                };
                for c in coef.as_array_mut().unwrap() {
                    *c = 1e300.into();
                }
            });
            assert!(
                err.contains("heave: the") && err.contains("from a wave of amplitude 1"),
                "{method:?}: {err}"
            );
        }
    }

    #[test]
    fn corrupted_predictors_are_refused_naming_the_field() {
        let predictor = |v: &mut serde_json::Value| v["dofs"][0]["predictor"].take();
        let put = |v: &mut serde_json::Value, p: serde_json::Value| v["dofs"][0]["predictor"] = p;
        // Order 40, horizon 6: P is 6 x 34.
        type Edit = fn(&mut serde_json::Value);
        let cases: [(Method, &str, Edit); 11] = [
            // Regression (review): a guarded fit without its guard forecast unguarded.
            (
                Method::Wiener,
                "a guarded Wiener fit has coefficients but no guard",
                |p| {
                    // This fit has none (autocorrelation): as a guarded one whose guard was cut.
                    assert!(p.get("guard").is_none());
                    p["fit"] = "guarded".into();
                },
            ),
            // Regression (review): a 0 x 10^12 map aborted the program on load.
            (
                Method::Wiener,
                "matrix of 0 x 1000000000000 is empty",
                |p| {
                    p["coefficients"] =
                        serde_json::json!({"rows": 0, "cols": 1e12 as u64, "coef": []});
                },
            ),
            (Method::Mca, "MCA model.prediction is 6 x 33", |p| {
                let m = &mut p["model"]["prediction"];
                m["cols"] = 33.into();
                m["coef"].as_array_mut().unwrap().truncate(6 * 33);
            }),
            (Method::Mca, "needs 204 coefficients, got 203", |p| {
                p["model"]["prediction"]["coef"]
                    .as_array_mut()
                    .unwrap()
                    .pop();
            }),
            (Method::Mca, "horizon < order", |p| p["horizon"] = 40.into()),
            (Method::Mca, "energy threshold must be in [0, 1)", |p| {
                p["energy"] = 1.5.into()
            }),
            (Method::Mca, "MCA model.minor_components 41", |p| {
                p["model"]["minor_components"] = 41.into()
            }),
            (Method::Mca, "MCA model.ridge", |p| {
                p["model"]["ridge"] = (-1.0).into()
            }),
            (Method::Wiener, "Wiener coefficients are 6 x 39", |p| {
                let m = &mut p["coefficients"];
                m["cols"] = 39.into();
                m["coef"].as_array_mut().unwrap().truncate(6 * 39);
            }),
            (Method::Ar, "AR weights hold 239 coefficients", |p| {
                p["weights"].as_array_mut().unwrap().pop();
            }),
            (Method::Mlp, "MLP params hold", |p| {
                p["params"].as_array_mut().unwrap().pop();
            }),
        ];
        for (method, want, edit) in cases {
            let err = load_error(method, |v| {
                let mut p = predictor(v);
                edit(&mut p);
                put(v, p);
            });
            assert!(err.contains(want), "{method}: want '{want}' in: {err}");
        }
    }

    /// The error of loading an MCA model file whose first coefficient is written as `value`.
    fn error_with_first_coefficient(value: &str) -> String {
        let model = train_models(&record(500), &[Dof::Heave], &options(Method::Mca)).unwrap();
        let text = serde_json::to_string(&model).unwrap();
        let start = text.find("\"coef\":[").unwrap() + "\"coef\":[".len();
        let end = start + text[start..].find(',').unwrap();
        let text = format!("{}{value}{}", &text[..start], &text[end..]);
        ModelFile::from_json(&text, Path::new("m.json"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn a_coefficient_beyond_f64_is_refused() {
        // JSON has no NaN or infinity; the nearest a file comes is a number beyond f64.
        let err = error_with_first_coefficient("-1e999");
        assert!(err.starts_with("m.json: ") && !err.contains('\n'), "{err}");
        assert!(
            err.contains("out of range") || err.contains("not finite"),
            "{err}"
        );
    }

    #[test]
    fn a_bare_nan_is_named_by_its_field() {
        // Regression (review): a NaN written into a coefficient is not JSON, and the error gave
        // only a column of the one-line file, not the field it broke.
        let err = error_with_first_coefficient("NaN");
        assert!(err.starts_with("m.json: at dofs[0]."), "{err}");
        assert!(err.contains(".coef[0]: ") && err.contains("[NaN,"), "{err}");
    }

    #[test]
    fn hand_edited_shapes_and_unfitted_models_are_refused_at_load() {
        // Regressions: order 0 in a persistence or AR model, and an MLP with no parameters,
        // used to load and then panic (index out of bounds, zero chunk size) or fail at the
        // service's first forecast.
        let data = record(500);
        let path = Path::new("m.json");
        let load = |v: &serde_json::Value| match ModelFile::from_json(&v.to_string(), path) {
            Ok(_) => String::from("loaded"),
            Err(e) => e.to_string(),
        };
        for method in [Method::Persistence, Method::Ar] {
            let model = train_models(&data, &[Dof::Heave], &options(method)).unwrap();
            let mut v = serde_json::to_value(&model).unwrap();
            assert_eq!(load(&v), "loaded", "{method}");
            v["config"]["order"] = 0.into();
            v["dofs"][0]["predictor"]["order"] = 0.into();
            if method == Method::Ar {
                v["dofs"][0]["predictor"]["weights"] = serde_json::json!([]);
            }
            let e = load(&v);
            assert!(
                e.contains("heave: order 0 and horizon 6 must be in 1..="),
                "{e}"
            );
        }
        let model = train_models(&data, &[Dof::Heave], &options(Method::Mlp)).unwrap();
        let mut v = serde_json::to_value(&model).unwrap();
        assert_eq!(load(&v), "loaded");
        v["dofs"][0]["predictor"]["params"] = serde_json::json!([]);
        let e = load(&v);
        assert!(e.contains("heave: the mlp model cannot forecast"), "{e}");
    }

    /// Regression (review): a hand-edited model file loaded silently with a misspelt field in
    /// an AR, MLP, persistence or zero predictor (Wiener and MCA refused it), a holdout
    /// fraction of -5, a negative LMS gain in an AR model's configuration, or 0 samples.
    #[test]
    fn hand_edited_fields_and_values_out_of_range_are_refused_at_load() {
        let data = record(500);
        let path = Path::new("m.json");
        let load = |v: &serde_json::Value| match ModelFile::from_json(&v.to_string(), path) {
            Ok(_) => String::from("loaded"),
            Err(e) => e.to_string(),
        };
        for method in [Method::Ar, Method::Mlp, Method::Persistence, Method::Zero] {
            let good =
                serde_json::to_value(train_models(&data, &[Dof::Heave], &options(method)).unwrap())
                    .unwrap();
            assert_eq!(load(&good), "loaded", "{method}");
            let mut v = good.clone();
            v["dofs"][0]["predictor"]["orderr"] = 5.into();
            assert!(
                load(&v).contains("unknown field `orderr`"),
                "{method}: {}",
                load(&v)
            );
            let mut v = good.clone();
            v["holdout_fraction"] = (-5.0).into();
            assert!(
                load(&v).contains("holdout_fraction -5 must be in (0, 1)"),
                "{}",
                load(&v)
            );
            let mut v = good.clone();
            v["dofs"][0]["samples"] = 0.into();
            assert!(load(&v).contains("samples 0"), "{}", load(&v));
        }
        let mut v =
            serde_json::to_value(train_models(&data, &[Dof::Heave], &options(Method::Ar)).unwrap())
                .unwrap();
        let good = v.clone();
        v["config"]["lms_gain"] = (-1.0).into();
        assert!(
            load(&v).contains("config: ") && load(&v).contains("LMS gain"),
            "{}",
            load(&v)
        );
        // Regression (review): the AR's own gain of 1e300 loaded, as eval and the configuration
        // refuse it; one at the bound still loads.
        let mut v = good.clone();
        v["dofs"][0]["predictor"]["gain"] = 1e300.into();
        assert!(
            load(&v).contains("AR gain must be in (0, 100], got 1e300"),
            "{}",
            load(&v)
        );
        let mut v = good.clone();
        v["dofs"][0]["predictor"]["gain"] = 150.0.into();
        assert!(
            load(&v).contains("AR gain must be in (0, 100], got 150"),
            "{}",
            load(&v)
        );
        let mut v = good;
        v["dofs"][0]["predictor"]["gain"] = 100.0.into();
        assert_eq!(load(&v), "loaded");
    }

    /// Regression (review): a model was written in place, so a retrain whose write failed
    /// (a full disk, a file size limit) left a truncated file the predictor then refused.
    #[test]
    fn a_save_that_fails_leaves_the_old_model_file_usable() {
        let dir = tempfile::tempdir().unwrap();
        // A name that fits the file system's limit (255 bytes) while its temporary file's
        // does not: no write can succeed, even as root.
        let path = dir.path().join(format!("{}.json", "m".repeat(245)));
        let old = train_models(&record(500), &[Dof::Heave], &options(Method::Zero)).unwrap();
        std::fs::write(&path, serde_json::to_vec(&old).unwrap()).unwrap();
        let new = train_models(&record(500), &[Dof::Heave], &options(Method::Persistence)).unwrap();
        let e = new.save(&path).unwrap_err().to_string();
        assert!(e.contains("creating a temporary file in"), "{e}");
        let back = ModelFile::load(&path).unwrap();
        assert_eq!(back.method, Method::Zero, "the old model, whole");
    }

    #[test]
    fn bad_files_and_bad_requests_give_clear_errors() {
        let data = record(500);
        let model = train_models(&data, &[Dof::Heave], &options(Method::Zero)).unwrap();
        let good = serde_json::to_value(&model).unwrap();
        let path = Path::new("m.json");
        let load = |v: &serde_json::Value| {
            ModelFile::from_json(&v.to_string(), path)
                .unwrap_err()
                .to_string()
        };

        let mut v = good.clone();
        v["format_version"] = 7.into();
        assert!(load(&v).contains("model format version 7, this shipcast reads version 1"));
        v["format_version"] = "1".into();
        assert!(
            load(&v).contains("model format version \"1\", this shipcast reads version 1"),
            "{}",
            load(&v)
        );
        let mut v = good.clone();
        v.as_object_mut().unwrap().remove("format_version");
        assert!(load(&v).ends_with(
            "m.json: not a shipcast model file (a JSON object with a 'format_version')"
        ));
        // Regression (review): wrapped in [ ... ], the whole model was quoted as its version.
        let wrapped = serde_json::json!([good.clone()]);
        assert_eq!(
            load(&wrapped),
            "m.json: not a shipcast model file (a JSON object with a 'format_version')"
        );
        let mut v = good.clone();
        v["format_version"] = serde_json::json!({"a": "x".repeat(1000)});
        let e = load(&v);
        assert!(e.len() < 120 && e.contains("...,"), "{e}");
        let mut v = good.clone();
        v["colour"] = "red".into();
        assert!(load(&v).contains("unknown field `colour`"), "{}", load(&v));
        let mut v = good.clone();
        v["config"]["oder"] = 3.into();
        assert!(load(&v).contains("unknown field `oder`"));
        let mut v = good.clone();
        v["dofs"][0]["sigma"] = serde_json::json!([0.1]);
        assert!(load(&v).contains("1 sigma values for horizon 6"));
        let mut v = good.clone();
        v["config"]["horizon"] = 7.into();
        assert!(load(&v).contains("does not match"));
        assert!(ModelFile::from_json("{", path).is_err());
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.json");
        assert!(ModelFile::load(&missing)
            .unwrap_err()
            .to_string()
            .contains(missing.to_str().unwrap()));

        assert!(train_models(&data, &[Dof::Pitch], &options(Method::Zero))
            .unwrap_err()
            .to_string()
            .contains("pitch_rad"));
        let short = train_models(&record(120), &[Dof::Heave], &options(Method::Zero)).unwrap_err();
        assert!(
            short
                .to_string()
                .starts_with("heave: series of 120 samples is too short"),
            "{short}"
        );
        let mut bad = options(Method::Zero);
        bad.holdout_fraction = 1.0;
        assert!(matches!(
            train_models(&data, &[Dof::Heave], &bad),
            Err(ModelError::BadHoldout(_))
        ));
    }
}
