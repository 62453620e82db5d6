//! Ship-motion predictors behind one trait.
//!
//! Every predictor maps the last `order` observed values of one degree of freedom to the next
//! `horizon` values. The protocol (docs/contracts.md section 4) is the same for all of them: fit
//! once on a training segment, then forecast from any window of past values; online methods may
//! also learn from every value observed after training.
//!
//! `forecast` writes into a caller-provided buffer and never allocates: predictors keep whatever
//! workspace they need, sized at `fit` time.
//!
//! # Example: fit a predictor and forecast
//!
//! A sum of a few sinusoids is extrapolated almost exactly by a linear predictor:
//!
//! ```
//! use shipcast_predict::{AnyPredictor, Method, Predictor, PredictorConfig};
//!
//! let x: Vec<f64> = (0..3000)
//!     .map(|t| {
//!         let t = t as f64 * 0.5; // 2 Hz
//!         (0.6 * t).sin() + 0.5 * (0.9 * t + 1.0).sin()
//!     })
//!     .collect();
//! let config = PredictorConfig { order: 100, horizon: 20, ..PredictorConfig::default() };
//! let mut wiener = AnyPredictor::new(Method::Wiener, &config).unwrap();
//! wiener.fit(&x[..2000]).unwrap();
//!
//! let mut out = [0.0; 20];
//! wiener.forecast(&x[..2500], &mut out).unwrap();
//! for (h, predicted) in out.iter().enumerate() {
//!     assert!((predicted - x[2500 + h]).abs() < 0.05, "step {}", h + 1);
//! }
//! ```

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Serialize and Deserialize for a predictor whose derives say `#[serde(remote = "Self")]`:
/// the derived code does the reading, then `validate(&self) -> Result<(), String>` runs, so a
/// hand-edited model file cannot skip the checks the constructor and `fit` make (a wrong shape
/// would slice out of range or multiply the wrong values). Its message names the field.
macro_rules! serde_validated {
    ($ty:ty) => {
        impl serde::Serialize for $ty {
            fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                // The inherent function the derive generates, not this trait method.
                <$ty>::serialize(self, serializer)
            }
        }
        impl<'de> serde::Deserialize<'de> for $ty {
            fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                let value = <$ty>::deserialize(deserializer)?;
                value.validate().map_err(serde::de::Error::custom)?;
                Ok(value)
            }
        }
    };
}

pub mod alloc_count;
pub mod ar_lms;
pub mod averaging;
pub mod baseline;
pub mod levinson;
pub mod linear_map;
pub mod mca;
pub mod mlp;
pub(crate) mod vector_state;
pub mod wiener;
pub mod wiener_ls;

#[cfg(any(test, feature = "conformance"))]
pub mod conformance;

// This crate's own tests count allocations (the conformance suite's allocation check).
#[cfg(test)]
#[global_allocator]
static ALLOCATOR: alloc_count::CountingAllocator = alloc_count::CountingAllocator;

pub use ar_lms::ArLmsPredictor;
pub use averaging::{AverageMode, Averaging, AveragingWeights, ForecastAverager};
pub use baseline::{PersistencePredictor, ZeroPredictor};
pub use mca::{McaPredictor, McaWeighting};
pub use mlp::MlpPredictor;
pub use wiener::WienerPredictor;
pub use wiener_ls::WienerFit;

/// Why a predictor could not be built, fitted or asked for a forecast.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PredictError {
    /// The configuration cannot work, whatever the data (e.g. MCA with horizon >= order).
    #[error("infeasible configuration: {0}")]
    Infeasible(String),
    /// The training series is shorter than the method needs.
    #[error("training series too short: {method} with order {order} needs at least {needed} values, got {got}")]
    TooShort {
        method: Method,
        order: usize,
        needed: usize,
        got: usize,
    },
    /// The training series is too short to fit the weights of K averaged forecasts, although
    /// the method itself could be fitted on it.
    #[error("training series too short to fit the weights of {k} averaged forecasts: {method} with order {order} needs at least {needed} values for them, got {got} (average fewer forecasts, average uniformly, or train on more)")]
    TooShortToWeigh {
        method: Method,
        order: usize,
        k: usize,
        needed: usize,
        got: usize,
    },
    /// A buffer passed to `forecast`/`update` has the wrong length.
    #[error("buffer length: {0}")]
    Length(String),
    /// `forecast` was called before `fit`.
    #[error("{0} predictor used before it was fitted")]
    NotFitted(Method),
    /// Non-finite values where only finite ones can be used.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// A numerical step failed (singular matrix, eigen-decomposition did not converge, ...).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// Validation (`mca_validate_energy`) rejected every candidate setting.
    #[error("{0}: no candidate setting gave a usable predictor")]
    NoUsableCandidate(Method),
}

/// The prediction methods shipcast knows, by their CLI names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    Mca,
    Wiener,
    Ar,
    Mlp,
    Persistence,
    Zero,
}

