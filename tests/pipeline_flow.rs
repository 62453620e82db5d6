//! End-to-end flow of the real processes: motion over iceoryx2 without gaps, forecasts over
//! iceoryx2 and zenoh, and forecasts identical to what the evaluation's predictor computes
//! from the same model and history.

mod pipeline_support;

use pipeline_support::{collect_forecasts, counter, run_ok, TestPipeline};
use shipcast::model::ModelFile;
use shipcast::motion_csv::MotionData;
use shipcast::payload::{Forecast, MotionSample};
use shipcast::predict::Predictor;
use shipcast::signal::decimate;
use shipcast::transport::iox::{self, IoxSubscriber, Sizing, WaitMode};
use shipcast::transport::zenoh::{self as zn, LatestSubscriber};
use shipcast::transport::{Counters, SeqTracker};
use shipcast::Dof;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// Ten minutes of simulated motion at 100x speed: every sample reaches the predictor and an
/// independent subscriber in order, and forecasts arrive over both transports with the same
/// content.
#[test]
fn ten_simulated_minutes_at_100x_flow_without_gaps_over_both_transports() {
    let p = TestPipeline::new("flow", "[producer]\nspeed = 100.0\nbackfill_s = 0.0\n");
    let names = p.names();
    let mut predictor = p.spawn("predictor", &[]);
    predictor.wait_for("(iceoryx2 and zenoh)");

    let node = iox::node(&names, "test-observer").unwrap();
    let motion =
        IoxSubscriber::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION, WaitMode::Event)
            .unwrap();
    let forecasts =
        IoxSubscriber::<Forecast>::new(&node, &names.forecast(), Sizing::FORECAST, WaitMode::Event)
            .unwrap();
    let session = zn::open(&zn::ZenohSettings::connect_to(&p.endpoint)).unwrap();
    let zenoh_forecasts = LatestSubscriber::new(&session, &names.forecast()).unwrap();

    let mut producer = p.spawn(
        "producer",
        &["--record-s", "600", "--wait-subscriber-s", "30"],
    );
    let (mut tracker, mut seen) = (SeqTracker::new(), Counters::default());
    let mut by_iox: HashMap<u64, Forecast> = HashMap::new();
    let mut by_zenoh: HashMap<u64, Forecast> = HashMap::new();
    // Everything waiting on iceoryx2; the newest on zenoh (its ring keeps only the latest).
    let drain_forecasts = |by_iox: &mut HashMap<u64, Forecast>,
                           by_zenoh: &mut HashMap<u64, Forecast>| {
        while let Some(f) = forecasts.receive().unwrap() {
            by_iox.insert(f.seq, f);
        }
        if let Some(b) = zenoh_forecasts.latest().unwrap() {
            let f = Forecast::from_json(&b).unwrap();
            by_zenoh.insert(f.seq, f);
        }
    };
    let deadline = Instant::now() + Duration::from_secs(60);
    while seen.received < 4800 && Instant::now() < deadline {
        motion.wait(Duration::from_millis(50)).unwrap();
        while let Some(s) = motion.receive().unwrap() {
            seen.count(tracker.check(&s));
        }
        drain_forecasts(&mut by_iox, &mut by_zenoh);
    }
    assert!(producer.wait_exit().success());
    let done = producer.wait_for("producer: stopped after");
    assert_eq!(counter(&done, "after"), 4800, "{done}");
    // The observer saw every sample, in order, no gap.
    assert_eq!(
        (seen.received, seen.lost, seen.rejected_order),
        (4800, 0, 0)
    );

    // Drain the last forecasts, then stop the predictor cleanly and read its counters.
    std::thread::sleep(Duration::from_millis(300));
    drain_forecasts(&mut by_iox, &mut by_zenoh);
    assert!(predictor.terminate().success());
    let stopped = predictor.wait_for("predictor: stopped;");
    assert_eq!(counter(&stopped, "received"), 4800, "{stopped}");
    assert_eq!(counter(&stopped, "lost"), 0, "{stopped}");
    assert_eq!(counter(&stopped, "rejected"), 0, "{stopped}");
    // 4800 samples -> (4800 - 17) / 4 + 1 = 1196 values at 2 Hz; forecasts from value 100 on.
    assert_eq!(counter(&stopped, "published"), 1196 - 99, "{stopped}");

    assert!(!by_iox.is_empty() && !by_zenoh.is_empty());
    let common: Vec<u64> = by_zenoh
        .keys()
        .filter(|k| by_iox.contains_key(k))
        .copied()
        .collect();
    assert!(!common.is_empty(), "no forecast seen on both transports");
    for seq in common {
        let (a, b) = (&by_iox[&seq], &by_zenoh[&seq]);
        assert_eq!(a, b, "forecast {seq} differs between iceoryx2 and zenoh");
        assert_eq!(a.steps, 50);
        assert_eq!(a.dt_s, 0.5);
        assert!(a.issued_stamp_ns >= a.source_stamp_ns);
        assert!(a.sigma[2][..50].iter().all(|s| s.is_finite() && *s > 0.0));
    }
}

