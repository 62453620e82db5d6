//! `shipcast replay`: the engine run over a recorded motion CSV as fast as possible, exactly as
//! the service would have run it (start, verification, recalibration, retraining, swaps; the
//! retraining inline, so the result is deterministic), and every delivered forecast scored
//! against the record itself.
//!
//! Step k of a forecast is scored against the record's value at `time_s + k * dt_s` (the
//! recorded sample, not the filtered one). Only forecasts issued at record time >= `skip_s`
//! whose every step lies inside the record are scored, each at the steps that fall on a
//! recorded sample.

use super::retrain::Retrainer;
use super::{Engine, EngineCounts};
use crate::config::{DeckConfig, PredictorServiceConfig};
use crate::decision::score::{DecisionReport, DecisionScorer, Happened};
use crate::decision::statements_file::StatementsKeeper;
use crate::engine::models::ModelSet;
use crate::transport::counters::Counters;
use serde::Serialize;
use shipcast_series::motion_csv::MotionData;
use shipcast_wire::payload::{Forecast, MotionSample, MAX_STEPS, NUM_DOF};
use shipcast_wire::Dof;

/// Scores of one DOF over a replay.
#[derive(Debug, Clone, Serialize)]
pub struct DofReplay {
    pub dof: &'static str,
    pub forecasts: u64,
    pub scored: u64,
    /// Of `scored`, those with a step on a sample missing from the record, scored at the others.
    pub partly_scored: u64,
    pub retrains: u64,
    pub swaps: u64,
    pub implausible: u64,
    /// Jumps of the level a forecast's first steps missed, each held at no skill until it
    /// had left the model's input (`jump.rs`).
    pub jumps: u64,
    /// Standard deviation about their mean of the record's values at the scored steps, all
    /// steps together: what predicting the motion's mean scores, and what `nrmse` divides by.
    /// (Until 2026-12-08 their RMS about zero: a record with an offset, a list of the ship,
    /// looked like strong skill; review.)
    pub std: f64,
    pub rms: Vec<f64>,
    pub zero_rms: Vec<f64>,
    pub persistence_rms: Vec<f64>,
    pub nrmse: Vec<f64>,
    pub mean_sigma: Vec<f64>,
    pub coverage_1sigma: Vec<f64>,
    pub coverage_2sigma: Vec<f64>,
    pub max_abs_error: f64,
    /// The largest error in sigmas, |error| / sigma, of any scored step with sigma > 0: the
    /// failure that matters most, a forecast far off while it claims a small sigma (Gaussian
    /// errors over some 10^5 steps reach about 4.5).
    pub max_abs_z: f64,
    /// Issue time of the forecast and lead [s] of the step where `max_abs_z` was reached
    /// (NaN if nothing was scored).
    pub max_abs_z_time_s: f64,
    pub max_abs_z_lead_s: f64,
    /// Fraction of scored steps with |error| > 3 sigma, over all steps (Gaussian: 0.0027).
    pub beyond_3sigma: f64,
    /// RMS error of the 10 s step per minute of record time (by issue time; NaN where nothing
    /// was scored): how the error evolves, e.g. how fast it recovers after a change of sea.
    pub rms_10s_by_minute: Vec<f64>,
    /// RMS of predicting zero at the same step and minutes (the motion's own level then): the
    /// error over it is the skill, free of the wave groups' swings of the motion itself.
    pub zero_rms_10s_by_minute: Vec<f64>,
}

/// The step whose error `rms_10s_by_minute` follows [s].
pub const TRACE_LEAD_S: f64 = 10.0;

