//! The engine end to end on records with known statistics (through `replay`, which drives it
//! exactly as the service does, with retraining inline).

use super::replay::{replay, DofReplay};
use super::retrain::Retrainer;
use super::Engine;
use crate::config::PredictorServiceConfig;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use shipcast_series::motion_csv::{Column, MotionData};
use shipcast_wire::payload::MotionSample;

/// A resonant AR(2) process at 2 Hz (period 8 s, pole radius 0.95), innovations N(0, scale^2).
fn ar2(n: usize, seed: u64, scale: impl Fn(usize) -> f64) -> Vec<f64> {
    let theta = std::f64::consts::TAU / 16.0;
    let (a1, a2) = (2.0 * 0.95 * theta.cos(), -0.95 * 0.95);
    let noise = Normal::new(0.0, 1.0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = vec![0.0; n];
    for t in 2..n {
        x[t] = a1 * x[t - 1] + a2 * x[t - 2] + scale(t) * noise.sample(&mut rng);
    }
    x
}

/// The root mean square of `values` (the std of a zero-mean process).
fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|x| x * x).sum::<f64>() / values.len() as f64).sqrt()
}

fn record(heave: Vec<f64>, rate: f64) -> MotionData {
    MotionData {
        ignored: Vec::new(),
        time: (0..heave.len()).map(|i| i as f64 / rate).collect(),
        columns: vec![Column {
            name: "heave_m".into(),
            values: heave,
        }],
    }
}

/// An engine at 2 Hz whose start-up models were fitted on 6000 values of `ar2(seed)` in every
/// DOF, retraining inline as `config` says.
fn engine_fitted_on_ar2(config: &PredictorServiceConfig, seed: u64) -> Engine {
    let clean = ar2(6000, seed, |_| 1.0);
    let models = super::models::fit(&vec![clean; 6], config, 1).unwrap();
    Engine::new(
        config.clone(),
        2.0,
        Some(models),
        Retrainer::inline(config.clone()),
    )
    .unwrap()
}

/// Sample `i` of a 2 Hz record with the six DOF values `dof`.
fn at_2hz(i: usize, dof: [f64; 6]) -> MotionSample {
    MotionSample {
        seq: i as u64,
        stamp_ns: 0,
        time_s: i as f64 / 2.0,
        dof,
    }
}

/// Sample `i` of a 2 Hz record that moves in heave alone, by `h`.
fn heave_only(i: usize, h: f64) -> MotionSample {
    at_2hz(i, [0.0, 0.0, h, 0.0, 0.0, 0.0])
}

fn run(data: &MotionData, skip_s: f64) -> DofReplay {
    let config = PredictorServiceConfig::default();
    let (report, _) = replay(data, &config, None, skip_s, false, &|_| {}).unwrap();
    assert_eq!(report.dofs.len(), 1);
    report.dofs.into_iter().next().unwrap()
}

#[test]
fn a_stationary_ar2_process_gets_nominal_coverage() {
    // Gaussian errors with a calibrated sigma: 68.3 % within 1 sigma, 95.4 % within 2 sigma.
    let d = run(&record(ar2(2 * 3 * 3600, 1, |_| 1.0), 2.0), 1200.0);
    assert!(d.scored > 15000, "{}", d.scored);
    for lead_s in [5.0, 10.0, 20.0] {
        let k = (lead_s * 2.0) as usize - 1;
        let (c1, c2) = (d.coverage_1sigma[k], d.coverage_2sigma[k]);
        assert!((0.63..=0.73).contains(&c1), "lead {lead_s}: 1 sigma {c1}");
        assert!((0.92..=0.97).contains(&c2), "lead {lead_s}: 2 sigma {c2}");
        // An AR(2) is predictable a few steps ahead, and never worse than zero. At 20 s this
        // one has almost no skill left (the optimum removes 1.7 % of the variance), so the
        // delivered error equals zero's up to the noise of estimating beta out of sample.
        assert!(d.nrmse[k] <= 1.002, "lead {lead_s}: nrmse {}", d.nrmse[k]);
    }
    assert!(d.nrmse[0] < 0.5, "{}", d.nrmse[0]);
    assert!(d.retrains >= 1 && d.swaps >= 1);
}

#[test]
fn a_listed_ship_is_forecast_about_its_list_not_towards_zero() {
    // Regression: the predictors are linear maps without a constant term, and fed a motion
    // about a static list (cargo, ballast, wind) they spent their coefficients on carrying the
    // list: on the paper sea a 0.05 rad list made the roll error 5 s ahead 3.7 times larger.
    // The same motion about a list of 5 times its std must be forecast as well as without it.
    let motion = ar2(2 * 2 * 3600, 3, |_| 1.0);
    let std = rms(&motion);
    let listed: Vec<f64> = motion.iter().map(|x| x + 5.0 * std).collect();
    let level = run(&record(motion, 2.0), 1200.0);
    let list = run(&record(listed, 2.0), 1200.0);
    for lead_s in [2.5, 5.0, 10.0, 20.0] {
        let k = (lead_s * 2.0) as usize - 1;
        let ratio = list.rms[k] / level.rms[k];
        assert!(
            (0.95..=1.05).contains(&ratio),
            "lead {lead_s}: rms {} against {}",
            list.rms[k],
            level.rms[k]
        );
        // No worse than the motion's own std (predicting the list), up to scoring noise.
        assert!(
            list.rms[k] <= 1.03 * std,
            "lead {lead_s}: rms {} std {std}",
            list.rms[k]
        );
    }
}

