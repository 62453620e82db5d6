//! The deck's decision reaches local readers over iceoryx2 (`DecisionSample` on
//! `.../advisory/deck`) as the same decision its JSON advisory carries on zenoh, and the deck
//! verifies its forecasts against the motion it reads, once their horizon has happened.

mod pipeline_support;

use pipeline_support::{TestPipeline, PATIENCE};
use shipcast_pipeline::transport::iox::{self, IoxSubscriber, Sizing, WaitMode};
use shipcast_pipeline::transport::zenoh as zn;
use shipcast_wire::payload::DecisionSample;
use std::collections::HashMap;
use std::time::{Duration, Instant};
use zenoh::Wait;

#[test]
fn the_deck_publishes_its_decision_over_iceoryx2_and_verifies_its_forecasts_live() {
    let p = TestPipeline::new("decisions", "[producer]\nspeed = 20.0\nbackfill_s = 0.0\n");
    let names = p.names();
    let predictor = p.spawn("predictor", &[]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let node = iox::node(&names, "test-decisions").unwrap();
    let local = IoxSubscriber::<DecisionSample>::new(
        &node,
        &names.advisory("deck"),
        Sizing::FORECAST,
        WaitMode::Event,
    )
    .unwrap();
    let session = zn::open(&zn::ZenohSettings::connect_to(&p.endpoint)).unwrap();
    let advisories = session
        .declare_subscriber(names.advisory("deck"))
        .wait()
        .unwrap();
    let status = session
        .declare_subscriber(names.status("deck"))
        .wait()
        .unwrap();
    let deck = p.spawn("deck", &[]);
    let _producer = p.spawn("producer", &["--wait-subscriber-s", "30"]);

    let mut by_iox: HashMap<u64, DecisionSample> = HashMap::new();
    let mut by_zenoh: HashMap<u64, serde_json::Value> = HashMap::new();
    let mut verified = 0u64;
    let deadline = Instant::now() + PATIENCE;
    // Until both transports agree on 20 decisions and the deck has verified some forecasts.
    while Instant::now() < deadline {
        local.wait(Duration::from_millis(100)).unwrap();
        while let Some(d) = local.receive().unwrap() {
            by_iox.insert(d.forecast_seq, d);
        }
        while let Ok(Some(s)) = advisories.try_recv() {
            let a: serde_json::Value = serde_json::from_slice(&s.payload().to_bytes()).unwrap();
            let seq = a["forecast_seq"].as_u64().expect("forecast_seq");
            by_zenoh.insert(seq, a["decision"].clone());
        }
        while let Ok(Some(s)) = status.try_recv() {
            let st: serde_json::Value = serde_json::from_slice(&s.payload().to_bytes()).unwrap();
            verified = st["outcomes"]["verified"].as_u64().unwrap_or(0);
        }
        let both = by_iox.keys().filter(|k| by_zenoh.contains_key(k)).count();
        if both >= 20 && verified > 0 {
            break;
        }
    }
    let both: Vec<u64> = by_iox
        .keys()
        .copied()
        .filter(|k| by_zenoh.contains_key(k))
        .collect();
    assert!(
        both.len() >= 20 && verified > 0,
        "{} decisions on both transports, {verified} verified; deck stderr:\n{}",
        both.len(),
        deck.stderr().join("\n")
    );
    for seq in both {
        let (d, j) = (&by_iox[&seq], &by_zenoh[&seq]);
        assert_eq!(d.mot_s, j["mot_s"].as_f64().unwrap(), "{seq}");
        assert_eq!(d.go == 1, j["go"].as_bool().unwrap(), "{seq}");
        match j["probability_now"].as_f64() {
            Some(p) => {
                assert_eq!(d.probability_now, p, "{seq}");
                assert!((0.0..=1.0).contains(&p));
            }
            None => assert!(d.probability_now.is_nan(), "{seq}"),
        }
        match j["next_exceedance_s"].as_f64() {
            Some(s) => assert_eq!(d.next_exceedance_s, s, "{seq}"),
            None => assert!(d.next_exceedance_s.is_nan(), "{seq}"),
        }
        assert_eq!(
            u64::from(d.ensemble_members),
            j["ensemble_members"].as_u64().unwrap(),
            "{seq}"
        );
    }
}

/// `[deck] statements_file`: the deck writes the statements it has verified when it stops,
/// and a deck started again reads them (docs/decisions.md).
#[test]
fn the_deck_keeps_its_verified_statements_across_runs() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("statements.json");
    // A TOML basic string: the path as JSON writes it.
    let extra = format!(
        "[producer]\nspeed = 20.0\nbackfill_s = 0.0\n[deck]\nstatements_file = {}\n",
        serde_json::to_string(&file).unwrap()
    );
    let p = TestPipeline::new("statements", &extra);
    let predictor = p.spawn("predictor", &[]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let status = p.watch_status_of("deck");
    let mut deck = p.spawn("deck", &[]);
    let _producer = p.spawn("producer", &["--wait-subscriber-s", "30"]);
    // Statements are made once 150 error paths (600 verified forecasts) exist, and verified
    // a horizon later.
    status.wait_until("900 verified forecasts", |s| {
        s["outcomes"]["verified"].as_u64().unwrap_or(0) >= 900
    });
    assert!(deck.terminate().success(), "{}", deck.stderr().join("\n"));
    let kept = shipcast_pipeline::decision::statements_file::load(&file)
        .unwrap()
        .expect("the deck wrote its statements when it stopped");
    let calls: f64 = kept
        .records(0.5)
        .unwrap()
        .iter()
        .map(|(_, r)| r.calls())
        .sum();
    assert!(calls >= 1.0, "{kept:?}");
    let again = p.spawn("deck", &[]);
    let line = again.wait_for("verified statements in");
    assert!(line.contains(&format!("starting from {calls} ")), "{line}");
}
