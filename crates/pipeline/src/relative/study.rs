//! The two-ship study: each ship's record replayed through the engine exactly as its predictor
//! would run it (`engine::replay`), the two forecast streams combined into the relative forecast
//! as the relative service does, the sigma calibrated causally from relative forecasts whose
//! whole horizon has passed, and every relative forecast scored against the true relative
//! motion of the two records, beside each ship's own point forecast (the tip on A, the spot on
//! B) at the same leads.

use super::still::Ship;
use super::verify::{observed, RelativeVerifier, MAX_PENDING};
use super::{Geometry, LiftDecider, LiftLimits, RelativeTrack, AXES};
use crate::config::PipelineConfig;
use crate::crane::verify::TipVerifier;
use crate::decision::reliability::{rate, Reliability, ReliabilityBin};
use crate::decision::score::curve_thresholds;
use crate::engine::models::ModelSet;
use crate::engine::replay::{replay, ReplayReport};
use crate::observed::{matches, ObservedMotion};
use crate::sigma_scale::SigmaScale;
use serde::Serialize;
use shipcast_series::motion_csv::MotionData;
use shipcast_wire::Dof;

/// Leads the study reports [s].
pub const STUDY_LEADS_S: [f64; 5] = [5.0, 10.0, 15.0, 20.0, 25.0];

/// Scores of one axis at one lead.
#[derive(Debug, Clone, Serialize)]
pub struct LeadScore {
    pub axis: &'static str,
    pub lead_s: f64,
    pub scored: u64,
    /// RMS error of the relative forecast, and the RMS of the true relative motion (what
    /// predicting no relative motion scores).
    pub relative_rms: f64,
    pub relative_zero_rms: f64,
    /// RMS error of the raw difference of the two point forecasts, before the mean's
    /// shrinkage (`relative::shrink`; equal to `relative_rms` with `shrink_mean` off).
    pub relative_raw_rms: f64,
    /// RMS error of each ship's own point forecast (A's tip, B's spot, A's axes) and the RMS of
    /// the point's motion.
    pub tip_rms: f64,
    pub tip_zero_rms: f64,
    pub spot_rms: f64,
    pub spot_zero_rms: f64,
    /// Each ship's own point sigma linearised from its DOF sigmas, the DOF errors taken as
    /// independent (what `shipcast crane` prints for its tip before enough tip forecasts are
    /// verified), and the fraction of the point's errors within +-1 and +-2 of it.
    pub tip_mean_sigma: f64,
    pub tip_coverage_1sigma: f64,
    pub tip_coverage_2sigma: f64,
    pub spot_mean_sigma: f64,
    pub spot_coverage_1sigma: f64,
    pub spot_coverage_2sigma: f64,
    /// A's tip sigma as `shipcast crane` issues it: scaled by its verified tip forecasts
    /// (`crane::verify`, `[crane]` calibration settings), and its coverage.
    pub tip_calibrated_mean_sigma: f64,
    pub tip_calibrated_coverage_1sigma: f64,
    pub tip_calibrated_coverage_2sigma: f64,
    /// Correlation of the two ships' point errors.
    pub error_correlation: f64,
    pub mean_sigma: f64,
    pub mean_sigma_independent: f64,
    /// Fractions of relative errors within +-1 and +-2 sigma, with the calibrated sigma (as
    /// issued) and with the independent one.
    pub coverage_1sigma: f64,
    pub coverage_2sigma: f64,
    pub coverage_1sigma_independent: f64,
    pub coverage_2sigma_independent: f64,
}

/// Each ship's own DOF forecast at the study's leads.
#[derive(Debug, Clone, Serialize)]
pub struct OwnDof {
    pub vessel: &'static str,
    pub dof: &'static str,
    pub lead_s: Vec<f64>,
    pub rms: Vec<f64>,
    pub zero_rms: Vec<f64>,
}

/// Go calls and how many failed at one go threshold.
#[derive(Debug, Clone, Serialize)]
pub struct LiftCurvePoint {
    pub threshold: f64,
    pub go_calls: u64,
    pub false_go_rate: f64,
}

