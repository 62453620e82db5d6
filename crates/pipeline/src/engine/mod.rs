//! The forecasting engine: from motion samples to published forecasts, with everything that
//! makes a forecast safe to act on. The predictor service drives it from iceoryx2 samples and
//! `shipcast replay` from a motion CSV; both run this same code.
//!
//! The predictors read and are fitted on each value less the DOF's level (`level.rs`: a static
//! list or trim, a sensor offset), and the level is added back to what they forecast.
//!
//! Per new decimated value (2 Hz) the engine:
//! 1. scores the steps of earlier forecasts that this value completes (live verification, and
//!    the evidence the calibrator learns from);
//! 2. watches for errors leaving sigma (a changed sea), and then retrains at once;
//! 3. updates online models, schedules retraining (first fit after `first_fit_s` of live data,
//!    then every `retrain_every_s`, on a window that grows up to `retrain_window`);
//! 4. forecasts with the running model, shrinks the mean per step towards the level by the
//!    verified regression coefficient and sets sigma to the error that shrunk forecast really
//!    had;
//! 5. never delivers an implausible mean (non-finite, or further from the level than
//!    `plausible_rms_factor` times the live RMS of the motion about it): that DOF falls back
//!    to "no skill" (the level, sigma = RMS), and the event is counted and logged.

pub mod burst;
pub mod calibrate;
pub mod change;
mod failures;
pub mod ingest;
pub mod jump;
pub mod level;
pub mod models;
pub mod replay;
pub mod retrain;
pub mod rolling;
mod schedule;
pub mod shape;
pub mod startup;
pub mod verify;

use crate::config::PredictorServiceConfig;
use crate::transport::{monotonic_ns, Counters};
use burst::Burst;
use calibrate::Calibrator;
use change::{Change, ChangeDetector};
use failures::{failure_gap, next_streak, FailedModels, REASON_MODEL_FAILED};
use ingest::{Ingest, NewValue};
use jump::{Judgement, JumpGuard};
use models::ModelSet;
use retrain::{replaces, Job, Retrainer};
use serde::Serialize;
use shape::SigmaShape;
use shipcast_predict::Predictor;
use shipcast_wire::payload::{Forecast, MotionSample, MAX_STEPS, NUM_DOF};
use shipcast_wire::Dof;
use verify::{ForecastLog, VerificationReport, Verifier};

/// Longest run of lost or rejected input samples bridged, by a straight line from the last good
/// sample to the next (1 s at 8 Hz); longer runs restart the history.
pub const MAX_FILL: u64 = 8;

/// Weight, in values, of a prior in the calibration (a model's held-out evidence, or the "no
/// skill" start) once live evidence comes in; and what is kept after a change of sea.
const PRIOR_VALUES: f64 = 240.0;
const KEPT_AFTER_CHANGE: f64 = 60.0;
/// An error [m, rad] against a sigma of 0 beyond which the forecast is wrong, not rounded.
const ERROR_AGAINST_NO_SIGMA: f64 = 1e-9;
/// The squared standardised error of such a forecast: any value the change detector's bound
/// (25 times its ratio) cuts to that bound.
const Z2_AGAINST_NO_SIGMA: f64 = 1e6;

/// Memory of the live RMS of the motion [values] (5 minutes at 2 Hz).
const RMS_MEMORY: f64 = 600.0;
const RMS_MEMORY_FAST: f64 = 60.0;
/// Largest deviation from the level, in live RMS, that one value brings into the live RMS.
const SPIKE_RMS: f64 = 8.0;

/// Values before the decimation's mismatch with the record is known well enough to clip one
/// value against (1 minute at 2 Hz).
const LABEL_WARMUP: u64 = 120;

/// Values of live history before the first forecast: the live RMS must mean something.
pub const MIN_VALUES_TO_PUBLISH: u64 = 60;

/// Memory and refractory time of the change detector [values]: two minutes, longer than a
/// wave group, whose passing must not count as a change of sea.
const CHANGE_MEMORY: f64 = 240.0;
const CHANGE_REFRACTORY: u64 = 240;
/// Values after a break of the record, beyond the history the models read, in which a
/// detected change is taken for the refill's (`Engine::rougher`): the change detector's memory
/// twice over.
const RESTART_GRACE: u64 = 2 * CHANGE_MEMORY as u64;

