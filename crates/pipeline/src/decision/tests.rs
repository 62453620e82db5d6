use super::*;

use crate::deck::tests::forecast_with_roll as forecast;

/// The Gaussian model decides from the first forecast: these tests are about it.
fn config(mot_s: f64) -> DeckConfig {
    DeckConfig {
        point_m: [0.0, 0.0, 0.0],
        mot_s,
        go_needs_verified_errors: false,
        ..DeckConfig::default()
    }
}

#[test]
fn by_default_go_waits_for_verified_errors_and_then_comes_from_them() {
    let config = DeckConfig {
        go_needs_verified_errors: true,
        ..config(5.0)
    };
    let mut decider = Decider::new(&config);
    let quiet = forecast(40, |_| 1.0, 0.1f64.to_radians() as f32);
    let d = decider.decide(&quiet);
    // No probability is stated before verified errors back one (the Gaussian model's, with
    // the first minutes' no-skill sigma, was far off on replays), so no go and no next window.
    assert_eq!(d.probability_now, None, "{d:?}");
    assert!(
        !d.go && d.next_window_s.is_none() && d.ensemble_members == 0,
        "{d:?}"
    );
    assert!(d.awaiting_verified_errors, "{d:?}");
    assert!(
        d.summary()
            .contains("no probability before verified errors"),
        "{}",
        d.summary()
    );
    // Verified errors of 3 sigma in roll at every step, one forecast in two (the rest 0):
    // on this forecast (1 deg, sigma 0.1 deg, limit 2.5 deg) none breaks the limit.
    let mut u = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
    u[0] = [3.0; MAX_STEPS];
    for _ in 0..ensemble::MIN_MEMBERS * ensemble::DEFAULT_STRIDE {
        decider.add_verified(&u, &[[0.0; MAX_STEPS]; NUM_QUANTITIES], 40);
    }
    let d = decider.decide(&quiet);
    assert_eq!(d.ensemble_members, ensemble::MIN_MEMBERS);
    assert!(!d.awaiting_verified_errors);
    // A longer forecast (the horizon grew): no path covers it, so nothing is stated yet,
    // neither from the ensemble nor, in its place, from the Gaussian model.
    let longer = forecast(50, |_| 1.0, 0.1f64.to_radians() as f32);
    let d = decider.decide(&longer);
    assert!(
        d.probability_now.is_none() && d.awaiting_verified_errors && !d.go,
        "{d:?}"
    );
    let d = decider.decide(&quiet);
    let all = ensemble::MIN_MEMBERS as f64;
    assert_eq!(d.probability_now, Some((all + 1.0) / (all + 2.0)));
    assert!(d.go && d.next_window_s == Some(0.5), "{d:?}");
    // The same errors on a forecast of 1.5 deg with sigma 0.4 deg reach 2.7 deg: every
    // member breaks the limit, where the Gaussian model (3 sigma errors being rare) states
    // a high probability for this window.
    let wide = forecast(40, |_| 1.5, 0.4f64.to_radians() as f32);
    let model_decides = DeckConfig {
        go_needs_verified_errors: false,
        ..config.clone()
    };
    let gaussian = Decider::new(&model_decides)
        .decide(&wide)
        .probability_now
        .unwrap();
    assert!(gaussian > 0.9, "{gaussian}");
    let d = decider.decide(&wide);
    assert_eq!(d.probability_now, Some(1.0 / (all + 2.0)));
    assert!(!d.go, "{d:?}");
}

#[test]
fn go_flips_when_the_roll_limit_is_crossed() {
    // Roll limit 2.5 deg, tiny sigma: the decision is the means' against the limit.
    let mut decider = Decider::new(&config(5.0));
    let below = decider.decide(&forecast(40, |_| 2.4, 1e-4));
    assert!(below.go, "{below:?}");
    assert!(below.probability_now.unwrap() > 0.99);
    assert_eq!(below.next_window_s, Some(0.5));
    assert_eq!(below.next_exceedance_s, None);
    let above = decider.decide(&forecast(40, |_| 2.6, 1e-4));
    assert!(!above.go, "{above:?}");
    assert!(above.probability_now.unwrap() < 0.01);
    assert_eq!(above.next_exceedance_s, Some(0.5));
    assert_eq!(above.next_window_s, None);
    // A tighter operator limit flips the same forecast to no-go.
    let mut tight = Decider::new(&DeckConfig {
        roll_limit_deg: 2.0,
        ..config(5.0)
    });
    assert!(!tight.decide(&forecast(40, |_| 2.4, 1e-4)).go);
}

