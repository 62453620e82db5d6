//! The pipeline configuration (`--config FILE.toml`) shared by `shipcast run` and every service.
//!
//! Every key has a default, so an empty file (or none) is a working pipeline; an unknown key is
//! an error that names it. Command-line flags override the file.

use crate::limits;
use crate::transport::naming::{NameError, Names, DEFAULT_VESSEL};
use crate::transport::zenoh::{Mode, ZenohSettings};
use crate::transport::zenoh_security::{is_inline_pem, AccessRules, TlsSettings, UserPassword};
use serde::{Deserialize, Serialize};
use shipcast_predict::{McaWeighting, Method, PredictorConfig};
use shipcast_sim::{Scenario, Station};
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

/// zenoh endpoints and security: the predictor listens, consumers connect.
///
/// Plain TCP on loopback is the default, for development and tests. With `tls` set (see
/// `shipcast certs` and docs/security.md) every link is mutual TLS, consumers are zenoh
/// clients of the predictor (or of a router), and the predictor enforces `access`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZenohConfig {
    /// Endpoints the publishing side (predictor) listens on.
    pub listen: Vec<String>,
    /// Extra endpoints every process connects to (a router or remote peer).
    pub connect: Vec<String>,
    /// UDP multicast scouting (off by default: explicit endpoints only).
    pub multicast_scouting: bool,
    /// TLS identity of this configuration's processes (paths relative to the config file, or
    /// inline PEM).
    pub tls: Option<TlsSettings>,
    /// zenoh user/password authentication.
    pub auth: Option<UserPassword>,
    /// Access rules the predictor enforces on its links (by certificate common name).
    pub access: Option<AccessRules>,
}

impl Default for ZenohConfig {
    fn default() -> Self {
        Self {
            listen: vec![DEFAULT_ZENOH_ENDPOINT.to_string()],
            connect: Vec::new(),
            multicast_scouting: false,
            tls: None,
            auth: None,
            access: None,
        }
    }
}

impl ZenohConfig {
    /// Settings of the process that publishes (listens on `listen`, enforces `access`).
    pub fn publisher_side(&self) -> ZenohSettings {
        ZenohSettings {
            mode: Mode::Peer,
            listen: self.listen.clone(),
            connect: self.connect.clone(),
            multicast_scouting: self.multicast_scouting,
            tls: self.tls.clone(),
            auth: self.auth.clone(),
            access: self.access.clone(),
            downsample_egress: None,
            client_connect_patience_ms: None,
        }
    }

    /// Settings of a consumer: connects to the publisher's listen endpoints and the extra ones.
    ///
    /// Plain: a peer listening on an ephemeral loopback port. Peers route only their own
    /// traffic, so two consumers (the deck publishing its advisory, `shipcast run` showing it)
    /// must be able to connect to each other directly; gossip through the predictor tells them
    /// where. Secure (`tls` set): a client that reaches everything through the node it
    /// connects to, so nothing goes around that node's access rules.
    pub fn consumer_side(&self) -> ZenohSettings {
        let mut connect = self.listen.clone();
        connect.extend(self.connect.iter().cloned());
        let secure = self.tls.is_some();
        ZenohSettings {
            mode: if secure { Mode::Client } else { Mode::Peer },
            listen: if secure {
                Vec::new()
            } else {
                vec![CONSUMER_LISTEN.to_string()]
            },
            connect,
            multicast_scouting: self.multicast_scouting && !secure,
            tls: self.tls.clone(),
            auth: self.auth.clone().map(|a| UserPassword {
                users_file: None,
                ..a
            }),
            access: None,
            downsample_egress: None,
            client_connect_patience_ms: secure.then_some(CLIENT_CONNECT_PATIENCE_MS),
        }
    }

    /// Make the relative paths of certificates, keys and the users file relative to `base`
    /// (the config file's directory), so the file works from any working directory and in
    /// `shipcast run`'s children.
    pub fn resolve_paths(&mut self, base: &Path) {
        let resolve = |v: &mut String| {
            if !is_inline_pem(v) && Path::new(v.as_str()).is_relative() {
                *v = base.join(v.as_str()).to_string_lossy().into_owned();
            }
        };
        if let Some(t) = &mut self.tls {
            resolve(&mut t.root_ca);
            resolve(&mut t.certificate);
            resolve(&mut t.private_key);
        }
        if let Some(f) = self.auth.as_mut().and_then(|a| a.users_file.as_mut()) {
            resolve(f);
        }
    }