/// Record time between refits after a change of sea, until the new sea fills three held-out
/// parts [s] (`schedule_retrain`).
const CHANGE_REFIT_EVERY_S: f64 = 60.0;

/// Counts of what the engine did, for status, logs and replay.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct EngineCounts {
    pub forecasts: u64,
    /// DOF forecasts replaced by the fallback because they were implausible.
    pub implausible: [u64; NUM_DOF],
    pub retrains: u64,
    /// Retrains that failed (the running models stayed in service).
    pub retrain_failures: u64,
    pub swaps: u64,
    /// Retrained models kept out because the running one scored better.
    pub kept_running: u64,
    pub changes: u64,
    /// DOF models that failed numerically (an online AR that diverged on a spike, say) and
    /// were taken out of service until the next model set.
    #[serde(default)]
    pub model_failures: u64,
    /// Jumps of a DOF's level that a forecast's first step missed far beyond its sigma; the
    /// DOF was held at no skill until the jump had left its model's input (`jump.rs`).
    #[serde(default)]
    pub jumps: [u64; NUM_DOF],
}

/// The engine's state.
pub struct Engine {
    config: PredictorServiceConfig,
    ingest: Ingest,
    models: Option<ModelSet>,
    retrainer: Retrainer,
    log: ForecastLog,
    calib: Calibrator,
    /// Scale on the calibrator's RMS sigma that matches the errors' +-1 and +-2 sigma coverage.
    shape: SigmaShape,
    burst: Burst,
    verifier: Verifier,
    change: ChangeDetector,
    /// Exponentially weighted mean square of each DOF about its level (`level.rs`), over
    /// about 5 minutes and over about 30 s: a growing sea shows in the short one first.
    mean_square: [f64; NUM_DOF],
    mean_square_fast: [f64; NUM_DOF],
    /// Per DOF, the mean square of the recorded sample at each decimated value's time less
    /// that value (weighted over about 5 minutes): what a forecast of the decimated values
    /// misses of the recorded motion even when exact ([`Ingest::recorded_at_label`]). It is
    /// added to every step's sigma in quadrature, before the shape factor, which is fitted on
    /// the errors against the recorded motion and so also covers the part of the mismatch that
    /// is correlated with the model's error (`shape.rs`): with the minimum-phase filter, whose
    /// timing is 10-40 ms off its label, +-2 sigma held 5.5 % of the 0.5 s heave errors on the
    /// paper sea without it (review), 0-17 % at every lead on a sea of three wave components.
    label_mismatch: [f64; NUM_DOF],
    jumps: JumpGuard,
    /// The two newest deviations from the level per DOF, older first (what tells a spike
    /// from motion that goes on).
    last_deviation: [[f64; 2]; NUM_DOF],
    forecast: Box<Forecast>,
    raw: [[f64; MAX_STEPS]; NUM_DOF],
    pub counters: Counters,
    pub counts: EngineCounts,
    /// Decimated values so far (the index of the newest is `values - 1`).
    values: u64,
    generation: u64,
    last_fit_at: Option<u64>,
    /// Value count at a detected change of sea, until the values since then fill three
    /// held-out parts: meanwhile retrains are judged on those values (`models::fit_recent`).
    changed_at: Option<u64>,
    /// Value count at the latest change of sea, while the retrain window still reaches back
    /// before it: until then every retrain also fits on the new sea's values alone and lets
    /// their held-out part choose (`models::fit_recent`), so a long window does not carry the
    /// old sea on once the first minutes after the change are over.
    sea_since: Option<u64>,
    /// Value index of each DOF's latest detected change.
    change_seen_at: [Option<u64>; NUM_DOF],
    /// Per DOF, the value index of its last "larger than claimed" detection.
    rougher_seen_at: [Option<u64>; NUM_DOF],
    /// Value index at which the record last broke (0: the start).
    restarted_at: u64,
    retrain_due: Option<&'static str>,
    prepared_for: Option<(u64, u32)>,
    last_time_s: f64,
    last_implausible_log: [u64; NUM_DOF],
    /// DOF whose running model failed: no skill until a new set is in use.
    failed: FailedModels,
}