/// The predictor service, given a model file from `shipcast train`, forecasts exactly what the
/// library predictor computes from the evaluation's decimation of the same record.
#[test]
fn service_forecasts_equal_the_eval_predictor_for_the_same_model_and_history() {
    let p = TestPipeline::new("equal", "[producer]\nspeed = 50.0\nbackfill_s = 0.0\n");
    let train_csv = p.path("train.csv");
    let replay_csv = p.path("replay.csv");
    let model = p.path("model.json");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    run_ok(&[
        "simulate",
        "--scenario",
        "ss4",
        "--seed",
        "5",
        "--duration",
        "1500",
        "--rate",
        "8",
        "--out",
        &s(&train_csv),
    ]);
    run_ok(&[
        "simulate",
        "--scenario",
        "ss4",
        "--seed",
        "6",
        "--duration",
        "150",
        "--rate",
        "8",
        "--out",
        &s(&replay_csv),
    ]);
    run_ok(&[
        "train",
        "--input",
        &s(&train_csv),
        "--out",
        &s(&model),
        "--method",
        "mca",
        "--order",
        "100",
        "--horizon",
        "50",
    ]);

    let names = p.names();
    let predictor = p.spawn("predictor", &["--model", &s(&model)]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let node = iox::node(&names, "test-observer").unwrap();
    let forecasts =
        IoxSubscriber::<Forecast>::new(&node, &names.forecast(), Sizing::FORECAST, WaitMode::Event)
            .unwrap();
    let mut producer = p.spawn(
        "producer",
        &["--input", &s(&replay_csv), "--wait-subscriber-s", "30"],
    );
    // 150 s at 8 Hz: 1200 samples -> 296 values at 2 Hz -> 197 forecasts.
    let got = collect_forecasts(&forecasts, 197);
    assert!(producer.wait_exit().success());
    assert_eq!(got.len(), 197, "forecasts received");

    // Recompute with the library: batch decimation of the CSV, the model file's predictors.
    let data = MotionData::read_path(&replay_csv).unwrap();
    let file = ModelFile::load(&model).unwrap();
    let mut predictors: Vec<_> = Dof::ALL
        .iter()
        .map(|d| file.dof(*d).unwrap().predictor.clone())
        .collect();
    let series: Vec<Vec<f64>> = Dof::ALL
        .iter()
        .map(|d| decimate(data.dof(*d).unwrap(), 4).unwrap())
        .collect();
    let mut out = vec![0.0; 50];
    for f in &got {
        // Value j stands for input j * 4 + 8 (the filter delay); time_s labels it.
        let input = (f.time_s * 8.0).round() as usize;
        assert_eq!(
            (input - 8) % 4,
            0,
            "time {} is not on the 2 Hz grid",
            f.time_s
        );
        let j = (input - 8) / 4;
        assert!((data.time[input] - f.time_s).abs() < 1e-9);
        for (d, pred) in predictors.iter_mut().enumerate() {
            pred.forecast(&series[d][j + 1 - 100..=j], &mut out)
                .unwrap();
            for (k, x) in out.iter().enumerate() {
                assert_eq!(
                    f.mean[d][k], *x as f32,
                    "forecast seq {} dof {d} step {k}",
                    f.seq
                );
            }
            let sigma = &file.dof(Dof::ALL[d]).unwrap().sigma;
            assert_eq!(f.sigma[d][0], sigma[0] as f32);
        }
    }
}

/// Retraining runs in the background and the new model is swapped in without pausing the
/// forecasts: every 2 Hz value still gets its forecast, and later forecasts carry the new
/// model version and its freshly measured sigma.
#[test]
fn retrained_models_are_swapped_in_without_a_missed_forecast() {
    let p = TestPipeline::new(
        "retrain",
        "[producer]\nspeed = 100.0\nbackfill_s = 0.0\n[predictor]\norder = 100\nholdout = 300\nretrain_window = 600\nwarmup_s = 900.0\nretrain_every_s = 60.0\n",
    );
    let names = p.names();
    let mut predictor = p.spawn("predictor", &["--busy-poll"]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let node = iox::node(&names, "test-observer").unwrap();
    let forecasts =
        IoxSubscriber::<Forecast>::new(&node, &names.forecast(), Sizing::FORECAST, WaitMode::Event)
            .unwrap();
    let mut producer = p.spawn(
        "producer",
        &["--record-s", "900", "--wait-subscriber-s", "30"],
    );
    // 900 s at 8 Hz: 7200 samples -> 1796 values at 2 Hz -> 1697 forecasts.
    let got = collect_forecasts(&forecasts, 1697);
    assert!(producer.wait_exit().success());
    assert!(predictor.terminate().success());
    assert_eq!(got.len(), 1697, "a forecast was missed");
    assert!(got.windows(2).all(|w| w[1].seq == w[0].seq + 1));
    assert!(got
        .windows(2)
        .all(|w| w[1].model_version >= w[0].model_version));
    let first = &got[0];
    let last = got.last().unwrap();
    assert_eq!(first.model_version, 1);
    assert!(last.model_version >= 2, "never retrained");
    assert_ne!(
        first.sigma[2][..50],
        last.sigma[2][..50],
        "sigma not re-measured"
    );
    predictor.wait_for("retrained model in use");
}
