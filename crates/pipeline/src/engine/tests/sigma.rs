//! Sigma that holds what happens: nominal coverage, no skill said honestly (without a model,
//! without its input, for an implausible forecast), and sigma that follows motion which
//! stands still, resumes or is rounded on the wire.

use super::*;

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
    // The tails too: Gaussian errors leave 0.27 % of the steps beyond 3 sigma, and a step
    // beyond 6.5 sigma has a chance of 1e-10 (here some 10^6 steps).
    assert!(d.beyond_3sigma < 0.0054, "{}", d.beyond_3sigma);
    assert!(
        d.max_abs_z < 6.5,
        "{} at {} s, {} s ahead",
        d.max_abs_z,
        d.max_abs_z_time_s,
        d.max_abs_z_lead_s
    );
}

#[test]
fn replay_reports_the_largest_error_in_sigmas_where_it_happened() {
    // Recomputed here from the delivered forecasts and the record: the largest |error| /
    // sigma, its forecast and lead, and the share of steps beyond 3 sigma.
    let x = ar2(2 * 1800, 4, |t| if t > 2400 { 3.0 } else { 1.0 });
    let data = record(x.clone(), 2.0);
    let config = PredictorServiceConfig::default();
    let skip_s = 600.0;
    let (report, forecasts) = replay(&data, &config, None, skip_s, true, &|_| {}).unwrap();
    let d = &report.dofs[0];
    let (mut worst, mut at, mut lead) = (0.0f64, f64::NAN, f64::NAN);
    let (mut beyond, mut n) = (0usize, 0usize);
    for f in forecasts.iter().filter(|f| f.time_s >= skip_s) {
        let first = (f.time_s * 2.0).round() as usize;
        let steps = f.steps as usize;
        if first + steps >= x.len() {
            continue;
        }
        for k in 0..steps {
            let e = x[first + k + 1] - f64::from(f.mean[2][k]);
            let s = f64::from(f.sigma[2][k]);
            n += 1;
            beyond += usize::from(e.abs() > 3.0 * s);
            if s > 0.0 && e.abs() / s > worst {
                (worst, at, lead) = (e.abs() / s, f.time_s, (k + 1) as f64 * 0.5);
            }
        }
    }
    assert_eq!(n as u64, d.scored * 50);
    // The variance change makes errors beyond 3 sigma before sigma follows it.
    assert!(worst > 3.0 && beyond > 0, "{worst} {beyond}");
    assert_eq!(
        (d.max_abs_z, d.max_abs_z_time_s, d.max_abs_z_lead_s),
        (worst, at, lead)
    );
    assert!((d.beyond_3sigma - beyond as f64 / n as f64).abs() < 1e-12);
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
    // Against the motion's std about its mean over the whole record: the level, a 5-minute
    // mean, wanders with the AR(2)'s slow swings a little (1 %).
    for k in 0..50 {
        assert!((d.nrmse[k] - 1.0).abs() < 0.02, "{}", d.nrmse[k]);
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

/// Regression (review): where the forecasts are very good (NRMSE 0.02-0.05 a few seconds
/// ahead, a narrow long-crested swell), the minimum-phase filter's label mismatch and the
/// model's error are correlated, and sigma, their root sum of squares with the shape factor
/// fitted on the decimated values only, held 57 % of roll's errors within +-1 sigma and 88 %
/// within +-2 sigma 5 s ahead. The shape factor now sees the errors against the recorded motion
/// over the whole of sigma, and may widen it further.
#[test]
fn sigma_holds_the_recorded_motion_where_the_forecasts_are_very_good() {
    let rate = 8.0;
    let mut sea = shipcast_sim::SimConfig {
        hs_m: 2.0,
        tp_s: 14.0,
        gamma: Some(10.0),
        heading_deg: 150.0,
        speed_kn: 5.0,
        spreading: shipcast_sim::Spreading::None,
        ..shipcast_sim::SimConfig::default()
    };
    sea.seed = 34;
    let motion = shipcast_sim::ShipMotion::new(&sea).unwrap();
    let roll: Vec<f64> = motion
        .stream(rate, 0.0)
        .unwrap()
        .take((2400.0 * rate) as usize)
        .map(|p| p.dof[3])
        .collect();
    let data = record(roll, rate);
    let config = PredictorServiceConfig::default();
    assert_eq!(config.filter, shipcast_series::FilterPhase::Minimum);
    let (report, _) = replay(&data, &config, None, 1200.0, false, &|_| {}).unwrap();
    let d = &report.dofs[0];
    assert!(d.scored > 2000, "{}", d.scored);
    // Skill this high is what the case is about.
    assert!(d.nrmse[9] < 0.1, "5 s NRMSE {}", d.nrmse[9]);
    // Within the bands an operator is promised, with a little room: not narrow, and not
    // merely wide either (a factor stuck at its top would hold nearly everything).
    for k in 0..20 {
        assert!(
            (0.62..=0.75).contains(&d.coverage_1sigma[k])
                && (0.92..=0.98).contains(&d.coverage_2sigma[k]),
            "{} s ahead: +-1 sigma holds {:.3}, +-2 sigma {:.3}",
            0.5 * (k + 1) as f64,
            d.coverage_1sigma[k],
            d.coverage_2sigma[k]
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

/// Regression (review): replay's `std` and `nrmse` were about zero, so a record with an offset
/// (a list of the ship) made forecasts without skill look excellent: at a 5 m offset, NRMSE
/// 0.075 for the flat forecast that predicting the mean scores 1.
#[test]
fn an_offset_record_is_scored_against_its_spread_about_the_mean() {
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    // The AR(2) motion's std is about 6: an offset of 10 std.
    let motion = ar2(2 * 1800, 2, |_| 1.0);
    let mut listed = motion.clone();
    listed.iter_mut().for_each(|x| *x += 60.0);
    let (a, _) = replay(&record(motion, 2.0), &config, None, 600.0, false, &|_| {}).unwrap();
    let (b, _) = replay(&record(listed, 2.0), &config, None, 600.0, false, &|_| {}).unwrap();
    let (a, b) = (&a.dofs[0], &b.dofs[0]);
    // The offset moves neither the spread nor how the flat forecast at the level scores.
    assert!((b.std / a.std - 1.0).abs() < 1e-6, "{} {}", b.std, a.std);
    for k in 0..50 {
        assert!((b.nrmse[k] - 1.0).abs() < 0.02, "step {k}: {}", b.nrmse[k]);
        assert!((b.nrmse[k] - a.nrmse[k]).abs() < 1e-3, "step {k}");
    }
    // Predicting zero is what the offset spoils, and zero_rms says so.
    assert!(b.zero_rms[0] > 9.0 * b.std, "{} {}", b.zero_rms[0], b.std);
}

/// Regression (review): each step's NRMSE was over the spread of that step's own values, which
/// a few forecasts barely have: with one forecast scored it was infinite, with three up to 449.
/// Over the spread of all scored values, one flat forecast c scores exactly
/// mean over steps of NRMSE^2 = 1 + ((mean - c) / std)^2, at least 1.
#[test]
fn one_scored_forecast_has_a_finite_nrmse_of_at_least_one_for_a_flat_forecast() {
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    // 0 to 54.5 s at 2 Hz: the first forecast (29.5 s) is the only one with 25 s inside.
    let (report, forecasts) = replay(
        &record(ar2(110, 5, |_| 1.0), 2.0),
        &config,
        None,
        0.0,
        true,
        &|_| {},
    )
    .unwrap();
    let d = &report.dofs[0];
    assert_eq!(d.scored, 1);
    let first = &forecasts[0].mean[2][..50];
    assert!(first.iter().all(|m| *m == first[0]), "flat");
    assert!(d.nrmse.iter().all(|v| v.is_finite()), "{:?}", d.nrmse);
    let mean_square = d.nrmse.iter().map(|v| v * v).sum::<f64>() / d.nrmse.len() as f64;
    assert!((1.0..10.0).contains(&mean_square), "{mean_square}");
}