/// The whole replay.
#[derive(Debug, Clone, Serialize)]
pub struct ReplayReport {
    pub input_rate_hz: f64,
    pub dt_s: f64,
    /// From a forecast's `time_s` to its newest sample (the decimation filter's delay) [s]:
    /// step k lies k * dt_s - delay_s after the newest sample.
    pub delay_s: f64,
    pub counts: EngineCounts,
    /// The record's samples as the engine took them: received, missing (gaps in time; runs
    /// of up to `MAX_FILL` bridged by a straight line, longer ones restart the
    /// history) and rejected.
    pub input: Counters,
    /// Times the history started again at a gap or a run of bad samples too long to bridge
    /// (the record's start is none).
    pub history_restarts: u64,
    /// The longest history held between restarts [s].
    pub longest_history_s: f64,
    /// Forecasts whose every step lies inside the record's span, scored or not (before
    /// `--skip-s`), and the issue time of the last of them.
    pub complete_forecasts: u64,
    pub last_complete_s: Option<f64>,
    /// Scored forecasts some of whose steps fell on samples missing from the record: scored
    /// at the steps that have one (the deck's decisions only from whole forecasts).
    pub partly_scored: u64,
    pub dofs: Vec<DofReplay>,
    /// Deck decisions scored against the record (one per MOT; empty unless asked).
    pub decisions: Vec<DecisionReport>,
}

/// Minimum operation times the replay scores deck decisions for [s].
pub const DECISION_MOTS_S: [f64; 2] = [10.0, 30.0];

/// Running sums of one DOF and step.
#[derive(Debug, Clone, Copy, Default)]
struct StepSums {
    n: f64,
    ee: f64,
    xx: f64,
    /// Sums of the values and their squares less the DOF's first value in the record, for
    /// the standard deviation about the mean without cancelling a large offset away.
    dx: f64,
    dxx: f64,
    pp: f64,
    sigma: f64,
    in1: f64,
    in2: f64,
    in3: f64,
}

/// The largest error in sigmas of one DOF: (|e| / sigma, issue time, lead).
#[derive(Debug, Clone, Copy)]
struct WorstZ {
    z: f64,
    time_s: f64,
    lead_s: f64,
}

impl Default for WorstZ {
    fn default() -> Self {
        Self {
            z: 0.0,
            time_s: f64::NAN,
            lead_s: f64::NAN,
        }
    }
}

/// Index of the sample at time `t`, if one was recorded there: the sample within half a step
/// of it (none in a gap). Not a quarter step: a record up to [`shipcast_series::RATE_TOLERANCE`]
/// off its snapped rate drifts from the forecast's steps by up to 25 ms over a 25 s horizon,
/// beyond a quarter of a 24 Hz step, and replay took such a record and then scored none of its
/// forecasts (review).
fn sample_at(time: &[f64], t: f64, step: f64) -> Option<usize> {
    let i = time.partition_point(|&x| x <= t - 0.5 * step);
    (i < time.len() && (time[i] - t).abs() < 0.5 * step).then_some(i)
}

/// Run the engine over `data` from `models` (None: no skill until the first live fit).
/// `progress` is told how many samples were fed since its last call. With `keep_forecasts`
/// every delivered forecast is also returned (6 KB each: for tests and short records).
pub fn replay(
    data: &MotionData,
    config: &PredictorServiceConfig,
    models: Option<ModelSet>,
    skip_s: f64,
    keep_forecasts: bool,
    progress: &dyn Fn(u64),
) -> anyhow::Result<(ReplayReport, Vec<Forecast>)> {
    replay_scored(data, config, models, skip_s, keep_forecasts, None, progress)
}

