//! Relative kinematics, alignment, the lift decision and the two-ship study on records with
//! known relations.

use super::calibrate::SigmaCalibration;
use super::shrink::MeanShrinkage;
use super::study::{study, StudyReport, STUDY_LEADS_S};
use super::*;
use crate::config::PipelineConfig;
use shipcast_series::motion_csv::{Column, MotionData};

fn forecast(time_s: f64, steps: u32, dof: [f32; 6], sigma: [f32; 6]) -> Forecast {
    let mut f = Forecast {
        time_s,
        dt_s: 0.5,
        steps,
        ..Forecast::default()
    };
    for d in 0..6 {
        for k in 0..steps as usize {
            f.mean[d][k] = dof[d];
            f.sigma[d][k] = sigma[d];
        }
    }
    f
}

fn geometry(tip: [f64; 3], spot: [f64; 3], psi_deg: f64) -> Geometry {
    let config = RelativeConfig {
        landing_spot_m: spot,
        target_position_m: [0.0, 40.0],
        target_heading_offset_deg: psi_deg,
        ..RelativeConfig::default()
    };
    Geometry::new(tip, &config)
}

fn relative(g: &Geometry, a: &Forecast, b: &Forecast) -> RelativeTrack {
    let mut t = RelativeTrack::default();
    t.fill(
        g,
        a,
        b,
        &SigmaCalibration::new(10.0, 10.0),
        &MeanShrinkage::new(true, 10.0, 10.0),
    )
    .unwrap();
    t
}

const NONE: [f32; 6] = [0.0; 6];

#[test]
fn relative_motion_follows_rigid_body_kinematics() {
    let g = geometry([0.0, 15.0, -20.0], [0.0, -8.0, -6.0], 0.0);
    // A heaves 1 m down: the tip goes down 1 m against a still spot.
    let heave = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    let t = relative(
        &g,
        &forecast(0.0, 4, heave, NONE),
        &forecast(0.0, 4, NONE, NONE),
    );
    assert!((t.mean[2][0] - 1.0).abs() < 1e-6 && t.mean[0][0].abs() < 1e-9);
    // Both heave the same: no relative motion.
    let t = relative(
        &g,
        &forecast(0.0, 4, heave, NONE),
        &forecast(0.0, 4, heave, NONE),
    );
    assert!(t.mean[2][3].abs() < 1e-6);
    // A small roll phi of A moves the tip (y 15, z -20) by (0, 20 phi, 15 phi) to first order.
    let phi = 1e-3f32;
    let roll = [0.0, 0.0, 0.0, phi, 0.0, 0.0];
    let t = relative(
        &g,
        &forecast(0.0, 4, roll, NONE),
        &forecast(0.0, 4, NONE, NONE),
    );
    assert!((t.mean[1][0] - 20.0 * f64::from(phi)).abs() < 1e-5);
    assert!((t.mean[2][0] - 15.0 * f64::from(phi)).abs() < 1e-5);
    // B turned 90 deg to starboard: B's surge is A's sway, so the spot moving 1 m along B's
    // bow moves the tip 1 m to A's port relative to it.
    let g = geometry([0.0, 15.0, -20.0], [0.0, 0.0, 0.0], 90.0);
    let surge = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let t = relative(
        &g,
        &forecast(0.0, 4, NONE, NONE),
        &forecast(0.0, 4, surge, NONE),
    );
    assert!((t.mean[1][0] + 1.0).abs() < 1e-6 && t.mean[0][0].abs() < 1e-6);
    // Rest vector: tip (0, 15, -20) minus B's CG (0, 40) minus the spot (0).
    assert_eq!(g.rest_m(), [0.0, -25.0, -20.0]);
}

#[test]
fn independent_sigma_adds_both_ships_linearised_variances() {
    let g = geometry([0.0, 15.0, -20.0], [30.0, 0.0, 0.0], 90.0);
    // A: heave 0.3 m, roll 0.01 rad -> tip z variance 0.09 + (15 * 0.01)^2.
    let a = forecast(0.0, 4, NONE, [0.0, 0.0, 0.3, 0.01, 0.0, 0.0]);
    // B: pitch 0.02 rad at 30 m forward -> spot z variance (30 * 0.02)^2; surge 0.5 m turned
    // 90 deg lands on A's y.
    let b = forecast(0.0, 4, NONE, [0.5, 0.0, 0.0, 0.0, 0.02, 0.0]);
    let t = relative(&g, &a, &b);
    let z = (0.09f64 + 0.0225 + 0.36).sqrt();
    assert!(
        (t.sigma_independent[2][0] - z).abs() < 1e-6,
        "{}",
        t.sigma_independent[2][0]
    );
    // y: A's roll at z = -20 (20 * 0.01) and B's surge 0.5.
    let y = (0.04f64 + 0.25).sqrt();
    assert!((t.sigma_independent[1][0] - y).abs() < 1e-6);
    assert_eq!(t.basis, SigmaBasis::Independent);
    assert_eq!(t.sigma, t.sigma_independent);
}