#[test]
fn next_window_and_next_exceedance_are_found_in_the_horizon() {
    let mut decider = Decider::new(&config(5.0));
    // Roll 4 deg for steps 0..10, 1 deg from step 10 on: the first window starts at step 10
    // (5.5 s after the forecast time); exceedance is predicted right away.
    let d = decider.decide(&forecast(40, |k| if k < 10 { 4.0 } else { 1.0 }, 0.001));
    assert!(!d.go);
    assert_eq!(d.next_window_s, Some(5.5));
    assert_eq!(d.next_exceedance_s, Some(0.5));
    // Quiet now, exceedance at step 25 (13 s): go, and the exceedance time is told.
    let d = decider.decide(&forecast(40, |k| if k < 25 { 1.0 } else { 4.0 }, 0.001));
    assert!(d.go);
    assert_eq!(d.next_exceedance_s, Some(13.0));
    // A MOT longer than the horizon cannot be decided.
    let mut long = Decider::new(&config(30.0));
    let d = long.decide(&forecast(40, |_| 0.0, 0.001));
    assert!(!d.go && d.probability_now.is_none(), "{d:?}");
    assert!(!d.awaiting_verified_errors);
    assert!(
        d.summary()
            .contains("NO-GO (MOT 30s, MOT beyond the horizon)"),
        "{}",
        d.summary()
    );
}

#[test]
fn uncertainty_and_window_length_lower_the_probability() {
    // Mean well inside (1 deg of 2.5), sigma 0.8 deg: every step is likely within, a longer
    // window less so, and less correlated errors make it less likely still.
    let sigma = 0.8f64.to_radians() as f32;
    let f = forecast(60, |_| 1.0, sigma);
    let mut short = Decider::new(&config(2.0));
    let mut long = Decider::new(&config(20.0));
    let p_short = short.decide(&f).probability_now.unwrap();
    let p_long = long.decide(&f).probability_now.unwrap();
    assert!(p_short > p_long, "{p_short} {p_long}");
    long.set_error_correlation([0.5; NUM_QUANTITIES]);
    let p_loose = long.decide(&f).probability_now.unwrap();
    assert!(p_loose < p_long, "{p_loose} {p_long}");
}

#[test]
fn deck_velocity_sigma_uses_the_step_correlation() {
    // Heave sigma 0.1 m at every step: the central difference over 2 steps (1 s) has sigma
    // 0.1 sqrt(2 - 2 rho^2), so perfectly correlated errors leave no velocity error.
    let mut f = forecast(10, |_| 0.0, 0.0);
    for k in 0..10 {
        f.sigma[HEAVE][k] = 0.1;
    }
    let point = ShipPoint::new([0.0; 3]);
    let mut t = Tracks::default();
    t.fill(&point, &f, 0.0);
    assert!(
        (t.sigma[3][5] - 0.1 * 2f64.sqrt()).abs() < 1e-7,
        "{}",
        t.sigma[3][5]
    );
    t.fill(&point, &f, 1.0);
    assert!(t.sigma[3][5].abs() < 1e-7);
    t.fill(&point, &f, 0.5);
    assert!((t.sigma[3][5] - 0.1 * (2.0f64 - 2.0 * 0.25).sqrt()).abs() < 1e-7);
}