/// The sample rate of a record with time stamps `time` (the mean of its regular steps, snapped
/// to the integer multiple of `forecast_hz` it lies within [`shipcast_series::RATE_TOLERANCE`]
/// of, as eval takes it), checked to feed an engine forecasting at `forecast_hz`. The error
/// speaks of the record, not of a configuration, and says when its steps are not even regular
/// (stamps rounded to fewer digits than the rate needs).
pub fn record_rate(time: &[f64], forecast_hz: f64) -> anyhow::Result<f64> {
    let median = shipcast_series::median_rate(time)?;
    let (measured, uncertainty) = regular_mean_rate(time, median);
    let multiple = (measured / forecast_hz).round();
    // Regression (review): replay snapped within 1e-5 only, so a record at 8.004 Hz that eval
    // took (within 1e-3) was refused here.
    let snap = shipcast_series::RATE_TOLERANCE + uncertainty;
    let rate = if multiple >= 1.0 && ((measured - multiple * forecast_hz) / measured).abs() < snap {
        multiple * forecast_hz
    } else {
        (measured * 1e6).round() / 1e6
    };
    // The engine counts samples, as the service does: stamps off the slots it puts them in
    // (a rate that drifts or changes, a sample out of place) would shift forecasts off their
    // time (eval refuses them too). Against the rate it runs at, not the median step, which
    // jittered stamps can bias.
    shipcast_series::check_runs_on_grid(time, 1.0 / rate, crate::engine::MAX_FILL as usize)?;
    if crate::config::decimation_factor(rate, forecast_hz).is_err() {
        anyhow::bail!("{}", rate_mismatch(time, rate, forecast_hz));
    }
    Ok(rate)
}

/// One over the mean of the regular steps (within
/// [`shipcast_series::regular_step_tolerance`] of the median step, `median_hz`), and how far
/// the stamps' rounding may have moved it (relative): gaps do not move it, and stamps rounded
/// to fewer digits than the rate needs average out, within one rounding per gap-free run.
/// Regression (review): a 6 Hz record stamped to the millisecond (steps of 0.167 and 0.166 s)
/// read as 5.988 Hz by its median step and was refused, while `eval` took it.
fn regular_mean_rate(time: &[f64], median_hz: f64) -> (f64, f64) {
    let median = 1.0 / median_hz;
    let tolerance = shipcast_series::regular_step_tolerance(time, median);
    let (mut sum, mut n, mut runs) = (0.0, 0usize, 0usize);
    for run in shipcast_series::gap_free_runs(time, median, tolerance).filter(|r| r.len() >= 2) {
        sum += time[run.end - 1] - time[run.start];
        n += run.len() - 1;
        runs += 1;
    }
    if n == 0 {
        (median_hz, 0.0)
    } else {
        (n as f64 / sum, tolerance * runs as f64 / sum)
    }
}

fn rate_mismatch(time: &[f64], rate: f64, forecast_hz: f64) -> String {
    // To a microsecond: the step as the stamps give it (0.13, not 0.1299999948).
    let median = (1e6 / rate).round() / 1e6;
    let steps = time.len().saturating_sub(1);
    let tolerance = shipcast_series::regular_step_tolerance(time, median);
    let off = time
        .windows(2)
        .filter(|p| (p[1] - p[0] - median).abs() > tolerance)
        .count();
    let irregular = if off * 10 > steps {
        format!(
            "; {off} of its {steps} time steps differ from it by more than {tolerance:.2e} s (time stamps rounded or jittered?)"
        )
    } else {
        String::new()
    };
    let multiple = rate / forecast_hz;
    if multiple.round() > crate::config::MAX_DECIMATION as f64 {
        return format!(
            "the record's typical time step is {median} s ({rate} Hz), {multiple:.0} times the forecast rate {forecast_hz} Hz: at most {} ([predictor] sample_rate_hz, or resample the record)",
            crate::config::MAX_DECIMATION
        );
    }
    format!(
        "the record's typical time step is {median} s ({rate} Hz), not an integer fraction of the forecast step {} s ([predictor] sample_rate_hz = {forecast_hz}){irregular}",
        1.0 / forecast_hz
    )
}

