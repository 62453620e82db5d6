//! The pipeline configuration (`--config FILE.toml`) shared by `shipcast run` and every service.
//!
//! Every key has a default, so an empty file (or none) is a working pipeline; an unknown key is
//! an error that names it. Command-line flags override the file.
//!
//! One file per section: [`zenoh`], [`producer`], [`predictor`], [`stations`] (deck, crane,
//! relative); this one holds the whole file's type, its loading and validation, and the flags
//! every service shares.

mod predictor;
mod producer;
mod stations;
#[cfg(test)]
mod tests;
mod zenoh;

pub use predictor::*;
pub use producer::*;
pub use stations::*;
pub use zenoh::*;

use crate::limits;
use crate::transport::naming::{NameError, Names, DEFAULT_VESSEL};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// zenoh endpoint the predictor listens on by default and the consumers connect to. Loopback
/// and an uncommon port: a fresh clone runs without touching the network or a local zenohd.
pub const DEFAULT_ZENOH_ENDPOINT: &str = "tcp/127.0.0.1:17447";

/// How long a secure consumer (a zenoh client) keeps trying to reach the predictor when it
/// starts: `shipcast run` starts its consumers while the predictor is still starting.
pub const CLIENT_CONNECT_PATIENCE_MS: u64 = 60_000;

/// Where consumers listen: loopback, port chosen by the system.
pub const CONSUMER_LISTEN: &str = "tcp/127.0.0.1:0";

/// Highest producer (and forecast) sample rate [Hz]: a motion sensor is sampled at tens of Hz.
pub const MAX_PRODUCER_RATE_HZ: f64 = 10_000.0;

/// Fastest pacing factor (0 means unpaced).
pub const MAX_SPEED: f64 = 1e6;

/// Longest forecast window (past values) and candidate order.
pub const MAX_ORDER: usize = 100_000;

/// Most live values kept for retraining (and held out).
pub const MAX_RETRAIN_WINDOW: usize = 1_000_000;

/// The shortest period between scheduled retrains (besides 0, never). A fit takes seconds of
/// CPU; a period of a few values kept the service refitting all the time, and one shorter than
/// a forecast step rounded to 0 values, which meant never (review: 0.2 s gave 1 retrain in 20
/// minutes instead of 4).
pub const MIN_RETRAIN_EVERY_S: f64 = 10.0;

/// Most simulated samples per DOF of start-up history (warmup_s x rate_hz): 48 MB for six DOF.
pub const MAX_WARMUP_SAMPLES: usize = 1_000_000;

/// Highest decimation factor from the producer rate to the forecast rate.
pub const MAX_DECIMATION: usize = 1_000;

/// Largest lever arm from the centre of gravity [m].
pub const MAX_LEVER_M: f64 = 1_000.0;

/// Why a configuration could not be loaded.
///
/// Causes are in the message and not chained as a `source` (fields named `error`, no
/// `#[from]`), so error-chain printers (`anyhow`'s `{:#}`) print them once.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("config {path}: {error}")]
    Read {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("config {path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("config: {0}")]
    Invalid(String),
    #[error("config: {0}")]
    Name(NameError),
}

impl From<NameError> for ConfigError {
    fn from(error: NameError) -> Self {
        ConfigError::Name(error)
    }
}

/// The whole pipeline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineConfig {
    /// Optional prefix of every service name and key, keeping parallel pipelines apart.
    pub instance: Option<String>,
    /// Vessel name in service names and keys.
    pub vessel: String,
    pub zenoh: ZenohConfig,
    pub producer: ProducerConfig,
    pub predictor: PredictorServiceConfig,
    pub deck: DeckConfig,
    pub crane: CraneConfig,
    pub relative: RelativeConfig,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self {
            instance: None,
            vessel: DEFAULT_VESSEL.to_string(),
            zenoh: ZenohConfig::default(),
            producer: ProducerConfig::default(),
            predictor: PredictorServiceConfig::default(),
            deck: DeckConfig::default(),
            crane: CraneConfig::default(),
            relative: RelativeConfig::default(),
        }
    }
}

/// toml's own message spans several lines with a source excerpt; ours is one line that names
/// the line and shows it, so a wrong type or a duplicate key can be found without the excerpt.
fn parse_message(text: &str, e: &toml::de::Error) -> String {
    let message = e.message().trim().replace('\n', " ");
    let Some(start) = e.span().map(|span| span.start.min(text.len())) else {
        return message;
    };
    let Some(before) = text.get(..start) else {
        return message;
    };
    let line = before.matches('\n').count() + 1;
    let source = text.lines().nth(line - 1).unwrap_or("").trim();
    let source: String = source.chars().take(80).collect();
    format!("line {line} (`{source}`): {message}")
}