#[test]
fn a_points_variance_turned_to_a_heading_matches_a_monte_carlo_of_its_displacement() {
    // Regression: the x-y covariance that yaw gives a point off both axes was dropped, so on a
    // ship turned 45 deg a spot at (10, 10), with a yaw sigma of 0.01 rad alone, had its x
    // sigma 0.10 m where it is 0.14 m.
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let point = ShipPoint::new([10.0, 10.0, -6.0]);
    let sigma = [0.05, 0.04, 0.3, 0.01, 0.008, 0.01];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    for psi_deg in [0.0f64, 45.0, 120.0] {
        let psi = psi_deg.to_radians();
        let f = forecast(0.0, 1, NONE, sigma.map(|s| s as f32));
        let mut track = PointTrack::default();
        track.fill(&point, psi, &f, 0, 1);
        // Small angles: the linearisation is exact to a few parts in a thousand.
        let n = 200_000;
        let mut sum_sq = [0.0; 3];
        for _ in 0..n {
            let dof: [f64; 6] =
                std::array::from_fn(|d| Normal::new(0.0, sigma[d]).unwrap().sample(&mut rng));
            let m = point_displacement(&point, psi, dof);
            for (sum, v) in sum_sq.iter_mut().zip(m) {
                *sum += v * v;
            }
        }
        for (a, (sum, var)) in sum_sq.iter().zip(&track.var).enumerate() {
            let mc = (sum / n as f64).sqrt();
            let stated = var[0].sqrt();
            // 200 000 draws: the sample sigma is within about 0.5 % (3 standard errors).
            assert!(
                (stated / mc - 1.0).abs() < 0.01,
                "psi {psi_deg} axis {a}: stated {stated}, Monte Carlo {mc}"
            );
        }
    }
}

#[test]
fn forecasts_are_aligned_on_the_later_origin() {
    let g = geometry([0.0; 3], [0.0; 3], 0.0);
    let mut a = forecast(10.0, 8, NONE, NONE);
    let b = forecast(11.0, 8, NONE, NONE);
    // A's step k is at 10 + (k + 1) 0.5: its steps 2.. meet B's 0..
    for k in 0..8 {
        a.mean[2][k] = k as f32;
    }
    let t = relative(&g, &a, &b);
    assert_eq!(
        (t.alignment.skip_a, t.alignment.skip_b, t.steps()),
        (2, 0, 6)
    );
    assert_eq!(t.alignment.time_s, 11.0);
    assert!((t.mean[2][0] - 2.0).abs() < 1e-9);
    let al = align(&forecast(10.1, 8, NONE, NONE), &b).unwrap();
    assert_eq!(al.skip_a, 2);
    assert!((al.misalignment_s - (-0.1)).abs() < 1e-9);
    assert!(matches!(
        align(&forecast(0.0, 8, NONE, NONE), &b),
        Err(AlignError::TooFarApart(_))
    ));
    let mut other = b;
    other.dt_s = 0.25;
    assert!(matches!(
        align(&a, &other),
        Err(AlignError::StepMismatch(..))
    ));
}

#[test]
fn each_ship_is_verified_at_its_own_steps_on_sample_grids_out_of_phase() {
    // Regression: both ships' motion was looked up at the later ship's step times, so with
    // B sampling 60 ms off A's grid every relative forecast was unverifiable.
    use crate::observed::MotionHistory;
    use shipcast_wire::payload::MotionSample;
    let g = geometry([0.0; 3], [0.0; 3], 0.0);
    // Heave is the record time itself: what is looked up says when it was recorded.
    let history = |offset_s: f64| {
        let mut h = MotionHistory::new(8.0, 60.0);
        for i in 0..(8 * 40) {
            let time_s = offset_s + i as f64 / 8.0;
            h.push(&MotionSample {
                seq: i,
                stamp_ns: 0,
                time_s,
                dof: [0.0, 0.0, time_s, 0.0, 0.0, 0.0],
            });
        }
        h
    };
    let (ha, hb) = (history(0.0), history(0.06));
    // The latest forecasts: A's at 10.0 on its grid, B's at 9.56 on its own.
    for (a_s, b_s) in [(10.0, 9.56), (9.5, 10.06)] {
        let t = relative(
            &g,
            &forecast(a_s, 20, NONE, NONE),
            &forecast(b_s, 20, NONE, NONE),
        );
        let (mut tip, mut spot) = (Vec::new(), Vec::new());
        assert!(
            verify::observed(&t, &g, &ha, &hb, &mut tip, &mut spot),
            "{:?}",
            t.alignment
        );
        assert_eq!(tip.len(), t.steps());
        for k in 0..t.steps() {
            // Each ship's own step k (after the older one's skip) on its own clock.
            let (ka, kb) = (k + t.alignment.skip_a, k + t.alignment.skip_b);
            assert!(
                (tip[k][2] - (a_s + (ka + 1) as f64 * 0.5)).abs() < 1e-9,
                "{k}"
            );
            assert!(
                (spot[k][2] - (b_s + (kb + 1) as f64 * 0.5)).abs() < 1e-9,
                "{k}"
            );
        }
    }
}

