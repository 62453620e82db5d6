//! Two ships in one sea: `shipcast run --two-ship` runs a producer and a predictor per vessel
//! and the relative service, which publishes the crane tip's forecast relative to the landing
//! spot on the other vessel, with sigma and the lift decision, on zenoh.

mod pipeline_support;

use pipeline_support::{Proc, TestPipeline, PATIENCE};
use shipcast_pipeline::pacing::poll_until;
use shipcast_pipeline::relative::{RelativeAdvisory, SigmaBasis};
use shipcast_pipeline::transport::zenoh::{self as zn, LatestSubscriber, ZenohSettings};
use shipcast_pipeline::transport::Names;
use shipcast_wire::payload::Forecast;
use std::time::Duration;

#[test]
fn a_two_ship_run_publishes_the_relative_forecast_of_both_vessels() {
    let p = TestPipeline::new(
        "twoship",
        "[relative]\ntarget_vessel = \"tender\"\ntarget_heading_offset_deg = 20.0\n",
    );
    let logs = tempfile::tempdir().unwrap();
    let config = p.config.to_str().unwrap().to_string();
    let mut run = Proc::spawn(
        "run",
        &[
            "run",
            "--config",
            &config,
            "--two-ship",
            "--duration",
            "30",
            "--no-display",
            "--log-dir",
            logs.path().to_str().unwrap(),
        ],
    );
    let names = p.names();
    let target = Names::new(Some(&p.instance), "tender").unwrap();
    let session = zn::open(&ZenohSettings::connect_to(&p.endpoint)).unwrap();
    let lift = LatestSubscriber::new(&session, &names.advisory("lift")).unwrap();
    let target_forecasts = LatestSubscriber::new(&session, &target.forecast()).unwrap();
    let advisory: RelativeAdvisory = poll_until(PATIENCE, Duration::from_millis(50), || {
        let bytes = lift.latest().ok().flatten()?;
        Some(serde_json::from_slice(&bytes).expect("the lift advisory is RelativeAdvisory JSON"))
    })
    .unwrap_or_else(|| panic!("no lift advisory; run:\n{}", run.stdout().join("\n")));
    assert_eq!(advisory.crane_vessel, names.vessel());
    assert_eq!(advisory.target_vessel, "tender");
    // Nothing verifies the relative forecast live: the independent sigma, and said so.
    assert_eq!(advisory.sigma_basis, SigmaBasis::Independent);
    assert_eq!(advisory.sigma_m, advisory.sigma_independent_m);
    let steps = advisory.mean_m[2].len();
    assert!(steps > 0 && advisory.mean_m.iter().all(|m| m.len() == steps));
    assert!(advisory
        .sigma_m
        .iter()
        .flatten()
        .all(|s| s.is_finite() && *s > 0.0));
    assert!(advisory.misalignment_s.abs() <= advisory.dt_s / 2.0 + 1e-9);
    let d = advisory.decision;
    assert_eq!(
        d.go,
        d.probability_now.is_some_and(|p| p >= d.go_probability)
    );
    // The target vessel's own predictor publishes under its own name, at its own station
    // (another sea state at the point, so another forecast than the crane vessel's).
    let bytes = poll_until(PATIENCE, Duration::from_millis(50), || {
        target_forecasts.latest().ok().flatten()
    })
    .expect("a forecast of the target vessel");
    let forecast = Forecast::from_json(&bytes).expect("forecast JSON");
    assert!(forecast.valid_steps() > 0);

    assert!(run.wait_exit().success(), "{}", run.stderr().join("\n"));
    let stdout = run.stdout().join("\n");
    assert!(stdout.contains("two ships in one sea"), "{stdout}");
    assert!(stdout.contains("heading +20 deg"), "{stdout}");
    assert!(stdout.contains("lift ddg51->tender"), "{stdout}");
    for name in ["target-producer", "target-predictor", "relative"] {
        let log = std::fs::read_to_string(logs.path().join(format!("{name}.log"))).unwrap();
        assert!(log.contains("stopped"), "{name}:\n{log}");
    }
    let relative = std::fs::read_to_string(logs.path().join("relative.log")).unwrap();
    assert!(
        relative.contains("rejected 0 from ddg51, 0 from tender, 0 pairs not combinable"),
        "{relative}"
    );
}

#[test]
fn a_target_that_is_the_crane_vessel_is_refused_in_one_line() {
    let p = TestPipeline::new("twoship-bad", "[relative]\ntarget_vessel = \"ddg51\"\n");
    let out = std::process::Command::new(pipeline_support::BIN)
        .args(["relative", "--config", p.config.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("is the crane vessel itself"), "{stderr}");
}
