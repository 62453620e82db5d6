//! Every numeric command-line value and configuration key is range-checked, and every config
//! key must do something for the chosen method, before any work starts: a bad value exits with
//! one `error:` line naming it, never a panic, a hang or a run on a silently changed value.
//! One case per class of bug found in review.

mod pipeline_support;

use pipeline_support::{unique_instance, Proc};

/// Run `shipcast args` (killed if it outlives the patience), and check it failed with one
/// error line naming `needle`, without a panic and without starting its work (`started` is a
/// log line the command prints once it works).
fn refuses(args: &[&str], needle: &str, started: &str) {
    let mut proc = Proc::spawn("shipcast", args);
    let status = proc.wait_exit();
    let stderr = proc.stderr().join("\n");
    assert_eq!(status.code(), Some(2), "{args:?}: {stderr}");
    let errors: Vec<String> = proc
        .stderr()
        .into_iter()
        .filter(|l| l.starts_with("error:"))
        .collect();
    assert_eq!(errors.len(), 1, "{args:?}: {stderr}");
    assert!(errors[0].contains(needle), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    assert!(
        !started.is_empty() && !stderr.contains(started),
        "{args:?} started its work: {stderr}"
    );
}

/// Seconds that overflow `Duration::from_secs_f64` (it panicked) are refused.
#[test]
fn huge_durations_are_refused_not_a_panic() {
    let instance = unique_instance("rng-dur");
    refuses(
        &["producer", "--instance", &instance, "--duration", "1e300"],
        "--duration",
        "producer: simulating",
    );
    refuses(
        &[
            "producer",
            "--instance",
            &instance,
            "--wait-subscriber-s",
            "1e300",
        ],
        "--wait-subscriber-s",
        "producer: simulating",
    );
    refuses(
        &[
            "router",
            "--listen",
            "tcp/127.0.0.1:0",
            "--duration",
            "1e300",
        ],
        "--duration",
        "router: up",
    );
    refuses(
        &["bench", "fleet", "--vessels", "1", "--seconds", "1e300"],
        "--seconds",
        "vessels  bytes",
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("certs");
    // A huge --days, and a station given twice (it overwrote its own files and was counted
    // twice): refused before anything is written.
    for (extra, needle) in [
        (&["--days", "4000000000"][..], "--days"),
        (
            &["--station", "crane", "--station", "crane"][..],
            "--station 'crane' is given twice",
        ),
    ] {
        let mut args = vec![
            "certs",
            "--out",
            out.to_str().unwrap(),
            "--listen",
            "tls/127.0.0.1:7447",
        ];
        args.extend_from_slice(extra);
        refuses(&args, needle, "wrote");
        assert!(!out.join("ca.pem").exists());
    }
}

/// A core past the CPU set made CPU_SET panic in the forked child; now a parse error.
#[test]
fn cores_beyond_the_cpu_set_are_refused() {
    refuses(
        &["bench", "latency", "--cores", "0,5000", "--samples", "10"],
        "not a core id",
        "target",
    );
    let instance = unique_instance("rng-core");
    refuses(
        &[
            "predictor",
            "--instance",
            &instance,
            "--pin-core",
            "5000",
            "--duration",
            "1",
        ],
        "--pin-core",
        "predictor:",
    );
}

/// Counts that allocate or loop in proportion (the bench hung or aborted in
/// `Vec::with_capacity`; the simulator would have written for days).
#[test]
fn huge_counts_are_refused_before_allocating() {
    for (args, needle) in [
        (
            vec![
                "bench",
                "latency",
                "--samples",
                "10",
                "--rounds",
                "1",
                "--warmup",
                "100000000000000",
            ],
            "--warmup",
        ),
        (
            vec![
                "bench",
                "latency",
                "--samples",
                "100000000000000",
                "--rounds",
                "1",
            ],
            "--samples",
        ),
        (
            vec![
                "bench",
                "fleet",
                "--vessels",
                "10,100000000",
                "--seconds",
                "1",
            ],
            "--vessels",
        ),
    ] {
        refuses(&args, needle, "target");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let out = out.to_str().unwrap();
    refuses(
        &["simulate", "--duration", "1e300", "--out", out],
        "--duration",
        "wrote",
    );
    refuses(
        &[
            "simulate",
            "--duration",
            "31536000",
            "--rate",
            "10000",
            "--out",
            out,
        ],
        "rows",
        "wrote",
    );
}

/// Rates outside what the arithmetic holds: a tiny producer rate panicked, a huge one ran a
/// nonsense simulation, and a huge rate times the start-up history aborted in an allocation.
#[test]
fn rates_out_of_range_are_refused() {
    let instance = unique_instance("rng-rate");
    for rate in ["1e-300", "1e300", "nan"] {
        refuses(
            &[
                "producer",
                "--instance",
                &instance,
                "--rate",
                rate,
                "--duration",
                "1",
            ],
            "producer.rate_hz",
            "producer: simulating",
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("p.toml");
    std::fs::write(&config, "[producer]\nrate_hz = 5000.0\n").unwrap();
    refuses(
        &[
            "predictor",
            "--config",
            config.to_str().unwrap(),
            "--instance",
            &instance,
            "--duration",
            "1",
        ],
        "start-up history",
        "predictor:",
    );
}

/// Values that used to be changed silently (0 printed every advisory, NaN waited not at all,
/// 0 turned fault injection off, a skip past the record printed a table of NaN).
#[test]
fn values_once_coerced_silently_are_refused() {
    let instance = unique_instance("rng-silent");
    refuses(
        &[
            "deck",
            "--instance",
            &instance,
            "--print-every",
            "0",
            "--duration",
            "1",
        ],
        "--print-every",
        "deck: advising",
    );
    refuses(
        &[
            "producer",
            "--instance",
            &instance,
            "--wait-subscriber-s",
            "nan",
            "--duration",
            "1",
        ],
        "--wait-subscriber-s",
        "producer: simulating",
    );
    refuses(
        &[
            "producer",
            "--instance",
            &instance,
            "--fault-nan-every",
            "0",
            "--duration",
            "1",
        ],
        "--fault-nan-every",
        "producer: simulating",
    );
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("m.csv");
    let csv = csv.to_str().unwrap();
    pipeline_support::run_ok(&["simulate", "--duration", "60", "--out", csv]);
    refuses(
        &["replay", "--input", csv, "--skip-s", "1e300"],
        "--skip-s",
        "heave",
    );
    refuses(
        &["replay", "--input", csv, "--skip-s", "60"],
        "whole record",
        "heave",
    );
    let config = dir.path().join("p.toml");
    std::fs::write(&config, "[crane]\nprint_every = 0\n").unwrap();
    refuses(
        &[
            "replay",
            "--input",
            csv,
            "--config",
            config.to_str().unwrap(),
        ],
        "crane.print_every",
        "heave",
    );
}

/// A method's section for another method did nothing (MCA settings under the default Wiener
/// predictor); now it is refused, by every command that reads the configuration.
#[test]
fn a_method_section_for_another_method_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("m.csv");
    let csv = csv.to_str().unwrap();
    pipeline_support::run_ok(&["simulate", "--duration", "60", "--out", csv]);
    let config = dir.path().join("p.toml");
    std::fs::write(&config, "[predictor.mca]\nshift = 3\n").unwrap();
    let config = config.to_str().unwrap();
    refuses(
        &["replay", "--input", csv, "--config", config],
        "[predictor.mca] applies to method = \"mca\" only",
        "heave",
    );
    let instance = unique_instance("rng-section");
    refuses(
        &[
            "predictor",
            "--config",
            config,
            "--instance",
            &instance,
            "--duration",
            "1",
        ],
        "[predictor.mca]",
        "predictor:",
    );
}

/// `shipcast producer --input` of a heave record of `rows` rows at `rate_hz` is refused with
/// `expected` and never starts replaying.
fn producer_refuses_a_record_at(rate_hz: f64, rows: usize, expected: &str) {
    let instance = unique_instance("rng-csvrate");
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("record.csv");
    let mut text = String::from("time_s,heave_m\n");
    for i in 0..rows {
        let t = i as f64 / rate_hz;
        text.push_str(&format!("{t},{}\n", (t * 0.6).sin()));
    }
    std::fs::write(&csv, text).unwrap();
    refuses(
        &[
            "producer",
            "--instance",
            &instance,
            "--input",
            csv.to_str().unwrap(),
            "--duration",
            "1",
        ],
        expected,
        "producer: replaying",
    );
}

/// A record at another rate than `producer.rate_hz` was sent as if it had that rate: the
/// predictor decimated a 2 Hz record as 8 Hz (inventing three held values per sample, counted
/// nowhere) and a 16 Hz one gave forecasts whose steps were not `dt_s` apart.
#[test]
fn a_csv_at_another_rate_than_the_producers_is_refused() {
    producer_refuses_a_record_at(
        2.0,
        40,
        "is sampled at 2.0000 Hz but producer.rate_hz is 8 Hz",
    );
}

/// Regression (review): the producer took a record within 1 % of its rate, where eval and replay
/// take one within 0.1 % of a multiple of the forecast rate: an 8.05 Hz record was sent as 8 Hz
/// (a 25 s forecast's last step 0.16 s off its time) although replay refused it.
#[test]
fn a_csv_within_one_percent_but_beyond_the_shared_tolerance_is_refused_as_replay_refuses_it() {
    producer_refuses_a_record_at(8.05, 400, "not an integer fraction of the forecast step");
}

const SIX_DOF_HEADER: &str = "time_s,surge_m,sway_m,heave_m,roll_rad,pitch_rad,yaw_rad\n";

/// A row of a record in which every DOF moves.
fn six_dof_row(t: f64) -> String {
    let m = |f: f64, a: f64| a * (t * f).sin();
    format!(
        "{t},{},{},{},{},{},{}\n",
        m(0.5, 0.3),
        m(0.55, 0.4),
        m(0.6, 1.0),
        m(0.65, 0.05),
        m(0.7, 0.02),
        m(0.45, 0.01)
    )
}

/// Regression (review): a column absent from either record (here a misspelt heave) was taken
/// as zero, and the lift scored on a motion that never was, with exit status 0.
#[test]
fn a_relative_study_of_records_without_every_dof_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("full.csv");
    let misspelt = dir.path().join("misspelt.csv");
    let mut text = String::from(SIX_DOF_HEADER);
    for i in 0..800 {
        text.push_str(&six_dof_row(i as f64 * 0.125));
    }
    std::fs::write(&full, &text).unwrap();
    std::fs::write(&misspelt, text.replacen("heave_m", "heave", 1)).unwrap();
    let (full, misspelt) = (full.to_str().unwrap(), misspelt.to_str().unwrap());
    for (crane, target) in [(misspelt, full), (full, misspelt)] {
        refuses(
            &[
                "relative",
                "--crane-record",
                crane,
                "--target-record",
                target,
            ],
            &format!("{misspelt}: no heave_m column"),
            "forecast pairs",
        );
    }
}

/// Regression (review): an 8 Hz and a 4 Hz record were both replayed, and then no forecast pair
/// could be scored, blamed on the overlap: their forecasts stand for instants 0.25 s apart (the
/// decimation filter's delays). And a target record shorter than the crane's was replayed to
/// report an overlap of -50 s.
#[test]
fn a_relative_study_whose_records_cannot_pair_is_refused_before_replaying() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, step: f64, rows: usize| {
        let path = dir.path().join(name);
        let mut text = String::from(SIX_DOF_HEADER);
        for i in 0..rows {
            text.push_str(&six_dof_row(i as f64 * step));
        }
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    };
    let (fast, slow) = (
        write("8hz.csv", 0.125, 20_000),
        write("4hz.csv", 0.25, 10_000),
    );
    refuses(
        &[
            "relative",
            "--crane-record",
            &fast,
            "--target-record",
            &slow,
        ],
        "forecasts stand for instants 0.250 s apart",
        "forecast pairs",
    );
    let short = write("short.csv", 0.125, 9_000);
    refuses(
        &[
            "relative",
            "--crane-record",
            &fast,
            "--target-record",
            &short,
        ],
        "skips the whole overlap of the records (it ends at 1124.9 s, with",
        "forecast pairs",
    );
}

/// Two records that never overlap in time printed "0 forecast pairs" and a table of zeros
/// that read as a perfect score, with exit status 0.
#[test]
fn a_relative_study_of_records_that_do_not_overlap_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, t0: f64| {
        let path = dir.path().join(name);
        let mut text = String::from(SIX_DOF_HEADER);
        for i in 0..800 {
            let t = t0 + i as f64 * 0.125;
            text.push_str(&six_dof_row(t));
        }
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    };
    let (a, b) = (write("a.csv", 0.0), write("b.csv", 5000.0));
    refuses(
        &[
            "relative",
            "--crane-record",
            &a,
            "--target-record",
            &b,
            "--skip-s",
            "0",
        ],
        "the records do not overlap in time",
        "forecast pairs",
    );
}
