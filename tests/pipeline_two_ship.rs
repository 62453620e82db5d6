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
        // Ten times real time, so that within the run relative forecasts are verified against
        // both ships' motion (over zenoh) and enough of them calibrate the sigma.
        "[producer]\nspeed = 10.0\n[relative]\ntarget_vessel = \"tender\"\ntarget_heading_offset_deg = 20.0\ncalibration_min_verified = 20.0\n",
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
            // Piped, stdout is no terminal: the view would print once a minute.
            "--view-every",
            "1",
        ],
    );
    let names = p.names();
    let target = Names::new(Some(&p.instance), "tender").unwrap();
    let session = zn::open(&ZenohSettings::connect_to(&p.endpoint)).unwrap();
    let lift = LatestSubscriber::new(&session, &names.advisory("relative")).unwrap();
    let target_forecasts = LatestSubscriber::new(&session, &target.forecast()).unwrap();
    let advisory: RelativeAdvisory = poll_until(PATIENCE, Duration::from_millis(50), || {
        let bytes = lift.latest().ok().flatten()?;
        Some(serde_json::from_slice(&bytes).expect("the lift advisory is RelativeAdvisory JSON"))
    })
    .unwrap_or_else(|| panic!("no lift advisory; run:\n{}", run.stdout().join("\n")));
    assert_eq!(advisory.crane_vessel, names.vessel());
    assert_eq!(advisory.target_vessel, "tender");
    // The first relative forecasts have nothing verified behind them: the independent
    // sigma, and said so.
    assert_eq!(advisory.sigma_basis, SigmaBasis::Independent);
    assert_eq!(advisory.sigma_m, advisory.sigma_independent_m);
    // Once their horizons have passed and both ships' motion has come in, the sigma is the
    // verified one: scaled away from the independent one.
    let calibrated: RelativeAdvisory = poll_until(PATIENCE, Duration::from_millis(50), || {
        let bytes = lift.latest().ok().flatten()?;
        let a: RelativeAdvisory = serde_json::from_slice(&bytes).ok()?;
        (a.sigma_basis == SigmaBasis::Calibrated).then_some(a)
    })
    .unwrap_or_else(|| {
        panic!(
            "the relative sigma was never calibrated; run:\n{}",
            run.stdout().join("\n")
        )
    });
    assert_ne!(calibrated.sigma_m, calibrated.sigma_independent_m);
    assert!(calibrated
        .sigma_m
        .iter()
        .flatten()
        .all(|s| s.is_finite() && *s > 0.0));
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
        relative.contains(
            "rejected 0 forecasts and 0 motion samples from ddg51, 0 and 0 from tender, 0 pairs not combinable"
        ),
        "{relative}"
    );
    // At least the 20 forecasts behind the calibrated sigma were verified.
    let verified: u64 = relative
        .split("relative forecasts (")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no verified count in:\n{relative}"));
    assert!(verified >= 20, "{relative}");
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