/// The lift decisions (`LiftDecider`, as the live service issues them) scored against the
/// two records: a call is every scored relative forecast whose horizon holds a window of MOT,
/// and its window held when the true relative displacement kept every lift limit at every
/// step of it.
#[derive(Debug, Clone, Serialize)]
pub struct LiftScore {
    pub mot_s: f64,
    pub go_probability: f64,
    pub calls: u64,
    pub go_calls: u64,
    pub false_go_rate: f64,
    /// Fraction of the calls whose window held.
    pub base_rate: f64,
    pub brier: f64,
    pub brier_climatology: f64,
    pub reliability: Vec<ReliabilityBin>,
    pub curve: Vec<LiftCurvePoint>,
}

/// The lift calls as they are scored: the reliability table and the go counts per threshold.
struct LiftCalls {
    mot_s: f64,
    go_probability: f64,
    reliability: Reliability,
    /// (threshold, go calls, false go calls), the configured threshold among them.
    thresholds: Vec<(f64, u64, u64)>,
    /// Where the configured threshold is in `thresholds`.
    default_index: usize,
}

impl LiftCalls {
    fn new(limits: &LiftLimits) -> Self {
        let (values, default_index) = curve_thresholds(limits.go_probability);
        Self {
            mot_s: limits.mot_s,
            go_probability: limits.go_probability,
            reliability: Reliability::new(limits.mot_s),
            thresholds: values.into_iter().map(|v| (v, 0, 0)).collect(),
            default_index,
        }
    }

    /// One call issued at `t0_s` stating `p`; `held`: its window held.
    fn record(&mut self, t0_s: f64, p: f64, held: bool) {
        self.reliability.record(t0_s, p, held);
        for (threshold, go, false_go) in &mut self.thresholds {
            if p >= *threshold {
                *go += 1;
                *false_go += u64::from(!held);
            }
        }
    }

    fn finish(&self) -> LiftScore {
        let curve: Vec<LiftCurvePoint> = self
            .thresholds
            .iter()
            .map(|&(threshold, go, false_go)| LiftCurvePoint {
                threshold,
                go_calls: go,
                false_go_rate: rate(false_go, go),
            })
            .collect();
        let default = &curve[self.default_index];
        LiftScore {
            mot_s: self.mot_s,
            go_probability: self.go_probability,
            calls: self.reliability.calls,
            go_calls: default.go_calls,
            false_go_rate: default.false_go_rate,
            base_rate: self.reliability.base_rate(),
            brier: self.reliability.brier(),
            brier_climatology: self.reliability.brier_climatology(),
            reliability: self.reliability.table(),
            curve,
        }
    }
}

/// The whole study.
#[derive(Debug, Clone, Serialize)]
pub struct StudyReport {
    pub rest_m: [f64; 3],
    pub pairs: u64,
    pub scored: u64,
    pub unpaired: u64,
    /// Record time of the first relative forecast issued with a fully calibrated sigma.
    pub calibrated_from_s: Option<f64>,
    pub leads: Vec<LeadScore>,
    pub own: Vec<OwnDof>,
    /// The lift decisions as issued (from verified errors once the ensemble is ready).
    pub lift: LiftScore,
    /// The Gaussian model's statements on the same calls, for comparison.
    pub lift_gaussian: LiftScore,
    /// The calls as issued before verified errors existed (the Gaussian model's, with the
    /// sigma of the first minutes).
    pub lift_before_verified: LiftScore,
}

#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    n: f64,
    rel: f64,
    rel_zero: f64,
    rel_raw: f64,
    tip: f64,
    tip_zero: f64,
    spot: f64,
    spot_zero: f64,
    /// Per point: sum of sigma, errors within +-1 and +-2 sigma.
    tip_sigma: [f64; 3],
    spot_sigma: [f64; 3],
    tip_calibrated: [f64; 3],
    ab: f64,
    sigma: f64,
    sigma_ind: f64,
    in1: f64,
    in2: f64,
    in1_ind: f64,
    in2_ind: f64,
}

/// One record's points, looked up by time.
struct Truth<'a> {
    data: &'a MotionData,
    columns: [Option<&'a [f64]>; 6],
    step: f64,
}

impl<'a> Truth<'a> {
    fn new(data: &'a MotionData) -> Self {
        let columns = std::array::from_fn(|d| data.dof(Dof::ALL[d]).ok());
        let step = data
            .time
            .windows(2)
            .map(|p| p[1] - p[0])
            .find(|s| *s > 0.0)
            .unwrap_or(1.0);
        Self {
            data,
            columns,
            step,
        }
    }
}