impl Engine {
    /// An engine for input at `input_rate_hz`, starting from `models` (None: no skill until
    /// the first live fit), retraining on `retrainer`.
    pub fn new(
        config: PredictorServiceConfig,
        input_rate_hz: f64,
        models: Option<ModelSet>,
        retrainer: Retrainer,
    ) -> anyhow::Result<Self> {
        let factor = crate::config::decimation_factor(input_rate_hz, config.sample_rate_hz)?;
        let order = models.as_ref().map_or(0, ModelSet::order);
        let capacity = config.history_values().max(order + config.horizon);
        let ingest = Ingest::new(factor, input_rate_hz, capacity, MAX_FILL, config.filter)?;
        let window = (config.verification_window_s * config.sample_rate_hz).round() as usize;
        let mut engine = Self {
            ingest,
            retrainer,
            log: ForecastLog::default(),
            calib: Calibrator::new(window.max(1), PRIOR_VALUES),
            shape: SigmaShape::new(window.max(1)),
            burst: Burst::default(),
            verifier: Verifier::new(window.max(1)),
            change: ChangeDetector::new(CHANGE_MEMORY, config.change_ratio, CHANGE_REFRACTORY),
            mean_square: [0.0; NUM_DOF],
            mean_square_fast: [0.0; NUM_DOF],
            label_mismatch: [0.0; NUM_DOF],
            jumps: JumpGuard::default(),
            last_deviation: [[0.0; 2]; NUM_DOF],
            forecast: Box::default(),
            raw: [[0.0; MAX_STEPS]; NUM_DOF],
            counters: Counters::default(),
            counts: EngineCounts::default(),
            values: 0,
            generation: 0,
            last_fit_at: None,
            changed_at: None,
            sea_since: None,
            change_seen_at: [None; NUM_DOF],
            rougher_seen_at: [None; NUM_DOF],
            restarted_at: 0,
            retrain_due: None,
            prepared_for: None,
            last_time_s: f64::NAN,
            last_implausible_log: [0; NUM_DOF],
            failed: FailedModels::default(),
            models: None,
            config,
        };
        if let Some(m) = models {
            engine.install(m);
        }
        Ok(engine)
    }

    pub fn config(&self) -> &PredictorServiceConfig {
        &self.config
    }

    pub fn models(&self) -> Option<&ModelSet> {
        self.models.as_ref()
    }

    pub fn model_version(&self) -> u32 {
        self.models.as_ref().map_or(0, |m| m.version)
    }

    /// Values of live history held.
    pub fn history_len(&self) -> usize {
        self.ingest.len()
    }

    /// Times the history started again (a gap or a run of bad samples too long to bridge, or
    /// a new producer run); the first start is none.
    pub fn history_restarts(&self) -> u64 {
        self.ingest.generation()
    }

    pub fn last_time_s(&self) -> f64 {
        self.last_time_s
    }

    /// Delay of the decimated values behind the newest sample [s] (the lead of step k is
    /// `k * dt_s - delay_s` after the newest sample).
    pub fn delay_s(&self) -> f64 {
        self.ingest.delay_s()
    }

    /// Live RMS of DOF `d` about its level (exponentially weighted over about 5 minutes): what
    /// predicting the level would score, and the scale of the plausibility bound.
    pub fn live_rms(&self, d: usize) -> f64 {
        self.live_variance(d).sqrt()
    }

    /// Whether DOF `d` found its errors larger than claimed within the change detector's
    /// memory. Not after "much smaller than claimed": the old model's sigma was too wide
    /// then, and carried over it would be found too wide again, in a loop of swaps. Nor in
    /// the first `order` + [`RESTART_GRACE`] values after the record broke: the forecasts made while the
    /// history refills are the level, scored against the model's sigma, and the old sigma
    /// they leave is no skill (review: carried, it held the first step's sigma 60-100 times
    /// its error for two minutes after a gap).
    fn rougher(&self, d: usize) -> bool {
        self.rougher_seen_at[d].is_some_and(|at| {
            let refilled = self.restarted_at + self.config.order as u64 + RESTART_GRACE;
            at + CHANGE_MEMORY as u64 >= self.values && at >= refilled
        })
    }

