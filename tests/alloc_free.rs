//! The forecast path does not allocate in steady state: a whole engine step (ingest and
//! decimation, scoring and calibration, the six-DOF forecast, the plausibility check, the
//! Forecast payload) plus its JSON encoding for zenoh, counted by a global allocator; and the
//! decision loops of the deck and of the lift once their ensembles are full.
//!
//! The allocator (`shipcast_predict::alloc_count`) counts per thread, and only while the
//! measuring thread asks it to: the engine's retraining thread (and the test harness) allocate
//! as they like. This test binary holds nothing else, so the counting allocator wraps no other
//! test.

use shipcast_bench::pipeline::{backfill_s, backfilled_engine, motion_record};
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::engine::retrain::Retrainer;
use shipcast_pipeline::engine::{startup, Engine};
use shipcast_predict::alloc_count::{counted, CountingAllocator};
use shipcast_wire::payload::{Forecast, MotionSample};
use shipcast_wire::payload_json::ForecastJsonEncoder;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// What a stretch of forecasting did.
#[derive(Debug, Default, PartialEq)]
struct Stretch {
    samples: u64,
    forecasts: u64,
    allocations: u64,
    json_bytes: usize,
}

/// Feed `samples` of `record` from `from` as the service does: a forecast is encoded for zenoh
/// (the handle is dropped, as zenoh drops it once written), the other samples prepare the
/// next forecast; between samples the engine does its bookkeeping (`poll_models`, where a due
/// retrain copies the history and a new model is swapped in), which is not counted.
fn forecast_stretch(
    engine: &mut Engine,
    json: &mut ForecastJsonEncoder,
    record: &[[f64; 6]],
    from: u64,
    rate_hz: f64,
) -> Stretch {
    let mut stretch = Stretch::default();
    for (seq, dof) in (from..).zip(&record[from as usize..]) {
        let sample = MotionSample {
            seq,
            stamp_ns: seq,
            time_s: seq as f64 / rate_hz,
            dof: *dof,
        };
        let ((forecast, bytes), n) = counted(|| {
            let pushed = engine.push(&sample).expect("valid samples are accepted");
            match pushed {
                Some(f) => (true, json.encode_shared(f).expect("encode").len()),
                None => {
                    engine.prepare_next().expect("prepare");
                    (false, 0)
                }
            }
        });
        engine.poll_models();
        stretch.samples += 1;
        stretch.forecasts += u64::from(forecast);
        stretch.allocations += n;
        stretch.json_bytes = stretch.json_bytes.max(bytes);
    }
    stretch
}

/// A forecast issued at `t0` with a 25 s horizon at 2 Hz: DOF `dof` is 0.9 times `truth` at
/// each step (a forecast with a little skill missing), every DOF's sigma is `sigma`.
fn swell_forecast(t0: f64, dof: usize, truth: impl Fn(f64) -> f64, sigma: f64) -> Forecast {
    let mut f = Forecast {
        time_s: t0,
        dt_s: 0.5,
        steps: 50,
        ..Forecast::default()
    };
    for k in 0..50 {
        f.mean[dof][k] = (0.9 * truth(t0 + (k + 1) as f64 * 0.5)) as f32;
        for d in 0..6 {
            f.sigma[d][k] = sigma as f32;
        }
    }
    f
}

#[test]
fn the_counter_sees_allocations() {
    // Otherwise a broken counter would pass the test below.
    let (v, n) = counted(|| std::hint::black_box(vec![1u8; 100]));
    assert_eq!((v.len(), n), (100, 1));
    let (_, n) = counted(|| ());
    assert_eq!(n, 0);
}

#[test]
fn engine_step_and_json_encoding_do_not_allocate_in_steady_state() {
    // The service's defaults, retraining on: at 2 Hz the first live fit is due after 240 s
    // and retrains every 300 s, so the measured stretch (20 minutes of record) holds retrains,
    // all requested and swapped in between samples.
    let config = PipelineConfig::default();
    let q = &config.predictor;
    let rate = config.producer.rate_hz;
    let backfill = (backfill_s(q) * rate).round() as u64;
    let warm = (120.0 * rate) as u64;
    let measured = (1200.0 * rate) as u64;
    let record = motion_record(&config, backfill + warm + measured).expect("simulated sea");
    let mut engine = backfilled_engine(&config, &record, backfill).expect("engine");
    let mut json = ForecastJsonEncoder::new();
    // Warm-up: the first forecasts size whatever grows on first use.
    let head = &record[..(backfill + warm) as usize];
    let warm_up = forecast_stretch(&mut engine, &mut json, head, backfill, rate);
    assert!(warm_up.forecasts > 0, "{warm_up:?}");

    let retrains_before = engine.counts.retrains;
    let stretch = forecast_stretch(&mut engine, &mut json, &record, backfill + warm, rate);
    // One forecast per four samples at 8 -> 2 Hz.
    assert_eq!(stretch.samples, measured);
    assert_eq!(stretch.forecasts, measured / 4);
    assert!(stretch.json_bytes > 1000, "{stretch:?}");
    assert_eq!(stretch.allocations, 0, "{stretch:?}");
    // The stretch really ran with retraining: at least one retrain was requested and done.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
    while engine.counts.retrains == retrains_before && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(50));
        engine.poll_models();
    }
    assert!(
        engine.counts.retrains > retrains_before,
        "{:?}",
        engine.counts
    );
}