impl ObservedMotion for Truth<'_> {
    fn dof_at(&self, t: f64) -> Option<[f64; 6]> {
        let time = &self.data.time;
        let tol = 0.25 * self.step;
        let i = time.partition_point(|&s| s < t - tol);
        time.get(i)
            .filter(|&&s| matches(s, t, tol))
            .map(|_| std::array::from_fn(|d| self.columns[d].map_or(0.0, |c| c[i])))
    }
}

/// One scored lift call as it was decided and what then happened: the audit trail of
/// `shipcast relative --calls-csv` (`super::calls_csv`).
#[derive(Debug, Clone, Copy)]
pub struct LiftCall<'a> {
    /// The forecast's origin [s].
    pub time_s: f64,
    /// The probability as issued.
    pub stated: f64,
    /// The ensemble's statement before the correction by earlier ones (None: not from the
    /// ensemble).
    pub uncorrected: Option<f64>,
    /// The Gaussian model's statement on the same forecast.
    pub gaussian: Option<f64>,
    pub held: bool,
    pub ensemble_members: usize,
    /// Steps in the window of MOT.
    pub window: usize,
    pub track: &'a RelativeTrack,
    /// The true relative displacement (tip - spot, A's axes) at every step of the forecast.
    pub actual: &'a [[f64; 3]],
}

/// Replays `crane` and `target` (records on one clock) with `config` and scores the relative
/// forecasts issued at record time >= `skip_s`. `models` start each ship's engine (None: no
/// skill until the first live fit).
pub fn study(
    crane: &MotionData,
    target: &MotionData,
    config: &PipelineConfig,
    models: (Option<ModelSet>, Option<ModelSet>),
    skip_s: f64,
    progress: &dyn Fn(u64),
) -> anyhow::Result<(StudyReport, ReplayReport, ReplayReport)> {
    study_calls(crane, target, config, models, skip_s, progress, &mut |_| {
        Ok(())
    })
}