    /// The larger of the slow and the fast mean square: when the sea grows, the bound and a
    /// no-skill sigma follow within half a minute; when it calms, the slow one keeps them wide
    /// until the evidence has caught up (the safe side).
    fn live_variance(&self, d: usize) -> f64 {
        self.mean_square[d].max(self.mean_square_fast[d])
    }

    /// The forecast last produced by [`Self::push`].
    pub fn forecast(&self) -> &Forecast {
        &self.forecast
    }

    /// Put a new model set in service: the calibration restarts from its held-out evidence
    /// (or from "no skill" if it has none from this sea).
    fn install(&mut self, set: ModelSet) {
        for d in 0..NUM_DOF {
            let prior = set.held_out.get(d).map_or(&[][..], Vec::as_slice);
            // The change detector keeps running: a new model is fitted mostly on the old sea,
            // so a change under way must not be forgotten at a swap; nor the errors it brought.
            if self.rougher(d) {
                let variance = self.live_variance(d);
                self.calib
                    .reset_carrying(d, prior, variance, KEPT_AFTER_CHANGE);
            } else {
                self.calib.reset(d, prior);
            }
        }
        // A DOF without a model of its own (`ModelSet::absent`) is delivered as no skill, as a
        // failed one is.
        self.failed.dof = set.absent;
        self.models = Some(set);
        self.prepared_for = None;
    }

    /// Feed one motion sample. Returns the new forecast if this sample completed one.
    pub fn push(&mut self, sample: &MotionSample) -> anyhow::Result<Option<&Forecast>> {
        let Some(v) = self.ingest.push(sample, &mut self.counters) else {
            return Ok(None);
        };
        if self.on_value(v)? {
            Ok(Some(&self.forecast))
        } else {
            Ok(None)
        }
    }

    fn on_value(&mut self, v: NewValue) -> anyhow::Result<bool> {
        if self.ingest.generation() != self.generation {
            // The record broke: pending forecasts will never be verified against it.
            self.generation = self.ingest.generation();
            self.log.clear();
            self.jumps.clear();
            self.last_fit_at = None;
            self.changed_at = None;
            self.sea_since = None;
            self.restarted_at = self.values;
        }
        self.last_time_s = v.time_s;
        self.values += v.skipped;
        let index = self.values;
        self.values += 1;
        let x: [f64; NUM_DOF] = std::array::from_fn(|d| self.ingest.newest(d));
        // Live verification scores against the recorded motion, as replay does; calibration
        // and the change detector stay on the decimated values the models forecast.
        let recorded: [f64; NUM_DOF] =
            std::array::from_fn(|d| self.ingest.recorded_at_label(d).unwrap_or(x[d]));
        // Scored before the value enters the live RMS, which bounds its weight in calibration.
        self.score(index, &x, &recorded);
        self.judge_jumps(index, v.time_s);
        for (d, x) in x.iter().enumerate() {
            // About the level: what predicting the level would score. Clipped once there is
            // a scale: one spike of 50 m in a sea of 1 m multiplied the live RMS, and with it
            // the plausibility bound and the no-skill sigma, for minutes (review). 8 RMS lets
            // a real growth through at twice the variance per value.
            //
            // A spike is one or two values; motion that resumes after hours of stillness
            // (a live RMS decayed towards 0) goes on: a value counts in full once the two
            // before it were as large. Clipped against the RMS alone, resumed motion took
            // 15 s to show in sigma after two still hours (review).
            let xd = x - self.ingest.level(d);
            let [older, newer] = self.last_deviation[d];
            let scale = self
                .live_variance(d)
                .sqrt()
                .max(older.abs().min(newer.abs()));
            self.last_deviation[d] = [newer, xd];
            let xd = if scale > 0.0 {
                xd.clamp(-SPIKE_RMS * scale, SPIKE_RMS * scale)
            } else {
                xd
            };
            let a = level::running_weight(self.values, RMS_MEMORY);
            if let Some(recorded) = self.ingest.recorded_at_label(d) {
                let miss = recorded - x;
                // A spike at the label is not the filter's: once the mismatch is known, one
                // value counts at most 4 times its RMS (clipped at 8 live RMS instead, one
                // spike kept the 0.5 s sigma 10 times too wide for minutes; review).
                let known = self.label_mismatch[d].sqrt();
                let limit = if self.values > LABEL_WARMUP && known > 0.0 {
                    4.0 * known
                } else {
                    SPIKE_RMS * scale
                };
                let miss = if limit > 0.0 {
                    miss.clamp(-limit, limit)
                } else {
                    miss
                };
                self.label_mismatch[d] += a * (miss * miss - self.label_mismatch[d]);
            }
            self.mean_square[d] += a * (xd * xd - self.mean_square[d]);
            let fast = a.max(1.0 / RMS_MEMORY_FAST);
            self.mean_square_fast[d] += fast * (xd * xd - self.mean_square_fast[d]);
        }
        // Retraining runs inline (replay) in the step, deterministically; in the background
        // (the service), handing over models and copying the history for a retrain happen in
        // `poll_models`, between forecasts, so the forecasting step never copies history.
        if self.retrainer.is_inline() {
            self.take_models();
            self.schedule_retrain();
        }
        if let Some(m) = self.models.as_mut() {
            let horizon = m.horizon();
            for (d, p) in m.predictors.iter_mut().enumerate() {
                if p.is_online() && !self.failed.dof[d] {
                    if let Some(recent) = self.ingest.last(d, p.order() + horizon) {
                        if let Err(e) = p.update(recent) {
                            self.failed.fail(
                                d,
                                (self.values, v.time_s),
                                &e,
                                &mut self.counts.model_failures,
                            );
                        }
                    }
                }
            }
        }
        self.handle_failures();
        if self.values < MIN_VALUES_TO_PUBLISH {
            return Ok(false);
        }
        self.compose(index, &x, v)?;
        self.handle_failures();
        Ok(true)
    }

