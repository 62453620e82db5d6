//! A fleet through `shipcast router` with real processes on 127.0.0.1: a vessel's predictor
//! connects to the router, a shore client subscribes to every vessel with one key expression,
//! a late joiner's query gets the latest forecast at once, and after the router is killed and
//! restarted on the same endpoint the shore receives again with nothing restarted. And a
//! secure fleet from `shipcast certs --router`: a vessel cannot put on another vessel's keys,
//! while the shore receives every vessel.

mod pipeline_support;

use pipeline_support::{run_ok, Proc, TestPipeline, PATIENCE};
use shipcast_pipeline::transport::zenoh::{self as zn, Mode, ZenohSettings};
use shipcast_wire::payload::Forecast;
use std::time::{Duration, Instant};
use zenoh::Wait;

fn shore_session(endpoint: &str) -> zenoh::Session {
    zn::open(&ZenohSettings {
        mode: Mode::Client,
        connect: vec![endpoint.to_string()],
        ..ZenohSettings::default()
    })
    .expect("shore connects to the router")
}

fn spawn_router(endpoint: &str, forecasts: &str) -> Proc {
    Proc::spawn(
        "router",
        &["router", "--listen", endpoint, "--forecasts", forecasts],
    )
}

fn start_router(endpoint: &str, forecasts: &str) -> Proc {
    let router = spawn_router(endpoint, forecasts);
    router.wait_for("router: up");
    router
}

/// A router on a loopback port that was free, and its endpoint. The port is released before
/// the router binds it, and a test beside this one may bind it first (CI, 2026-12-07: the
/// router refused 127.0.0.1:29018, "Address already in use"): then another port is tried.
fn start_router_on_a_free_port(forecasts: &str) -> (Proc, String) {
    const IN_USE: &str = "Address already in use";
    for _ in 0..3 {
        let endpoint = zn::free_loopback_endpoint().expect("a free port");
        let router = spawn_router(&endpoint, forecasts);
        match router.wait_for_any(&["router: up", IN_USE]) {
            Some(line) if line.contains(IN_USE) => continue,
            Some(_) => return (router, endpoint),
            None => panic!("router: not up; stderr:\n{}", router.stderr().join("\n")),
        }
    }
    panic!("router: three free ports were taken before it bound them");
}