/// [`study`], handing every scored lift call to `on_call` (an error from it ends the study).
pub fn study_calls(
    crane: &MotionData,
    target: &MotionData,
    config: &PipelineConfig,
    models: (Option<ModelSet>, Option<ModelSet>),
    skip_s: f64,
    progress: &dyn Fn(u64),
    on_call: &mut dyn FnMut(&LiftCall) -> anyhow::Result<()>,
) -> anyhow::Result<(StudyReport, ReplayReport, ReplayReport)> {
    let (report_a, fa) = replay(crane, &config.predictor, models.0, skip_s, true, progress)?;
    let (report_b, fb) = replay(target, &config.predictor, models.1, skip_s, true, progress)?;
    let geometry = Geometry::new(config.crane.tip_m, &config.relative);
    let r = &config.relative;
    let mut decider = LiftDecider::new(LiftLimits::new(r));
    let mut verifier = RelativeVerifier::from_config(r, MAX_PENDING);
    // The records' columns are known: a watched DOF among them that never moves is a frozen
    // sensor, not an absent column.
    verifier.set_present_dofs(Ship::Crane, &crane.dofs());
    verifier.set_present_dofs(Ship::Target, &target.dofs());
    let c = &config.crane;
    let mut tip_verifier = TipVerifier::new(
        geometry.tip,
        SigmaScale::adaptive(c.calibration_halflife, c.calibration_min_verified),
        crate::crane::verify::MAX_PENDING,
    );
    let (ta, tb) = (Truth::new(crane), Truth::new(target));
    let dt = config.predictor.sample_rate_hz.recip();
    let lead_k: Vec<usize> = STUDY_LEADS_S
        .iter()
        .map(|l| ((l / dt).round() as usize).max(1) - 1)
        .collect();
    let mut sums = vec![[Sums::default(); 3]; lead_k.len()];
    let mut lift = LiftCalls::new(decider.limits());
    let mut lift_gaussian = LiftCalls::new(decider.limits());
    let mut lift_before_verified = LiftCalls::new(decider.limits());
    let (mut tip, mut spot, mut actual) = (Vec::new(), Vec::new(), Vec::new());
    let (mut pairs, mut scored, mut unpaired) = (0u64, 0u64, 0u64);
    let mut calibrated_from_s = None;
    let mut j = 0usize;
    for a in &fa {
        // A's tip alone, as `shipcast crane` verifies it: every forecast of A, paired or not.
        tip_verifier.verify_until(a.time_s, &ta);
        tip_verifier.push(a);
        // B's forecast issued at the same record time (both engines run on one clock).
        while j < fb.len() && fb[j].time_s < a.time_s - 0.25 * dt {
            j += 1;
        }
        let Some(b) = fb
            .get(j)
            .filter(|b| (b.time_s - a.time_s).abs() <= 0.25 * dt)
        else {
            unpaired += 1;
            continue;
        };
        // Verify what has fully passed by now: causal. Then the sensors, before the pair is
        // combined (a thaw restarts the calibration it is combined with).
        verifier.verify_until(a.time_s, &geometry, &ta, &tb);
        verifier.watch_sensors([a.time_s, b.time_s], &ta, &tb);
        let mut track = Box::<RelativeTrack>::default();
        if track
            .fill(&geometry, a, b, &verifier.calibration, &verifier.shrinkage)
            .is_err()
        {
            unpaired += 1;
            continue;
        }
        pairs += 1;
        // Decided on every forecast, as the live service does, so its statement's outcome
        // teaches the later ones whether it is scored or not.
        let issued = decider.decide(&mut track, &verifier.lift);
        if calibrated_from_s.is_none() && track.basis == super::SigmaBasis::Calibrated {
            calibrated_from_s = Some(track.alignment.time_s);
        }
        if track.alignment.time_s >= skip_s
            && observed(&track, &geometry, &ta, &tb, &mut tip, &mut spot)
        {
            scored += 1;
            score(&track, &tip, &spot, &tip_verifier, &lead_k, &mut sums);
            if let Some(p) = issued.probability_now {
                let window = decider.limits().window_steps(track.dt_s);
                actual.clear();
                let relative = tip.iter().zip(&spot);
                actual.extend(relative.map(|(t, s)| std::array::from_fn(|a| t[a] - s[a])));
                let held = decider.limits().window_holds(window, |k| actual[k]);
                let t0 = track.alignment.time_s;
                lift.record(t0, p, held);
                if issued.ensemble_members == 0 {
                    lift_before_verified.record(t0, p, held);
                }
                let gaussian = decider.gaussian_probability(&track);
                if let Some(p) = gaussian {
                    lift_gaussian.record(t0, p, held);
                }
                on_call(&LiftCall {
                    time_s: t0,
                    stated: p,
                    uncorrected: track.lift_statement,
                    gaussian,
                    held,
                    ensemble_members: issued.ensemble_members,
                    window,
                    track: &track,
                    actual: &actual,
                })?;
            }
        }
        verifier.push(&track);
    }
    let leads = finish(&sums);
    let own = own_scores(&report_a, &report_b, &lead_k);
    Ok((
        StudyReport {
            rest_m: geometry.rest_m(),
            pairs,
            scored,
            unpaired,
            calibrated_from_s,
            leads,
            own,
            lift: lift.finish(),
            lift_gaussian: lift_gaussian.finish(),
            lift_before_verified: lift_before_verified.finish(),
        },
        report_a,
        report_b,
    ))
}

