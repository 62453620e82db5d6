//! A fleet through `shipcast router` with real processes on 127.0.0.1: a vessel's predictor
//! connects to the router, a shore client subscribes to every vessel with one key expression,
//! a late joiner's query gets the latest forecast at once, and after the router is killed and
//! restarted on the same endpoint the shore receives again with nothing restarted.

mod pipeline_support;

use pipeline_support::{Proc, TestPipeline, PATIENCE};
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

fn start_router(endpoint: &str, forecasts: &str) -> Proc {
    let router = Proc::spawn(
        "router",
        &["router", "--listen", endpoint, "--forecasts", forecasts],
    );
    router.wait_for("router: up");
    router
}

#[test]
fn shore_follows_the_fleet_through_a_router_and_survives_its_restart() {
    let p = TestPipeline::new("router", "[producer]\nspeed = 20.0\nbackfill_s = 0.0\n");
    let router_endpoint = zn::free_loopback_endpoint().expect("a free port");
    let fleet = format!("{}/shipcast/*/forecast", p.instance);
    let mut router = start_router(&router_endpoint, &fleet);
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