    /// Ask for a retrain at once after a model failed (`FailedModels`).
    fn handle_failures(&mut self) {
        if std::mem::take(&mut self.failed.unhandled) {
            self.retrain_due.get_or_insert(REASON_MODEL_FAILED);
        }
    }

    /// The longest input a model in service or a retrain's candidate reads (order +
    /// horizon): once a model has run that long, the values a model failed on have left it.
    fn longest_input(&self) -> u64 {
        let q = &self.config;
        let running = self.models.as_ref().map_or(0, ModelSet::order);
        let longest = models::candidate_orders(q).max().unwrap_or(0).max(running);
        (longest + q.horizon) as u64
    }

    /// Score what the new value completes; learn from it; watch for a changed sea.
    fn score(&mut self, index: u64, x: &[f64; NUM_DOF], recorded: &[f64; NUM_DOF]) {
        let version = self.model_version();
        // A spike (a sensor fault, or a value far beyond what the motion has done) would
        // dominate the calibration's sums for a whole window and shrink every step to no
        // skill: the calibrator sees it clipped at the plausibility bound. Verification keeps
        // the value as it came.
        let cap: [f64; NUM_DOF] = std::array::from_fn(|d| {
            let bound = self.config.plausible_rms_factor * self.live_rms(d);
            if bound > 0.0 {
                bound
            } else {
                f64::INFINITY
            }
        });
        // Squared standardised errors twice: against the calibrated sigma each forecast was
        // issued with (what detects a change) and against the calibrated sigma in force now
        // (what sizes the inflation, `ChangeDetector::inflation`). While the sea grows, the
        // calibration catches up within the horizon the verified forecasts were issued over;
        // inflation sized from the issued sigma stacked on it, and during the replay study's
        // 300 s ramp sigma was 1.3-1.7 times the error. Detection must stay on the issued
        // sigma: measured against the sigma of now, a nine-fold variance change was never
        // detected (docs/results/replay_study.md).
        let mut z2 = [0.0; NUM_DOF];
        let mut z2_now = [0.0; NUM_DOF];
        let mut n = [0usize; NUM_DOF];
        let variance_now: [f64; NUM_DOF] = std::array::from_fn(|d| self.live_variance(d));
        // A jump shows first as a first step missed far beyond its sigma (`jump.rs`). Its
        // errors stay evidence: they widen sigma and set off the change detector, the safe
        // side (left out, a DOF that stood still and then moved kept the sigma 0 of its
        // stillness once the hold ended).
        for (f, k) in self.log.due(index) {
            // Only a model's forecasts: the level alone (no model) reads no history to ring.
            let by_model = k < jump::FIRST_STEPS && version > 0 && f.version == version;
            for d in (0..NUM_DOF).filter(|&d| by_model && !f.held[d]) {
                let miss = x[d] - f.level[d] - f.raw[d][k];
                let rms = variance_now[d].sqrt();
                if self
                    .jumps
                    .observe_first_step(d, index, miss, f.sigma_calibrated[d][k], rms)
                {
                    self.counts.jumps[d] += 1;
                    tracing::warn!(
                        dof = Dof::ALL[d].name(),
                        time_s = self.last_time_s,
                        miss,
                        sigma = f.sigma_calibrated[d][k],
                        rms,
                        "predictor: a jump of the level (a first step missed by {:.3}, {:.0} sigmas): no skill until it has left the model's input",
                        miss,
                        miss.abs() / f.sigma_calibrated[d][k].max(f64::MIN_POSITIVE)
                    );
                }
            }
        }
        for (f, k) in self.log.due(index) {
            for d in 0..NUM_DOF {
                self.verifier
                    .observe(d, k, f.mean[d][k], f.sigma[d][k], f.last[d], recorded[d]);
                // Every delivered forecast shows the errors' shape, whichever model made it;
                // one delivered as no skill is the level, not the model's mean, and measured
                // against the model's sigma its errors pushed the factor to its top for the
                // model's forecasts after it (review).
                let s = f.sigma_calibrated[d][k].hypot(f.label_miss[d]);
                if s > 0.0 && !f.no_skill[d] {
                    self.shape
                        .observe(d, k, (recorded[d] - f.mean[d][k]).abs() / s);
                }
                if f.version == version {
                    // The model forecast the deviation from the level it was issued at.
                    let clipped = (x[d] - f.level[d]).clamp(-cap[d], cap[d]);
                    self.calib
                        .observe(d, k, f.raw[d][k].clamp(-cap[d], cap[d]), clipped);
                    let e = x[d] - f.mean[d][k];
                    // A DOF without motion (sigma 0 and no error: a record without that
                    // column) has nothing to say about the sea. An error against sigma 0 is
                    // as far outside sigma as can be: a DOF that stood still and now moves
                    // (review: it was skipped, and sigma stayed 0 while the errors grew).
                    let s = f.sigma_calibrated[d][k];
                    if s > 0.0 || e.abs() > ERROR_AGAINST_NO_SIGMA {
                        let z2_against = |sigma: f64| {
                            if sigma > 0.0 {
                                e * e / (sigma * sigma)
                            } else {
                                Z2_AGAINST_NO_SIGMA
                            }
                        };
                        z2[d] += z2_against(s);
                        let now = self.calib.get(d, k, variance_now[d]).sigma;
                        let s_now = if now.is_finite() && now > 0.0 { now } else { s };
                        let z2_step = z2_against(s_now);
                        self.burst.observe(d, k, z2_step);
                        z2_now[d] += z2_step;
                        n[d] += 1;
                    }
                }
            }
        }
        self.verifier.tick();
        self.calib.tick();
        self.shape.tick();
        for (d, z) in z2.iter().enumerate() {
            let mean = (n[d] > 0).then(|| z / n[d] as f64);
            self.change
                .observe_for_inflation(d, (n[d] > 0).then(|| z2_now[d] / n[d] as f64));
            if let Some(c) = self.change.observe(d, mean) {
                self.counts.changes += 1;
                tracing::info!(
                    dof = Dof::ALL[d].name(),
                    time_s = self.last_time_s,
                    "predictor: live errors left sigma ({}): recalibrating and retraining on recent data",
                    match c {
                        Change::Rougher => "larger than claimed",
                        Change::Calmer => "much smaller than claimed",
                    }
                );
                self.calib.discount(d, KEPT_AFTER_CHANGE);
                self.shape.discount(d, KEPT_AFTER_CHANGE);
                self.retrain_due.get_or_insert("sea changed");
                self.change_seen_at[d] = Some(self.values);
                match c {
                    Change::Rougher => self.rougher_seen_at[d] = Some(self.values),
                    // A carried error is then too wide as well (review: it came back).
                    Change::Calmer => self.calib.drop_carry(d),
                }
                self.note_change_of_sea();
            }
        }
    }