#[test]
fn a_vessel_whose_forecasts_stopped_is_not_paired_though_its_last_still_overlaps() {
    // Regression: the target's last forecast was paired with every new one of the crane
    // vessel, its steps shifted, until they no longer overlapped.
    let mut currency = PairCurrency::default();
    // Two producers 3 s apart on their record clocks: current, whatever the offset.
    for k in 0..10 {
        currency.arrived(0, 100.0 + 0.5 * k as f64);
        currency.arrived(1, 97.0 + 0.5 * k as f64);
        assert_eq!(currency.check(2.0), Ok(()));
    }
    // The target falls silent after its forecast of 101.5 (the crane vessel's of 104.5 came
    // before it): 2 s of the crane vessel's forecasts after that are tolerated, no more.
    let last_target = forecast(101.5, 50, NONE, NONE);
    for k in 1..=5 {
        currency.arrived(0, 104.5 + 0.5 * k as f64);
        assert_eq!(currency.check(2.0), Ok(()), "{k}");
    }
    currency.arrived(0, 107.5);
    let crane = forecast(107.5, 50, NONE, NONE);
    // Still overlapping (so `align` alone would pair them), but not current.
    assert!(align(&crane, &last_target).is_ok());
    assert!(matches!(
        currency.check(2.0),
        Err(AlignError::Stale("the target vessel", advanced, _)) if (advanced - 2.5).abs() < 1e-12
    ));
    // It speaks again, 2.5 s on: current (its own silence left nobody behind). A clock
    // that goes back advances nothing.
    currency.arrived(1, 104.0);
    assert_eq!(currency.check(2.0), Ok(()));
    currency.arrived(1, 0.0);
    currency.arrived(1, 0.5);
    assert_eq!(currency.check(2.0), Ok(()));
    for k in 0..5 {
        currency.arrived(1, 1.0 + 0.5 * k as f64);
    }
    assert!(matches!(
        currency.check(2.0),
        Err(AlignError::Stale("the crane vessel", ..))
    ));
}

#[test]
fn the_lift_decision_flips_when_the_relative_motion_crosses_a_limit() {
    // No verified errors yet, and the Gaussian model allowed to decide.
    let config = RelativeConfig {
        go_needs_verified_errors: false,
        ..RelativeConfig::default()
    };
    let mut lift = LiftDecider::new(LiftLimits::new(&config));
    let unverified = LiftEvidence::new(*lift.limits());
    let g = geometry([0.0; 3], [0.0; 3], 0.0);
    let calm = [0.0, 0.0, 0.5, 0.0, 0.0, 0.0];
    let sigma = [0.05, 0.05, 0.05, 0.0, 0.0, 0.0];
    let still = forecast(0.0, 50, NONE, NONE);
    let mut t = relative(&g, &forecast(0.0, 50, calm, sigma), &still);
    let d = lift.decide(&mut t, &unverified);
    assert!(d.go, "{d:?}");
    assert!(d.probability_now.unwrap() > 0.99);
    assert_eq!(d.ensemble_members, 0);
    assert_eq!(d.next_exceedance_s, None);
    // 1.2 m relative heave from step 10 on: beyond the 1 m limit inside the MOT.
    let mut rough = forecast(0.0, 50, calm, sigma);
    for k in 9..50 {
        rough.mean[2][k] = 1.2;
    }
    let mut t = relative(&g, &rough, &still);
    let d = lift.decide(&mut t, &unverified);
    assert!(!d.go && d.probability_now.unwrap() < 0.01, "{d:?}");
    assert_eq!(d.next_exceedance_s, Some(5.0));
    // Beyond the limit to the horizon's end: no window to go in. Go now: the window from the
    // first step.
    assert_eq!((d.next_window_s, d.next_window_probability), (None, None));
    let mut t = relative(&g, &forecast(0.0, 50, calm, sigma), &still);
    let now = lift.decide(&mut t, &unverified);
    assert_eq!(now.next_window_s, Some(0.5));
    assert_eq!(now.next_window_probability, now.probability_now);
    // Regression (review): the lift stated no next window, and the display read every no-go
    // as "no go window within the horizon". Rough for steps 9..30 only: the first window of
    // MOT (10 s, 20 steps) whose mean holds starts at step 30, 15.5 s ahead.
    for k in 30..50 {
        rough.mean[2][k] = 0.5;
    }
    let mut t = relative(&g, &rough, &still);
    let d = lift.decide(&mut t, &unverified);
    assert!(!d.go, "{d:?}");
    assert_eq!(d.next_window_s, Some(15.5), "{d:?}");
    assert!(d.next_window_probability.unwrap() >= config.go_probability);
    let line = advisory(&t, &g, ("ddg51", "supply"), (7, 9), d).summary();
    assert!(line.contains("next go window in 15.5s"), "{line}");
    // A forecast shorter than the MOT decides nothing.
    let mut t = relative(
        &g,
        &forecast(0.0, 10, calm, sigma),
        &forecast(0.0, 10, NONE, NONE),
    );
    let d = lift.decide(&mut t, &unverified);
    assert!(!d.go && d.probability_now.is_none());
    // The advisory carries the published steps and survives JSON.
    let adv = advisory(&t, &g, ("ddg51", "supply"), (7, 9), d);
    assert_eq!(adv.mean_m[2].len(), 10);
    let back: RelativeAdvisory =
        serde_json::from_str(&serde_json::to_string(&adv).unwrap()).unwrap();
    assert_eq!(back, adv);
    assert!(adv.summary().contains("ddg51->supply"), "{}", adv.summary());
}

/// A record of heave, roll and pitch at 2 Hz: two sines per DOF with a phase `shift`.
fn record(seconds: f64, shift: f64) -> MotionData {
    let n = (seconds * 2.0) as usize;
    let time: Vec<f64> = (0..n).map(|i| i as f64 / 2.0).collect();
    let wave = |amp: f64, period: f64, t: f64| {
        amp * (std::f64::consts::TAU * t / period + shift).sin()
            + 0.4 * amp * (std::f64::consts::TAU * t / (period * 1.37) + shift).sin()
    };
    let column = |name: &str, amp: f64, period: f64| Column {
        name: name.into(),
        values: time.iter().map(|&t| wave(amp, period, t)).collect(),
    };
    MotionData {
        ignored: Vec::new(),
        columns: vec![
            column("heave_m", 1.0, 9.0),
            column("roll_rad", 0.03, 11.0),
            column("pitch_rad", 0.01, 7.5),
        ],
        time,
    }
}