fn score(
    track: &RelativeTrack,
    tip: &[[f64; 3]],
    spot: &[[f64; 3]],
    tip_verifier: &TipVerifier,
    lead_k: &[usize],
    sums: &mut [[Sums; 3]],
) {
    for (i, &k) in lead_k.iter().enumerate() {
        if k >= track.steps() {
            continue;
        }
        for axis in 0..3 {
            let truth = tip[k][axis] - spot[k][axis];
            let e = truth - track.mean[axis][k];
            let e_raw = truth - track.raw_mean[axis][k];
            let ea = tip[k][axis] - track.tip.mean[axis][k];
            let eb = spot[k][axis] - track.spot.mean[axis][k];
            let (s, si) = (track.sigma[axis][k], track.sigma_independent[axis][k]);
            let acc = &mut sums[i][axis];
            acc.n += 1.0;
            acc.rel += e * e;
            acc.rel_zero += truth * truth;
            acc.rel_raw += e_raw * e_raw;
            acc.tip += ea * ea;
            acc.tip_zero += tip[k][axis].powi(2);
            acc.spot += eb * eb;
            acc.spot_zero += spot[k][axis].powi(2);
            acc.ab += ea * eb;
            for (e, var, cover) in [
                (ea, track.tip.var[axis][k], &mut acc.tip_sigma),
                (eb, track.spot.var[axis][k], &mut acc.spot_sigma),
            ] {
                let s = var.sqrt();
                cover[0] += s;
                cover[1] += f64::from(u8::from(e.abs() <= s));
                cover[2] += f64::from(u8::from(e.abs() <= 2.0 * s));
            }
            // The tip's steps are A's from its origin on (skip_a 0 when A's forecast is the
            // later one, as in the study, where both engines share one clock).
            let (tip_sigma, _) =
                tip_verifier.sigma(axis, k + track.alignment.skip_a, track.tip.var[axis][k]);
            let cover = &mut acc.tip_calibrated;
            cover[0] += tip_sigma;
            cover[1] += f64::from(u8::from(ea.abs() <= tip_sigma));
            cover[2] += f64::from(u8::from(ea.abs() <= 2.0 * tip_sigma));
            acc.sigma += s;
            acc.sigma_ind += si;
            let inside = |w: f64| f64::from(u8::from(e.abs() <= w));
            acc.in1 += inside(s);
            acc.in2 += inside(2.0 * s);
            acc.in1_ind += inside(si);
            acc.in2_ind += inside(2.0 * si);
        }
    }
}

fn finish(sums: &[[Sums; 3]]) -> Vec<LeadScore> {
    let mut out = Vec::new();
    for (i, per_axis) in sums.iter().enumerate() {
        for (axis, s) in per_axis.iter().enumerate() {
            let n = s.n.max(1.0);
            let rms = |v: f64| (v / n).sqrt();
            out.push(LeadScore {
                axis: AXES[axis],
                lead_s: STUDY_LEADS_S[i],
                scored: s.n as u64,
                relative_rms: rms(s.rel),
                relative_zero_rms: rms(s.rel_zero),
                relative_raw_rms: rms(s.rel_raw),
                tip_rms: rms(s.tip),
                tip_zero_rms: rms(s.tip_zero),
                spot_rms: rms(s.spot),
                spot_zero_rms: rms(s.spot_zero),
                tip_mean_sigma: s.tip_sigma[0] / n,
                tip_coverage_1sigma: s.tip_sigma[1] / n,
                tip_coverage_2sigma: s.tip_sigma[2] / n,
                spot_mean_sigma: s.spot_sigma[0] / n,
                spot_coverage_1sigma: s.spot_sigma[1] / n,
                spot_coverage_2sigma: s.spot_sigma[2] / n,
                tip_calibrated_mean_sigma: s.tip_calibrated[0] / n,
                tip_calibrated_coverage_1sigma: s.tip_calibrated[1] / n,
                tip_calibrated_coverage_2sigma: s.tip_calibrated[2] / n,
                error_correlation: s.ab / (s.tip * s.spot).sqrt(),
                mean_sigma: s.sigma / n,
                mean_sigma_independent: s.sigma_ind / n,
                coverage_1sigma: s.in1 / n,
                coverage_2sigma: s.in2 / n,
                coverage_1sigma_independent: s.in1_ind / n,
                coverage_2sigma_independent: s.in2_ind / n,
            });
        }
    }
    out
}

fn own_scores(a: &ReplayReport, b: &ReplayReport, lead_k: &[usize]) -> Vec<OwnDof> {
    let mut out = Vec::new();
    for (vessel, report) in [("crane", a), ("target", b)] {
        for d in &report.dofs {
            let pick = |v: &[f64]| -> Vec<f64> {
                lead_k
                    .iter()
                    .map(|&k| v.get(k).copied().unwrap_or(f64::NAN))
                    .collect()
            };
            out.push(OwnDof {
                vessel,
                dof: d.dof,
                lead_s: STUDY_LEADS_S.to_vec(),
                rms: pick(&d.rms),
                zero_rms: pick(&d.zero_rms),
            });
        }
    }
    out
}
