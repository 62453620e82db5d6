//! A model that fails numerically, and what the engine does about it: that DOF is taken out
//! of service and delivered as no skill, a retrain is asked for, and retrains for failures in
//! a row back off so that the values a model failed on leave every model's input first.

use shipcast_wire::payload::NUM_DOF;
use shipcast_wire::Dof;

/// DOF whose running model failed numerically (an online AR whose update diverged on a
/// spike, say): taken out of service until the next model set. Their forecasts are no skill
/// (the level, sigma the live RMS, counted as implausible) and a retrain is asked for at once
/// (`Engine::handle_failures`). A model that cannot forecast one DOF must not stop the other
/// five, nor the service.
#[derive(Debug, Default)]
pub(super) struct FailedModels {
    pub(super) dof: [bool; NUM_DOF],
    /// A failure since the engine last asked for a retrain.
    pub(super) unhandled: bool,
    /// Value count when the latest retrain for a failure was asked for. The values that made
    /// a model fail (a spike) stay in the input of the model that replaces it for up to an
    /// order and a horizon, and it can fail on them in turn: 14 failures and retrains had
    /// followed each other within 34 s. So retrains for failures back off (`failure_gap`).
    pub(super) retrain_at: Option<u64>,
    /// Value count of the latest failure.
    pub(super) last_failure_at: Option<u64>,
    /// Retrains for failures asked for in a row: each after a model failed again within the
    /// longest input of the previous retrain (the values it failed on could still be there).
    pub(super) streak: u32,
}

/// Values to wait after the `streak`-th retrain for a failure in a row before the next:
/// the first failure is retrained at once, then the wait doubles from
/// [`FIRST_FAILURE_GAP`] up to `longest`, the longest input a model reads (after which the
/// values it failed on have left every model's input).
pub(super) fn failure_gap(streak: u32, longest: u64) -> u64 {
    match streak {
        0 => 0,
        n => FIRST_FAILURE_GAP
            .saturating_mul(1 << (n - 1).min(32))
            .min(longest),
    }
}

/// The streak of a retrain for a failure about to be asked for: one more if a model failed
/// again while the values the previous one failed on could still be in its input (within
/// `longest` values of that retrain, or at it: an inline retrain's model is updated, and may
/// fail, on the very value it was asked for at); else the first of a new streak.
pub(super) fn next_streak(failed: &FailedModels, longest: u64) -> u32 {
    let again = match (failed.retrain_at, failed.last_failure_at) {
        (Some(r), Some(f)) => f >= r && f - r < longest,
        _ => false,
    };
    if again {
        failed.streak.saturating_add(1)
    } else {
        1
    }
}

/// Wait after the first retrain for a failure before another [values]: 2 s at 2 Hz.
pub(super) const FIRST_FAILURE_GAP: u64 = 4;

/// Why a retrain is due when a model failed (`FailedModels`).
pub(super) const REASON_MODEL_FAILED: &str = "a model failed";

impl FailedModels {
    /// Take DOF `d`'s model out of service at value count `at`; `failures` counts every
    /// failure.
    pub(super) fn fail(
        &mut self,
        d: usize,
        (at, time_s): (u64, f64),
        error: &dyn std::fmt::Display,
        failures: &mut u64,
    ) {
        self.dof[d] = true;
        self.last_failure_at = Some(at);
        *failures += 1;
        self.unhandled = true;
        tracing::warn!(
            dof = Dof::ALL[d].name(),
            time_s,
            failures = *failures,
            "predictor: the {} model failed ({error}); no skill for it until a retrain",
            Dof::ALL[d].name()
        );
    }
}