/// Regression: whether a limit held over a window was judged on a one-sided difference for
/// the deck velocity at its first step, the velocity half a step later. With the recorded
/// values on either side, both end steps take the central difference: exact for a quadratic.
#[test]
fn the_velocity_at_the_end_steps_of_what_happened_is_a_central_difference() {
    // Heave h = t^2 at t = 0.5, 1.0, ..., 5.0 (dt 0.5); the deck point's vertical is -h, so
    // its velocity is -2t.
    let mut f = forecast(10, |_| 0.0, 0.0);
    for k in 0..10 {
        let t = 0.5 * (k + 1) as f64;
        f.mean[HEAVE][k] = (t * t) as f32;
    }
    let point = ShipPoint::new([0.0; 3]);
    let mut t = Tracks::default();
    t.fill(&point, &f, 0.0);
    // One-sided at the ends: the velocity 0.25 s into the step or before it.
    assert!((t.mean[3][0] - -1.5).abs() < 1e-6, "{}", t.mean[3][0]);
    assert!((t.mean[3][9] - -9.5).abs() < 1e-6, "{}", t.mean[3][9]);
    let heave_at = |t: f64| {
        let mut dof = [0.0; 6];
        dof[HEAVE] = t * t;
        dof
    };
    t.central_ends(&point, Some(&heave_at(0.0)), Some(&heave_at(5.5)));
    assert!((t.mean[3][0] - -1.0).abs() < 1e-6, "{}", t.mean[3][0]);
    assert!((t.mean[3][9] - -10.0).abs() < 1e-6, "{}", t.mean[3][9]);
    // Interior steps were central already, and stay as they were.
    assert!((t.mean[3][4] - -5.0).abs() < 1e-6, "{}", t.mean[3][4]);
    // Without the neighbours, the ends stay one-sided.
    t.fill(&point, &f, 0.0);
    t.central_ends(&point, None, None);
    assert!((t.mean[3][0] - -1.5).abs() < 1e-6);
}

/// Replay's curve of thresholds asks what a deck with each threshold would have stated: the
/// correction of a statement never raises it to that deck's threshold, whichever it is.
#[test]
fn a_statement_is_corrected_below_the_threshold_it_is_compared_with() {
    let config = DeckConfig {
        go_needs_verified_errors: true,
        ..config(5.0)
    };
    let mut decider = Decider::new(&config);
    let mut u = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
    u[0] = [3.0; MAX_STEPS];
    for _ in 0..ensemble::MIN_MEMBERS * ensemble::DEFAULT_STRIDE {
        decider.add_verified(&u, &[[0.0; MAX_STEPS]; NUM_QUANTITIES], 40);
    }
    let n = window_steps(5.0, 0.5);
    // Windows stated at 0.5 that always held: the correction pulls 0.5 far up.
    for _ in 0..2000 {
        decider.add_outcome(n, 0.5, true);
    }
    decider.decide(&forecast(40, |_| 1.0, 0.1f64.to_radians() as f32));
    assert!(decider.uses_ensemble());
    let at_default = decider.corrected(n, 0.5);
    assert!(
        at_default > 0.9 && at_default < config.go_probability,
        "{at_default}"
    );
    for threshold in [0.6, 0.7, 0.9] {
        let p = decider.corrected_for(n, 0.5, threshold);
        assert!(p > 0.5 && p < threshold, "{threshold}: {p}");
    }
    assert_eq!(
        decider.corrected_for(n, 0.5, config.go_probability),
        at_default
    );
}

/// A deck (MOT 5 s, go only from verified errors) whose ensemble holds enough verified errors
/// of zero to decide: a calm forecast is a go.
fn decider_with_no_errors() -> Decider {
    let config = DeckConfig {
        go_needs_verified_errors: true,
        ..config(5.0)
    };
    let mut decider = Decider::new(&config);
    let no_error = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
    for _ in 0..ensemble::MIN_MEMBERS * ensemble::DEFAULT_STRIDE {
        decider.add_verified(&no_error, &no_error, 40);
    }
    decider
}

/// A calm 40-step forecast at `time_s` (roll 1 deg at every step, sigma 0.1 deg).
fn quiet_forecast(time_s: f64) -> Forecast {
    Forecast {
        time_s,
        ..forecast(40, |_| 1.0, 0.1f64.to_radians() as f32)
    }
}