    /// Check the security settings that parse but cannot work.
    fn validate(&self) -> Result<(), ConfigError> {
        let bad = |m: &str| Err(ConfigError::Invalid(format!("zenoh.{m}")));
        let tls_endpoint = self
            .listen
            .iter()
            .chain(&self.connect)
            .any(|e| e.starts_with("tls/"));
        if tls_endpoint && self.tls.is_none() {
            return bad("tls (root_ca, certificate, private_key) is required for tls/ endpoints");
        }
        if self.tls.is_some() && self.multicast_scouting {
            return bad("multicast_scouting must be off with tls: consumers reach the data only through the node that enforces the access rules");
        }
        if let Some(a) = &self.access {
            if a.key_exprs.is_empty() || (a.publishers.is_empty() && a.vessels.is_empty()) {
                return bad(
                    "access needs key_exprs and publishers or vessels (everything else is denied)",
                );
            }
            if self.tls.is_none() {
                return bad("access names certificate common names, so it needs tls");
            }
        }
        if let Some(a) = &self.auth {
            if a.user.is_some() != a.password.is_some() {
                return bad("auth needs both user and password");
            }
        }
        Ok(())
    }
}

/// Where motion comes from and how fast it is published.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProducerConfig {
    /// Replay this motion CSV instead of simulating.
    pub input: Option<PathBuf>,
    /// Simulated sea and ship.
    pub scenario: Scenario,
    pub seed: u64,
    /// Sample rate of the simulator [Hz].
    pub rate_hz: f64,
    /// Pacing: 1 = real time, 100 = a hundred times faster, 0 = as fast as possible.
    pub speed: f64,
    /// Stop after this much record time [s]; none = endless (simulator) or end of file.
    pub record_s: Option<f64>,
    /// Publish the first this-many seconds of record at `backfill_speed` before pacing at
    /// `speed`: a sensor handing over its recent log, so forecasts can start without waiting
    /// for `order` values of history in real time.
    pub backfill_s: f64,
    pub backfill_speed: f64,
    /// Where the simulated vessel keeps station in the sea of `scenario` and `seed`, relative
    /// to the reference vessel (x_m forward, y_m starboard, heading_offset_deg to starboard);
    /// the default is the reference vessel itself.
    pub station: Station,
}

impl Default for ProducerConfig {
    fn default() -> Self {
        Self {
            input: None,
            scenario: Scenario::Paper,
            seed: 1,
            rate_hz: 8.0,
            speed: 1.0,
            record_s: None,
            backfill_s: 240.0,
            backfill_speed: 50.0,
            station: Station::REFERENCE,
        }
    }
}