    /// Re-level the history of a DOF whose level jumped, once the values after the jump show
    /// it is a step (`jump.rs`).
    fn judge_jumps(&mut self, index: u64, time_s: f64) {
        for d in 0..NUM_DOF {
            // All the history holds: a step back is looked for among every value since the
            // jump.
            let recent = self.ingest.last(d, self.ingest.len());
            let rms = self.live_rms(d);
            match self.jumps.judge(d, index, recent, rms) {
                Judgement::Relevel { values, by } => {
                    self.ingest.relevel(d, values, by);
                    tracing::info!(
                        dof = Dof::ALL[d].name(),
                        time_s,
                        by,
                        "predictor: the level stepped by {by:.3}: the history since is re-levelled"
                    );
                }
                Judgement::Spike {
                    values,
                    low,
                    high,
                    centre,
                } => {
                    self.ingest.remove_spike(d, values, low, high, centre);
                    tracing::info!(
                        dof = Dof::ALL[d].name(),
                        time_s,
                        "predictor: the jump was a spike: its values beyond [{low:.3}, {high:.3}] are taken out of the history"
                    );
                }
                Judgement::Keep => {}
            }
        }
    }

    /// Forecast, recalibrate, check and fill `self.forecast`.
    fn compose(&mut self, index: u64, x: &[f64; NUM_DOF], v: NewValue) -> anyhow::Result<()> {
        let horizon = self.config.horizon.min(MAX_STEPS);
        let horizon = self.models.as_ref().map_or(horizon, ModelSet::horizon);
        let version = self.model_version();
        // A model whose input the history does not hold yet (after a restart) forecasts
        // nothing: no skill, not its calibrated sigma (review: 16-20 sigmas off after a gap).
        let mut no_input = [false; NUM_DOF];
        for (d, no_input) in no_input.iter_mut().enumerate() {
            let raw = &mut self.raw[d][..horizon];
            raw.fill(0.0);
            if let Some(m) = self.models.as_mut().filter(|_| !self.failed.dof[d]) {
                let p = &mut m.predictors[d];
                *no_input = self.ingest.len() < p.order();
                if let Some(past) = self.ingest.last(d, p.order()) {
                    if let Err(e) = p.forecast(past, raw) {
                        raw.fill(0.0);
                        self.failed.fail(
                            d,
                            (self.values, v.time_s),
                            &e,
                            &mut self.counts.model_failures,
                        );
                    }
                }
            }
        }
        let variance: [f64; NUM_DOF] = std::array::from_fn(|d| self.live_variance(d));
        let entry = self.log.push();
        entry.index = index;
        entry.steps = horizon;
        entry.version = version;
        entry.last = *x;
        let f = &mut *self.forecast;
        for (d, var) in variance.iter().enumerate() {
            let rms = var.sqrt();
            let level = self.ingest.level(d);
            entry.level[d] = level;
            let bound = self.config.plausible_rms_factor * rms;
            let inflate = self.change.inflation(d);
            let label_miss = self.label_mismatch[d].sqrt();
            entry.label_miss[d] = label_miss;
            let input = self.models.as_ref().map_or(0, |m| m.predictors[d].order());
            let jump_held = self.jumps.holds(d, index, input);
            let held = jump_held || no_input[d];
            entry.held[d] = held;
            // A failed model's DOF is delivered as no skill, like an implausible forecast.
            let mut plausible = !self.failed.dof[d];
            for k in 0..horizon {
                let c = self.calib.get(d, k, variance[d]);
                let raw = self.raw[d][k];
                let deviation = c.beta * raw;
                let sigma = if c.sigma.is_finite() { c.sigma } else { rms };
                entry.raw[d][k] = if raw.is_finite() { raw } else { 0.0 };
                entry.mean[d][k] = level + deviation;
                entry.sigma_calibrated[d][k] = sigma;
                let widen = inflate.max(self.burst.factor(d, k));
                entry.sigma[d][k] = (sigma * widen).hypot(label_miss) * self.shape.factor(d, k);
                plausible &= deviation.is_finite() && deviation.abs() <= bound;
            }
            // The sigma floor of a forecast delivered as no skill, if it is one.
            let no_skill_floor = if held {
                // No skill while a jump is in the model's input: the level, with sigma at
                // least the newest deviation (the jump itself, until it is re-levelled) and
                // the live RMS.
                // Without input alone, the newest deviation is a wave, not a jump (review).
                let deviation = if jump_held { x[d] - level } else { 0.0 };
                Some(deviation.hypot(rms))
            } else if !plausible {
                self.counts.implausible[d] += 1;
                // One line per DOF per minute of record time at most (a failed model was
                // logged when it failed).
                if !self.failed.dof[d]
                    && (self.values >= self.last_implausible_log[d] + 120
                        || self.counts.implausible[d] == 1)
                {
                    self.last_implausible_log[d] = self.values;
                    tracing::warn!(
                        dof = Dof::ALL[d].name(),
                        time_s = v.time_s,
                        count = self.counts.implausible[d],
                        "predictor: implausible forecast (beyond {} x the live RMS {:.3}) replaced by no-skill",
                        self.config.plausible_rms_factor,
                        rms
                    );
                }
                Some(rms)
            } else {
                None
            };
            entry.no_skill[d] = no_skill_floor.is_some();
            if let Some(floor) = no_skill_floor {
                no_skill(
                    &mut entry.mean[d][..horizon],
                    &mut entry.sigma[d][..horizon],
                    level,
                    floor,
                );
            }
            for k in 0..MAX_STEPS {
                let (m, s) = if k < horizon {
                    (entry.mean[d][k], entry.sigma[d][k])
                } else {
                    (0.0, 0.0)
                };
                // The wire carries f32: a mean of 1e5 m (a position, an offset) is rounded by
                // up to 4 mm, beyond a 0.5 s sigma of 0.4 mm (review: coverage 0.23). The
                // rounding is known, and sigma carries it.
                let mean = m as f32;
                f.mean[d][k] = mean;
                f.sigma[d][k] = (s + (m - f64::from(mean)).abs()) as f32;
            }
        }
        f.seq = self.counts.forecasts;
        f.source_seq = v.source_seq;
        f.source_stamp_ns = v.source_stamp_ns;
        f.time_s = v.time_s;
        f.dt_s = 1.0 / self.config.sample_rate_hz;
        f.steps = horizon as u32;
        f.model_version = version;
        f.issued_stamp_ns = monotonic_ns();
        self.counts.forecasts += 1;
        Ok(())
    }