/// A study configuration for short records (first fit at 120 s, sigma calibrated after 20
/// verified forecasts) with the tip and the spot at the same lever arm and B at the same
/// heading: two identical records have no relative motion.
fn same_point_config() -> PipelineConfig {
    let mut config = PipelineConfig::default();
    config.predictor.first_fit_s = 120.0;
    config.relative.calibration_min_verified = 20.0;
    config.crane.tip_m = [10.0, 5.0, -6.0];
    config.relative.landing_spot_m = [10.0, 5.0, -6.0];
    config.relative.target_heading_offset_deg = 0.0;
    config
}

#[test]
fn the_study_scores_the_relative_forecast_against_the_records() {
    // Two identical records: the relative forecast is exactly zero.
    let config = same_point_config();
    let a = record(900.0, 0.0);
    let (same, own_a, _) = study(&a, &a, &config, (None, None), 300.0, &|_| {}).unwrap();
    assert!(same.scored > 500, "{}", same.scored);
    assert_eq!(same.leads.len(), 3 * STUDY_LEADS_S.len());
    for l in &same.leads {
        assert_eq!(l.relative_rms, 0.0, "{l:?}");
        assert_eq!(l.relative_zero_rms, 0.0);
    }
    let heave = same
        .leads
        .iter()
        .find(|l| l.axis == "z" && l.lead_s == 10.0)
        .unwrap();
    assert!(heave.tip_rms > 0.0 && (heave.tip_rms - heave.spot_rms).abs() < 1e-12);
    assert!((heave.error_correlation - 1.0).abs() < 1e-9);
    // No relative motion: every lift window held, so nothing can be a false go, and the
    // verified errors (none) back go calls once enough of them exist.
    let lift = &same.lift;
    assert!(lift.calls > 0 && lift.go_calls > 0, "{lift:?}");
    assert_eq!((lift.base_rate, lift.false_go_rate), (1.0, 0.0), "{lift:?}");
    assert_eq!(lift.brier_climatology, 0.0);
    // The own heave forecast of ship A is the plain replay's.
    let own = same
        .own
        .iter()
        .find(|o| o.vessel == "crane" && o.dof == "heave")
        .unwrap();
    let d = own_a.dofs.iter().find(|d| d.dof == "heave").unwrap();
    assert_eq!(own.rms[1], d.rms[19]);
    // B the negative of A (every sine shifted by pi): the engine is linear, so B's forecasts
    // are the negatives of A's; up to the second-order terms of the rotations the relative
    // motion and error are twice A's and the errors perfectly anti-correlated, so the
    // calibrated sigma is wider than the independent sqrt(2) sigma_A (errors that add). By how
    // much depends on how A's own sigma held on this record (the calibration's exact scale is
    // checked against a Monte Carlo in `calibrate`). The raw difference, unshrunk, for these
    // exact relations; shrunk below.
    let b = record(900.0, std::f64::consts::PI);
    let mut raw = config.clone();
    raw.relative.shrink_mean = false;
    let (opposite, _, _) = study(&a, &b, &raw, (None, None), 300.0, &|_| {}).unwrap();
    let z = opposite
        .leads
        .iter()
        .find(|l| l.axis == "z" && l.lead_s == 10.0)
        .unwrap();
    let near = |x: f64, y: f64| (x - y).abs() < 0.01 * y;
    assert!(near(z.relative_zero_rms, 2.0 * z.tip_zero_rms), "{z:?}");
    assert!(near(z.relative_rms, 2.0 * z.tip_rms), "{z:?}");
    assert!(z.error_correlation < -0.99, "{z:?}");
    assert!(opposite.calibrated_from_s.is_some());
    assert!(z.mean_sigma > 1.2 * z.mean_sigma_independent, "{z:?}");
    // Twice A's heave (up to 2.8 m, two sines of 9 and 12 s) against the 1 m vertical limit:
    // every window of 10 s breaks; the verified errors say so, and nothing is a go.
    let lift = &opposite.lift;
    assert!(lift.calls > 0 && lift.go_calls == 0, "{lift:?}");
    assert_eq!(lift.base_rate, 0.0);
    assert!(lift.brier < 0.01, "{lift:?}");
    // Shrunk by verified forecasts, the relative mean is at every lead and axis no worse than
    // predicting no relative motion, and not worse than the raw difference by more than a
    // factor 0.02 off would add (2 % of the relative motion: the causal estimate's noise; on
    // these nearly exact forecasts the raw error is itself about 1 % of the motion).
    let (shrunk, _, _) = study(&a, &b, &config, (None, None), 300.0, &|_| {}).unwrap();
    for (s, r) in shrunk.leads.iter().zip(&opposite.leads) {
        assert_eq!((s.axis, s.lead_s), (r.axis, r.lead_s));
        assert!(s.relative_rms <= s.relative_zero_rms, "{s:?}");
        let slack = 0.02 * s.relative_zero_rms;
        assert!(
            s.relative_rms <= r.relative_rms + slack,
            "{s:?} against {r:?}"
        );
    }
    // The lift decides on the raw difference and its own sigma: the shrinkage of the issued
    // mean leaves every statement as it was.
    let (l, r) = (&shrunk.lift, &opposite.lift);
    assert_eq!(
        (l.calls, l.go_calls, l.brier),
        (r.calls, r.go_calls, r.brier)
    );
    assert_eq!(shrunk.lift_gaussian.brier, opposite.lift_gaussian.brier);
    for (s, r) in shrunk.leads.iter().zip(&opposite.leads) {
        assert_eq!(s.relative_raw_rms, r.relative_rms, "{s:?}");
    }
}