#[test]
fn without_a_model_forecasts_say_no_skill_honestly() {
    // No start-up model and no retraining: every delivered forecast is flat at the motion's
    // level (here about zero: the error is that of predicting zero, up to the level's
    // estimate) and sigma is the live RMS of the motion.
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    let data = record(ar2(2 * 1800, 2, |_| 1.0), 2.0);
    let (report, forecasts) = replay(&data, &config, None, 0.0, true, &|_| {}).unwrap();
    let d = &report.dofs[0];
    assert_eq!((d.retrains, d.swaps), (0, 0));
    for k in 0..50 {
        assert!((d.nrmse[k] - 1.0).abs() < 0.01, "{}", d.nrmse[k]);
    }
    // Flat: the level, the same at every step.
    assert!(forecasts
        .iter()
        .all(|f| f.mean[2][..50].iter().all(|m| *m == f.mean[2][0])));
    // Once the level has minutes of motion behind it, it is close to the motion's mean, 0.
    let worst = forecasts
        .iter()
        .filter(|f| f.time_s >= 300.0)
        .map(|f| f64::from(f.mean[2][0].abs()))
        .fold(0.0, f64::max);
    assert!(worst < 0.1 * d.std, "level {worst} std {}", d.std);
    // sigma = the live RMS, which after half an hour is close to the motion's RMS.
    let last = forecasts.last().unwrap();
    let sigma = f64::from(last.sigma[2][10]);
    assert!(
        (sigma / d.std - 1.0).abs() < 0.25,
        "sigma {sigma} std {}",
        d.std
    );
}

#[test]
fn an_implausible_forecast_is_never_published() {
    // Outliers of 2000 standard deviations: a linear model's forecast from them is far beyond
    // what the motion can do. No delivered mean ever leaves the bound, and the outliers did
    // make forecasts implausible (so the check was exercised).
    let mut x = ar2(2 * 3600, 3, |_| 1.0);
    for i in (900..x.len()).step_by(701) {
        x[i] = 2000.0;
    }
    // A model with skill on this process (held-out evidence: beta near 1 from the start), no
    // retraining, so the outliers reach it as they are.
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    let mut engine = engine_fitted_on_ar2(&config, 30);
    let mut published = 0;
    for (i, v) in x.iter().enumerate() {
        let sample = heave_only(i, *v);
        if engine.push(&sample).unwrap().is_none() {
            continue;
        }
        published += 1;
        let bound = config.plausible_rms_factor * engine.live_rms(2);
        let f = engine.forecast();
        for k in 0..f.steps as usize {
            let m = f64::from(f.mean[2][k]);
            assert!(
                m.is_finite() && m.abs() <= bound * (1.0 + 1e-6),
                "{m} beyond {bound}"
            );
        }
    }
    assert!(published > 7000);
    // The outliers are jumps the first step missed (held at no skill, `jump.rs`) or make a
    // forecast implausible: either way the guard was exercised.
    assert!(
        engine.counts.implausible[2] + engine.counts.jumps[2] > 0,
        "no forecast was ever implausible or held"
    );
}

#[test]
fn a_large_wave_forecast_well_is_delivered_not_replaced_by_no_skill() {
    // Regression: on the Gullfaks C record (1989) a heave trough of 7.1 m came out of a sea
    // whose live RMS was 0.97 m, and the engine had forecast it seconds ahead; a bound of 5 live
    // RMS threw those forecasts away for "no skill", so the largest errors came at the one wave
    // that mattered. Here a focusing wave group: 25 wave components of random frequency
    // (periods 5-12 s) all in phase at one moment, 90 minutes into the record, so the sea
    // (RMS sqrt(25 / 2)) peaks at 25, about 7 times its RMS. Every component has been in the
    // record all along, so the wave is predictable, as a dispersive group is.
    let rate = 2.0;
    let focus_s = 5400.0;
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let omegas: Vec<f64> = (0..25)
        .map(|_| 0.52 + 0.74 * rand::Rng::random::<f64>(&mut rng))
        .collect();
    let x: Vec<f64> = (0..((focus_s + 60.0) * rate) as usize)
        .map(|i| {
            let t = i as f64 / rate;
            omegas.iter().map(|w| (w * (t - focus_s)).cos()).sum()
        })
        .collect();
    let data = record(x, rate);
    let score = |factor: f64| {
        let config = PredictorServiceConfig {
            plausible_rms_factor: factor,
            ..PredictorServiceConfig::default()
        };
        let (report, _) = replay(&data, &config, None, focus_s - 20.0, false, &|_| {}).unwrap();
        report.dofs.into_iter().next().unwrap()
    };
    let peak = omegas.len() as f64;
    // Delivered: the crest is forecast to within a fifth of its height at every lead.
    let default = score(PredictorServiceConfig::default().plausible_rms_factor);
    assert_eq!(default.implausible, 0, "{default:?}");
    assert!(default.max_abs_error < 0.2 * peak, "{default:?}");
    // Bounded at 5 live RMS, the forecasts of the crest were replaced by the level: the crest
    // itself became the error.
    let tight = score(5.0);
    assert!(tight.implausible > 0, "{tight:?}");
    assert!(tight.max_abs_error > 0.9 * peak, "{tight:?}");
    assert!(
        default.rms[9] < 0.2 * tight.rms[9],
        "{:?} {:?}",
        default.rms,
        tight.rms
    );
}

/// What [`spiked_ar_run`] saw: the first forecast with a failed model, the first after it
/// with heave back in service, the values heave spent on no skill, and the retrains asked for
/// failures.
struct SpikedRun {
    engine: Engine,
    failed_at: Option<usize>,
    replaced_at: Option<usize>,
    last_failed_at: Option<usize>,
    failure_retrains: usize,
}

