//! With security off (plain TCP on 127.0.0.1, as in development), the consumers themselves
//! reject the injection of issue 14: forecasts from a second publisher, with a repeated seq or
//! a foreign source, are refused, counted and logged by the crane (zenoh), the deck (iceoryx2)
//! and the live view of `shipcast run`, while the real forecasts keep arriving.

mod pipeline_support;

use pipeline_support::{
    fake_forecast_json, wait_crane_lines, Proc, TestPipeline, FAKE_SEQ, PATIENCE,
};
use shipcast_wire::payload::{Forecast, MotionSample};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// An anonymous zenoh client on a plain TCP endpoint (open to all without security).
fn plain_client(endpoint: &str) -> zenoh::Session {
    let mut config = zenoh::Config::default();
    config.insert_json5("mode", "\"client\"").unwrap();
    config
        .insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    config
        .insert_json5("connect/endpoints", &format!("[\"{endpoint}\"]"))
        .unwrap();
    zenoh::open(config)
        .wait()
        .expect("plain TCP is open to all")
}

#[test]
fn with_security_off_the_crane_rejects_a_second_publisher() {
    let p = TestPipeline::new("inject", "[producer]\nspeed = 5.0\nbackfill_s = 0.0\n");
    let predictor = p.spawn("predictor", &[]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let crane = p.spawn("crane", &[]);
    let _producer = p.spawn("producer", &["--wait-subscriber-s", "30"]);
    crane.wait_for("crane t=");

    // The outsider of issue 14: an anonymous zenoh client on the predictor's endpoint.
    let outsider = plain_client(&p.endpoint);
    let publisher = outsider
        .declare_publisher(p.names().forecast())
        .wait()
        .unwrap();
    let fake = fake_forecast_json();
    let before = crane.stdout().len();
    for i in 0..10 {
        let put = publisher.put(fake.clone());
        // Half without an id, half claiming the outsider's own.
        let put = if i % 2 == 0 {
            put
        } else {
            put.attachment(outsider.zid().to_string().into_bytes())
        };
        put.wait().unwrap();
        std::thread::sleep(Duration::from_millis(100));
    }
    wait_crane_lines(&crane, before, 40);
    assert!(
        !crane
            .stdout()
            .iter()
            .any(|l| l.contains(&format!("seq {FAKE_SEQ}"))),
        "the crane used the fake forecast"
    );
    // Each fake one rejected, on one line each, as not from the live predictor (a genuine
    // forecast that beats the predictor's token at start-up would say "(none)" instead).
    let rejected: Vec<String> = crane
        .stderr()
        .into_iter()
        .filter(|l| l.contains("crane: rejected") && !l.contains("live predictor (none)"))
        .collect();
    assert_eq!(rejected.len(), 10, "{}", crane.stderr().join("\n"));
    assert!(
        rejected.iter().all(|l| l.contains("without a publisher id")
            || l.contains("not the live publisher of its key")),
        "{rejected:?}"
    );
    drop(publisher);
    drop(outsider);
    let mut crane = crane;
    let status = crane.terminate();
    assert!(status.success());
    let last = crane.wait_for("crane: stopped after");
    assert!(last.contains(" source, 0 seq, 0 payload)"), "{last}");
    let source_rejections: u64 = last
        .split_once(" rejected (")
        .and_then(|(_, r)| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no rejection counts in: {last}"));
    assert!(source_rejections >= 10, "{last}");
}

/// The latest `.../status/deck` document the deck published, waiting until `done` holds for it.
fn wait_deck_status(
    sub: &zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
    deck: &Proc,
    done: impl Fn(&serde_json::Value) -> bool,
) -> serde_json::Value {
    let deadline = Instant::now() + PATIENCE;
    loop {
        assert!(
            Instant::now() < deadline,
            "the deck's status never showed what was expected; stderr:\n{}",
            deck.stderr().join("\n")
        );
        if let Ok(Some(sample)) = sub.recv_timeout(Duration::from_millis(200)) {
            let status: serde_json::Value =
                serde_json::from_slice(&sample.payload().to_bytes()).expect("status JSON");
            if done(&status) {
                return status;
            }
        }
    }
}

#[test]
fn the_deck_rejects_a_second_iceoryx2_publisher_and_keeps_advising() {
    use shipcast_pipeline::transport::iox::{self, IoxPublisher, Sizing};
    let p = TestPipeline::new("deckinject", "[producer]\nspeed = 5.0\nbackfill_s = 0.0\n");
    let predictor = p.spawn("predictor", &[]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let deck = p.spawn("deck", &[]);
    let _producer = p.spawn("producer", &["--wait-subscriber-s", "30"]);
    deck.wait_for("deck t=");

    let session = plain_client(&p.endpoint);
    let names = p.names();
    let status = session
        .declare_subscriber(names.status("deck"))
        .wait()
        .unwrap();
    let advisories = session
        .declare_subscriber(names.advisory("deck"))
        .wait()
        .unwrap();
    let count = |s: &serde_json::Value, path: &[&str]| -> u64 {
        path.iter()
            .fold(s, |v, k| &v[*k])
            .as_u64()
            .unwrap_or_else(|| panic!("no {path:?} in {s}"))
    };
    let before = wait_deck_status(&status, &deck, |s| count(s, &["accepted"]) > 0);

    // Another process on the same machine opens the forecast service and publishes the
    // injection of issue 14 on it, with a NaN in the second half.
    let node = iox::node(&names, "intruder").expect("iceoryx2 node");
    let intruder =
        IoxPublisher::<Forecast>::new(&node, &names.forecast(), Sizing::FORECAST).unwrap();
    let mut fake = Forecast::from_json(&fake_forecast_json()).unwrap();
    for i in 0..10 {
        if i == 5 {
            fake.sigma[2][0] = f32::NAN;
        }
        assert_eq!(intruder.send(&fake).unwrap(), 1, "the deck is subscribed");
        std::thread::sleep(Duration::from_millis(100));
    }
    // The predictor's forecasts keep being accepted while the intruder is still connected.
    let accepted_before = count(&before, &["accepted"]);
    let after = wait_deck_status(&status, &deck, |s| {
        count(s, &["rejected", "source"]) >= 10 && count(s, &["accepted"]) >= accepted_before + 20
    });
    assert_eq!(count(&after, &["rejected", "source"]), 10, "{after}");
    assert_eq!(count(&after, &["rejected", "seq"]), 0, "{after}");
    assert_eq!(count(&after, &["rejected", "payload"]), 0, "{after}");
    assert_eq!(
        count(&after, &["rejected", "source"]),
        count(&before, &["rejected", "source"]) + 10
    );
    // No advisory was made from a fake forecast.
    let mut advised = 0;
    while let Ok(Some(sample)) = advisories.try_recv() {
        let a: serde_json::Value = serde_json::from_slice(&sample.payload().to_bytes()).unwrap();
        assert_ne!(
            a["forecast_seq"], FAKE_SEQ,
            "the deck advised from the fake"
        );
        advised += 1;
    }
    assert!(advised >= 20, "{advised} advisories");
    // One log line per rejection, naming the reason.
    let rejected: Vec<String> = deck
        .stderr()
        .into_iter()
        .filter(|l| l.contains("deck: rejected"))
        .collect();
    assert_eq!(rejected.len(), 10, "{rejected:?}");
    assert!(
        rejected
            .iter()
            .all(|l| l.contains("not the live publisher of its key")),
        "{rejected:?}"
    );
    drop(intruder);
    // The intruder now publishes forged motion on the producer's service: the predictor
    // (which forecasts from it) and the deck (which verifies against it) follow only the
    // producer's port, and each counts the 10 it refused.
    let predictor_status = session
        .declare_subscriber(names.status("predictor"))
        .wait()
        .unwrap();
    let forger = IoxPublisher::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION).unwrap();
    let forged = MotionSample {
        seq: 1 << 40,
        stamp_ns: 0,
        time_s: 1.0e6,
        dof: [5.0; 6],
    };
    for _ in 0..10 {
        assert!(
            forger.send(&forged).unwrap() >= 2,
            "the predictor and the deck are subscribed"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let after = wait_deck_status(&status, &deck, |s| count(s, &["motion_rejected"]) >= 10);
    assert_eq!(count(&after, &["motion_rejected"]), 10, "{after}");
    let deadline = Instant::now() + PATIENCE;
    let seen = loop {
        assert!(
            Instant::now() < deadline,
            "the predictor's status never counted the forged motion"
        );
        if let Ok(Some(sample)) = predictor_status.recv_timeout(Duration::from_millis(200)) {
            let s: serde_json::Value =
                serde_json::from_slice(&sample.payload().to_bytes()).unwrap();
            if count(&s, &["counters", "rejected_source"]) >= 10 {
                break s;
            }
        }
    };
    assert_eq!(count(&seen, &["counters", "rejected_source"]), 10, "{seen}");
    // The forged record time (1e6 s) never reached the engine.
    assert!(
        seen["last_time_s"].as_f64().is_some_and(|t| t < 1.0e5),
        "{seen}"
    );
    drop(forger);
    // The deck verifies its forecasts against the motion once their horizon has happened
    // (25 s of record, 1.25 s at 20x): its decisions learn from what really happened.
    let verified = wait_deck_status(&status, &deck, |s| count(s, &["outcomes", "verified"]) > 20);
    assert!(
        count(&verified, &["outcomes", "verified"]) > 20,
        "{verified}"
    );
}

#[test]
fn the_live_view_of_run_rejects_a_second_publisher() {
    let p = TestPipeline::new("runinject", "[producer]\nspeed = 5.0\nbackfill_s = 0.0\n");
    let logs = p.path("logs");
    let run = p.spawn(
        "run",
        &[
            "--duration",
            "120",
            "--log-dir",
            logs.to_str().unwrap(),
            "--view-every",
            "1",
        ],
    );
    run.wait_for("forecast   t=");
    let outsider = plain_client(&p.endpoint);
    let publisher = outsider
        .declare_publisher(p.names().forecast())
        .wait()
        .unwrap();
    let fake = fake_forecast_json();
    for i in 0..10 {
        let put = publisher.put(fake.clone());
        let put = if i % 2 == 0 {
            put
        } else {
            put.attachment(outsider.zid().to_string().into_bytes())
        };
        put.wait().unwrap();
        std::thread::sleep(Duration::from_millis(100));
    }
    // Each fake rejected on one log line as not from the live predictor (a genuine forecast
    // that beats the predictor's token at start-up says "(none)" instead), and counted by
    // source on the view's checks line.
    let fakes_rejected = || {
        run.stderr()
            .into_iter()
            .filter(|l| {
                l.contains("run: forecast rejected") && !l.contains("live predictor (none)")
            })
            .count()
    };
    let by_source = |l: &str| -> u64 {
        l.split_once(" (")
            .and_then(|(_, r)| r.split_whitespace().next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no source count in: {l}"))
    };
    let deadline = Instant::now() + PATIENCE;
    let checks = loop {
        let last = run
            .stdout()
            .into_iter()
            .rev()
            .find(|l| l.starts_with("checks     rejected forecasts"));
        if let Some(l) = last {
            if fakes_rejected() >= 10 && by_source(&l) >= 10 {
                break l;
            }
        }
        assert!(
            Instant::now() < deadline,
            "the view did not reject the fakes:\n{}",
            run.stderr().join("\n")
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(fakes_rejected(), 10, "{}", run.stderr().join("\n"));
    assert!(checks.contains(" 0 seq, 0 payload)"), "{checks}");
    assert!(
        !run.stdout().iter().any(|l| l.contains("heave +5s +9.99")),
        "the view showed the fake forecast"
    );
}