#[test]
fn parsing_a_received_forecast_does_not_allocate() {
    // What every consumer does with each forecast it receives over zenoh: a full forecast of
    // 50 steps, encoded as the predictor does, parsed back.
    let mut f = Forecast {
        seq: 7,
        time_s: 12.5,
        dt_s: 0.5,
        steps: 50,
        ..Forecast::default()
    };
    for d in 0..6 {
        for k in 0..50 {
            f.mean[d][k] = (d * 100 + k) as f32 * 0.01;
            f.sigma[d][k] = 0.1 + k as f32 * 0.001;
        }
    }
    let mut json = ForecastJsonEncoder::new();
    let bytes = json.encode(&f).expect("encode").to_vec();
    let (back, n) = counted(|| Forecast::from_json(&bytes));
    assert_eq!(back.expect("valid JSON"), f);
    assert_eq!(n, 0, "allocations parsing one forecast");
}

#[test]
fn an_inline_retrain_is_counted_in_the_step() {
    // `shipcast replay` retrains inline, in the step (deterministic): there the step copies
    // the history and fits, and the counter must see it. The same stretch as the service's.
    let config = PipelineConfig::default();
    let q = config.predictor.clone();
    let rate = config.producer.rate_hz;
    let backfill = (backfill_s(&q) * rate).round() as u64;
    let measured = (600.0 * rate) as u64;
    let record = motion_record(&config, backfill + measured).expect("simulated sea");
    let models = startup::initial_models(&config).expect("start-up models");
    let mut engine =
        Engine::new(q.clone(), rate, models, Retrainer::inline(q)).expect("inline engine");
    let mut json = ForecastJsonEncoder::new();
    forecast_stretch(
        &mut engine,
        &mut json,
        &record[..backfill as usize],
        0,
        rate,
    );
    let stretch = forecast_stretch(&mut engine, &mut json, &record, backfill, rate);
    assert!(engine.counts.retrains > 0, "{:?}", engine.counts);
    assert!(stretch.allocations > 0, "{stretch:?}");
}

#[test]
fn deciding_and_verifying_from_a_full_error_ensemble_do_not_allocate() {
    use shipcast_pipeline::config::DeckConfig;
    use shipcast_pipeline::decision::outcomes::Outcomes;
    use shipcast_pipeline::decision::{ensemble, Decider};
    // A swell in roll sampled at 8 Hz, forecasts at 2 Hz with a 25 s horizon: the deck's
    // live loop (samples in, due forecasts verified, a decision, the forecast kept for
    // verification), first until the ensemble's ring is full, then counted.
    let roll = |t: f64| (2.0 * (t * std::f64::consts::TAU / 9.0).sin()).to_radians();
    let forecast_at = |t0: f64| swell_forecast(t0, 3, roll, 0.3f64.to_radians());
    let mut decider = Decider::new(&DeckConfig::default());
    let mut outcomes = Outcomes::new(
        8.0,
        25.0,
        2.0,
        shipcast_pipeline::config::DeckConfig::default().error_correlation,
    );
    let full = ensemble::DEFAULT_CAPACITY * ensemble::DEFAULT_STRIDE + 60;
    let (mut allocations, mut sample) = (0, 0u64);
    for step in 0..(full + 400) {
        let t0 = step as f64 * 0.5;
        let f = forecast_at(t0);
        let (decision, n) = counted(|| {
            while sample as f64 / 8.0 <= t0 + 1e-9 {
                let t = sample as f64 / 8.0;
                let mut dof = [0.0; 6];
                dof[3] = roll(t);
                outcomes.push_sample(&MotionSample {
                    seq: sample,
                    stamp_ns: sample,
                    time_s: t,
                    dof,
                });
                sample += 1;
            }
            outcomes.verify_ready(&mut decider);
            let decision = decider.decide(&f);
            outcomes.push_decision(&f, &decider);
            decision
        });
        if step >= full {
            allocations += n;
            assert_eq!(decision.ensemble_members, ensemble::DEFAULT_CAPACITY);
        }
    }
    assert_eq!(decider.ensemble().len(), ensemble::DEFAULT_CAPACITY);
    assert_eq!(outcomes.counts.unverifiable, 0, "{:?}", outcomes.counts);
    assert_eq!(allocations, 0);
}