/// Where the relative motion is unpredictable noise between two ships that move together, the
/// raw difference of their forecasts only adds the difference of their errors and is worse
/// than predicting no relative motion; the shrunk mean is not.
#[test]
fn a_difference_worse_than_no_relative_motion_is_shrunk_towards_none() {
    let report = noise_pair_study();
    let z: Vec<_> = report.leads.iter().filter(|l| l.axis == "z").collect();
    assert_eq!(z.len(), STUDY_LEADS_S.len());
    for l in z {
        assert!(l.relative_raw_rms > l.relative_zero_rms, "{l:?}");
        // At least half of the raw difference's excess over no relative motion is removed,
        // and what is issued is within 2 % of no relative motion.
        let excess = l.relative_raw_rms - l.relative_zero_rms;
        assert!(l.relative_rms < l.relative_raw_rms - 0.5 * excess, "{l:?}");
        assert!(l.relative_rms <= 1.02 * l.relative_zero_rms, "{l:?}");
    }
}

/// The study of a pair that moves together but for white noise: B heaves as A does plus 0.1 m
/// of it, so the relative motion is the noise alone. 900 s, scored from 300 s.
fn noise_pair_study() -> StudyReport {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let config = same_point_config();
    let a = record(900.0, 0.0);
    let mut b = a.clone();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    let noise = Normal::new(0.0, 0.1).unwrap();
    for v in &mut b.columns[0].values {
        *v += noise.sample(&mut rng);
    }
    study(&a, &b, &config, (None, None), 300.0, &|_| {})
        .unwrap()
        .0
}

/// Regression: in the pair's first quarter hour B's own heave sigma falls from the motion's
/// std towards its error while the relative error (the noise) stays 0.1 m. The calibration's
/// ten-minute memory kept the ratio of the no-skill minutes, and the relative sigma covered
/// 57-60 % of the errors within +-1 sigma and 86-88 % within +-2 sigma at every lead.
/// `SigmaScale::adaptive`'s memory grows with its evidence (65-68 % and 93-95 % now).
#[test]
fn a_relative_sigma_learnt_in_the_no_skill_minutes_is_not_kept_too_narrow() {
    let report = noise_pair_study();
    let z: Vec<_> = report.leads.iter().filter(|l| l.axis == "z").collect();
    assert_eq!(z.len(), STUDY_LEADS_S.len());
    for l in z {
        assert!(l.scored > 1000, "{l:?}");
        assert!(l.coverage_1sigma >= 0.64, "{l:?}");
        assert!(l.coverage_2sigma >= 0.92, "{l:?}");
        // Not by a sigma inflated past the errors either.
        assert!(l.mean_sigma < 1.1 * l.relative_rms, "{l:?}");
    }
}