impl PipelineConfig {
    /// Parse TOML text; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &Path) -> Result<Self, ConfigError> {
        let config = Self::from_toml_unvalidated(text, origin)?;
        config.validate()?;
        Ok(config)
    }

    /// [`Self::from_toml`] without the checks, for a command that applies its flags first and
    /// then validates once: checked before, a file that needs a flag to make sense (a short
    /// `warmup_s` with `--model`, a bad endpoint that `--listen` replaces) was refused.
    fn from_toml_unvalidated(text: &str, origin: &Path) -> Result<Self, ConfigError> {
        let mut config: PipelineConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: origin.to_path_buf(),
            message: parse_message(text, &e),
        })?;
        if let Some(dir) = origin.parent() {
            config.zenoh.resolve_paths(dir);
        }
        Ok(config)
    }

    /// Load `path`, or the defaults when none is given.
    pub fn load(path: Option<&Path>) -> Result<Self, ConfigError> {
        let config = Self::load_unvalidated(path)?;
        config.validate()?;
        Ok(config)
    }

    /// [`Self::load`] without the checks: the caller applies its flags, then calls
    /// [`Self::validate`].
    pub fn load_unvalidated(path: Option<&Path>) -> Result<Self, ConfigError> {
        match path {
            None => Ok(Self::default()),
            Some(p) => {
                let text = std::fs::read_to_string(p).map_err(|error| ConfigError::Read {
                    path: p.to_path_buf(),
                    error,
                })?;
                Self::from_toml_unvalidated(&text, p)
            }
        }
    }

    /// The service names and keys of this pipeline.
    pub fn names(&self) -> Result<Names, ConfigError> {
        Ok(Names::new(self.instance.as_deref(), &self.vessel)?)
    }

    /// Check values that parse but cannot work.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let names = self.names()?;
        self.zenoh.validate()?;
        self.validate_access_covers(&names)
            .map_err(ConfigError::Invalid)?;
        self.validate_producer().map_err(ConfigError::Invalid)?;
        self.validate_predictor().map_err(ConfigError::Invalid)?;
        self.validate_consumers().map_err(ConfigError::Invalid)?;
        self.relative
            .validate(&self.vessel)
            .map_err(ConfigError::Invalid)?;
        self.producer
            .station
            .validate()
            .map_err(|e| ConfigError::Invalid(format!("producer.station: {e}")))?;
        Ok(())
    }

    /// A pipeline's access rules (it publishes: `publishers` set) must cover its own keys.
    /// Regression: `--instance` or `--vessel` over a file from `shipcast certs` moved the
    /// keys out of the rules, and the predictor denied its own stations every forecast, in
    /// silence (found by a security audit).
    fn validate_access_covers(&self, names: &Names) -> Result<(), String> {
        use ::zenoh::key_expr::keyexpr;
        let Some(access) = self
            .zenoh
            .access
            .as_ref()
            .filter(|a| !a.publishers.is_empty())
        else {
            return Ok(());
        };
        let own = format!("{}{}/**", names.fleet_prefix(), names.vessel());
        let Ok(own_keys) = keyexpr::new(own.as_str()) else {
            return Ok(());
        };
        let covered = access
            .key_exprs
            .iter()
            .filter_map(|k| keyexpr::new(k.as_str()).ok())
            .any(|k| k.includes(own_keys));
        if covered {
            return Ok(());
        }
        Err(format!(
            "zenoh.access.key_exprs {:?} do not cover this pipeline's keys '{own}' (instance {:?}, vessel '{}'; changed by --instance or --vessel?): the access rules would deny its stations every forecast",
            access.key_exprs,
            self.instance.as_deref().unwrap_or(""),
            self.vessel
        ))
    }

    fn validate_producer(&self) -> Result<(), String> {
        let p = &self.producer;
        limits::rate("producer.rate_hz", p.rate_hz, MAX_PRODUCER_RATE_HZ)?;
        limits::non_negative(
            "producer.speed (0 = as fast as possible)",
            p.speed,
            MAX_SPEED,
        )?;
        if let Some(r) = p.record_s {
            limits::positive("producer.record_s", r, limits::MAX_SECONDS)?;
        }
        limits::non_negative("producer.backfill_s", p.backfill_s, limits::MAX_SECONDS)?;
        limits::positive("producer.backfill_speed", p.backfill_speed, MAX_SPEED)?;
        Ok(())
    }

    fn validate_predictor(&self) -> Result<(), String> {
        let q = &self.predictor;
        q.check_method_sections()?;
        limits::count(
            "predictor.horizon",
            q.horizon,
            1,
            shipcast_wire::payload::MAX_STEPS,
        )?;
        limits::count("predictor.order", q.order, 1, MAX_ORDER)?;
        limits::rate(
            "predictor.sample_rate_hz",
            q.sample_rate_hz,
            MAX_PRODUCER_RATE_HZ,
        )?;
        for (name, v) in [
            ("predictor.stale_after_s", q.stale_after_s),
            ("predictor.first_fit_s", q.first_fit_s),
            ("predictor.verification_window_s", q.verification_window_s),
        ] {
            limits::positive(name, v, limits::MAX_SECONDS)?;
        }
        limits::positive(
            "predictor.plausible_rms_factor",
            q.plausible_rms_factor,
            1e6,
        )?;
        limits::non_negative(
            "predictor.retrain_every_s (0 = never)",
            q.retrain_every_s,
            limits::MAX_SECONDS,
        )?;
        if q.retrain_every_s > 0.0 && q.retrain_every_s < MIN_RETRAIN_EVERY_S {
            return Err(format!(
                "predictor.retrain_every_s = {} s: at least {MIN_RETRAIN_EVERY_S} s between retrains, or 0 for never",
                q.retrain_every_s
            ));
        }
        if !(q.change_ratio.is_finite() && q.change_ratio > 1.0) {
            return Err(format!(
                "predictor.change_ratio must be above 1, got {}",
                q.change_ratio
            ));
        }
        limits::non_negative("predictor.warmup_s", q.warmup_s, 86_400.0)?;
        // The start-up history is simulated at the producer's rate and held in memory.
        let warmup_samples = q.warmup_s * self.producer.rate_hz;
        if warmup_samples > MAX_WARMUP_SAMPLES as f64 {
            return Err(format!(
                "predictor.warmup_s x producer.rate_hz = {warmup_samples:.0} samples of start-up history, at most {MAX_WARMUP_SAMPLES}"
            ));
        }
        for &o in &q.candidate_orders {
            limits::count("predictor.candidate_orders", o, 1, MAX_ORDER)?;
        }
        limits::count(
            "predictor.retrain_window",
            q.retrain_window,
            0,
            MAX_RETRAIN_WINDOW,
        )?;
        limits::count("predictor.holdout", q.holdout, 0, MAX_RETRAIN_WINDOW)?;
        // The first fit waits for `first_fit_s` of history, and the history holds
        // `history_values`: a longer wait would never end, silently. Checked before the span
        // below, whose "raise retrain_window to N" would otherwise lead to this error next
        // (review: 405 asked, then 480 needed).
        let first_fit_values = (q.first_fit_s * q.sample_rate_hz).round();
        if q.retrain_every_s > 0.0 && first_fit_values > q.history_values() as f64 {
            // Advice that can be followed: beyond the window's own limit, only first_fit_s
            // can move (review: "raise retrain_window to at least 1200000", then refused).
            let remedy = if first_fit_values <= MAX_RETRAIN_WINDOW as f64 {
                format!(
                    "lower first_fit_s or raise retrain_window to at least {first_fit_values:.0}"
                )
            } else {
                format!(
                    "lower first_fit_s to at most {} s (retrain_window is at most {MAX_RETRAIN_WINDOW})",
                    limits::shown(MAX_RETRAIN_WINDOW as f64 / q.sample_rate_hz)
                )
            };
            return Err(format!(
                "predictor.first_fit_s = {} s is {first_fit_values:.0} values at {} Hz, more than the history holds (predictor.retrain_window = {}): the first fit would never come; {remedy}",
                q.first_fit_s, q.sample_rate_hz, q.retrain_window
            ));
        }
        // Every fit the engine makes must be able to fit and score some candidate: the live
        // retrains on the retrain window, and the start-up fit on simulated history (no model
        // file, warmup_s > 0), which needs its held-out part whether or not retraining is on.
        if q.retrain_every_s > 0.0 {
            let span = FitSpan {
                len: q.retrain_window,
                shown: format!("predictor.retrain_window = {} values", q.retrain_window),
                raise: "retrain_window",
                seconds_for: None,
            };
            if let Some(problem) = q.fit_span_problem(&span) {
                return Err(problem);
            }
        }
        // A rate that is no integer multiple of the forecast rate is refused where the factor
        // is needed, with its own message.
        let startup_fit = q.model.is_none() && q.warmup_s > 0.0;
        if let Some(factor) = self.decimation_factor().ok().filter(|_| startup_fit) {
            // The start-up history as `startup::initial_models` makes it: ceil(warmup_s x the
            // producer's rate) samples, decimated to the forecast rate (the filter's warm-up
            // costs a few values).
            let rate = self.producer.rate_hz;
            let samples = (q.warmup_s * rate).ceil() as usize;
            let len = shipcast_series::decimated_len(samples, factor);
            // The warm-up that makes `values` values.
            let seconds_for = |values: usize| {
                shipcast_series::decimation_inputs_for(values, factor) as f64 / rate
            };
            let span = FitSpan {
                len,
                shown: format!(
                    "predictor.warmup_s = {} s ({len} values at {} Hz)",
                    q.warmup_s, q.sample_rate_hz
                ),
                raise: "warmup_s",
                seconds_for: Some(&seconds_for),
            };
            if let Some(problem) = q.fit_span_problem(&span) {
                return Err(format!(
                    "{problem} (the start-up fit on simulated history; or give predictor.model, or set warmup_s = 0 to start with no skill)"
                ));
            }
        }
        Ok(())
    }

    fn validate_consumers(&self) -> Result<(), String> {
        let d = &self.deck;
        for (name, v) in [
            ("deck.roll_limit_deg", d.roll_limit_deg),
            ("deck.pitch_limit_deg", d.pitch_limit_deg),
            (
                "deck.vertical_velocity_limit_mps",
                d.vertical_velocity_limit_mps,
            ),
            (
                "deck.vertical_displacement_limit_m",
                d.vertical_displacement_limit_m,
            ),
            ("deck.mot_s", d.mot_s),
        ] {
            limits::positive(name, v, 1e6)?;
        }
        limits::non_negative("deck.min_window_s", d.min_window_s, limits::MAX_SECONDS)?;
        for (name, point) in [
            ("deck.point_m", d.point_m),
            ("crane.tip_m", self.crane.tip_m),
        ] {
            if !point
                .iter()
                .all(|v| v.is_finite() && v.abs() <= MAX_LEVER_M)
            {
                let shown: Vec<String> = point.iter().map(|&v| limits::shown(v)).collect();
                return Err(format!(
                    "{name} must be three finite numbers within +-{MAX_LEVER_M} m, got [{}]",
                    shown.join(", ")
                ));
            }
        }
        limits::count("crane.print_every", self.crane.print_every, 1, u64::MAX)?;
        limits::positive(
            "crane.calibration_halflife",
            self.crane.calibration_halflife,
            1e9,
        )?;
        limits::positive(
            "crane.calibration_min_verified",
            self.crane.calibration_min_verified,
            1e9,
        )?;
        if !(d.go_probability > 0.0 && d.go_probability < 1.0) {
            return Err(format!(
                "deck.go_probability must be between 0 and 1, got {}",
                d.go_probability
            ));
        }
        if let Some(r) = d
            .error_correlation
            .iter()
            .find(|r| !(0.0..1.0).contains(*r))
        {
            return Err(format!(
                "deck.error_correlation values must be in [0, 1), got {r}"
            ));
        }
        Ok(())
    }

    /// Decimation factor from the producer rate to the predictor rate.
    pub fn decimation_factor(&self) -> Result<usize, ConfigError> {
        decimation_factor(self.producer.rate_hz, self.predictor.sample_rate_hz)
    }
}