#[test]
fn the_two_ship_study_scores_the_relative_forecast_from_two_simulated_records() {
    let dir = tempfile::tempdir().unwrap();
    let path = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let simulate = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "simulate",
            "--duration",
            "900",
            "--rate",
            "8",
            "--seed",
            "3",
            "--out",
            out,
        ];
        args.extend_from_slice(extra);
        pipeline_support::run_ok(&args);
    };
    let (a, b, same) = (path("a.csv"), path("b.csv"), path("same.csv"));
    simulate(&a, &[]);
    simulate(
        &b,
        &["--vessel-y-m", "40", "--vessel-heading-offset-deg", "10"],
    );
    simulate(&same, &["--vessel-x-m", "0"]);
    let study = |config: &str, target: &str| -> serde_json::Value {
        let out = pipeline_support::run_ok(&[
            "relative",
            "--config",
            config,
            "--crane-record",
            &a,
            "--target-record",
            target,
            "--skip-s",
            "300",
            "--json",
        ]);
        serde_json::from_str(&out).expect("one JSON report")
    };
    // The default geometry matches b.csv (40 m to starboard, bow +10 deg).
    let plain = path("plain.toml");
    std::fs::write(&plain, "").unwrap();
    let r = study(&plain, &b);
    let plain_scored = r["scored"].clone();
    assert_eq!(r["unpaired"], 0);
    assert!(r["scored"].as_u64().unwrap() > 500, "{r}");
    let leads = r["leads"].as_array().unwrap();
    assert_eq!(leads.len(), 15);
    for l in leads {
        let f = |k: &str| l[k].as_f64().unwrap();
        assert!(
            f("relative_zero_rms") > 0.0 && f("relative_rms") > 0.0,
            "{l}"
        );
        assert!(f("coverage_1sigma") < f("coverage_2sigma"), "{l}");
        assert!(f("error_correlation").abs() <= 1.0, "{l}");
    }
    assert_eq!(r["own"].as_array().unwrap().len(), 12);
    // The audit trail: one row per scored lift call, consistent with the report. The Gaussian
    // model states from the start here, so calls come before and after verified errors.
    let early = path("early.toml");
    std::fs::write(&early, "[relative]\ngo_needs_verified_errors = false\n").unwrap();
    let calls = path("calls.csv");
    let out = pipeline_support::run_ok(&[
        "relative",
        "--config",
        &early,
        "--crane-record",
        &a,
        "--target-record",
        &b,
        "--skip-s",
        "300",
        "--json",
        "--calls-csv",
        &calls,
    ]);
    let r: serde_json::Value = serde_json::from_str(&out).expect("one JSON report");
    let lift = &r["lift"];
    let text = std::fs::read_to_string(&calls).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len() as u64, lift["calls"].as_u64().unwrap());
    let window = (header.len() - 6) / 9;
    assert_eq!(window, 20, "MOT 10 s at 2 Hz: {header:?}");
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (stated, uncorrected, held) = (column("stated"), column("uncorrected"), column("held"));
    let mut go = 0;
    let mut holds = 0;
    for row in &rows {
        assert_eq!(row.len(), header.len());
        let p: f64 = row[stated].parse().unwrap();
        go += usize::from(p >= lift["go_probability"].as_f64().unwrap());
        // Whether the window held, from the row's own true displacements and the limits.
        let kept = (1..=window).all(|k| {
            ["x", "y", "z"].iter().all(|axis| {
                let v: f64 = row[column(&format!("actual_{axis}_{k}"))].parse().unwrap();
                v.abs() <= 1.0
            })
        });
        assert_eq!(row[held], if kept { "1" } else { "0" });
        holds += usize::from(kept);
    }
    assert_eq!(go as u64, lift["go_calls"].as_u64().unwrap());
    let base_rate = holds as f64 / rows.len() as f64;
    assert!((base_rate - lift["base_rate"].as_f64().unwrap()).abs() < 1e-12);
    // The Gaussian model's calls before verified errors, the ensemble's after.
    assert!(rows.iter().any(|r| r[uncorrected].is_empty()));
    assert!(rows.iter().any(|r| !r[uncorrected].is_empty()));
    // The reference vessel against itself with the spot at the tip: no relative motion, no
    // relative error, and the two ships' errors perfectly correlated.
    let itself = path("itself.toml");
    std::fs::write(
        &itself,
        "[relative]\ntarget_position_m = [0.0, 0.0]\ntarget_heading_offset_deg = 0.0\nlanding_spot_m = [10.0, 15.0, -20.0]\n",
    )
    .unwrap();
    let r = study(&itself, &same);
    let leads = r["leads"].as_array().unwrap();
    assert_eq!(leads.len(), 15, "{r}");
    for l in leads {
        assert_eq!(l["relative_rms"].as_f64().unwrap(), 0.0, "{l}");
        assert!(
            (l["error_correlation"].as_f64().unwrap() - 1.0).abs() < 1e-9,
            "{l}"
        );
    }
    // `relative` on records `a` and `b` with `extra` arguments, refused: its stderr.
    let refused = |a: &str, b: &str, extra: &[&str]| -> String {
        let out = std::process::Command::new(pipeline_support::BIN)
            .args(["relative", "--crane-record", a, "--target-record", b])
            .args(extra)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    // Skipping the whole record is one clear line.
    let e = refused(&a, &b, &["--skip-s", "5000"]);
    assert!(
        e.contains("skips the whole overlap of the records") && e.lines().count() == 1,
        "{e}"
    );
    // Regression: records stamped in epoch seconds. --skip-s is record time, so it must reach
    // past a year (it was refused there), and the default warm-up counts from the records'
    // start (a fixed 1200 s of record time scored an epoch record's warm-up too).
    const EPOCH: f64 = 1_700_000_000.0;
    let shifted = |from: &str, to: &str, by: f64| {
        let text = std::fs::read_to_string(from).unwrap();
        let mut lines = text.lines();
        let mut out = format!("{}\n", lines.next().unwrap());
        for line in lines {
            let (t, rest) = line.split_once(',').unwrap();
            let t: f64 = t.parse().unwrap();
            out.push_str(&format!("{},{rest}\n", t + by));
        }
        std::fs::write(to, out).unwrap();
    };
    let (ea, eb) = (path("a_epoch.csv"), path("b_epoch.csv"));
    shifted(&a, &ea, EPOCH);
    shifted(&b, &eb, EPOCH);
    let epoch_skip = format!("{}", EPOCH + 300.0);
    let out = pipeline_support::run_ok(&[
        "relative",
        "--crane-record",
        &ea,
        "--target-record",
        &eb,
        "--skip-s",
        &epoch_skip,
        "--json",
    ]);
    let epoch: serde_json::Value = serde_json::from_str(&out).expect("one JSON report");
    assert_eq!(epoch["scored"], plain_scored, "{epoch}");
    // 900 s of record: the default warm-up of 1200 s from its start skips all of it, and the
    // message says it was the default, not a --skip-s the user never gave.
    let e = refused(&ea, &eb, &[]);
    assert!(
        e.contains("the default warm-up of 1200 s")
            && e.contains("skips the whole overlap of the records"),
        "{e}"
    );
    // Regression: B stamped half a sample (1/16 s at 8 Hz) after A replayed both and then said
    // only that no pair could be scored. One clear line before any replay now.
    let half = path("b_half.csv");
    shifted(&b, &half, 0.0625);
    let e = refused(&a, &half, &["--skip-s", "300"]);
    assert!(
        e.contains("not sampled at the same instants")
            && e.contains("0.0625 s off")
            && e.lines().count() == 1,
        "{e}"
    );
}