#[test]
fn verified_errors_decide_the_lift_once_enough_exist() {
    use crate::decision::ensemble::MIN_MEMBERS;
    use crate::decision::recalibrate::SHRINK_CALLS;
    let config = RelativeConfig::default();
    let mut lift = LiftDecider::new(LiftLimits::new(&config));
    let mut evidence = LiftEvidence::new(*lift.limits());
    // Every verified forecast said no relative motion (z = 0) and the tip then rose exactly
    // one sigma on every axis at every step (u = 1).
    let ones = [[1.0; MAX_STEPS]; 3];
    let zeros = [[0.0; MAX_STEPS]; 3];
    let g = geometry([0.0; 3], [0.0; 3], 0.0);
    let still = forecast(0.0, 50, NONE, NONE);
    let sigma = [0.5, 0.5, 0.5, 0.0, 0.0, 0.0];
    // Paths verified while the horizon was 5 s are too short for a window of MOT 10 s: a
    // ready ensemble without one usable path states nothing, and says it waits for them.
    let mut short = LiftEvidence::new(*lift.limits());
    for _ in 0..MIN_MEMBERS * 4 {
        short.ensemble.offer(&ones, &zeros, 10);
    }
    assert!(short.ensemble.ready());
    let mut calm = relative(&g, &forecast(0.0, 50, NONE, [0.05; 6]), &still);
    let d = lift.decide(&mut calm, &short);
    assert!(
        d.probability_now.is_none() && d.awaiting_verified_errors && !d.go,
        "{d:?}"
    );
    // Ten long paths among them are too few to state a probability from; once as many cover
    // the window as make the ensemble ready, only those stand behind it.
    for _ in 0..10 * 4 {
        short.ensemble.offer(&ones, &zeros, 50);
    }
    let d = lift.decide(&mut calm, &short);
    assert!(
        d.probability_now.is_none() && d.awaiting_verified_errors,
        "{d:?}"
    );
    for _ in 0..(MIN_MEMBERS - 10) * 4 {
        short.ensemble.offer(&ones, &zeros, 50);
    }
    let d = lift.decide(&mut calm, &short);
    assert_eq!(d.ensemble_members, MIN_MEMBERS, "{d:?}");
    assert_eq!(short.ensemble.len(), 2 * MIN_MEMBERS);
    assert!(d.probability_now.is_some() && !d.awaiting_verified_errors);
    // Relative heave 0.6 m with sigma 0.5 m (per axis, the independent sum of A's and B's):
    // what happened before puts the tip at mean + sigma, beyond the 1 m limit.
    let mut near = relative(
        &g,
        &forecast(0.0, 50, [0.0, 0.0, 0.6, 0.0, 0.0, 0.0], sigma),
        &still,
    );
    let s = near.sigma[2][0];
    assert!(0.6 + s > config.vertical_limit_m && 0.2 + s < config.vertical_limit_m);
    for _ in 0..(MIN_MEMBERS - 1) * 4 {
        evidence.ensemble.offer(&ones, &zeros, 50);
    }
    // One member short (one verified forecast in 4 is kept): by default nothing is stated
    // before verified errors, nor recorded.
    let d = lift.decide(&mut near, &evidence);
    assert_eq!((d.ensemble_members, near.lift_statement), (0, None));
    assert!(
        d.awaiting_verified_errors && d.probability_now.is_none() && !d.go,
        "{d:?}"
    );
    // A calm forecast too: the Gaussian model would say go.
    let mut calm = relative(&g, &forecast(0.0, 50, NONE, [0.05; 6]), &still);
    let d = lift.decide(&mut calm, &evidence);
    assert!(lift.gaussian_probability(&calm).unwrap() > 0.99);
    assert!(d.awaiting_verified_errors && !d.go, "{d:?}");
    evidence.ensemble.offer(&ones, &zeros, 50);
    let n = MIN_MEMBERS as f64;
    let d = lift.decide(&mut near, &evidence);
    assert_eq!(d.ensemble_members, MIN_MEMBERS);
    assert!(!d.awaiting_verified_errors);
    // Every member breaks the limit: only the broken-or-held pseudo-members' share is left.
    assert!(
        (d.probability_now.unwrap() - 1.0 / (n + 2.0)).abs() < 1e-12,
        "{d:?}"
    );
    // The same forecast calm from step 20 on (10.5 s): the verified paths put the tip at
    // sigma there, within the limit, so the next window of MOT starts then.
    let mut easing = forecast(0.0, 50, [0.0, 0.0, 0.6, 0.0, 0.0, 0.0], sigma);
    for k in 20..50 {
        easing.mean[2][k] = 0.0;
    }
    let mut easing = relative(&g, &easing, &still);
    let later = lift.decide(&mut easing, &evidence);
    assert!(
        !later.go && later.ensemble_members == MIN_MEMBERS,
        "{later:?}"
    );
    assert_eq!(later.next_window_s, Some(10.5), "{later:?}");
    let p = later.next_window_probability.unwrap();
    assert!(
        p >= config.go_probability && p <= (n + 1.0) / (n + 2.0),
        "{later:?}"
    );
    // Regression (review): paths one step shorter than the track, enough for the decision's
    // window, gave no later window at all: they judge windows as far as they reach.
    let mut shorter = LiftEvidence::new(*lift.limits());
    for _ in 0..MIN_MEMBERS * 4 {
        shorter.ensemble.offer(&ones, &zeros, 49);
    }
    let d = lift.decide(&mut easing, &shorter);
    assert_eq!(d.ensemble_members, MIN_MEMBERS, "{d:?}");
    assert_eq!(d.next_window_s, Some(10.5), "{d:?}");
    assert_eq!(near.lift_statement, d.probability_now);
    assert!(!d.go);
    // 0.2 m of relative heave: every member holds (0.2 + sigma < 1 m, and x, y stay within
    // the horizontal limit).
    let mut low = relative(
        &g,
        &forecast(0.0, 50, [0.0, 0.0, 0.2, 0.0, 0.0, 0.0], sigma),
        &still,
    );
    assert!(low.sigma[0][0] < config.horizontal_limit_m);
    let raw = (n + 1.0) / (n + 2.0);
    let d = lift.decide(&mut low, &evidence);
    assert!((d.probability_now.unwrap() - raw).abs() < 1e-12, "{d:?}");
    assert!(d.go);
    // Earlier calls stated the same and every one of their windows broke: the statement is
    // moved down by their mean miss, shrunk by m / (m + SHRINK_CALLS).
    let m = SHRINK_CALLS;
    for _ in 0..m as usize {
        evidence.statements.add(raw, false);
    }
    let d = lift.decide(&mut low, &evidence);
    assert!(
        (d.probability_now.unwrap() - raw / 2.0).abs() < 1e-9,
        "{d:?}"
    );
    assert!(!d.go);
    // The uncorrected statement is what its outcome is recorded against.
    assert_eq!(low.lift_statement, Some(raw));
}

