//! What the study measured: one record per experiment, and the lookups the report makes in
//! them. Running the experiments is the parent module's job.

use crate::averaging::AverageOutcome;
use crate::measured::{self, MeasuredOutcome};
use crate::plan::Plan;
use crate::seas::SeaKind;
use crate::skill::overall;
use crate::variant::Variant;
use shipcast_eval::{EvalError, EvalResult};
use shipcast_predict::{Method, PredictError};
use shipcast_wire::Dof;

/// Why a study run has no result, typed where the report treats the cause apart.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Failure {
    /// The configuration cannot work (MCA with horizon >= order): by design, not a fault.
    #[error("{0}")]
    Infeasible(String),
    /// Validation rejected every candidate setting (each map beyond its size bound).
    #[error("{0}")]
    NoUsableCandidate(String),
    /// Anything else, as its message.
    #[error("{0}")]
    Other(String),
}

impl Failure {
    /// The failure of an evaluation, classified by its typed cause.
    pub fn of_eval(error: &EvalError) -> Self {
        let message = error.to_string();
        match error {
            EvalError::Predict(PredictError::Infeasible(_)) => Failure::Infeasible(message),
            EvalError::Predict(PredictError::NoUsableCandidate(_)) => {
                Failure::NoUsableCandidate(message)
            }
            _ => Failure::Other(message),
        }
    }
}

impl From<String> for Failure {
    fn from(message: String) -> Self {
        Failure::Other(message)
    }
}

impl From<Failure> for String {
    fn from(failure: Failure) -> Self {
        failure.to_string()
    }
}

/// One method on one series.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub sea: SeaKind,
    pub dof: Dof,
    pub order: usize,
    pub method: Method,
    pub variant: Variant,
    /// Noise added, % of the peak amplitude.
    pub noise_pct: f64,
    pub result: Result<EvalResult, Failure>,
}

/// The bound on one series: the optimal linear predictor of `order` from the exact
/// autocorrelation.
#[derive(Clone, Debug)]
pub struct BoundOutcome {
    pub sea: SeaKind,
    pub dof: Dof,
    pub order: usize,
    pub result: Result<BoundScores, String>,
}

#[derive(Clone, Debug)]
pub struct BoundScores {
    /// Exact RMS error per step under the sea's autocorrelation.
    pub exact_rms: Vec<f64>,
    /// RMS error per step of the same predictor at the protocol's origins of the test segment.
    pub measured_rms: Vec<f64>,
    pub origins: usize,
}

/// Table 2: training time and time for 500 predictions.
#[derive(Clone, Debug)]
pub struct Timing {
    pub method: Method,
    pub horizon: usize,
    pub result: Result<TimingScores, String>,
}

#[derive(Clone, Debug)]
pub struct TimingScores {
    pub train_seconds: f64,
    /// 500 forecasts, plus for the online AR the 500 updates that go with them.
    pub predict_500_seconds: f64,
}

/// A "predicted against true" figure: the forecast `TRACE_LEAD` steps ahead for every instant
/// of a window, from MCA with the paper's settings and from the bound.
#[derive(Clone, Debug)]
pub struct Trace {
    pub dof: Dof,
    pub noise_pct: f64,
    /// (time [s], value) of the clean motion.
    pub truth: Vec<(f64, f64)>,
    /// What the predictors saw, when it differs from the truth (noisy records).
    pub observed: Option<Vec<(f64, f64)>>,
    pub mca: Result<Vec<(f64, f64)>, String>,
    pub bound: Result<Vec<(f64, f64)>, String>,
}

/// A sea as the report needs it.
#[derive(Clone, Debug)]
pub struct SeaInfo {
    pub kind: SeaKind,
    pub title: String,
    pub components: usize,
    /// Standard deviation of each DOF's test segment (index = `Dof::index`).
    pub test_std: [f64; 6],
}

/// Everything the study measured.
#[derive(Clone, Debug)]
pub struct Study {
    pub plan: Plan,
    pub seas: Vec<SeaInfo>,
    pub outcomes: Vec<Outcome>,
    pub bounds: Vec<BoundOutcome>,
    pub timings: Vec<Timing>,
    pub traces: Vec<Trace>,
    /// The averaged forecasts (MCA, heave) on each series.
    pub averages: Vec<AverageOutcome>,
    /// What the measured-sea record is, when one was given.
    pub measured_title: Option<String>,
    /// The measured-sea section's rows and record, when one was given.
    pub measured: Vec<MeasuredOutcome>,
    pub measured_record: Option<measured::RecordInfo>,
    /// Wall time of the whole run [s].
    pub elapsed_seconds: f64,
    /// Worker threads used after the timing jobs.
    pub threads: usize,
}

impl Study {
    pub fn sea(&self, kind: SeaKind) -> Option<&SeaInfo> {
        self.seas.iter().find(|s| s.kind == kind)
    }

    /// The outcome of `method` with `variant` on a noise-free series, if it was run.
    pub fn outcome(
        &self,
        sea: SeaKind,
        dof: Dof,
        order: usize,
        method: Method,
        variant: Variant,
    ) -> Option<&Outcome> {
        self.noisy_outcome(sea, dof, order, method, variant, 0.0)
    }

    pub fn noisy_outcome(
        &self,
        sea: SeaKind,
        dof: Dof,
        order: usize,
        method: Method,
        variant: Variant,
        noise_pct: f64,
    ) -> Option<&Outcome> {
        self.outcomes.iter().find(|o| {
            o.sea == sea
                && o.dof == dof
                && o.order == order
                && o.method == method
                && o.variant == variant
                && o.noise_pct == noise_pct
        })
    }

    /// The eigenvalue-weighted MCA variant with the lowest heave error over the whole horizon
    /// on the dense sea at the big order: the one the figure and the horizon table show.
    pub fn best_inverse(&self) -> Option<Variant> {
        let order = self.plan.big_order();
        Variant::INVERSE
            .into_iter()
            .filter_map(|v| {
                rms_curve(self.outcome(SeaKind::Dense, Dof::Heave, order, Method::Mca, v))
                    .ok()
                    .map(|rms| (v, overall(rms)))
            })
            .filter(|(_, e)| e.is_finite())
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(v, _)| v)
    }

    /// The bound's RMS per step, exact (its expectation) or measured at the test origins, or
    /// why there is none.
    pub fn bound_curve(
        &self,
        sea: SeaKind,
        dof: Dof,
        order: usize,
        exact: bool,
    ) -> Result<&[f64], String> {
        match self.bound(sea, dof, order) {
            Some(b) => b
                .result
                .as_ref()
                .map(|b| {
                    if exact {
                        b.exact_rms.as_slice()
                    } else {
                        b.measured_rms.as_slice()
                    }
                })
                .map_err(|e| e.clone()),
            None => Err("not run".into()),
        }
    }

    pub fn bound(&self, sea: SeaKind, dof: Dof, order: usize) -> Option<&BoundOutcome> {
        self.bounds
            .iter()
            .find(|b| b.sea == sea && b.dof == dof && b.order == order)
    }
}

/// RMS per step of an outcome, or why there is none.
pub fn rms_curve(outcome: Option<&Outcome>) -> Result<&[f64], Failure> {
    match outcome {
        Some(o) => o
            .result
            .as_ref()
            .map(|r| r.rms.as_slice())
            .map_err(|e| e.clone()),
        None => Err(Failure::Other("not run".into())),
    }
}