/// The forecasting service.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PredictorServiceConfig {
    pub method: Method,
    /// Past values per forecast (MCA window length n, of which n - horizon are past values).
    pub order: usize,
    /// Forecast steps (at most 128).
    pub horizon: usize,
    /// Rate the motion is decimated to before forecasting [Hz]; must divide the input rate.
    pub sample_rate_hz: f64,
    /// Start from this model file (`shipcast train`) instead of training on simulated history.
    pub model: Option<PathBuf>,
    /// Simulated history used for the start-up model [s of record time].
    pub warmup_s: f64,
    /// Anti-alias filter of the decimation: "minimum" (default: the same magnitude as the
    /// evaluation's linear-phase filter with half its delay, so forecasts reach 0.5 s further
    /// ahead of the newest sample; docs/results/filter_delay.md) or "linear" (the evaluation
    /// protocol's, delay 1.0 s at 8 -> 2 Hz).
    pub filter: shipcast_series::FilterPhase,
    /// Fit the first model on live data once this much live history is held [s of record
    /// time]; until a model has been verified on this sea, forecasts say "no skill".
    pub first_fit_s: f64,
    /// Retrain from live data every this many seconds of record time (0 = never, including
    /// the first live fit).
    pub retrain_every_s: f64,
    /// Live history kept for retraining [values at sample_rate_hz]; the newest `holdout`
    /// values (at most a third of what is held) score the candidates and are not trained on.
    pub retrain_window: usize,
    pub holdout: usize,
    /// Orders tried at every fit (those up to `order` that the data allow); the best on the
    /// held-out values wins, per DOF.
    pub candidate_orders: Vec<usize>,
    /// Rolling window of record time over which forecasts are verified and recalibrated [s].
    pub verification_window_s: f64,
    /// A forecast mean beyond this many times the live RMS of the motion is never delivered.
    pub plausible_rms_factor: f64,
    /// Live squared errors this many times what sigma claims (or 1 / this) mean the sea has
    /// changed: recalibrate and retrain at once.
    pub change_ratio: f64,
    /// Report the producer as stale after this much record time without samples [s].
    pub stale_after_s: f64,
    /// Spin on the subscriber instead of sleeping until woken (lowest latency, one core busy).
    pub busy_poll: bool,
    /// `[predictor.mca]`: settings of the MCA method; only with `method = "mca"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mca: Option<McaSettings>,
    /// `[predictor.ar]`: settings of the AR-LMS method; only with `method = "ar"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ar: Option<ArSettings>,
    /// `[predictor.mlp]`: settings of the MLP method; only with `method = "mlp"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mlp: Option<MlpSettings>,
}

/// `[predictor.mca]`: the MCA method's settings (the `shipcast eval` MCA options).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct McaSettings {
    /// Eigen-direction weights: "inverse" (all, 1/(lambda + eps): the conditional mean) or
    /// "paper" (the minor components, unweighted).
    pub weighting: McaWeighting,
    /// Shift between consecutive training windows.
    pub shift: usize,
    /// Energy fraction of the minor components (paper weighting).
    pub energy: f64,
    /// Ridge (inverse weighting: eps relative to the mean eigenvalue; 0 = default).
    pub ridge: f64,
    /// Choose the energy threshold (inverse weighting: the ridge) on held-out training data.
    pub validate_energy: bool,
}

impl Default for McaSettings {
    /// The service's MCA: eigenvalue-weighted, validated (not the paper's settings, which
    /// are worse than predicting zero on a realistic sea; README "Honest accuracy").
    fn default() -> Self {
        let paper = PredictorConfig::default();
        Self {
            weighting: McaWeighting::Inverse,
            shift: 2,
            energy: paper.mca_energy,
            ridge: paper.mca_ridge,
            validate_energy: true,
        }
    }
}

/// `[predictor.ar]`: the AR method's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArSettings {
    /// LMS step size.
    pub lms_gain: f64,
    /// Normalised LMS (step divided by the input power).
    pub normalized: bool,
}

impl Default for ArSettings {
    fn default() -> Self {
        let paper = PredictorConfig::default();
        Self {
            lms_gain: paper.lms_gain,
            normalized: paper.lms_normalized,
        }
    }
}

/// `[predictor.mlp]`: the MLP method's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MlpSettings {
    /// Hidden tanh units.
    pub hidden: usize,
    /// Rprop epochs per fit.
    pub epochs: usize,
    /// Seed of the initial weights.
    pub seed: u64,
}

impl Default for MlpSettings {
    fn default() -> Self {
        let paper = PredictorConfig::default();
        Self {
            hidden: paper.mlp_hidden,
            epochs: paper.mlp_epochs,
            seed: paper.seed,
        }
    }
}

impl Default for PredictorServiceConfig {
    fn default() -> Self {
        Self {
            // Chosen out of sample (train on one stretch or realisation, score on another, at
            // every origin; README "Honest accuracy"): the Wiener predictor with its order
            // validated per DOF is the most robust on measured seas, where the
            // eigenvalue-weighted MCA learns one realisation's wave components and fails on
            // band-limited records.
            method: Method::Wiener,
            order: 200,
            horizon: 50,
            sample_rate_hz: 2.0,
            model: None,
            warmup_s: 3000.0,
            filter: shipcast_series::FilterPhase::Minimum,
            first_fit_s: 240.0,
            retrain_every_s: 300.0,
            retrain_window: 6000,
            holdout: 1000,
            candidate_orders: vec![25, 50, 100, 200],
            verification_window_s: 1200.0,
            plausible_rms_factor: 5.0,
            change_ratio: 3.0,
            stale_after_s: 2.0,
            busy_poll: false,
            mca: None,
            ar: None,
            mlp: None,
        }
    }
}