#[test]
fn verification_records_a_lift_statement_against_whether_its_window_held() {
    use crate::decision::recalibrate::SHRINK_CALLS;
    let config = RelativeConfig::default();
    let limits = LiftLimits::new(&config);
    let g = geometry([0.0; 3], [0.0; 3], 0.0);
    let sigma = [0.5, 0.5, 0.5, 0.0, 0.0, 0.0];
    let mut t = relative(
        &g,
        &forecast(0.0, 50, NONE, sigma),
        &forecast(0.0, 50, NONE, NONE),
    );
    let window = limits.window_steps(t.dt_s);
    let mut evidence = LiftEvidence::new(limits);
    // A forecast the Gaussian model decided on: nothing recorded.
    let calm = vec![[0.0, 0.0, 0.5]; 50];
    evidence.learn(&t, &calm);
    assert_eq!(evidence.statements.calls(), 0.0);
    // Stated 0.7 and held over the whole window.
    t.lift_statement = Some(0.7);
    evidence.learn(&t, &calm);
    assert_eq!(evidence.statements.calls(), 1.0);
    let up = 0.7 + 0.3 / (1.0 + SHRINK_CALLS);
    assert!((evidence.statements.correct(0.7, limits.go_probability) - up).abs() < 1e-12);
    // Stated 0.7 and the last step of the window went 1.2 m: broken. After it, nothing
    // counts.
    let mut rough = calm.clone();
    rough[window - 1][2] = 1.2;
    rough[window][2] = 5.0;
    evidence.learn(&t, &rough);
    let mean_miss = (1.0 - 1.4) / (2.0 + SHRINK_CALLS);
    assert!(
        (evidence.statements.correct(0.7, limits.go_probability) - (0.7 + mean_miss)).abs() < 1e-12
    );
    let mut late = calm;
    late[window][2] = 5.0;
    evidence.learn(&t, &late);
    let mean_miss = (2.0 - 2.1) / (3.0 + SHRINK_CALLS);
    assert!(
        (evidence.statements.correct(0.7, limits.go_probability) - (0.7 + mean_miss)).abs() < 1e-12
    );
}

/// Regression (review): a lift forecast that stated sigma 0 and missed gave an infinite
/// standardised error, which the ensemble takes as none, so its misses taught the lift that
/// forecasts are exact and it said go.
#[test]
fn a_lift_miss_at_sigma_zero_is_an_error_beyond_any_limit_not_none() {
    use crate::decision::ensemble::MIN_MEMBERS;
    let config = RelativeConfig::default();
    let mut lift = LiftDecider::new(LiftLimits::new(&config));
    let g = geometry([0.0; 3], [0.0; 3], 0.0);
    let still = forecast(0.0, 50, NONE, NONE);
    let certain = relative(&g, &still, &still);
    assert!(certain.raw_sigma[2][..50].iter().all(|&s| s == 0.0));
    let mut missed = LiftEvidence::new(*lift.limits());
    let mut exact = LiftEvidence::new(*lift.limits());
    for _ in 0..MIN_MEMBERS * 4 {
        missed.learn(&certain, &[[0.0, 0.0, 0.3]; 50]);
        exact.learn(&certain, &[[0.0; 3]; 50]);
    }
    let n = MIN_MEMBERS as f64;
    let mut calm = relative(&g, &forecast(0.0, 50, NONE, [0.05; 6]), &still);
    let d = lift.decide(&mut calm, &missed);
    assert_eq!(d.ensemble_members, MIN_MEMBERS, "{d:?}");
    assert!(
        (d.probability_now.unwrap() - 1.0 / (n + 2.0)).abs() < 1e-12 && !d.go,
        "{d:?}"
    );
    let d = lift.decide(&mut calm, &exact);
    assert!(
        (d.probability_now.unwrap() - (n + 1.0) / (n + 2.0)).abs() < 1e-12 && d.go,
        "{d:?}"
    );
    // The next forecast states sigma 0 again: the misses still break the limit.
    let mut again = certain.clone();
    let d = lift.decide(&mut again, &missed);
    assert!(
        (d.probability_now.unwrap() - 1.0 / (n + 2.0)).abs() < 1e-12 && !d.go,
        "{d:?}"
    );
}

/// A ship whose recorded heave is `h(t)` at every time asked, roll and pitch following it.
struct HeaveRecord<F: Fn(f64) -> f64>(F);

impl<F: Fn(f64) -> f64> crate::observed::ObservedMotion for HeaveRecord<F> {
    fn dof_at(&self, t: f64) -> Option<[f64; 6]> {
        let h = (self.0)(t);
        Some([0.0, 0.0, h, 0.1 * h, 0.05 * h, 0.0])
    }
}