    /// Let every model do ahead the part of the next forecast that the history so far
    /// determines (`Predictor::prepare`); once per new value and model.
    pub fn prepare_next(&mut self) -> anyhow::Result<()> {
        let now = (self.values, self.model_version());
        if self.prepared_for == Some(now) {
            return Ok(());
        }
        if let Some(m) = self.models.as_mut() {
            for (d, p) in m.predictors.iter_mut().enumerate() {
                if self.failed.dof[d] {
                    continue;
                }
                if let Some(known) = self.ingest.last(d, p.order()) {
                    if let Err(e) = p.prepare(known) {
                        self.failed.fail(
                            d,
                            (self.values, self.last_time_s),
                            &e,
                            &mut self.counts.model_failures,
                        );
                    }
                }
            }
        }
        self.handle_failures();
        self.prepared_for = Some(now);
        Ok(())
    }

    /// Pick up a retrain finished in the background and hand a due retrain its copy of the
    /// history (the service calls this between samples, after publishing: both stay off the
    /// forecasting step). With an inline retrainer the step itself does both.
    pub fn poll_models(&mut self) {
        if !self.retrainer.is_inline() {
            self.take_models();
            self.schedule_retrain();
        }
    }

    /// Live scores over the verification window.
    pub fn verification(&self) -> VerificationReport {
        let horizon = self
            .models
            .as_ref()
            .map_or(self.config.horizon, ModelSet::horizon);
        self.verifier.report(
            horizon,
            1.0 / self.config.sample_rate_hz,
            self.config.verification_window_s,
        )
    }
}

/// A forecast without skill: the level at every step, with sigma at least `floor` (the live
/// RMS, or more) and never below what the calibration said.
fn no_skill(mean: &mut [f64], sigma: &mut [f64], level: f64, floor: f64) {
    mean.fill(level);
    for s in sigma {
        *s = s.max(floor);
    }
}

#[cfg(test)]
mod tests;