/// Integer ratio of two rates, or an error naming them.
pub fn decimation_factor(input_hz: f64, output_hz: f64) -> Result<usize, ConfigError> {
    let ratio = input_hz / output_hz;
    let factor = ratio.round();
    if !(factor >= 1.0 && factor <= MAX_DECIMATION as f64 && (ratio - factor).abs() < 1e-9) {
        return Err(ConfigError::Invalid(format!(
            "input rate {input_hz} Hz is not an integer multiple (1..={MAX_DECIMATION}) of the forecast rate {output_hz} Hz"
        )));
    }
    Ok(factor as usize)
}

impl PipelineConfig {
    /// Refuses a station's MOT (`name`, e.g. "deck.mot_s") longer than the forecast horizon:
    /// no window of it fits in a forecast, so the station would run without ever stating a
    /// probability or a go. Checked by the stations that decide, not by the whole
    /// configuration: a predictor run with a short horizon has no window to decide.
    pub fn check_mot_fits_horizon(&self, name: &str, mot_s: f64) -> Result<(), String> {
        let p = &self.predictor;
        let steps = crate::decision::window_steps(mot_s, 1.0 / p.sample_rate_hz);
        if steps > p.horizon {
            return Err(format!(
                "{name} ({mot_s} s) is longer than the forecast horizon ({} s: predictor.horizon \
                 {} steps at {} Hz), so no window of it could be decided; lower it or raise \
                 predictor.horizon",
                p.horizon as f64 / p.sample_rate_hz,
                p.horizon,
                p.sample_rate_hz
            ));
        }
        Ok(())
    }
}

impl PipelineConfig {
    /// The configuration as TOML, as `shipcast run` hands it to its children.
    pub fn to_toml(&self) -> Result<String, ConfigError> {
        toml::to_string(self).map_err(|e| ConfigError::Invalid(format!("serialise: {e}")))
    }
}