impl PredictorServiceConfig {
    /// The predictor settings: this section's order and horizon, and the chosen method's
    /// section (its defaults when left out).
    pub fn predictor_config(&self) -> PredictorConfig {
        let mca = self.mca.clone().unwrap_or_default();
        let ar = self.ar.clone().unwrap_or_default();
        let mlp = self.mlp.clone().unwrap_or_default();
        PredictorConfig {
            order: self.order,
            horizon: self.horizon,
            mca_shift: mca.shift,
            mca_energy: mca.energy,
            mca_ridge: mca.ridge,
            mca_validate_energy: mca.validate_energy,
            mca_weighting: mca.weighting,
            lms_gain: ar.lms_gain,
            lms_normalized: ar.normalized,
            mlp_hidden: mlp.hidden,
            mlp_epochs: mlp.epochs,
            seed: mlp.seed,
        }
    }

    /// A method section is refused unless it is the chosen method's: a key that does nothing
    /// is an error, not a silent no-op.
    fn check_method_sections(&self) -> Result<(), String> {
        for (section, present, method) in [
            ("mca", self.mca.is_some(), Method::Mca),
            ("ar", self.ar.is_some(), Method::Ar),
            ("mlp", self.mlp.is_some(), Method::Mlp),
        ] {
            if present && self.method != method {
                return Err(format!(
                    "[predictor.{section}] applies to method = \"{}\" only, but method is \"{}\"",
                    method.name(),
                    self.method.name()
                ));
            }
        }
        Ok(())
    }
}

/// Helideck landing advisory.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeckConfig {
    /// Helideck point from the centre of gravity [m], ship axes x forward, y starboard, z down.
    pub point_m: [f64; 3],
    pub roll_limit_deg: f64,
    pub pitch_limit_deg: f64,
    /// Limit of the deck point's vertical velocity [m/s].
    pub vertical_velocity_limit_mps: f64,
    /// Shortest window worth reporting [s].
    pub min_window_s: f64,
    /// Limit of the deck point's vertical displacement from its rest position [m].
    pub vertical_displacement_limit_m: f64,
    /// Minimum operation time: the go/no-go is about a window this long [s].
    pub mot_s: f64,
    /// Go when the probability that every limit holds over the whole window is at least this.
    pub go_probability: f64,
    /// Correlation of the standardised forecast errors between neighbouring steps, used before
    /// enough verified forecasts estimate it (roll, pitch, deck vertical displacement, deck
    /// vertical velocity); docs/decisions.md says where the defaults come from.
    pub error_correlation: [f64; 4],
    /// Go (now or a next window) only once the probability comes from verified forecast
    /// errors (the error ensemble, docs/decisions.md); before that the Gaussian model's
    /// probability is stated but never says go. False lets the model decide from the start.
    pub go_needs_verified_errors: bool,
    /// Publish the advisory on zenoh `.../advisory/deck`.
    pub publish: bool,
}

impl Default for DeckConfig {
    fn default() -> Self {
        Self {
            // Flight deck of a DDG-51: near the stern, on the centre line, about 5 m above CG.
            point_m: [-62.0, 0.0, -5.0],
            roll_limit_deg: 2.5,
            pitch_limit_deg: 1.5,
            vertical_velocity_limit_mps: 1.0,
            min_window_s: 2.0,
            vertical_displacement_limit_m: 2.0,
            mot_s: 10.0,
            go_probability: 0.95,
            error_correlation: [0.95, 0.95, 0.95, 0.8],
            go_needs_verified_errors: true,
            publish: true,
        }
    }
}