/// An online AR engine (on AR(2) heave and roll) fed heave with a spike of 1e5 at each of
/// `spikes`: far beyond what its LMS gain allows, so its update diverges on it.
fn spiked_ar_run(spikes: &[usize]) -> SpikedRun {
    let config = PredictorServiceConfig {
        method: shipcast_predict::Method::Ar,
        // Plain LMS with a gain this process's power allows (the paper's diverges on it in
        // training already, and every fit would fall back to the zero forecast); a spike of
        // 1e5 is far beyond what it allows.
        ar: Some(crate::config::ArSettings {
            lms_gain: 1e-5,
            normalized: false,
        }),
        ..PredictorServiceConfig::default()
    };
    let engine = engine_fitted_on_ar2(&config, 40);
    let x = ar2(2 * 1800, 41, |_| 1.0);
    let mut run = SpikedRun {
        engine,
        failed_at: None,
        replaced_at: None,
        last_failed_at: None,
        failure_retrains: 0,
    };
    let engine = &mut run.engine;
    let mut retrain_at = None;
    for (i, v) in x.iter().enumerate() {
        let mut sample = heave_only(i, if spikes.contains(&i) { 1e5 } else { *v });
        sample.dof[3] = *v;
        if engine.push(&sample).unwrap().is_none() {
            continue;
        }
        if engine.failed.retrain_at != retrain_at {
            retrain_at = engine.failed.retrain_at;
            run.failure_retrains += 1;
        }
        let f = engine.forecast();
        if run.failed_at.is_none() && engine.counts.model_failures > 0 {
            run.failed_at = Some(i);
        }
        if engine.failed.dof[2] {
            run.last_failed_at = Some(i);
            // No skill, honestly: the level, sigma at least the live RMS.
            let rms = engine.live_rms(2);
            for k in 0..f.steps as usize {
                assert_eq!(f.mean[2][k], engine.ingest.level(2) as f32);
                assert!(f64::from(f.sigma[2][k]) >= rms * (1.0 - 1e-6));
            }
        } else if run.failed_at.is_some() && run.replaced_at.is_none() {
            run.replaced_at = Some(i);
        }
        for d in [2, 3] {
            assert!(f.mean[d][..f.steps as usize].iter().all(|m| m.is_finite()));
        }
    }
    run
}

#[test]
fn a_model_that_fails_numerically_is_taken_out_of_service_and_replaced_by_a_retrain() {
    // Regression: an online AR whose LMS update diverged on one spike returned an error that
    // stopped replay and the predictor service. Now that DOF says no skill (the level, sigma the
    // live RMS) until a retrain puts a new model in, and the other DOF go on as they were.
    // A burst of four bad samples: one or two alone are a spike that the jump guard takes out
    // of the history before the online update learns from it (`jump.rs`).
    let spike = 600;
    let run = spiked_ar_run(&[spike, spike + 1, spike + 2, spike + 3]);
    let failed_at = run.failed_at.expect("the spike never made the AR fail");
    assert!(failed_at >= spike, "failed at {failed_at}");
    let replaced_at = run
        .replaced_at
        .expect("the failed model was never replaced");
    assert!(run.engine.counts.swaps >= 1);
    // Replaced at the next retrain the data allow, not at the next scheduled one (300 s).
    assert!(
        replaced_at - failed_at < 600,
        "{failed_at} -> {replaced_at}"
    );
    // And the replacement stays in service once the spike has left every model's input
    // (order + horizon: at most 250 values).
    let last = run.last_failed_at.unwrap_or(failed_at);
    assert!(last < spike + 250, "heave failed again at {last}");
    let e = &run.engine;
    assert!(e.counts.implausible[2] > 0 && e.counts.implausible[3] == 0);
}

#[test]
fn retrains_for_failures_back_off_while_models_keep_failing() {
    // Regression: the values a model failed on stay in its replacement's input, and it fails
    // in turn: 14 failures, each retrained at once, within 34 s. A faulty heave sensor that
    // spikes every 5 values for 100 s makes model after model fail (12 failures and retrains
    // without the backoff); the retrains for them wait twice as long each time (4, 8, 16, ...
    // values), so at most 8 in the 200 values.
    let spikes: Vec<usize> = (600..800).step_by(5).collect();
    let run = spiked_ar_run(&spikes);
    assert!(
        run.engine.counts.model_failures >= 3,
        "{} failures",
        run.engine.counts.model_failures
    );
    assert!(
        (3..=8).contains(&run.failure_retrains),
        "{} retrains for failures",
        run.failure_retrains
    );
    // Once the sensor is sound again, a model is back in service for good.
    let last = run.last_failed_at.expect("heave never failed");
    assert!(last < 800 + 2 * 250, "heave failed again at {last}");
}

#[test]
fn a_streak_of_retrains_for_failures_goes_on_while_models_keep_failing() {
    use super::failures::{next_streak, FailedModels};
    let longest = 250;
    let failed = |retrain_at, last_failure_at, streak| FailedModels {
        retrain_at,
        last_failure_at,
        streak,
        ..FailedModels::default()
    };
    // The first failure starts a streak.
    assert_eq!(next_streak(&failed(None, Some(10), 0), longest), 1);
    // A model failed again after the previous retrain, while the values could still be in its
    // input: the streak goes on, also at the cap (regression: a retrain that had waited the
    // whole longest input started the streak anew, so a sensor that kept spiking got eight
    // quick retrains per cycle for ever).
    assert_eq!(next_streak(&failed(Some(100), Some(101), 3), longest), 4);
    assert_eq!(next_streak(&failed(Some(100), Some(349), 9), longest), 10);
    // An inline retrain's model failing on the value it was asked for at.
    assert_eq!(next_streak(&failed(Some(100), Some(100), 2), longest), 3);
    // The model stayed in service for the longest input: a new streak.
    assert_eq!(next_streak(&failed(Some(100), Some(350), 9), longest), 1);
    // The failure that triggered the previous retrain is not "again".
    assert_eq!(next_streak(&failed(Some(100), Some(99), 5), longest), 1);
    assert_eq!(
        next_streak(&failed(Some(1), Some(2), u32::MAX), longest),
        u32::MAX
    );
}

#[test]
fn the_wait_between_retrains_for_failures_doubles_up_to_the_longest_input() {
    use super::failures::{failure_gap, FIRST_FAILURE_GAP};
    assert_eq!(failure_gap(0, 250), 0);
    assert_eq!(failure_gap(1, 250), FIRST_FAILURE_GAP);
    assert_eq!(failure_gap(2, 250), 2 * FIRST_FAILURE_GAP);
    assert_eq!(failure_gap(3, 250), 4 * FIRST_FAILURE_GAP);
    assert_eq!(failure_gap(7, 250), 250);
    assert_eq!(failure_gap(u32::MAX, 250), 250);
}