#[test]
fn the_lift_decision_and_its_verification_do_not_allocate_once_warm() {
    use shipcast_pipeline::config::RelativeConfig;
    use shipcast_pipeline::decision::ensemble;
    use shipcast_pipeline::observed::MotionHistory;
    use shipcast_pipeline::relative::verify::{RelativeVerifier, MAX_PENDING};
    use shipcast_pipeline::relative::{Geometry, LiftDecider, LiftLimits, RelativeTrack};
    // Two ships heaving in one swell, A's crest 2 s ahead of B's, sampled at 8 Hz, each
    // forecast at 2 Hz with a 25 s horizon: the relative service's loop (both ships' motion
    // in, due relative forecasts verified, the pair combined, the lift decided, the track
    // kept for verification), first until the lift's ensemble is full, then counted.
    let heave = |t: f64| 0.8 * (t * std::f64::consts::TAU / 9.0).sin();
    let forecast_at = |t0: f64, lag_s: f64| swell_forecast(t0, 2, |t| heave(t - lag_s), 0.1);
    let config = RelativeConfig::default();
    let geometry = Geometry::new([0.0, 15.0, -20.0], &config);
    let limits = LiftLimits::new(&config);
    let mut decider = LiftDecider::new(limits);
    // Watching both ships' sensors as the live service does (a frozen sensor stops the lift).
    let mut verifier = RelativeVerifier::from_config(&config, MAX_PENDING).watching_live();
    let (mut a, mut b) = (MotionHistory::new(8.0, 74.0), MotionHistory::new(8.0, 74.0));
    let mut track = Box::<RelativeTrack>::default();
    let full = ensemble::DEFAULT_CAPACITY * ensemble::DEFAULT_STRIDE + 60;
    let (mut allocations, mut sample) = (0, 0u64);
    for step in 0..(full + 400) {
        let t0 = step as f64 * 0.5;
        let (fa, fb) = (forecast_at(t0, 0.0), forecast_at(t0, 2.0));
        let (decision, n) = counted(|| {
            while sample as f64 / 8.0 <= t0 + 1e-9 {
                let t = sample as f64 / 8.0;
                for (history, lag_s) in [(&mut a, 0.0), (&mut b, 2.0)] {
                    let mut dof = [0.0; 6];
                    dof[2] = heave(t - lag_s);
                    // Roll and pitch move a little: watched sensors that never move are
                    // frozen ones.
                    dof[3] = 1e-4 * heave(t - lag_s - 1.0);
                    dof[4] = 1e-4 * heave(t - lag_s - 2.0);
                    history.push(&MotionSample {
                        seq: sample,
                        stamp_ns: sample,
                        time_s: t,
                        dof,
                    });
                }
                sample += 1;
            }
            if let (Some(ta), Some(tb)) = (a.newest_s(), b.newest_s()) {
                verifier.verify_until(ta.min(tb), &geometry, &a, &b);
            }
            verifier.watch_sensors([fa.time_s, fb.time_s], &a, &b);
            track
                .fill(
                    &geometry,
                    &fa,
                    &fb,
                    &verifier.calibration,
                    &verifier.shrinkage,
                )
                .expect("one clock, one step");
            let decision = decider.decide(&mut track, &verifier.lift);
            verifier.push(&track);
            decision
        });
        if step >= full {
            allocations += n;
            assert_eq!(decision.ensemble_members, ensemble::DEFAULT_CAPACITY);
        }
    }
    assert_eq!(verifier.unverifiable(), 0);
    assert!(verifier.lift.statements.calls() > 0.0);
    assert!(verifier.lift.frozen.is_none());
    assert_eq!(allocations, 0);
}

#[test]
fn a_forged_row_of_a_million_values_is_refused_without_being_kept() {
    // A received forecast whose sigma row 1 holds a million values: the parser counts them
    // and refuses the row by its length. Kept in a growing vector, it took some twenty
    // allocations (and 4 MB); the refusal's message takes a few.
    let mut text = String::from(
        r#"{"seq":1,"source_seq":1,"source_stamp_ns":1,"issued_stamp_ns":1,"time_s":1.0,"dt_s":0.5,"steps":3,"model_version":1,"mean":[[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0]],"sigma":[[1,1,1],["#,
    );
    text.push_str(&vec!["0.5"; 1_000_000].join(","));
    text.push_str("],[1,1,1],[1,1,1],[1,1,1],[1,1,1]]}");
    let (result, n) = counted(|| Forecast::from_json(text.as_bytes()));
    let err = result.expect_err("a row of a million values");
    assert!(
        err.to_string()
            .contains("'sigma' row 1 has 1000000 values, expected steps = 3"),
        "{err}"
    );
    assert!(n <= 4, "{n} allocations refusing the forged row");
}