/// Crane-tip forecast.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CraneConfig {
    /// Crane tip from the centre of gravity [m], ship axes x forward, y starboard, z down.
    pub tip_m: [f64; 3],
    /// Print one line every this many forecasts.
    pub print_every: u64,
}

impl Default for CraneConfig {
    fn default() -> Self {
        Self {
            // An alongside transfer rig: amidships, 15 m outboard to starboard, 20 m up.
            tip_m: [10.0, 15.0, -20.0],
            print_every: 1,
        }
    }
}

/// Ship-to-ship relative motion (`shipcast relative`, docs/two_ships.md): the crane tip
/// (`crane.tip_m`) on the crane vessel against a landing spot on the target vessel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RelativeConfig {
    /// `shipcast run` also runs the target vessel (its own producer and predictor, simulated
    /// in the same sea at `target_position_m`, `target_heading_offset_deg`) and the relative
    /// service.
    pub two_ship: bool,
    /// The vessel carrying the crane; none = the pipeline's `vessel`.
    pub crane_vessel: Option<String>,
    /// The vessel the load goes to.
    pub target_vessel: String,
    /// The target's centre of gravity forward and to starboard of the crane vessel's [m].
    pub target_position_m: [f64; 2],
    /// The target's bow turned this far to starboard of the crane vessel's heading [deg].
    pub target_heading_offset_deg: f64,
    /// Landing spot from the target's centre of gravity [m], its axes x forward, y starboard,
    /// z down.
    pub landing_spot_m: [f64; 3],
    /// Limits of the tip's motion relative to the spot [m]: vertical, and each horizontal axis.
    pub vertical_limit_m: f64,
    pub horizontal_limit_m: f64,
    /// Minimum operation time of the lift [s].
    pub mot_s: f64,
    /// Go when the window probability reaches this.
    pub go_probability: f64,
    /// Step-to-step correlation of the standardised relative errors (AR(1) in lead).
    pub error_correlation: f64,
    /// Half-life of the sigma calibration, in verified forecasts.
    pub calibration_halflife: f64,
    /// Verified forecasts (weighted) behind a step before its sigma is calibrated.
    pub calibration_min_verified: f64,
    /// Publish the relative forecast on zenoh `.../<crane vessel>/advisory/relative`.
    pub publish: bool,
    /// Print one line every this many relative forecasts.
    pub print_every: u64,
}

impl Default for RelativeConfig {
    fn default() -> Self {
        Self {
            two_ship: false,
            crane_vessel: None,
            target_vessel: "supply".to_string(),
            // Alongside to starboard, 40 m between the centres of gravity, its bow 10 deg to
            // starboard of the crane vessel's: two headings, one sea (docs/two_ships.md).
            target_position_m: [0.0, 40.0],
            target_heading_offset_deg: 10.0,
            // On the target's deck, port side (facing the crane vessel), 6 m above its CG.
            landing_spot_m: [10.0, -8.0, -6.0],
            vertical_limit_m: 1.0,
            horizontal_limit_m: 1.0,
            mot_s: 10.0,
            go_probability: 0.9,
            error_correlation: 0.95,
            calibration_halflife: 1200.0,
            calibration_min_verified: 100.0,
            publish: true,
            print_every: 1,
        }
    }
}

impl RelativeConfig {
    /// The crane vessel's name: `crane_vessel`, else the pipeline's `vessel`.
    pub fn crane_vessel<'a>(&'a self, vessel: &'a str) -> &'a str {
        self.crane_vessel.as_deref().unwrap_or(vessel)
    }