#[test]
fn a_retrain_is_compared_on_the_dof_both_sets_can_be_scored_on() {
    use super::replaces;
    let nan = f64::NAN;
    const NONE_FAILED: [bool; 6] = [false; 6];
    // Regression: a DOF absent from the record (or constant) scores NaN for both sets; summed
    // in, it made every retrain replace the running set, however it scored elsewhere.
    let running = [0.5, 0.5, nan, 0.5, 0.5, 0.5];
    let (better, new, old) = replaces(&[0.6, 0.6, nan, 0.6, 0.6, 0.6], &running, &NONE_FAILED);
    assert!(!better);
    assert!((new - 0.6).abs() < 1e-12 && (old - 0.5).abs() < 1e-12);
    assert!(replaces(&[0.4, 0.5, nan, 0.5, 0.5, 0.5], &running, &NONE_FAILED).0);
    // Equal scores keep the running set.
    assert!(!replaces(&running, &running, &NONE_FAILED).0);
    // A DOF only the new set can be scored on (the running model failed there, or its order
    // is too long for the data) makes the new set replace it.
    assert!(replaces(&[0.9, 0.9, 0.9, 0.9, 0.9, 0.9], &running, &NONE_FAILED).0);
    // Nothing comparable at all: the new set, as before.
    let (better, new, old) = replaces(&[nan; 6], &[nan; 6], &NONE_FAILED);
    assert!(better && new.is_nan() && old.is_nan());
    // Regression: a DOF whose running model failed stayed on no skill when the retrain scored
    // worse on the others (the running set was kept, failed model and all).
    let mut heave_failed = NONE_FAILED;
    heave_failed[2] = true;
    let running = [0.5, 0.5, 0.5, 0.5, 0.5, 0.5];
    let worse = [0.6, 0.6, 0.6, 0.6, 0.6, 0.6];
    assert!(!replaces(&worse, &running, &NONE_FAILED).0);
    let (better, new, old) = replaces(&worse, &running, &heave_failed);
    assert!(better);
    // The means compared are over the other five DOF.
    assert!((new - 0.6).abs() < 1e-12 && (old - 0.5).abs() < 1e-12);
}

#[test]
fn a_sudden_variance_change_is_detected_and_sigma_follows_within_minutes() {
    // Innovations 3 times larger (variance 9 x) from 1 h on: the engine detects a change,
    // and over the last half hour coverage is back near nominal.
    let change = 2 * 3600;
    let x = ar2(2 * 7200, 4, |t| if t < change { 1.0 } else { 3.0 });
    let data = record(x, 2.0);
    let d = run(&data, 3600.0 + 1800.0);
    let config = PredictorServiceConfig::default();
    let (full, _) = replay(&data, &config, None, 0.0, false, &|_| {}).unwrap();
    assert!(
        full.counts.changes >= 1,
        "no change detected: {:?} {:?}",
        full.counts,
        d
    );
    let k = 19;
    assert!(
        (0.60..=0.76).contains(&d.coverage_1sigma[k]),
        "{}",
        d.coverage_1sigma[k]
    );
    assert!(
        (0.90..=0.98).contains(&d.coverage_2sigma[k]),
        "{}",
        d.coverage_2sigma[k]
    );
}