#[test]
fn a_frozen_sensor_withholds_go_and_its_thaw_drops_the_evidence_of_its_stillness() {
    let mut decider = decider_with_no_errors();
    let n = window_steps(5.0, 0.5);
    for _ in 0..500 {
        decider.add_outcome(n, 0.99, true);
    }
    let heave = |h: f64| [0.0, 0.0, h, 0.01, 0.0, 0.0];
    // Heave moves for a minute, roll sits at a constant it never leaves (an absent channel
    // feeding a constant): go, from the verified errors.
    let mut t = 0.0;
    while t < 60.0 {
        let d = decider.decide_from(&quiet_forecast(t), Some(&heave((0.8 * t).sin())));
        assert!(d.go && d.frozen_dof.is_none(), "t={t}: {d:?}");
        t += 0.5;
    }
    // The heave sensor sticks: go holds for less than STILL_AFTER_S of repeats, then the
    // deck says no go and names the sensor, with no probability.
    let stuck = heave((0.8 * (t - 0.5)).sin());
    while t < 60.0 + 2.0 * still::STILL_AFTER_S {
        let d = decider.decide_from(&quiet_forecast(t), Some(&stuck));
        let frozen = t - 59.5 >= still::STILL_AFTER_S;
        assert_eq!(d.go, !frozen, "t={t}: {d:?}");
        assert_eq!(d.frozen_dof, frozen.then_some(Dof::Heave), "t={t}: {d:?}");
        assert_eq!(d.probability_now.is_none(), frozen, "t={t}: {d:?}");
        assert!(!decider.may_go() || !frozen);
        t += 0.5;
    }
    let d = decider.decide_from(&quiet_forecast(t), Some(&stuck));
    assert!(
        d.summary().contains("heave sensor repeats its value"),
        "{}",
        d.summary()
    );
    // Statements verified during the stillness are statements about nothing.
    for _ in 0..300 {
        decider.add_outcome(n, 0.99, true);
    }
    assert_eq!(decider.statement_calls(), 800.0);
    // It moves again: the verified errors are gone, so no go until errors of the motion now
    // are verified, and the statements are those from before the stillness began.
    let d = decider.decide_from(&quiet_forecast(t + 0.5), Some(&heave(0.2)));
    assert!(
        d.frozen_dof.is_none() && d.awaiting_verified_errors && !d.go,
        "{d:?}"
    );
    assert!(decider.ensemble().is_empty());
    assert_eq!(decider.statement_calls(), 500.0);
    // A decision without recorded values (a deck that gets no motion) neither freezes nor thaws.
    let d = decider.decide(&quiet_forecast(t + 1000.0));
    assert!(
        d.frozen_dof.is_none() && d.awaiting_verified_errors,
        "{d:?}"
    );
}

/// Regressions (review): a stillness that began during another restored the statements made
/// during the first; a producer restart during a stillness kept the statements made in it.
#[test]
fn overlapping_stillnesses_and_a_restart_go_back_to_the_statements_before_any_of_them() {
    let config = DeckConfig {
        go_needs_verified_errors: true,
        ..config(5.0)
    };
    let mut decider = Decider::new(&config);
    let n = window_steps(5.0, 0.5);
    for _ in 0..500 {
        decider.add_outcome(n, 0.9, true);
    }
    let look = |decider: &mut Decider, t: f64, heave: f64, roll: f64| {
        decider.decide_from(&quiet_forecast(t), Some(&[0.0, 0.0, heave, roll, 0.0, 0.0]));
    };
    // Heave and roll move; heave sticks at 60 s, roll at 80 s.
    let mut t: f64 = 0.0;
    while t < 200.0 {
        let heave = if t < 60.0 { (0.8 * t).sin() } else { 0.3 };
        let roll = if t < 80.0 {
            0.02 * (0.7 * t).sin()
        } else {
            0.01
        };
        look(&mut decider, t, heave, roll);
        // Statements verified while heave is frozen (from 90 s), before roll's stillness began.
        if (95.0..105.0).contains(&t) {
            for _ in 0..10 {
                decider.add_outcome(n, 0.9, true);
            }
        }
        t += 0.5;
    }
    assert_eq!(decider.statement_calls(), 700.0);
    // Roll thaws first: back to before heave's stillness, not to roll's later copy.
    look(&mut decider, t, 0.3, 0.015);
    assert_eq!(decider.statement_calls(), 500.0);
    // Statements during heave's remaining stillness, then a new producer run while it is
    // frozen: they go as at a thaw.
    for _ in 0..50 {
        decider.add_outcome(n, 0.9, true);
    }
    look(&mut decider, 0.0, 0.3, 0.015);
    assert_eq!(decider.statement_calls(), 500.0);
}