/// [`replay`], also scoring the deck decisions of `deck` (for the MOTs of
/// [`DECISION_MOTS_S`]) against the record.
pub fn replay_scored(
    data: &MotionData,
    config: &PredictorServiceConfig,
    models: Option<ModelSet>,
    skip_s: f64,
    keep_forecasts: bool,
    deck: Option<&DeckConfig>,
    progress: &dyn Fn(u64),
) -> anyhow::Result<(ReplayReport, Vec<Forecast>)> {
    let dt = 1.0 / config.sample_rate_hz;
    let mut actual = Box::<Forecast>::default();
    let rate = record_rate(&data.time, config.sample_rate_hz)?;
    let mut engine = Engine::new(
        config.clone(),
        rate,
        models,
        Retrainer::inline(config.clone()),
    )?;
    let present: Vec<Dof> = data.dofs();
    let columns: Vec<Option<&[f64]>> = Dof::ALL.iter().map(|&d| data.dof(d).ok()).collect();
    // Each DOF's first finite value: what `StepSums::dx` is counted from.
    let shifts: Vec<f64> = columns
        .iter()
        .map(|c| {
            c.and_then(|c| c.iter().copied().find(|v| v.is_finite()))
                .unwrap_or(0.0)
        })
        .collect();
    let step_in = 1.0 / rate;
    let delay = engine.delay_s();
    let mut scorer = deck.map(|d| DecisionScorer::new("deck", d, &DECISION_MOTS_S, delay));
    // The record's columns are known here: a deck DOF among them that never moves is a
    // frozen sensor, not an absent column (the live deck cannot tell the two apart).
    if let Some(scorer) = scorer.as_mut() {
        scorer.decider_mut().set_present_dofs(&present);
    }
    // A deck that keeps its statements across runs starts from them here too, and leaves
    // this run's behind (docs/decisions.md).
    let mut keeper = match (deck.and_then(|d| d.statements_file.as_deref()), &mut scorer) {
        (Some(path), Some(scorer)) => Some(StatementsKeeper::open(path, dt, scorer.decider_mut())?),
        _ => None,
    };
    let mut sums = vec![[StepSums::default(); MAX_STEPS]; NUM_DOF];
    let mut max_abs = [0.0f64; NUM_DOF];
    let mut worst = [WorstZ::default(); NUM_DOF];
    let trace_k = ((TRACE_LEAD_S / dt).round() as usize).max(1) - 1;
    let t0 = data.time.first().copied().unwrap_or(0.0);
    let minutes = trace_minutes(t0, data.time.last().copied().unwrap_or(t0), data.time.len());
    let mut trace = vec![vec![(0.0f64, 0.0f64, 0u64); minutes]; NUM_DOF];
    let mut scored = 0u64;
    let mut kept = Vec::new();
    let mut unreported = 0u64;
    // Record index of each step of the forecast being scored, None where the record misses
    // that sample (reused: one per forecast).
    let mut idx: Vec<Option<usize>> = Vec::with_capacity(MAX_STEPS);
    let mut partly_scored = 0u64;
    let end_s = data.time.last().copied().unwrap_or(f64::NEG_INFINITY);
    let mut longest_history = 0usize;
    let (mut complete_forecasts, mut last_complete_s) = (0u64, None);
    for (i, &t) in data.time.iter().enumerate() {
        let sample = MotionSample {
            seq: i as u64,
            stamp_ns: 0,
            time_s: t,
            dof: std::array::from_fn(|d| columns[d].map_or(0.0, |c| c[i])),
        };
        unreported += 1;
        if unreported == 4096 {
            progress(unreported);
            unreported = 0;
        }
        let produced = engine.push(&sample)?.is_some();
        longest_history = longest_history.max(engine.history_len());
        if !produced {
            continue;
        }
        let f = engine.forecast();
        if keep_forecasts {
            kept.push(*f);
        }
        // Before `skip_s` a forecast is not scored, but the deck still learns from it.
        let counted = f.time_s >= skip_s;
        let steps = f.steps as usize;
        // The record's sample at every step. A forecast whose horizon runs past the record's
        // end is not scored; one whose steps fall on samples missing from the record (a lost
        // sample bridged, or a gap) is scored at the steps that have one. Regression (review):
        // any missing step dropped the whole forecast, and with 5 % of the samples lost 220
        // of 2337 forecasts were scored, without a word.
        if f.time_s + steps as f64 * dt > end_s + 0.5 * step_in {
            continue;
        }
        idx.clear();
        idx.extend((1..=steps).map(|k| sample_at(&data.time, f.time_s + k as f64 * dt, step_in)));
        let whole = idx.iter().all(Option::is_some);
        if idx.iter().all(Option::is_none) {
            continue;
        }
        complete_forecasts += 1;
        last_complete_s = Some(f.time_s);
        if !counted && scorer.is_none() {
            continue;
        }
        // The newest sample the forecast used is persistence's forecast.
        let last = sample_at(&data.time, f.time_s + delay, step_in).unwrap_or(i);
        // The deck's windows are judged on every step, so only from a whole forecast.
        if let Some(scorer) = scorer.as_mut().filter(|_| whole) {
            actual.time_s = f.time_s;
            actual.dt_s = f.dt_s;
            actual.steps = f.steps;
            for (d, column) in columns.iter().enumerate() {
                for (k, &j) in idx.iter().enumerate() {
                    actual.mean[d][k] = match (column, j) {
                        (Some(c), Some(j)) => c[j] as f32,
                        _ => 0.0,
                    };
                }
            }
            // At the precision of the steps' values (f32), for the velocity's differences.
            let record_at = |t: f64| {
                sample_at(&data.time, t, step_in).map(|j| {
                    std::array::from_fn(|d| columns[d].map_or(0.0, |c| f64::from(c[j] as f32)))
                })
            };
            let happened = Happened {
                at_steps: &actual,
                before: record_at(f.time_s),
                after: record_at(f.time_s + (steps + 1) as f64 * dt),
            };
            scorer.observe(f, &happened, counted);
        }
        if !counted {
            continue;
        }
        scored += 1;
        partly_scored += u64::from(!whole);
        for &dof in &present {
            let d = dof.index();
            let Some(col) = columns[d] else { continue };
            for (k, j) in idx.iter().enumerate() {
                let Some(&j) = j.as_ref() else { continue };
                let x = col[j];
                // A record read from CSV has no non-finite value; one built in memory may.
                if !x.is_finite() {
                    continue;
                }
                let dx = x - shifts[d];
                let m = f64::from(f.mean[d][k]);
                let s = f64::from(f.sigma[d][k]);
                let e = x - m;
                let p = x - col[last];
                let acc = &mut sums[d][k];
                acc.n += 1.0;
                acc.ee += e * e;
                acc.xx += x * x;
                acc.dx += dx;
                acc.dxx += dx * dx;
                acc.pp += p * p;
                acc.sigma += s;
                acc.in1 += f64::from(u8::from(e.abs() <= s));
                acc.in2 += f64::from(u8::from(e.abs() <= 2.0 * s));
                acc.in3 += f64::from(u8::from(e.abs() <= 3.0 * s));
                max_abs[d] = max_abs[d].max(e.abs());
                if s > 0.0 && e.abs() / s > worst[d].z {
                    worst[d] = WorstZ {
                        z: e.abs() / s,
                        time_s: f.time_s,
                        lead_s: (k + 1) as f64 * dt,
                    };
                }
                if k == trace_k && minutes > 0 {
                    let minute =
                        (((f.time_s - t0) / 60.0).floor().max(0.0) as usize).min(minutes - 1);
                    let t = &mut trace[d][minute];
                    t.0 += e * e;
                    t.1 += x * x;
                    t.2 += 1;
                }
            }
        }
    }
    progress(unreported);
    let steps = engine.forecast().steps as usize;
    let counts = engine.counts;
    let input = engine.counters;
    let dofs = present
        .iter()
        .map(|&dof| {
            let d = dof.index();
            let s = &sums[d][..steps];
            let per = |f: &dyn Fn(&StepSums) -> f64| -> Vec<f64> { s.iter().map(f).collect() };
            let root = |a: f64, n: f64| if n > 0.0 { (a / n).sqrt() } else { f64::NAN };
            let rms = per(&|a| root(a.ee, a.n));
            let zero_rms = per(&|a| root(a.xx, a.n));
            // Standard deviation about the mean from shifted sums (`StepSums::dx`).
            let std_of = |dx: f64, dxx: f64, n: f64| {
                if n > 0.0 {
                    (dxx / n - (dx / n).powi(2)).max(0.0).sqrt()
                } else {
                    f64::NAN
                }
            };
            let (dx, dxx, n, in3) = s.iter().fold((0.0, 0.0, 0.0, 0.0), |acc, a| {
                (acc.0 + a.dx, acc.1 + a.dxx, acc.2 + a.n, acc.3 + a.in3)
            });
            // Over every step's values: each step's own, from a few forecasts, is near 0 (a
            // single forecast's values at one step have none; review: NRMSE 449).
            let std = std_of(dx, dxx, n);
            DofReplay {
                dof: dof.name(),
                forecasts: counts.forecasts,
                scored,
                partly_scored,
                retrains: counts.retrains,
                swaps: counts.swaps,
                implausible: counts.implausible[d],
                jumps: counts.jumps[d],
                std,
                nrmse: rms.iter().map(|a| a / std).collect(),
                rms,
                zero_rms,
                persistence_rms: per(&|a| root(a.pp, a.n)),
                mean_sigma: per(&|a| if a.n > 0.0 { a.sigma / a.n } else { f64::NAN }),
                coverage_1sigma: per(&|a| if a.n > 0.0 { a.in1 / a.n } else { f64::NAN }),
                coverage_2sigma: per(&|a| if a.n > 0.0 { a.in2 / a.n } else { f64::NAN }),
                max_abs_error: max_abs[d],
                max_abs_z: worst[d].z,
                max_abs_z_time_s: worst[d].time_s,
                max_abs_z_lead_s: worst[d].lead_s,
                beyond_3sigma: if n > 0.0 { 1.0 - in3 / n } else { f64::NAN },
                rms_10s_by_minute: by_minute(&trace[d], |t| t.0),
                zero_rms_10s_by_minute: by_minute(&trace[d], |t| t.1),
            }
        })
        .collect();
    if let (Some(keeper), Some(scorer)) = (keeper.as_mut(), &scorer) {
        keeper.save(scorer.decider())?;
    }
    Ok((
        ReplayReport {
            input_rate_hz: rate,
            dt_s: dt,
            delay_s: delay,
            counts,
            input,
            history_restarts: engine.history_restarts(),
            longest_history_s: longest_history as f64 * dt,
            complete_forecasts,
            last_complete_s,
            partly_scored,
            dofs,
            decisions: scorer.map_or_else(Vec::new, DecisionScorer::finish),
        },
        kept,
    ))
}

/// Minutes the per-minute trace spans, from the record's first sample. A record has many
/// samples a minute, so a span of more minutes than rows is time stamps far apart (epoch
/// seconds with a hole, a corrupt value): the trace is left empty rather than sized by them.
fn trace_minutes(first_s: f64, last_s: f64, rows: usize) -> usize {
    let span = ((last_s - first_s) / 60.0).ceil();
    if !(span >= 0.0 && span < rows as f64) {
        if rows > 0 {
            tracing::warn!(
                span_min = span,
                rows,
                "replay: the record spans more minutes than it has rows: no per-minute trace"
            );
        }
        return 0;
    }
    span as usize + 1
}

/// Per minute, the root of the mean of one of the trace's sums (NaN where nothing was scored).
fn by_minute(trace: &[(f64, f64, u64)], sum: impl Fn(&(f64, f64, u64)) -> f64) -> Vec<f64> {
    trace
        .iter()
        .map(|t| {
            if t.2 > 0 {
                (sum(t) / t.2 as f64).sqrt()
            } else {
                f64::NAN
            }
        })
        .collect()
}