/// A resonant AR(2) at 2 Hz whose period, pole radius and innovation scale switch at value
/// `change` (the recursion runs on, so the record is continuous).
fn ar2_switching(
    n: usize,
    seed: u64,
    change: usize,
    before: (f64, f64),
    after: (f64, f64, f64),
) -> Vec<f64> {
    let coeffs = |period_values: f64, radius: f64| {
        let theta = std::f64::consts::TAU / period_values;
        (2.0 * radius * theta.cos(), -radius * radius)
    };
    let (b, a) = (coeffs(before.0, before.1), coeffs(after.0, after.1));
    let noise = Normal::new(0.0, 1.0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = vec![0.0; n];
    for t in 2..n {
        let ((a1, a2), scale) = if t < change { (b, 1.0) } else { (a, after.2) };
        x[t] = a1 * x[t - 1] + a2 * x[t - 2] + scale * noise.sample(&mut rng);
    }
    x
}

#[test]
fn after_a_change_of_sea_the_10s_error_is_back_near_its_new_level_within_a_bounded_time() {
    // Six independent columns (so one replay averages six realisations) of an AR(2) whose sea
    // changes at 30 min: period 8 s -> 16 s, pole radius 0.95 -> 0.985, innovations x 3 (the
    // engine before post-change refits was still 1.5 x the new level 9 minutes after).
    //
    // The bound follows from the engine's constants, not from a run: the old model's errors
    // on the new process are at least 3 x sigma (the innovations alone), so the detector's
    // 2-minute mean of (e / sigma)^2 (CHANGE_MEMORY, 240 values) jumps towards 9 or more and
    // crosses 3 within 240 * ln(8 / 6) = 69 values; 2 minutes allows for a slower rise. All six
    // DOF then agree, the post-change window starts, and the first fit on it alone comes after
    // `first_fit_s` (4 min) of it. Scored over 3-minute windows (the study's), the first window
    // entirely after that ends at 2 + 4 + 3 = 9 minutes after the change.
    let rate = 2.0;
    let change = (1800.0 * rate) as usize;
    let n = change + (3600.0 * rate) as usize;
    let names = [
        "surge_m",
        "sway_m",
        "heave_m",
        "roll_rad",
        "pitch_rad",
        "yaw_rad",
    ];
    let data = MotionData {
        ignored: Vec::new(),
        time: (0..n).map(|i| i as f64 / rate).collect(),
        columns: names
            .iter()
            .enumerate()
            .map(|(d, name)| Column {
                name: (*name).into(),
                values: ar2_switching(n, 40 + d as u64, change, (16.0, 0.95), (32.0, 0.985, 3.0)),
            })
            .collect(),
    };
    let config = PredictorServiceConfig::default();
    let (report, _) = replay(&data, &config, None, 60.0, false, &|_| {}).unwrap();
    assert!(report.counts.changes >= 6, "{:?}", report.counts);
    // Mean square of the 10 s error per minute, averaged over the six realisations.
    let minutes = report.dofs[0].rms_10s_by_minute.len();
    let ms: Vec<f64> = (0..minutes)
        .map(|m| {
            report
                .dofs
                .iter()
                .map(|d| d.rms_10s_by_minute[m].powi(2))
                .sum::<f64>()
                / report.dofs.len() as f64
        })
        .collect();
    let rms_over = |from: usize, to: usize| {
        let w = &ms[from..to];
        (w.iter().sum::<f64>() / w.len() as f64).sqrt()
    };
    // The new steady state: the last half hour (the window has regrown to 25 min by then).
    let change_min = change / (60.0 * rate) as usize;
    let end = minutes - 1; // the last minute holds forecasts whose steps leave the record
    let steady = rms_over(end - 30, end);
    let bound_min = 9;
    for last in change_min + bound_min..=end {
        let w = rms_over(last - 3, last);
        assert!(
            (w / steady - 1.0).abs() <= 0.2,
            "3-minute window ending {} min after the change: 10 s RMS {w:.3}, steady state {steady:.3}",
            last - change_min
        );
    }
}

#[test]
fn epoch_time_stamps_leave_the_results_and_the_trace_as_from_zero() {
    // Regression: the per-minute trace was sized by the last time stamp itself, so a record
    // stamped in epoch seconds (1.7e9) needed gigabytes and one at 1e13 aborted. It now counts
    // minutes from the record's first sample; stamps 1.7e9 s later (a multiple of 60 s, so the
    // minutes fall alike) must give the very same report.
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    let data = record(ar2(2 * 600, 4, |_| 1.0), 2.0);
    let mut late = data.clone();
    let offset = 60.0 * 28_333_333.0;
    late.time.iter_mut().for_each(|t| *t += offset);
    let (a, _) = replay(&data, &config, None, 60.0, false, &|_| {}).unwrap();
    let (b, _) = replay(&late, &config, None, 60.0 + offset, false, &|_| {}).unwrap();
    let (a, b) = (&a.dofs[0], &b.dofs[0]);
    assert_eq!(a.rms_10s_by_minute.len(), 11);
    assert_eq!(b.rms_10s_by_minute.len(), 11);
    assert_eq!(a.scored, b.scored);
    for (x, y) in a.nrmse.iter().zip(&b.nrmse) {
        assert!((x - y).abs() < 1e-9, "{x} {y}");
    }
}

#[test]
fn after_a_change_of_sea_retrains_try_the_new_sea_alone_until_the_window_has_left_the_old_one() {
    // Regression test: with a window of hours, retrains once the first minutes after a change
    // were over fitted only on the whole window, old sea included. The new sea's own values
    // must stay a candidate for as long as the window reaches back before the change, and no
    // longer. A window of 6000 values (50 min) keeps the record short.
    let rate = 2.0;
    let config = PredictorServiceConfig {
        retrain_window: 6000,
        ..PredictorServiceConfig::default()
    };
    let change = (1800.0 * rate) as usize;
    let n = change + config.retrain_window + 600;
    let columns: Vec<Vec<f64>> = (0..6)
        .map(|d| ar2_switching(n, 60 + d, change, (16.0, 0.95), (32.0, 0.985, 3.0)))
        .collect();
    let mut engine = Engine::new(
        config.clone(),
        rate,
        None,
        Retrainer::inline(config.clone()),
    )
    .unwrap();
    let phase_end = change + (4 * 60 * 2) + 3 * config.holdout;
    let (mut detected, mut seen_after_phase, mut cleared_at) = (None, false, None);
    for i in 0..n {
        let mut sample = MotionSample {
            seq: i as u64,
            time_s: i as f64 / rate,
            ..MotionSample::default()
        };
        for (d, c) in columns.iter().enumerate() {
            sample.dof[d] = c[i];
        }
        engine.push(&sample).unwrap();
        match (detected, engine.sea_since) {
            (None, Some(at)) => detected = Some(at),
            (Some(_), Some(at)) => {
                assert_eq!(Some(at), detected, "the change's start moved");
                if i > phase_end {
                    assert!(engine.changed_at.is_none(), "still in the first minutes");
                    // What a retrain now fits on alone: every value since the change.
                    let since = (engine.values - at) as usize;
                    assert_eq!(
                        engine.new_sea_values(config.retrain_window),
                        Some(since),
                        "value {i}"
                    );
                    seen_after_phase = true;
                }
            }
            (Some(_), None) if cleared_at.is_none() => cleared_at = Some(i),
            _ => {}
        }
    }
    let at = detected.expect("no change of sea detected") as usize;
    // The detector needs up to 2 minutes (a_sudden_variance_change_is_detected...).
    assert!(
        (change..change + 240).contains(&at),
        "detected at value {at}, change at {change}"
    );
    assert!(
        seen_after_phase,
        "the new sea was no longer a candidate after the first minutes"
    );
    // Cleared as soon as the window holds the new sea only (`at` is a count of values, the
    // loop's index one less).
    let cleared = cleared_at.expect("the old sea never left the window");
    assert!(
        cleared + 1 == at + config.retrain_window,
        "cleared at value {cleared}, change detected at {at}"
    );
}

/// Regression (review): a 6 Hz record stamped to the millisecond read as 5.988 Hz by its
/// median step and was refused by replay while eval took it; gaps and epoch stamps must still
/// give the record's own rate, and a rate that is no multiple is still refused.
#[test]
fn a_record_rate_comes_from_its_regular_steps_whatever_the_rounding_and_gaps() {
    use super::replay::record_rate;
    let ms = |t: f64| (t * 1000.0).round() / 1000.0;
    let six: Vec<f64> = (0..3000).map(|i| ms(i as f64 / 6.0)).collect();
    assert_eq!(record_rate(&six, 2.0).unwrap(), 6.0);
    // Ten hertz in epoch seconds with a 20 s gap.
    let mut ten: Vec<f64> = (0..2000).map(|i| 1.7e9 + i as f64 * 0.1).collect();
    ten.extend((2200..4000).map(|i| 1.7e9 + i as f64 * 0.1));
    assert_eq!(record_rate(&ten, 2.0).unwrap(), 10.0);
    let odd: Vec<f64> = (0..3000).map(|i| i as f64 * 0.13).collect();
    let e = record_rate(&odd, 2.0).unwrap_err().to_string();
    assert!(e.contains("typical time step is 0.13 s"), "{e}");
    // Regression (review): rates whose millisecond steps differ by more than 1 % (0.083 and
    // 0.084 s at 12 Hz) were refused as irregular.
    for rate in [12.0, 16.0, 24.0] {
        let stamped: Vec<f64> = (0..3000).map(|i| ms(100.0 + i as f64 / rate)).collect();
        assert_eq!(record_rate(&stamped, 2.0).unwrap(), rate, "{rate} Hz");
    }
}

/// Regression (review): eval took a record at 8.004 Hz (within 1e-3 of 8 Hz) while replay
/// refused it (within 1e-5 only), and the producer's `--input` took anything within 1 %. Eval
/// and replay now take and refuse the same rates, at the shared tolerance.
#[test]
fn eval_and_replay_take_and_refuse_the_same_record_rates() {
    use super::replay::record_rate;
    use shipcast_series::{decimation_factor, sample_rate, RATE_TOLERANCE};
    for (rate, taken) in [
        (8.0, true),
        (8.004, true),
        (7.9965, true),
        (8.0 * (1.0 + 0.9 * RATE_TOLERANCE), true),
        (8.0 * (1.0 + 1.5 * RATE_TOLERANCE), false),
        (8.02, false),
        (7.9, false),
    ] {
        let time: Vec<f64> = (0..4000).map(|i| 50.0 + i as f64 / rate).collect();
        let eval = sample_rate(&time).and_then(|r| decimation_factor(r, 2.0));
        let replay = record_rate(&time, 2.0);
        assert_eq!(eval.is_ok(), taken, "eval at {rate} Hz: {eval:?}");
        assert_eq!(replay.is_ok(), taken, "replay at {rate} Hz: {replay:?}");
        if taken {
            assert_eq!((eval.unwrap(), replay.unwrap()), (4, 8.0), "{rate} Hz");
        }
    }
}

/// Regression (review): a 24 Hz record 0.05 % off its rate was taken (within the shared
/// tolerance) but none of its forecasts was scored, their far steps drifting beyond the quarter
/// step that scoring matched samples within.
#[test]
fn a_record_taken_within_the_rate_tolerance_is_scored_at_every_lead() {
    let rate = 24.0 * 1.0005;
    let heave: Vec<f64> = (0..(rate * 1200.0) as usize)
        .map(|i| (std::f64::consts::TAU * i as f64 / rate / 9.0).sin())
        .collect();
    let d = run(&record(heave, rate), 600.0);
    // Forecasts issued over the last ten minutes less a horizon, two a second.
    assert!(d.scored > 2 * 500, "{}", d.scored);
    assert!(d.rms.iter().all(|r| r.is_finite()), "{:?}", d.rms);
}

/// Regression (review): the version was taken when a retrain was asked for, so a retrained
/// model that the running one outscored used up a number and the next model put in use
/// skipped one. Every forecast's version is the previous one or one more, and it rises as
/// often as a model is put in use.
#[test]
fn the_model_version_rises_by_one_at_every_model_put_in_use_and_only_then() {
    let config = PredictorServiceConfig::default();
    let mut engine = engine_fitted_on_ar2(&config, 7);
    let mut seen = engine.model_version();
    let mut rises = 0u64;
    // The case the old numbering failed: a model put in use after one was kept out.
    let (mut kept_seen, mut rise_after_kept) = (0u64, false);
    for (i, h) in ar2(2 * 3 * 3600, 8, |_| 1.0).into_iter().enumerate() {
        let sample = at_2hz(i, [h; 6]);
        if let Some(f) = engine.push(&sample).unwrap() {
            if f.model_version != seen {
                assert_eq!(f.model_version, seen + 1, "after {rises} rises");
                seen = f.model_version;
                rises += 1;
                rise_after_kept |= kept_seen > 0;
            }
        }
        kept_seen = engine.counts.kept_running;
    }
    assert!(
        rise_after_kept,
        "no model was put in use after one was kept out: the case is not tested"
    );
    assert_eq!(rises, engine.counts.swaps);
}

/// Regression (review): a DOF that stood still for ten minutes and then moved kept sigma 0
/// while its errors grew (the change detector skipped forecasts of sigma 0). An error
/// against sigma 0 is a change, and sigma follows the new motion within half a minute.
#[test]
fn a_dof_that_stood_still_and_then_moves_is_a_change_and_gets_its_sigma() {
    let config = PredictorServiceConfig::default();
    let mut engine = Engine::new(config.clone(), 2.0, None, Retrainer::inline(config)).unwrap();
    let onset = 1200;
    let motion = ar2(onset + 600, 4, |_| 1.0);
    let std = (motion[onset..].iter().map(|x| x * x).sum::<f64>() / 600.0).sqrt();
    // The 10 s step's sigma 5 s and 30 s after the onset.
    let (mut after_5s, mut after_30s) = (None, None);
    for (i, &m) in motion.iter().enumerate() {
        let h = if i < onset { 0.0 } else { m };
        let sample = heave_only(i, h);
        if let Some(f) = engine.push(&sample).unwrap() {
            if i == onset + 10 {
                after_5s = Some(f.sigma[2][9] as f64);
            }
            if i == onset + 60 {
                after_30s = Some(f.sigma[2][9] as f64);
            }
        }
        if i < onset {
            assert_eq!(engine.counts.changes, 0, "a change while still, at {i}");
        }
    }
    assert!(engine.counts.changes >= 1);
    // The live variance grows from 0 over its half-minute memory: 5 s in it holds about a
    // sixth of the new one (0.4 std); the stillness's errors of 0 must not hold it lower.
    let (early, later) = (after_5s.unwrap(), after_30s.unwrap());
    assert!(
        early > 0.4 * std,
        "sigma {early} 5 s after the onset, std {std}"
    );
    assert!(
        later > 0.6 * std,
        "sigma {later} 30 s after the onset, std {std}"
    );
}

/// Regression (review): one spike of 50 m in a sea of about 1 m entered the live RMS
/// unclipped. It multiplied the live RMS, which is the no-skill sigma and sizes the
/// plausibility bound, for minutes.
#[test]
fn one_spike_does_not_inflate_the_live_rms_behind_the_no_skill_sigma() {
    // No model yet (the first fit comes after `first_fit_s`): sigma is the no-skill one, the
    // live RMS itself.
    let config = PredictorServiceConfig {
        first_fit_s: 1e6,
        ..PredictorServiceConfig::default()
    };
    let mut engine = Engine::new(config.clone(), 2.0, None, Retrainer::inline(config)).unwrap();
    let mut heave = ar2(2 * 1800, 10, |_| 1.0);
    let std = rms(&heave);
    let spike = 2 * 1200;
    heave[spike] = 50.0 * std;
    let (mut before, mut after) = (Vec::new(), Vec::new());
    for (i, &h) in heave.iter().enumerate() {
        let sample = at_2hz(i, [h; 6]);
        let Some(f) = engine.push(&sample).unwrap() else {
            continue;
        };
        let s = f.sigma[2][19] as f64;
        if (spike - 240..spike).contains(&i) {
            before.push(s);
        }
        // The two minutes after the spike.
        if (spike + 10..spike + 240).contains(&i) {
            after.push(s);
        }
    }
    let largest = |v: &[f64]| v.iter().fold(0.0f64, |m, &s| m.max(s));
    let (b, a) = (largest(&before), largest(&after));
    assert!(
        a < 1.5 * b,
        "10 s sigma up to {a} after the spike, {b} before"
    );
}

/// Regression (review): the wire's f32 rounds a mean of 1e5 m by up to 4 mm, far beyond the
/// first step's sigma, and +-1 sigma held 23 % of the errors. Sigma carries the rounding.
#[test]
fn a_large_offset_rounded_to_the_wire_keeps_sigma_honest() {
    let heave: Vec<f64> = ar2(2 * 2 * 3600, 12, |_| 0.001)
        .into_iter()
        .map(|x| 1e5 + x)
        .collect();
    let d = run(&record(heave, 2.0), 1200.0);
    let (c1, c2) = (d.coverage_1sigma[0], d.coverage_2sigma[0]);
    assert!(c1 >= 0.6, "1 sigma {c1}");
    assert!(c2 >= 0.9, "2 sigma {c2}");
    // Honest, not merely wide: sigma stays near the error it has to cover.
    let (sigma, rms) = (d.mean_sigma[0], d.rms[0]);
    assert!(
        sigma <= 1.5 * rms,
        "sigma {sigma} against an RMS error of {rms}"
    );
}

/// Regression (review): with the live RMS clipped at 8 times itself against spikes, a DOF
/// that moved, stood still for two hours (its live RMS decayed to 1e-5 of the motion's) and
/// moved again was delivered with a 10 s sigma of 0.0002 of the motion's 5 s after the restart.
/// A spike is one or two values; motion that goes on counts in full from its third value.
#[test]
fn motion_that_resumes_after_hours_of_stillness_gets_its_sigma_within_seconds() {
    let config = PredictorServiceConfig::default();
    let mut engine = Engine::new(config.clone(), 2.0, None, Retrainer::inline(config)).unwrap();
    let (moving, still) = (1200, 2 * 7200);
    let motion = ar2(moving + still + 600, 5, |_| 1.0);
    let restart = moving + still;
    let std = (motion[restart..].iter().map(|x| x * x).sum::<f64>() / 600.0).sqrt();
    let mut after_5s = None;
    for (i, &m) in motion.iter().enumerate() {
        let h = if (moving..restart).contains(&i) {
            0.0
        } else {
            m
        };
        let sample = heave_only(i, h);
        if let Some(f) = engine.push(&sample).unwrap() {
            if i == restart + 10 {
                after_5s = Some(f.sigma[2][19] as f64);
            }
        }
    }
    let sigma = after_5s.unwrap();
    assert!(
        sigma > 0.4 * std,
        "10 s sigma {sigma} 5 s after the restart, std {std}"
    );
}

/// Regression (review): forecasts were calibrated against the decimated values, which the
/// minimum-phase filter labels 10-40 ms off their time, and scored against the recorded motion.
/// On a sea of three wave components, where the models forecast the decimated values almost
/// exactly, +-2 sigma held 0-17 % of the errors at every lead. The difference between the two
/// is now part of sigma.
#[test]
fn sigma_holds_the_recorded_motion_not_only_the_decimated_values() {
    let rate = 8.0;
    let heave: Vec<f64> = (0..(1800.0 * rate) as usize)
        .map(|i| {
            let t = i as f64 / rate;
            let wave = |period: f64, amp: f64, phase: f64| {
                amp * (std::f64::consts::TAU * t / period + phase).sin()
            };
            wave(7.0, 0.6, 0.3) + wave(9.5, 1.0, 1.1) + wave(13.0, 0.4, 2.0)
        })
        .collect();
    let data = record(heave, rate);
    let config = PredictorServiceConfig::default();
    assert_eq!(config.filter, shipcast_series::FilterPhase::Minimum);
    let (report, _) = replay(&data, &config, None, 1200.0, false, &|_| {}).unwrap();
    let d = &report.dofs[0];
    assert!(d.scored > 1000, "{}", d.scored);
    // Errors of a few sines are not Gaussian (a sine's +-2 RMS holds all of it): what is
    // asserted is sigma of the errors' size, against a coverage of 0-17 % before.
    for k in 0..20 {
        assert!(
            d.coverage_2sigma[k] >= 0.85 && d.mean_sigma[k] >= 0.7 * d.rms[k],
            "step {}: +-2 sigma holds {} (rms {}, mean sigma {})",
            k + 1,
            d.coverage_2sigma[k],
            d.rms[k],
            d.mean_sigma[k]
        );
    }
}

/// Regression (review): after a step of the level the history held the step as a deviation,
/// the model rang, and forecasts were metres off with the sigma of the sea (a 3 m heave step:
/// 6.2 m off at 305 sigmas). Every forecast issued from the first stepped value on keeps its
/// errors within a few sigmas, a step below the level's own test (2.5 std) as well as one
/// far above it (8 std), and the history is re-levelled.
#[test]
fn a_step_of_the_level_is_held_at_no_skill_and_re_levelled() {
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    let clean = ar2(2 * 1800, 31, |_| 1.0);
    let std = rms(&clean);
    for step in [2.5 * std, 8.0 * std] {
        let onset = 2 * 900;
        let heave: Vec<f64> = clean
            .iter()
            .enumerate()
            .map(|(i, x)| x + if i >= onset { step } else { 0.0 })
            .collect();
        let mut engine = engine_fitted_on_ar2(&config, 30);
        // The largest error in sigmas of the forecasts made in the 30 s after the onset, and
        // the +-2 sigma coverage of all made after it.
        let (mut worst, mut inside, mut scored) = (0.0f64, 0, 0);
        for (i, &h) in heave.iter().enumerate() {
            let Some(f) = engine.push(&heave_only(i, h)).unwrap() else {
                continue;
            };
            if i < onset {
                continue;
            }
            // Step k of the forecast made at value i is value i + 1 + k.
            for k in 0..f.steps as usize {
                let Some(&actual) = heave.get(i + 1 + k) else {
                    break;
                };
                let z = (actual - f64::from(f.mean[2][k])).abs() / f64::from(f.sigma[2][k]);
                if i < onset + 60 {
                    worst = worst.max(z);
                }
                inside += usize::from(z <= 2.0);
                scored += 1;
            }
        }
        assert!(worst < 3.0, "step {step}: an error of {worst} sigmas");
        let coverage = inside as f64 / scored as f64;
        assert!(coverage > 0.9, "step {step}: +-2 sigma held {coverage}");
        assert_eq!(engine.counts.jumps, [0, 0, 1, 0, 0, 0], "step {step}");
        // The level is on the new one, and the history about it.
        let level = engine.ingest.level(2);
        assert!(
            (level - step).abs() < 0.5 * std,
            "step {step}: level {level}"
        );
        let recent = engine.ingest.last(2, 200).unwrap();
        let mean = recent.iter().sum::<f64>() / recent.len() as f64;
        assert!(mean.abs() < 0.5 * std, "step {step}: history mean {mean}");
    }
}

/// Regression (review): a 2 m heave offset undone 30 s later, inside the jump's hold, left the
/// level 2 m off until its 5-minute mean followed (heave's 5 s NRMSE 1.34, worse than the
/// level). The level steps back with the motion and the history is about it again.
#[test]
fn an_offset_undone_inside_the_hold_is_relevelled_back() {
    // A model reading 50 s, as the service's default does: the jump is held for 60 s.
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        order: 100,
        candidate_orders: vec![100],
        ..PredictorServiceConfig::default()
    };
    let clean = ar2(2 * 1200, 33, |_| 1.0);
    let std = rms(&clean);
    let mut engine = engine_fitted_on_ar2(&config, 30);
    let order = shipcast_predict::Predictor::order(&engine.models.as_ref().unwrap().predictors[2]);
    assert_eq!(order, 100);
    let (onset, end) = (2 * 900, 2 * 930);
    let offset = 5.0 * std;
    for (i, x) in clean.iter().enumerate().take(end + 100) {
        let h = x + if (onset..end).contains(&i) {
            offset
        } else {
            0.0
        };
        engine.push(&heave_only(i, h)).unwrap();
    }
    // One jump, re-levelled up and back inside its hold.
    assert_eq!(engine.counts.jumps, [0, 0, 1, 0, 0, 0]);
    assert_eq!(engine.jumps.relevelled, [0, 0, 2, 0, 0, 0]);
    let level = engine.ingest.level(2);
    assert!(level.abs() < 0.5 * std, "level {level} (std {std})");
    let recent = engine.ingest.last(2, 200).unwrap();
    let mean = recent.iter().sum::<f64>() / recent.len() as f64;
    assert!(mean.abs() < 0.5 * std, "history mean {mean} (std {std})");
}