#[test]
fn shore_follows_the_fleet_through_a_router_and_survives_its_restart() {
    let p = TestPipeline::new("router", "[producer]\nspeed = 20.0\nbackfill_s = 0.0\n");
    let fleet = format!("{}/shipcast/*/forecast", p.instance);
    let (mut router, router_endpoint) = start_router_on_a_free_port(&fleet);
    let predictor = p.spawn("predictor", &["--zenoh-connect", &router_endpoint]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let _producer = p.spawn("producer", &[]);

    let shore = shore_session(&router_endpoint);
    let sub = shore.declare_subscriber(fleet.clone()).wait().unwrap();
    let first = sub.recv_timeout(PATIENCE).unwrap().expect("a forecast");
    assert_eq!(first.key_expr().as_str(), p.names().forecast());
    Forecast::from_json(&first.payload().to_bytes()).expect("a valid forecast");

    // A late joiner asks the router and has the latest forecast at once.
    let late = shore_session(&router_endpoint);
    let replies = late.get(fleet.clone()).wait().unwrap();
    let reply = replies.recv_timeout(PATIENCE).unwrap().expect("a reply");
    let sample = reply.result().expect("the router's latest forecast");
    assert_eq!(sample.key_expr().as_str(), p.names().forecast());
    let latest = Forecast::from_json(&sample.payload().to_bytes()).unwrap();
    assert!(latest.steps > 0);
    drop(late);

    // Kill the router and start a new one on the same endpoint; nothing else is restarted.
    router.kill9();
    let restarted = start_router(&router_endpoint, &fleet);
    // Whatever was queued before the kill is not evidence of recovery.
    while sub.try_recv().ok().flatten().is_some() {}
    let deadline = Instant::now() + PATIENCE;
    let resumed = loop {
        if let Some(s) = sub.recv_timeout(Duration::from_millis(200)).unwrap() {
            break Forecast::from_json(&s.payload().to_bytes()).unwrap();
        }
        assert!(
            Instant::now() < deadline,
            "the shore did not resume after the router restart; router:\n{}",
            restarted.stderr().join("\n")
        );
    };
    assert!(
        resumed.seq > latest.seq,
        "{} <= {}",
        resumed.seq,
        latest.seq
    );
}

#[test]
fn in_a_secure_fleet_a_vessel_cannot_put_on_another_vessels_keys() {
    let p = TestPipeline::new("secfleet", "");
    let tls = |e: String| e.replacen("tcp/", "tls/", 1);
    let router_endpoint = tls(zn::free_loopback_endpoint().expect("a free port"));
    let listen = tls(p.endpoint.clone());
    let dir = p.path("fleet");
    let dir_s = dir.to_str().expect("utf-8");
    run_ok(&[
        "certs",
        "--out",
        dir_s,
        "--instance",
        &p.instance,
        "--listen",
        &listen,
        "--router",
        &router_endpoint,
        "--vessel",
        "alpha",
        "--vessel",
        "bravo",
        "--station",
        "shore",
    ]);
    // A fleet needs its router, and each vessel once: one-line errors, nothing written.
    for (args, reason) in [
        (
            vec!["--vessel", "alpha", "--vessel", "bravo"],
            "give its --router",
        ),
        (
            vec![
                "--router",
                &router_endpoint,
                "--vessel",
                "alpha",
                "--vessel",
                "alpha",
            ],
            "'alpha' is given twice",
        ),
    ] {
        let other = p.path("refused");
        let mut all = vec![
            "certs",
            "--out",
            other.to_str().unwrap(),
            "--listen",
            &listen,
        ];
        all.extend(args);
        let out = std::process::Command::new(pipeline_support::BIN)
            .args(&all)
            .output()
            .expect("run certs");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(reason), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(!other.join("ca.pem").exists());
    }
    let alpha_toml = dir.join("alpha.toml");
    let text = std::fs::read_to_string(&alpha_toml).expect("alpha.toml");
    std::fs::write(
        &alpha_toml,
        format!("{text}\n[producer]\nspeed = 20.0\nbackfill_s = 0.0\n\n[predictor]\norder = 100\nholdout = 300\nretrain_window = 1000\nwarmup_s = 900.0\nretrain_every_s = 0.0\n"),
    )
    .expect("write alpha.toml");
    let router_toml = dir.join("router.toml");
    let router = Proc::spawn(
        "router",
        &["router", "--config", router_toml.to_str().unwrap()],
    );
    router.wait_for("router: up");
    let alpha = alpha_toml.to_str().unwrap();
    let predictor = Proc::spawn("predictor", &["predictor", "--config", alpha]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let _producer = Proc::spawn(
        "producer",
        &["producer", "--config", alpha, "--wait-subscriber-s", "30"],
    );

    let shore_config = zenoh::Config::from_file(dir.join("shore.json5")).expect("shore.json5");
    let shore = zenoh::open(shore_config)
        .wait()
        .expect("the shore connects");
    let fleet = format!("{}/shipcast/*/forecast", p.instance);
    let sub = shore.declare_subscriber(fleet).wait().unwrap();
    let alpha_key = format!("{}/shipcast/alpha/forecast", p.instance);
    let bravo_key = format!("{}/shipcast/bravo/forecast", p.instance);
    let first = sub
        .recv_timeout(PATIENCE)
        .unwrap()
        .expect("a forecast of alpha");
    assert_eq!(first.key_expr().as_str(), alpha_key);

    // Vessel bravo, with its own valid certificate, connects to the router and puts a fake
    // forecast on alpha's key, then a forecast on its own.
    let bravo = shipcast_pipeline::config::PipelineConfig::load(Some(&dir.join("bravo.toml")))
        .expect("bravo.toml loads");
    let bravo = zn::open(&ZenohSettings {
        mode: Mode::Client,
        listen: Vec::new(),
        connect: vec![router_endpoint.clone()],
        access: None,
        ..bravo.zenoh.publisher_side()
    })
    .expect("bravo connects to the router");
    let forecast = |seq: u64| {
        let mut out = Vec::new();
        Forecast {
            seq,
            time_s: 1.0,
            dt_s: 0.5,
            steps: 1,
            ..Forecast::default()
        }
        .write_json(&mut out)
        .unwrap();
        out
    };
    const FAKE_SEQ: u64 = 987654321;
    for _ in 0..5 {
        bravo
            .put(alpha_key.clone(), forecast(FAKE_SEQ))
            .wait()
            .unwrap();
    }
    let deadline = Instant::now() + PATIENCE;
    let mut from_alpha = 0;
    let mut from_bravo = 0;
    while from_bravo == 0 || from_alpha < 10 {
        assert!(
            Instant::now() < deadline,
            "alpha {from_alpha}, bravo {from_bravo}; router:\n{}",
            router.stderr().join("\n")
        );
        bravo.put(bravo_key.clone(), forecast(7)).wait().unwrap();
        let Some(s) = sub.recv_timeout(Duration::from_millis(200)).unwrap() else {
            continue;
        };
        let f = Forecast::from_json(&s.payload().to_bytes()).expect("a valid forecast");
        if s.key_expr().as_str() == bravo_key {
            assert_eq!(f.seq, 7);
            from_bravo += 1;
        } else {
            assert_eq!(s.key_expr().as_str(), alpha_key);
            assert_ne!(
                f.seq, FAKE_SEQ,
                "bravo's put on alpha's key reached the shore"
            );
            from_alpha += 1;
        }
    }
    // The shore may only subscribe: its own put on a vessel's key goes nowhere.
    let watcher = zenoh::open(zenoh::Config::from_file(dir.join("shore.json5")).unwrap())
        .wait()
        .expect("a second shore session");
    watcher
        .put(alpha_key.clone(), forecast(FAKE_SEQ))
        .wait()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(2);
    while Instant::now() < deadline {
        if let Some(s) = sub.recv_timeout(Duration::from_millis(200)).unwrap() {
            let f = Forecast::from_json(&s.payload().to_bytes()).unwrap();
            assert_ne!(
                f.seq, FAKE_SEQ,
                "the shore's put reached another subscriber"
            );
        }
    }
}
