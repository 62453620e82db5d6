//! The latency harness end to end: every path and mode reports a count, every loss is counted
//! (none on iceoryx2, a rare one on zenoh), and the percentiles are ordered. No timing thresholds: the figures depend on the machine.

use shipcast_bench::latency;
use shipcast_bench::plan::{Mode, Path, Plan, Source};
use shipcast_eval::progress::NoProgress;
use std::collections::BTreeSet;
use std::process::Command;

fn plan(samples: u64) -> Plan {
    Plan {
        samples,
        warmup: 20,
        // Two rounds: the rows of a path merge the rounds' histograms.
        rounds: 2,
        // Fast enough to keep the test short, slow enough that a consumer descheduled for
        // tens of milliseconds by other work on the two cores does not overflow its queue.
        rate_hz: 500.0,
        cores: (0, 1),
        // Unique per process and call: parallel tests never share services or keys.
        instance: Plan::unique_instance("test"),
        shipcast_exe: Some(env!("CARGO_BIN_EXE_shipcast").into()),
    }
}

#[test]
fn every_path_and_mode_reports_counts_its_losses_and_ordered_percentiles() {
    let plan = plan(300);
    let modes = [Mode::Event, Mode::Poll];
    let report = latency::run(&plan, &modes, &NoProgress).expect("benchmark runs");
    let seen: BTreeSet<(&str, &str, &str)> = report
        .rows
        .iter()
        .map(|r| (r.path, r.mode, r.source))
        .collect();
    for mode in modes {
        let expected = Path::ALL[..4]
            .iter()
            .map(|p| (*p, Source::Services))
            .chain(Path::ALL[..4].iter().map(|p| (*p, Source::InProcess)))
            .chain([Path::Iceoryx2Raw, Path::ZenohRaw].map(|p| (p, Source::Raw)))
            .chain([(Path::ZenohRaw, Source::RawProcesses)]);
        for (path, source) in expected {
            assert!(
                seen.contains(&(path.name(), mode.name(), source.name())),
                "no row for {path} {mode} {}: {}",
                source.name(),
                report.table()
            );
        }
    }
    // Every path is measured, producer-to-predictor of the services through the predictor's
    // receive stamps.
    assert!(report.not_measured.is_empty(), "{:?}", report.not_measured);
    for r in &report.rows {
        assert!(r.count > 0, "{r:?}");
        // The forecast publisher drops rather than blocks when zenoh's queue is full
        // (`CongestionControl::Drop`, transport/zenoh.rs): under a loaded machine a forecast
        // of the zenoh paths may go (CI lost 1 of 76 once while other builds ran). Such a
        // loss must be counted, and stay rare; iceoryx2 loses nothing.
        if r.path.contains("zenoh") {
            assert!(r.lost * 20 <= r.count, "more than 5 % lost: {r:?}");
        } else {
            assert_eq!(r.lost, 0, "{r:?}");
        }
        let p = r.percentiles();
        assert!(p.windows(2).all(|w| w[0] <= w[1]), "unordered {r:?}");
        assert!(p[0] > 0.0, "zero latency {r:?}");
    }
    // One sample per measured send on the motion path; both legs of every raw exchange; one
    // forecast per 4 samples (the 8 -> 2 Hz decimation).
    let row = |path: Path, source: Source| {
        report
            .rows
            .iter()
            .find(|r| r.path == path.name() && r.mode == "event" && r.source == source.name())
            .unwrap()
    };
    for source in [Source::Services, Source::InProcess] {
        assert_eq!(row(Path::ProducerToPredictor, source).count, plan.samples);
    }
    assert_eq!(row(Path::Iceoryx2Raw, Source::Raw).count, 2 * plan.samples);
    // The inter-process floor: this side's legs and the ones the child wrote back.
    // Zenoh may drop (above): what arrived and what was counted lost make up what was sent.
    let received_or_lost = |r: &shipcast_bench::PathStats| r.count + r.lost;
    assert_eq!(
        received_or_lost(row(Path::ZenohRaw, Source::RawProcesses)),
        2 * plan.samples
    );
    for source in [Source::Services, Source::InProcess] {
        let forecasts = row(Path::SampleToForecastPublished, source).count;
        // Up to one more per round: where the decimation phase falls is up to each round.
        assert!(
            (plan.samples / 4..=plan.samples / 4 + plan.rounds).contains(&forecasts),
            "{forecasts}"
        );
        assert_eq!(row(Path::SampleToForecastLocal, source).count, forecasts);
        assert_eq!(
            received_or_lost(row(Path::SampleToForecastZenoh, source)),
            forecasts
        );
    }
    assert!(report
        .header()
        .contains("cores: sender/producer 0, receiver/predictor 1"));
}

#[test]
fn cli_prints_json_rows_and_refuses_bad_flags() {
    let exe = env!("CARGO_BIN_EXE_shipcast");
    let out = Command::new(exe)
        .args(["bench", "latency", "--samples", "40", "--rate", "1000"])
        .args(["--mode", "event", "--rounds", "1", "--json"])
        .output()
        .expect("run shipcast");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let rows = rows.as_array().expect("a JSON array");
    assert!(rows.len() >= Path::ALL.len());
    for r in rows {
        assert_eq!(r["mode"], "event");
        for key in [
            "path", "count", "lost", "p50_us", "p90_us", "p99_us", "p999_us", "max_us",
        ] {
            assert!(r.get(key).is_some(), "row without {key}: {r}");
        }
    }
    assert!(String::from_utf8_lossy(&out.stderr).contains("machine: "));

    for bad in [
        &["--cores", "1,1"][..],
        &["--mode", "fast"],
        &["--rate", "0"],
        &["--samples", "0"],
        &["--samples", "3", "--rounds", "4"],
    ] {
        let out = Command::new(exe)
            .args(["bench", "latency"])
            .args(bad)
            .output()
            .expect("run shipcast");
        assert!(!out.status.success(), "{bad:?} was accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{bad:?}: {err}");
    }
}