/// Regression (review): one 30 m heave sample in a sea of 0.45 m RMS stayed in every retrain's
/// window (the history they copy) for 50 minutes. Once the jump it made is judged a spike, the
/// history holds nothing like it, and the values about it are the motion's.
#[test]
fn a_spike_is_taken_out_of_the_history_that_retrains_copy() {
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    let clean = ar2(2 * 1200, 35, |_| 1.0);
    let std = rms(&clean);
    let at = 2 * 900;
    let mut engine = engine_fitted_on_ar2(&config, 30);
    for (i, x) in clean.iter().enumerate().take(at + 100) {
        let h = x + if i == at { 40.0 * std } else { 0.0 };
        engine.push(&heave_only(i, h)).unwrap();
    }
    assert_eq!(engine.counts.jumps, [0, 0, 1, 0, 0, 0]);
    assert_eq!(engine.jumps.spikes, [0, 0, 1, 0, 0, 0]);
    let history = engine.ingest.last(2, 400).unwrap();
    let largest = history.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    assert!(largest < 5.0 * std, "{largest} (std {std})");
    // Only the spike went: the values after it are the record's, about the level.
    let level = engine.ingest.level(2);
    for (k, stored) in history[history.len() - 50..].iter().enumerate() {
        let recorded = clean[at + 50 + k] - level;
        assert!(
            (stored - recorded).abs() < 0.1 * std,
            "{k}: {stored} {recorded}"
        );
    }
}