impl Method {
    /// Every method, in the order tables list them.
    pub const ALL: [Method; 6] = [
        Method::Mca,
        Method::Wiener,
        Method::Ar,
        Method::Mlp,
        Method::Persistence,
        Method::Zero,
    ];

    /// CLI / JSON name.
    pub const fn name(self) -> &'static str {
        match self {
            Method::Mca => "mca",
            Method::Wiener => "wiener",
            Method::Ar => "ar",
            Method::Mlp => "mlp",
            Method::Persistence => "persistence",
            Method::Zero => "zero",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let lower = s.trim().to_ascii_lowercase();
        Method::ALL
            .into_iter()
            .find(|m| m.name() == lower)
            .ok_or_else(|| {
                format!("unknown method '{s}' (expected mca, wiener, ar, mlp, persistence or zero)")
            })
    }
}

/// Everything needed to build any predictor. Defaults are the paper's settings
/// (docs/contracts.md section 4); the improvements the paper lacks are off by default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PredictorConfig {
    /// Number of past values a forecast may use. For MCA this is the window length n, of which
    /// n - horizon are past values.
    pub order: usize,
    /// Number of steps forecast (H).
    pub horizon: usize,
    /// MCA: shift between consecutive training windows.
    pub mca_shift: usize,
    /// MCA: minor components are the smallest eigenvalues whose sum is at most this fraction of
    /// the trace (at least `horizon` of them).
    pub mca_energy: f64,
    /// MCA: ridge added to B2^T B2, relative to its mean diagonal (0 = paper). With inverse
    /// weighting: eps relative to the mean eigenvalue (0 = `mca::INVERSE_DEFAULT_RIDGE`).
    pub mca_ridge: f64,
    /// MCA: choose the energy threshold by validation on the end of the training segment
    /// (inverse weighting: the ridge).
    pub mca_validate_energy: bool,
    /// MCA: weights of the eigen-directions (`paper`: minor components, unweighted;
    /// `inverse`: all, 1/(lambda + eps), the conditional mean; not in the paper).
    pub mca_weighting: McaWeighting,
    /// AR: LMS step size (paper: 0.005).
    pub lms_gain: f64,
    /// AR: normalised LMS (step divided by the input power) instead of plain LMS.
    pub lms_normalized: bool,
    /// Wiener: how the weights are estimated (paper: the biased autocorrelation).
    pub wiener_fit: WienerFit,
    /// MLP: hidden tanh units (paper: 100).
    pub mlp_hidden: usize,
    /// MLP: Rprop epochs (full-batch).
    pub mlp_epochs: usize,
    /// Seed for every random choice a method makes (MLP initial weights).
    pub seed: u64,
}

impl Default for PredictorConfig {
    fn default() -> Self {
        Self {
            order: 800,
            horizon: 50,
            mca_shift: 10,
            mca_energy: 0.015,
            mca_ridge: 0.0,
            mca_validate_energy: false,
            mca_weighting: McaWeighting::Paper,
            lms_gain: 0.005,
            lms_normalized: false,
            wiener_fit: WienerFit::Autocorrelation,
            mlp_hidden: 100,
            mlp_epochs: 200,
            seed: 1,
        }
    }
}

/// What a fitted predictor can tell about itself (reported by `shipcast eval --json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// MCA: number of minor components used.
    pub minor_components: Option<usize>,
    /// MCA: the energy threshold used (the one chosen when validation is on).
    pub energy: Option<f64>,
    /// MCA: the ridge used (inverse weighting with validation: the one chosen).
    pub ridge: Option<f64>,
    /// MCA: how the eigen-directions were weighted.
    pub mca_weighting: Option<McaWeighting>,
}

/// A ship-motion predictor for one degree of freedom.
pub trait Predictor: Send {
    /// Which method this is.
    fn method(&self) -> Method;

    /// Number of past values `forecast` needs.
    fn order(&self) -> usize;

    /// Number of steps `forecast` writes.
    fn horizon(&self) -> usize;

    /// Learn from a training series (oldest first). Replaces anything learned before.
    fn fit(&mut self, train: &[f64]) -> Result<(), PredictError>;

    /// Forecast `horizon()` steps after the end of `past`. `past` holds at least `order()`
    /// values, oldest first; only the last `order()` are used. `out` holds at least
    /// `horizon()` values; `out[h-1]` is the forecast h steps after the last value of `past`.
    /// Never allocates.
    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError>;

    /// Do now the part of the next forecast that depends only on values already known, so that
    /// `forecast` has less to do once the next value arrives (the linear methods: all but one
    /// column of their matrix product). `known` ends with the newest value observed; the next
    /// `forecast` is expected on `known` plus one new value. `forecast` gives the same result,
    /// bit for bit, whether or not this ran and whatever `known` held. Methods with nothing to
    /// prepare ignore it. Never allocates.
    fn prepare(&mut self, known: &[f64]) -> Result<(), PredictError> {
        let _ = known;
        Ok(())
    }