/// Regression: the lift had no watch of frozen sensors (the deck has had one since
/// 2026-12-04). A target whose heave sensor stuck left the lift saying go on verified errors
/// of a motion that was not there, and kept that evidence when the sensor moved again.
#[test]
fn a_frozen_sensor_on_either_ship_stops_the_lift_and_its_thaw_drops_the_evidence() {
    use super::still::Ship;
    use super::verify::RelativeVerifier;
    use crate::decision::ensemble::MIN_MEMBERS;
    use crate::decision::still::STILL_AFTER_S;
    let config = RelativeConfig::default();
    let g = geometry([0.0; 3], [0.0; 3], 0.0);
    let mut lift = LiftDecider::new(LiftLimits::new(&config));
    let mut verifier = RelativeVerifier::from_config(&config, 64).watching_live();
    // Verified errors of zero on every axis and step: a calm forecast is a go.
    let zeros = [[0.0; MAX_STEPS]; 3];
    for _ in 0..MIN_MEMBERS * 4 {
        verifier.lift.ensemble.offer(&zeros, &zeros, 50);
    }
    // Calls verified before the stillness, which its thaw must keep.
    for _ in 0..5 {
        verifier.lift.statements.add(0.99, true);
    }
    let crane = HeaveRecord(|t: f64| (0.7 * t).sin());
    // The target's heave holds one value from 100 s until it moves again at 200 s.
    let target = HeaveRecord(|t: f64| (0.7 * t.clamp(0.0, 100.0)).sin() + (t - 200.0).max(0.0));
    let calm = |t: f64| {
        let f = forecast(t, 50, NONE, [0.05; 6]);
        relative(&g, &f, &f)
    };
    // A relative sigma calibrated on verified forecasts (of 1 cm errors).
    let observed = vec![[0.01; 3]; 50];
    for _ in 0..2 * config.calibration_min_verified as usize {
        let c = &mut verifier.calibration;
        c.observe(
            &calm(0.0),
            &observed,
            &vec![[0.0; 3]; 50],
            &verifier.shrinkage,
        );
    }
    assert!(verifier.calibration.scale(2, 0).is_some());
    let mut t = 0.0;
    while t <= 200.0 {
        verifier.watch_sensors([t, t], &crane, &target);
        let mut track = calm(t);
        let d = lift.decide(&mut track, &verifier.lift);
        if (100.0 + STILL_AFTER_S..=200.0).contains(&t) {
            assert!(
                !d.go && d.probability_now.is_none() && !d.awaiting_verified_errors,
                "t={t}: {d:?}"
            );
            assert_eq!(
                (d.frozen_ship, d.frozen_dof),
                (Some(Ship::Target), Some(Dof::Heave)),
                "t={t}"
            );
            assert!(track.lift_statement.is_none());
            // A call verified during the stillness: a statement about nothing.
            verifier.lift.statements.add(0.99, true);
        } else {
            assert!(d.go && d.frozen_dof.is_none(), "t={t}: {d:?}");
        }
        verifier.push(&track);
        t += 0.5;
    }
    assert_eq!(verifier.pending(), 64);
    // The target moves again: the verified errors go, the statements go back to the five of
    // before the stillness, the forecasts waiting for their horizon are dropped, and go waits
    // for errors verified on the motion as it is now.
    verifier.watch_sensors([200.5, 200.5], &crane, &target);
    assert!(verifier.lift.ensemble.is_empty());
    assert_eq!(verifier.lift.statements.calls(), 5.0);
    assert_eq!((verifier.pending(), verifier.dropped_at_thaw), (0, 64));
    // The calibration learnt before and during the stillness starts afresh (review: learnt
    // while one ship's errors were those of nothing, it left the relative sigma too narrow).
    assert_eq!(verifier.calibration.scale(2, 0), None);
    assert_eq!(verifier.calibration.verified(), 0);
    let d = lift.decide(&mut calm(200.5), &verifier.lift);
    assert!(
        !d.go && d.awaiting_verified_errors && d.frozen_dof.is_none(),
        "{d:?}"
    );
    // The summary says why there is no go while frozen.
    let mut frozen = calm(150.0);
    verifier.lift.frozen = Some(super::still::FrozenSensor {
        ship: Ship::Target,
        dof: Dof::Roll,
    });
    let d = lift.decide(&mut frozen, &verifier.lift);
    let adv = advisory(&frozen, &g, ("a", "b"), (0, 0), d);
    assert!(
        adv.summary()
            .contains("NO-GO (MOT 10s, the target vessel's roll sensor repeats its value)"),
        "{}",
        adv.summary()
    );
}

/// Regression (review): a stillness of a column the record lacks (0 throughout, never frozen)
/// left a snapshot of the lift's statements from its first 30 s, and the first real thaw hours
/// later went back to it, dropping every statement verified since.
#[test]
fn a_column_the_record_lacks_leaves_no_statements_for_a_later_thaw_to_go_back_to() {
    use super::still::Ship;
    use super::verify::RelativeVerifier;
    let config = RelativeConfig::default();
    let mut verifier = RelativeVerifier::from_config(&config, 64);
    for ship in Ship::BOTH {
        verifier.set_present_dofs(ship, &[Dof::Heave]);
    }
    // Heave only: roll and pitch read 0 (absent columns). The target's heave sticks from
    // 1000 s to 1100 s.
    struct HeaveOnly(fn(f64) -> f64);
    impl crate::observed::ObservedMotion for HeaveOnly {
        fn dof_at(&self, t: f64) -> Option<[f64; 6]> {
            Some([0.0, 0.0, (self.0)(t), 0.0, 0.0, 0.0])
        }
    }
    let crane = HeaveOnly(|t| (0.7 * t).sin());
    let target = HeaveOnly(|t| (0.7 * t.clamp(0.0, 1000.0)).sin() + (t - 1100.0).max(0.0));
    let mut t = 0.0;
    while t < 1100.0 {
        verifier.watch_sensors([t, t], &crane, &target);
        // One verified call per look while nothing is frozen.
        if verifier.lift.frozen.is_none() {
            verifier.lift.statements.add(0.95, true);
        }
        t += 0.5;
    }
    let before = verifier.lift.statements.calls();
    // Calls up to the freeze were found (1000 s and its 30 s of stillness: 2060 looks).
    assert_eq!(before, 2060.0);
    verifier.lift.statements.add(0.95, true);
    verifier.watch_sensors([1100.5, 1100.5], &crane, &target);
    assert_eq!(verifier.lift.frozen, None);
    assert_eq!(verifier.lift.statements.calls(), before);
}