/// Regression (review): after a gap restarted the history, a model without its input yet
/// forecast the level with its own small sigma (16-20 sigmas off). Until the history holds its
/// input it is held at no skill: the level, sigma at least the live RMS.
#[test]
fn a_model_without_its_input_after_a_restart_says_no_skill() {
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    let heave = ar2(2 * 1800, 41, |_| 1.0);
    let mut engine = engine_fitted_on_ar2(&config, 30);
    let order = shipcast_predict::Predictor::order(&engine.models.as_ref().unwrap().predictors[2]);
    let (gap_from, gap_to) = (1200, 1500);
    let mut checked = 0;
    for (i, &h) in heave.iter().enumerate() {
        if (gap_from..gap_to).contains(&i) {
            continue;
        }
        if engine.push(&heave_only(i, h)).unwrap().is_none() {
            continue;
        }
        let f = engine.forecast();
        if i >= gap_to && engine.history_len() < order {
            let rms = engine.live_rms(2);
            for k in 0..f.steps as usize {
                assert_eq!(f.mean[2][k], engine.ingest.level(2) as f32, "value {i}");
                assert!(
                    f64::from(f.sigma[2][k]) >= rms * (1.0 - 1e-6),
                    "value {i} step {k}: sigma {} live RMS {rms}",
                    f.sigma[2][k]
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 10, "{checked}");
}