    /// True if the method learns online from values observed after training.
    fn is_online(&self) -> bool {
        false
    }

    /// Learn from a newly observed value. `recent` ends with that value and holds at least
    /// `order() + horizon()` values, so that the h-step predictor issued h steps ago can be
    /// corrected. Offline methods ignore it. Never allocates.
    fn update(&mut self, recent: &[f64]) -> Result<(), PredictError> {
        let _ = recent;
        Ok(())
    }

    /// Facts about the fitted model.
    fn diagnostics(&self) -> Diagnostics {
        Diagnostics::default()
    }
}

/// Any predictor, by value: static dispatch in hot paths and one serialisable model type for
/// model files (`shipcast train`).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "lowercase")]
pub enum AnyPredictor {
    Mca(McaPredictor),
    Wiener(WienerPredictor),
    Ar(ArLmsPredictor),
    Mlp(MlpPredictor),
    Persistence(PersistencePredictor),
    Zero(ZeroPredictor),
}

impl AnyPredictor {
    /// Build an unfitted predictor of `method` with `config`. Fails on configurations that can
    /// never work (e.g. MCA with horizon >= order).
    pub fn new(method: Method, config: &PredictorConfig) -> Result<Self, PredictError> {
        if config.order == 0 {
            return Err(PredictError::Infeasible("order must be at least 1".into()));
        }
        if config.horizon == 0 {
            return Err(PredictError::Infeasible(
                "horizon must be at least 1".into(),
            ));
        }
        Ok(match method {
            Method::Mca => AnyPredictor::Mca(McaPredictor::new(config)?),
            Method::Wiener => AnyPredictor::Wiener(WienerPredictor::new(config)?),
            Method::Ar => AnyPredictor::Ar(ArLmsPredictor::new(config)?),
            Method::Mlp => AnyPredictor::Mlp(MlpPredictor::new(config)?),
            Method::Persistence => AnyPredictor::Persistence(PersistencePredictor::new(config)?),
            Method::Zero => AnyPredictor::Zero(ZeroPredictor::new(config)?),
        })
    }

    fn inner(&self) -> &dyn Predictor {
        match self {
            AnyPredictor::Mca(p) => p,
            AnyPredictor::Wiener(p) => p,
            AnyPredictor::Ar(p) => p,
            AnyPredictor::Mlp(p) => p,
            AnyPredictor::Persistence(p) => p,
            AnyPredictor::Zero(p) => p,
        }
    }

    fn inner_mut(&mut self) -> &mut dyn Predictor {
        match self {
            AnyPredictor::Mca(p) => p,
            AnyPredictor::Wiener(p) => p,
            AnyPredictor::Ar(p) => p,
            AnyPredictor::Mlp(p) => p,
            AnyPredictor::Persistence(p) => p,
            AnyPredictor::Zero(p) => p,
        }
    }
}

impl Predictor for AnyPredictor {
    fn method(&self) -> Method {
        self.inner().method()
    }
    fn order(&self) -> usize {
        self.inner().order()
    }
    fn horizon(&self) -> usize {
        self.inner().horizon()
    }
    fn fit(&mut self, train: &[f64]) -> Result<(), PredictError> {
        self.inner_mut().fit(train)
    }
    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        self.inner_mut().forecast(past, out)
    }
    fn prepare(&mut self, known: &[f64]) -> Result<(), PredictError> {
        self.inner_mut().prepare(known)
    }
    fn is_online(&self) -> bool {
        self.inner().is_online()
    }
    fn update(&mut self, recent: &[f64]) -> Result<(), PredictError> {
        self.inner_mut().update(recent)
    }
    fn diagnostics(&self) -> Diagnostics {
        self.inner().diagnostics()
    }
}

/// Check the buffers handed to `forecast`; shared by every implementation so the error
/// messages agree.
pub(crate) fn check_forecast_buffers(
    order: usize,
    horizon: usize,
    past: &[f64],
    out: &[f64],
) -> Result<(), PredictError> {
    if past.len() < order {
        return Err(PredictError::Length(format!(
            "forecast needs {order} past values, got {}",
            past.len()
        )));
    }
    if out.len() < horizon {
        return Err(PredictError::Length(format!(
            "forecast writes {horizon} steps, output buffer holds {}",
            out.len()
        )));
    }
    Ok(())
}

/// Check a training series before fitting: at least `needed` values, all finite. Shared by
/// every implementation so the error messages agree.
pub(crate) fn check_training(
    method: Method,
    order: usize,
    needed: usize,
    train: &[f64],
) -> Result<(), PredictError> {
    if train.len() < needed {
        return Err(PredictError::TooShort {
            method,
            order,
            needed,
            got: train.len(),
        });
    }
    if train.iter().any(|v| !v.is_finite()) {
        return Err(PredictError::NonFinite("training series"));
    }
    Ok(())
}