    fn validate(&self, vessel: &str) -> Result<(), String> {
        let r = self;
        Names::new(None, &r.target_vessel).map_err(|e| format!("relative.target_vessel: {e}"))?;
        if let Some(c) = &r.crane_vessel {
            Names::new(None, c).map_err(|e| format!("relative.crane_vessel: {e}"))?;
        }
        if r.crane_vessel(vessel) == r.target_vessel {
            return Err(format!(
                "relative.target_vessel '{}' is the crane vessel itself",
                r.target_vessel
            ));
        }
        let position = [r.target_position_m[0], r.target_position_m[1]];
        for (name, values) in [
            ("relative.target_position_m", &position[..]),
            ("relative.landing_spot_m", &r.landing_spot_m[..]),
        ] {
            if !values
                .iter()
                .all(|v| v.is_finite() && v.abs() <= MAX_LEVER_M)
            {
                return Err(format!(
                    "{name} must be finite numbers within +-{MAX_LEVER_M} m, got {values:?}"
                ));
            }
        }
        if !r.target_heading_offset_deg.is_finite() {
            return Err("relative.target_heading_offset_deg must be finite".into());
        }
        for (name, v) in [
            ("relative.vertical_limit_m", r.vertical_limit_m),
            ("relative.horizontal_limit_m", r.horizontal_limit_m),
            ("relative.mot_s", r.mot_s),
            ("relative.calibration_halflife", r.calibration_halflife),
            (
                "relative.calibration_min_verified",
                r.calibration_min_verified,
            ),
        ] {
            limits::positive(name, v, 1e9)?;
        }
        if !(r.go_probability > 0.0 && r.go_probability < 1.0) {
            return Err(format!(
                "relative.go_probability must be between 0 and 1, got {}",
                r.go_probability
            ));
        }
        if !(0.0..1.0).contains(&r.error_correlation) {
            return Err(format!(
                "relative.error_correlation must be in [0, 1), got {}",
                r.error_correlation
            ));
        }
        limits::count("relative.print_every", r.print_every, 1, u64::MAX)?;
        Ok(())
    }
}

impl PipelineConfig {
    /// Parse TOML text; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &Path) -> Result<Self, ConfigError> {
        let config: PipelineConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: origin.to_path_buf(),
            // toml's message spans several lines with a source excerpt; keep it on one line.
            message: e.message().trim().replace('\n', " "),
        })?;
        let mut config = config;
        if let Some(dir) = origin.parent() {
            config.zenoh.resolve_paths(dir);
        }
        config.validate()?;
        Ok(config)
    }

    /// Load `path`, or the defaults when none is given.
    pub fn load(path: Option<&Path>) -> Result<Self, ConfigError> {
        match path {
            None => Ok(Self::default()),
            Some(p) => {
                let text = std::fs::read_to_string(p).map_err(|error| ConfigError::Read {
                    path: p.to_path_buf(),
                    error,
                })?;
                Self::from_toml(&text, p)
            }
        }
    }

    /// The service names and keys of this pipeline.
    pub fn names(&self) -> Result<Names, ConfigError> {
        Ok(Names::new(self.instance.as_deref(), &self.vessel)?)
    }

    /// Check values that parse but cannot work.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.names()?;
        self.zenoh.validate()?;
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
                return Err(format!(
                    "{name} must be three finite numbers within +-{MAX_LEVER_M} m, got {point:?}"
                ));
            }
        }
        limits::count("crane.print_every", self.crane.print_every, 1, u64::MAX)?;
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

/// Flags every pipeline subcommand accepts; they override the config file.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct CommonArgs {
    /// Pipeline configuration (TOML); every key has a default.
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// Prefix of every service name and zenoh key (keeps parallel pipelines apart).
    #[arg(long, value_name = "NAME")]
    pub instance: Option<String>,
    /// Vessel name in service names and keys.
    #[arg(long, value_name = "NAME")]
    pub vessel: Option<String>,
    /// zenoh endpoint the predictor listens on (repeatable; replaces the configured ones).
    #[arg(long, value_name = "ENDPOINT")]
    pub zenoh_listen: Vec<String>,
    /// zenoh endpoint to connect to (repeatable; replaces the configured ones).
    #[arg(long, value_name = "ENDPOINT")]
    pub zenoh_connect: Vec<String>,
    /// Pacing of the producer: 1 = real time, 0 = as fast as possible.
    #[arg(long, value_name = "F")]
    pub speed: Option<f64>,
    /// Stop after this many seconds of wall-clock time.
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
}