/// Regression (review): a miss by a forecast that stated sigma 0 was taken as no error, so a
/// source of sigma-0 forecasts filled the ensemble with perfect forecasts and the deck said go
/// on them.
#[test]
fn a_miss_at_sigma_zero_is_an_error_beyond_any_limit_not_none() {
    let config = DeckConfig {
        go_needs_verified_errors: true,
        ..config(5.0)
    };
    let certain = forecast(40, |_| 1.0, 0.0);
    // What happened: roll 0.5 deg off at every step; the other DOFs as forecast (0), so
    // their sigma-0 tracks were exact.
    let happened = forecast(40, |_| 1.5, 0.0);
    let mut errors = Tracks::default();
    let mut miss = Decider::new(&config);
    let mut exact = Decider::new(&config);
    for _ in 0..ensemble::MIN_MEMBERS * ensemble::DEFAULT_STRIDE {
        for (decider, actual) in [(&mut miss, &happened), (&mut exact, &certain)] {
            decider.decide(&certain);
            let predicted = decider.tracks().clone();
            decider.fill_tracks(actual, &mut errors);
            decider.verify(&predicted, &errors);
        }
    }
    let mut u = [[f64::NAN; MAX_STEPS]; NUM_QUANTITIES];
    miss.decide(&certain);
    miss.fill_tracks(&happened, &mut errors);
    assert_eq!(standardised_errors(miss.tracks(), &errors, &mut u), 40);
    assert!(
        u[0][..40].iter().all(|&x| x == UNBOUNDED_ERROR),
        "{:?}",
        &u[0][..3]
    );
    assert!(u[1][..40].iter().all(|&x| x == 0.0), "{:?}", &u[1][..3]);
    // A forecast of 1 deg with sigma 0.1 deg (limit 2.5 deg): under errors that broke
    // sigma's promise every member breaks the limit; under exact ones every member holds.
    let quiet = forecast(40, |_| 1.0, 0.1f64.to_radians() as f32);
    let all = ensemble::MIN_MEMBERS as f64;
    let d = miss.decide(&quiet);
    assert_eq!(d.probability_now, Some(1.0 / (all + 2.0)), "{d:?}");
    assert!(!d.go, "{d:?}");
    let d = exact.decide(&quiet);
    assert_eq!(d.probability_now, Some((all + 1.0) / (all + 2.0)), "{d:?}");
    assert!(d.go, "{d:?}");
    // The source's next forecast states sigma 0 again: its misses still break the limit (put
    // on a sigma of 0 they would vanish).
    let d = miss.decide(&certain);
    assert_eq!(d.probability_now, Some(1.0 / (all + 2.0)), "{d:?}");
    assert!(!d.go, "{d:?}");
    let d = exact.decide(&certain);
    assert!(d.go, "{d:?}");
    // What counts as a miss at sigma 0: more than the values' rounding (a zero motion's deck
    // displacement is 0 or 9e-16 m by yaw); a missing value or sigma is no error.
    assert_eq!(standardised_error(8.9e-16, 0.0, 0.0), 0.0);
    assert_eq!(standardised_error(1.0 + 1e-7, 1.0, 0.0), 0.0);
    assert_eq!(standardised_error(0.0, 1e-3, 0.0), -UNBOUNDED_ERROR);
    assert!(standardised_error(0.5, 0.0, f64::NAN).is_nan());
    assert!(standardised_error(f64::NAN, 0.0, 0.0).is_nan());
    // A velocity from two rounded displacements of a metre (review), and an infinite mean.
    assert_eq!(standardised_error(1.2e-7, 0.0, 0.0), 0.0);
    assert_eq!(
        standardised_error(0.3, f64::INFINITY, 0.0),
        -UNBOUNDED_ERROR
    );
}