impl CommonArgs {
    /// The config file (or the defaults) with the flags applied, validated.
    pub fn load(&self) -> Result<PipelineConfig, ConfigError> {
        let mut config = PipelineConfig::load(self.config.as_deref())?;
        if let Some(i) = &self.instance {
            config.instance = Some(i.clone());
        }
        if let Some(v) = &self.vessel {
            config.vessel = v.clone();
        }
        if !self.zenoh_listen.is_empty() {
            config.zenoh.listen = self.zenoh_listen.clone();
        }
        if !self.zenoh_connect.is_empty() {
            config.zenoh.connect = self.zenoh_connect.clone();
        }
        if let Some(s) = self.speed {
            config.producer.speed = s;
        }
        config.validate()?;
        Ok(config)
    }

    /// Wall-clock limit, if any.
    pub fn duration(&self) -> Result<Option<std::time::Duration>, ConfigError> {
        self.duration
            .map(|s| limits::seconds("--duration", s).map_err(ConfigError::Invalid))
            .transpose()
    }
}

impl PipelineConfig {
    /// The configuration as TOML, as `shipcast run` hands it to its children.
    pub fn to_toml(&self) -> Result<String, ConfigError> {
        toml::to_string(self).map_err(|e| ConfigError::Invalid(format!("serialise: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every cause in `{:#}` of `error` (what the binary prints) appears exactly once.
    fn assert_causes_print_once(error: anyhow::Error, causes: &[String]) {
        let chain = format!("{error:#}");
        for cause in causes {
            assert_eq!(
                chain.matches(cause.as_str()).count(),
                1,
                "'{cause}' in: {chain}"
            );
        }
    }

    #[test]
    fn error_causes_print_once_in_error_chains() {
        let missing = Path::new("/nonexistent/shipcast-config.toml");
        let io = std::fs::read_to_string(missing).unwrap_err().to_string();
        let err = PipelineConfig::load(Some(missing)).unwrap_err();
        assert_causes_print_once(err.into(), &[io, missing.display().to_string()]);

        let name = crate::transport::Names::new(Some("bad name"), "v").unwrap_err();
        let err = ConfigError::from(name.clone());
        assert_causes_print_once(err.into(), &[name.to_string()]);

        let json = serde_json::from_slice::<serde_json::Value>(b"{").unwrap_err();
        let err = shipcast_wire::payload::Forecast::from_json(b"{").unwrap_err();
        assert_causes_print_once(err.into(), &[json.to_string()]);
    }

    #[test]
    fn empty_file_gives_the_defaults() {
        let c = PipelineConfig::from_toml("", Path::new("x.toml")).unwrap();
        assert_eq!(c, PipelineConfig::default());
        assert_eq!(c.names().unwrap().forecast(), "shipcast/ddg51/forecast");
        assert_eq!(c.decimation_factor().unwrap(), 4);
    }

    #[test]
    fn keys_override_defaults() {
        let text = r#"
            instance = "t7"
            vessel = "s175"
            [producer]
            speed = 100.0
            [predictor]
            method = "mca"
            order = 100
            busy_poll = true
            [predictor.mca]
            energy = 0.02
            [zenoh]
            listen = ["tcp/127.0.0.1:7000"]
        "#;
        let c = PipelineConfig::from_toml(text, Path::new("x.toml")).unwrap();
        assert_eq!(c.names().unwrap().motion(), "t7/shipcast/s175/motion");
        assert_eq!(c.producer.speed, 100.0);
        let pc = c.predictor.predictor_config();
        assert_eq!((pc.order, pc.horizon, pc.mca_energy), (100, 50, 0.02));
        assert!(c.predictor.busy_poll);
        assert_eq!(c.zenoh.consumer_side().connect, vec!["tcp/127.0.0.1:7000"]);
        assert_eq!(c.zenoh.consumer_side().listen, vec![CONSUMER_LISTEN]);
    }

    #[test]
    fn unknown_key_is_an_error_naming_it() {
        let err = PipelineConfig::from_toml("[deck]\nroll_limt_deg = 3", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("roll_limt_deg"), "{err}");
        assert!(err.starts_with("config p.toml"), "{err}");
        assert!(!err.contains('\n'), "{err}");
        let err = PipelineConfig::from_toml("colour = 1", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("colour"), "{err}");
    }

    #[test]
    fn toml_round_trip_and_flags_override_the_file() {
        let mut c = PipelineConfig {
            instance: Some("abc".into()),
            ..PipelineConfig::default()
        };
        c.producer.input = Some("/tmp/x.csv".into());
        c.predictor.model = Some("/tmp/m.json".into());
        let text = c.to_toml().unwrap();
        assert_eq!(PipelineConfig::from_toml(&text, Path::new("t")).unwrap(), c);

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        std::fs::write(&path, "vessel = \"s175\"\n[producer]\nspeed = 5.0\n").unwrap();
        let args = CommonArgs {
            config: Some(path),
            instance: Some("i1".into()),
            zenoh_listen: vec!["tcp/127.0.0.1:9".into()],
            speed: Some(100.0),
            ..CommonArgs::default()
        };
        let c = args.load().unwrap();
        assert_eq!(c.vessel, "s175");
        assert_eq!(c.instance.as_deref(), Some("i1"));
        assert_eq!(c.producer.speed, 100.0);
        assert_eq!(c.zenoh.listen, vec!["tcp/127.0.0.1:9"]);
        let bad = CommonArgs {
            duration: Some(-1.0),
            ..CommonArgs::default()
        };
        assert!(bad
            .duration()
            .unwrap_err()
            .to_string()
            .contains("--duration"));
    }

    #[test]
    fn method_sections_apply_to_their_method_only() {
        // The default method (Wiener) has no settings of its own: an MCA section is refused.
        for (text, needle) in [
            (
                "[predictor.mca]\nshift = 3",
                "[predictor.mca] applies to method = \"mca\"",
            ),
            (
                "[predictor]\nmethod = \"mca\"\n[predictor.ar]\nlms_gain = 0.1",
                "[predictor.ar]",
            ),
            (
                "[predictor]\nmethod = \"ar\"\n[predictor.mlp]\nhidden = 3",
                "[predictor.mlp]",
            ),
        ] {
            let err = PipelineConfig::from_toml(text, Path::new("p.toml"))
                .unwrap_err()
                .to_string();
            assert!(err.contains(needle), "{text}: {err}");
        }
        // The old catch-all table, where order and horizon were silently overridden, is gone.
        let err = PipelineConfig::from_toml("[predictor.tuning]\norder = 5", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("tuning"), "{err}");
        // An unknown key inside a method section is named.
        let err = PipelineConfig::from_toml(
            "[predictor]\nmethod = \"mca\"\n[predictor.mca]\nshfit = 3",
            Path::new("p.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("shfit"), "{err}");
        // Each method's section reaches its predictor settings; left out, the defaults do.
        let c = PipelineConfig::from_toml(
            "[predictor]\nmethod = \"ar\"\n[predictor.ar]\nlms_gain = 0.25\nnormalized = true",
            Path::new("p.toml"),
        )
        .unwrap();
        let pc = c.predictor.predictor_config();
        assert_eq!((pc.lms_gain, pc.lms_normalized), (0.25, true));
        let pc = PipelineConfig::default().predictor.predictor_config();
        assert_eq!(
            (pc.mca_weighting, pc.mca_shift, pc.mca_validate_energy),
            (McaWeighting::Inverse, 2, true)
        );
        assert_eq!(pc.lms_gain, PredictorConfig::default().lms_gain);
        // Round trip through the TOML `shipcast run` hands its children.
        let text = c.to_toml().unwrap();
        assert_eq!(PipelineConfig::from_toml(&text, Path::new("t")).unwrap(), c);
    }

    #[test]
    fn impossible_values_are_refused() {
        for (text, needle) in [
            ("[predictor]\nhorizon = 200", "horizon"),
            ("[producer]\nspeed = -1.0", "speed"),
            ("vessel = \"a/b\"", "vessel"),
            ("[predictor]\nsample_rate_hz = 3.0", "multiple"),
        ] {
            let r = PipelineConfig::from_toml(text, Path::new("p.toml"))
                .and_then(|c| c.decimation_factor().map(|_| c));
            let err = r.unwrap_err().to_string();
            assert!(err.contains(needle), "{text}: {err}");
        }
        assert!(PipelineConfig::load(Some(Path::new("/nonexistent/x.toml"))).is_err());
    }
}
