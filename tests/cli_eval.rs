//! `shipcast eval` as a user runs it: the built binary on small CSVs in a temporary directory.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const HEADER: &str = "time_s,surge_m,sway_m,heave_m,roll_rad,pitch_rad,yaw_rad,wave_m";

/// A sea of a few sinusoids per DOF at `rate` Hz, `n` rows.
fn sea_csv(dir: &Path, name: &str, rate: f64, n: usize) -> PathBuf {
    let mut text = String::from(HEADER);
    text.push('\n');
    for i in 0..n {
        let t = i as f64 / rate;
        text.push_str(&t.to_string());
        for d in 0..7 {
            let d = d as f64;
            let v =
                (0.55 * t + d).sin() + 0.5 * (0.83 * t + 2.0 * d).sin() + 0.3 * (0.31 * t).cos();
            text.push_str(&format!(",{}", if d >= 3.0 { 0.01 * v } else { v }));
        }
        text.push('\n');
    }
    write(dir, name, &text)
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write test CSV");
    path
}

fn shipcast(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shipcast"))
        .args(args)
        .env_remove("RUST_LOG")
        .output()
        .expect("run shipcast")
}

/// Small protocol so every method runs in well under a second.
const SMALL: [&str; 10] = [
    "--order",
    "40",
    "--horizon",
    "6",
    "--train",
    "300",
    "--epochs",
    "5",
    "--stride",
    "2",
];

/// `shipcast eval` on `input` with the small protocol, `extra` flags overriding it.
fn eval(input: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["eval", "--input", input.to_str().expect("utf-8 path")];
    for pair in SMALL.chunks(2) {
        if !extra.contains(&pair[0]) {
            args.extend_from_slice(pair);
        }
    }
    args.extend_from_slice(extra);
    shipcast(&args)
}

/// Non-zero exit, one stderr line starting with `error:` and containing `reason`, no panic.
fn assert_one_line_error(output: &Output, reason: &str) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "succeeded; stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "stderr: {stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert_eq!(
        lines[0].matches(reason).count(),
        1,
        "want '{reason}' once in: {stderr}"
    );
}

#[test]
fn json_lines_have_the_contract_fields_for_every_pair() {
    let dir = tempfile::tempdir().unwrap();
    let input = sea_csv(dir.path(), "sea.csv", 2.0, 500);
    let output = eval(&input, &["--dof", "all", "--method", "all", "--json"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect();
    assert_eq!(lines.len(), 6 * 6);
    let origins = (340..=494).step_by(2).count();
    for v in &lines {
        for field in [
            "dof",
            "method",
            "order",
            "horizon",
            "train",
            "sample_rate",
            "origins",
            "rms",
            "nrmse",
            "persistence_rms",
            "train_seconds",
            "predict_seconds",
        ] {
            assert!(v.get(field).is_some(), "missing {field}: {v}");
        }
        assert_eq!(v["order"], 40);
        assert_eq!(v["train"], 300);
        assert_eq!(v["origins"], origins);
        assert_eq!(v["rms"].as_array().unwrap().len(), 6);
        assert_eq!(v["nrmse"].as_array().unwrap().len(), 6);
        assert!(v.get("rms_clean").is_none());
        if v["method"] == "mca" {
            assert!(v["minor_components"].as_u64().unwrap() >= 6, "{v}");
        }
        if v["method"] == "persistence" {
            assert_eq!(v["rms"], v["persistence_rms"]);
        }
    }
}

#[test]
fn noise_adds_rms_clean_and_8_hz_input_is_decimated() {
    let dir = tempfile::tempdir().unwrap();
    let input = sea_csv(dir.path(), "sea8.csv", 8.0, 2000);
    let output = eval(
        &input,
        &[
            "--dof",
            "heave",
            "--method",
            "zero",
            "--json",
            "--noise-pct",
            "10",
        ],
    );
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    // 2000 samples at 8 Hz decimate to (2000 - 17) / 4 + 1 = 496 at 2 Hz.
    assert_eq!(v["origins"], (340..=490).step_by(2).count());
    assert_eq!(v["sample_rate"], 2.0);
    let rms = v["rms"].as_array().unwrap();
    let clean = v["rms_clean"].as_array().unwrap();
    assert_eq!(clean.len(), rms.len());
    assert_ne!(rms, clean);
}

/// Regression (review): `train` and `eval` fitted on and scored against spikes without a word.
/// Each column's samples far outside their minute are named, with their count and the first
/// one's time; a clean record gets no such line, and the run goes on either way.
#[test]
fn spikes_in_a_record_are_named_and_the_run_goes_on() {
    let dir = tempfile::tempdir().expect("temp dir");
    let clean = sea_csv(dir.path(), "clean.csv", 2.0, 1000);
    let text = std::fs::read_to_string(&clean).expect("read");
    // Heave (the fourth column) 40 m up in row 701, at t = 350 s.
    let spiked: String = text
        .lines()
        .enumerate()
        .map(|(i, line)| {
            if i != 701 {
                return format!("{line}\n");
            }
            let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
            let heave: f64 = cells[3].parse().expect("heave");
            cells[3] = (heave + 40.0).to_string();
            format!("{}\n", cells.join(","))
        })
        .collect();
    let spiked = write(dir.path(), "spiked.csv", &spiked);
    let named = |path: &Path| {
        let out = eval(path, &["--dof", "heave", "--method", "zero"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stderr)
            .lines()
            .filter(|l| l.contains("robust scales"))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    assert_eq!(named(&clean), Vec::<String>::new());
    let lines = named(&spiked);
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(
        lines[0].contains("1 sample(s) of heave_m") && lines[0].contains("t = 350 s"),
        "{lines:?}"
    );
}

#[test]
fn table_is_the_default_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = sea_csv(dir.path(), "sea.csv", 2.0, 500);
    let output = eval(&input, &["--dof", "pitch", "--method", "persistence"]);
    assert!(output.status.success());
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("rms/skill 0.5 s"), "{stdout}");
    assert!(stdout.contains("pitch  persistence"), "{stdout}");
}

#[test]
fn bad_input_gives_one_line_error_and_non_zero_exit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = sea_csv(d, "sea.csv", 2.0, 500);
    let rows = |f: &dyn Fn(usize) -> String| -> String {
        let body: String = (0..500).map(|i| f(i) + "\n").collect();
        format!("time_s,heave_m\n{body}")
    };
    let cases: Vec<(PathBuf, Vec<&str>, &str)> = vec![
        (write(d, "empty.csv", ""), vec![], "empty file"),
        (
            write(d, "pitch_only.csv", "time_s,pitch_rad\n0,1\n0.5,2\n"),
            vec!["--dof", "heave"],
            "no 'heave_m' column",
        ),
        (
            write(d, "no_time.csv", "t,heave_m\n0,1\n"),
            vec![],
            "no 'time_s' column",
        ),
        (
            write(
                d,
                "nan.csv",
                &rows(&|i| {
                    if i == 7 {
                        format!("{},NaN", i as f64 * 0.5)
                    } else {
                        format!("{},1", i as f64 * 0.5)
                    }
                }),
            ),
            vec![],
            "line 9, column 'heave_m': non-finite value 'NaN'",
        ),
        (
            write(
                d,
                "back.csv",
                &rows(&|i| format!("{},1", if i == 20 { 3.0 } else { i as f64 * 0.5 })),
            ),
            vec![],
            "line 22, column 'time_s'",
        ),
        (
            write(
                d,
                "hole.csv",
                &rows(&|i| {
                    if i == 3 {
                        "1.5,".to_string()
                    } else {
                        format!("{},1", i as f64 * 0.5)
                    }
                }),
            ),
            vec![],
            "line 5, column 'heave_m': missing value",
        ),
        (
            write(
                d,
                "irregular.csv",
                &rows(&|i| format!("{},1", i as f64 * 0.5 + if i > 100 { 0.25 } else { 0.0 })),
            ),
            vec![],
            "irregular sampling",
        ),
        (
            sea_csv(d, "three_hz.csv", 3.0, 600),
            vec![],
            "not an integer multiple",
        ),
        (good.clone(), vec!["--order", "900"], "too short"),
        (
            good.clone(),
            vec!["--method", "mca", "--horizon", "40"],
            "mca",
        ),
        (
            good.clone(),
            vec!["--method", "kalman"],
            "unknown method 'kalman'",
        ),
        (
            good.clone(),
            vec!["--dof", "heavy"],
            "unknown degree of freedom 'heavy'",
        ),
        (dir.path().join("absent.csv"), vec![], "absent.csv"),
    ];
    for (input, extra, reason) in cases {
        let output = eval(&input, &extra);
        assert_one_line_error(&output, reason);
    }
}

/// `shipcast train` of `method` with order 40 and horizon 6 from `input` to `out`; must succeed.
fn train_order_40_horizon_6(input: &Path, out: &Path, method: &str) {
    let output = shipcast(&[
        "train",
        "--input",
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--method",
        method,
        "--order",
        "40",
        "--horizon",
        "6",
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

#[test]
fn train_writes_a_loadable_model_for_every_dof_present() {
    let dir = tempfile::tempdir().unwrap();
    let input = sea_csv(dir.path(), "sea.csv", 2.0, 500);
    let out = dir.path().join("model.json");
    train_order_40_horizon_6(&input, &out, "wiener");
    let model = shipcast_eval::model::ModelFile::load(&out).unwrap();
    assert_eq!(model.dofs.len(), 6);
    assert_eq!(model.sample_rate, 2.0);
    assert_eq!(model.config.order, 40);
    for m in &model.dofs {
        assert_eq!(m.sigma.len(), 6);
        assert_eq!(m.samples, 500);
    }

    let bad = shipcast(&[
        "train",
        "--input",
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--method",
        "mca",
        "--order",
        "10",
        "--horizon",
        "10",
    ]);
    assert_one_line_error(&bad, "infeasible");

    // Regression (review): "too short" advised a lower --holdout, which makes it worse: the
    // held-out share must hold order + horizon values (50 of 500 cannot hold 60 + 6).
    let train_on = |input: &std::path::Path, holdout: &str| {
        shipcast(&[
            "train",
            "--input",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--order",
            "60",
            "--horizon",
            "6",
            "--holdout",
            holdout,
        ])
    };
    let train = |holdout: &str| train_on(&input, holdout);
    assert_one_line_error(&train("0.1"), "or a larger --holdout help");
    // It names the length that is enough: 651 samples (the last 66 held out), and 650 not.
    let short = train("0.1");
    let e = String::from_utf8_lossy(&short.stderr).to_string();
    assert!(
        e.contains("500 samples at 2 Hz are too short")
            && e.contains("at least 651 samples at that rate"),
        "{e}"
    );
    let text = std::fs::read_to_string(sea_csv(dir.path(), "long.csv", 2.0, 700)).unwrap();
    let rows = |n: usize| {
        let path = dir.path().join(format!("first{n}.csv"));
        let lines: Vec<&str> = text.lines().take(1 + n).collect();
        std::fs::write(&path, lines.join("\n") + "\n").unwrap();
        path
    };
    assert!(train_on(&rows(651), "0.1").status.success());
    assert_one_line_error(&train_on(&rows(650), "0.1"), "at least 651 samples");
    let larger = train("0.2");
    assert!(
        larger.status.success(),
        "{}",
        String::from_utf8_lossy(&larger.stderr)
    );
    // Regression (review): a tiny --holdout was written out in 300 digits, and a held-out
    // share that left too little to train on said nothing of --holdout.
    let tiny = train("1e-300");
    assert_one_line_error(&tiny, "--holdout 1e-300 of it");
    assert!(String::from_utf8_lossy(&tiny.stderr).len() < 400);
    assert_one_line_error(&train("0.9"), "or a smaller --holdout help");
}

/// Regression (review): `train` on a record with only some DOF columns wrote a model file that
/// `replay` (and the predictor) refused: "no model for surge". The DOFs without a model now
/// start at no skill, and the log names them.
#[test]
fn a_model_of_some_dofs_is_replayed_with_the_others_at_no_skill() {
    let dir = tempfile::tempdir().unwrap();
    let input = sea_csv(dir.path(), "sea.csv", 2.0, 500);
    let text = std::fs::read_to_string(&input).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let (t, h) = (
        header.iter().position(|c| *c == "time_s").unwrap(),
        header.iter().position(|c| *c == "heave_m").unwrap(),
    );
    let heave_only: String = text
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            format!("{},{}\n", f[t], f[h])
        })
        .collect();
    let heave_csv = dir.path().join("heave.csv");
    std::fs::write(&heave_csv, heave_only).unwrap();
    let model = dir.path().join("heave.json");
    train_order_40_horizon_6(&heave_csv, &model, "wiener");
    let config = dir.path().join("h6.toml");
    std::fs::write(&config, "[predictor]\nhorizon = 6\nretrain_every_s = 0.0\n").unwrap();
    let output = shipcast(&[
        "replay",
        "--input",
        input.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("no model for surge, sway, roll, pitch, yaw: forecast at no skill"),
        "{stderr}"
    );
    let dofs: Vec<serde_json::Value> = String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v.get("dof").is_some())
        .collect();
    let nrmse = |dof: &str| {
        dofs.iter().find(|v| v["dof"] == dof).unwrap()["nrmse"][0]
            .as_f64()
            .unwrap()
    };
    // Heave is forecast by its model; roll, without one, is the level: no skill.
    assert!(nrmse("heave") < 0.8, "{}", nrmse("heave"));
    assert!((nrmse("roll") - 1.0).abs() < 0.1, "{}", nrmse("roll"));
}

/// `--average K --average-mode M`: the JSON names the combination, K = 1 prints the same
/// numbers as no flag, weighted averaging reports its weights, and a K beyond the horizon is a
/// one-line error.
#[test]
fn averaged_forecasts_are_named_and_k_one_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let input = sea_csv(dir.path(), "sea.csv", 2.0, 500);
    let json = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["--dof", "heave", "--method", "wiener", "--json"];
        args.extend_from_slice(extra);
        let output = eval(&input, &args);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        serde_json::from_slice(&output.stdout).unwrap()
    };
    let plain = json(&[]);
    let one = json(&["--average", "1", "--average-mode", "weighted"]);
    assert_eq!(plain["rms"], one["rms"]);
    assert_eq!(
        plain["average"],
        serde_json::json!({"k": 1, "mode": "uniform"})
    );
    let weighted = json(&["--average", "3", "--average-mode", "weighted"]);
    assert_eq!(
        weighted["average"],
        serde_json::json!({"k": 3, "mode": "weighted"})
    );
    assert_eq!(weighted["origins"], plain["origins"]);
    let weights = weighted["average_weights"].as_array().unwrap();
    assert_eq!(weights.len(), 6);
    assert_eq!(weights[0].as_array().unwrap().len(), 3);

    let table = eval(
        &input,
        &["--dof", "heave", "--method", "zero", "--average", "4"],
    );
    let stdout = String::from_utf8_lossy(&table.stdout);
    assert!(
        stdout.contains("forecasts averaged: uniform mean of 4"),
        "{stdout}"
    );

    let too_many = eval(&input, &["--dof", "heave", "--average", "7"]);
    assert_one_line_error(&too_many, "between 1 and the horizon 6");
    let bad_mode = eval(
        &input,
        &[
            "--dof",
            "heave",
            "--average",
            "2",
            "--average-mode",
            "median",
        ],
    );
    assert!(!bad_mode.status.success());
}

/// A hand-edited model file: `shipcast replay --model` refuses it with one line naming the
/// field, instead of slicing out of range while forecasting.
#[test]
fn replay_refuses_a_corrupted_model_file_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let input = sea_csv(dir.path(), "sea.csv", 2.0, 500);
    let model = dir.path().join("model.json");
    train_order_40_horizon_6(&input, &model, "mca");
    // Replay with the model file edited by `edit`.
    let replay_edited = |name: &str, edit: &dyn Fn(&mut serde_json::Value)| {
        let mut json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&model).unwrap()).unwrap();
        edit(&mut json);
        let bad = write(dir.path(), name, &json.to_string());
        shipcast(&[
            "replay",
            "--input",
            input.to_str().unwrap(),
            "--model",
            bad.to_str().unwrap(),
        ])
    };
    let output = replay_edited("bad.json", &|json| {
        let matrix = &mut json["dofs"][2]["predictor"]["model"]["prediction"];
        // 6 x 33 instead of 6 x 34: consistent in itself, one past value short.
        matrix["cols"] = 33.into();
        matrix["coef"].as_array_mut().unwrap().truncate(6 * 33);
    });
    assert_one_line_error(
        &output,
        "MCA model.prediction is 6 x 33; horizon 6 and order 40 need 6 x 34",
    );
    // A rate edited to 1e-300 was printed in 300 plain digits.
    let output = replay_edited("rate.json", &|json| json["sample_rate"] = 1e-300.into());
    assert_one_line_error(
        &output,
        "model forecasts at 1e-300 Hz, the predictor runs at 2 Hz",
    );
}

/// A model file of another horizon than the configuration's was accepted, and then every
/// live retrain (at the configured horizon) was thrown away as "another horizon".
#[test]
fn replay_refuses_a_model_of_another_horizon_than_the_configured_one() {
    let dir = tempfile::tempdir().unwrap();
    let input = sea_csv(dir.path(), "sea.csv", 2.0, 500);
    let model = dir.path().join("model.json");
    train_order_40_horizon_6(&input, &model, "wiener");
    let output = shipcast(&[
        "replay",
        "--input",
        input.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
    ]);
    assert_one_line_error(
        &output,
        "model horizon 6 differs from predictor.horizon 50: set predictor.horizon = 6",
    );
}

/// Regression: a record too short for any window of MOT to be verified was reported as "the
/// horizon is shorter than the MOT", which was true only of the 30 s MOT; and one too short
/// for any forecast to be scored printed a table of NaN and succeeded.
#[test]
fn replay_of_a_record_too_short_to_score_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let record = |name: &str, duration: &str| {
        let csv = dir.path().join(name).to_str().unwrap().to_string();
        assert!(
            shipcast(&["simulate", "--duration", duration, "--out", &csv])
                .status
                .success()
        );
        csv
    };
    // 45 s: the first forecast comes 31.5 s into the record, and its 25 s of steps end
    // beyond the record.
    let short = record("short.csv", "45");
    let output = shipcast(&["replay", "--input", &short, "--skip-s", "0"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && output.stdout.is_empty(),
        "{stderr}"
    );
    let error = stderr.lines().last().unwrap_or_default();
    assert!(
        error.starts_with("error: no forecast could be scored in")
            && error.contains("all 25 s of its steps"),
        "{stderr}"
    );
    // 2 minutes: forecasts are scored, but the deck states no probability before it has
    // verified errors.
    let csv = record("two_minutes.csv", "120");
    let output = shipcast(&["replay", "--input", &csv, "--skip-s", "0"]);
    assert!(output.status.success());
    let out = String::from_utf8_lossy(&output.stdout);
    let no_call = |mot: &str| {
        out.lines()
            .find(|l| l.starts_with(&format!("deck MOT {mot}s:")))
            .unwrap_or_else(|| panic!("no line for MOT {mot} s:\n{out}"))
            .to_string()
    };
    // The default horizon is 25 s: MOT 10 s fits it, 30 s does not.
    assert_eq!(
        no_call("10"),
        "deck MOT 10s: no call (no probability was stated in the scored part of the record: the deck states none before it has verified errors, about 5 minutes)"
    );
    assert_eq!(
        no_call("30"),
        "deck MOT 30s: no call (the horizon is shorter than the MOT)"
    );
}

/// Regression (review): a record with a 2 s hole every 20 s (a logger that drops a block)
/// restarts the history at each hole, and no forecast has all of its 25 s of steps on
/// recorded samples; the error said forecasts must be issued after "--skip-s", an option
/// never given. Such forecasts are now scored at the steps the record has; a record without
/// holes that is merely short says only what a forecast needs.
#[test]
fn replay_of_a_record_whose_gaps_restart_the_history_names_them_not_skip_s() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("plain.csv").to_str().unwrap().to_string();
    assert!(shipcast(&["simulate", "--duration", "200", "--out", &csv])
        .status
        .success());
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let mut gappy = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let t: f64 = line.split_once(',').unwrap().0.parse().unwrap();
        if t % 20.0 < 18.0 {
            gappy.push_str(line);
            gappy.push('\n');
        }
    }
    let holes = dir.path().join("holes.csv").to_str().unwrap().to_string();
    std::fs::write(&holes, gappy).unwrap();
    let error = |args: &[&str]| {
        let output = shipcast(args);
        let stderr = String::from_utf8_lossy(&output.stderr).to_string();
        assert!(!output.status.success(), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        stderr.lines().last().unwrap_or_default().to_string()
    };
    // Holes at 18, 38, ..., 178 s restart it; every forecast's horizon spans a hole. Since
    // 2026-12-07 a forecast is scored at the steps the record has (review: with 5 % of the
    // samples lost, 220 of 2337 forecasts were scored, without a word), and the table says
    // how many were scored only in part.
    let output = shipcast(&["replay", "--input", &holes]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let scored = stdout
        .lines()
        .find(|l| l.starts_with("scored: "))
        .unwrap_or_default();
    let count = |s: &str| -> u64 { s.split_whitespace().next().unwrap().parse().unwrap() };
    let (all, partly) = scored
        .strip_prefix("scored: ")
        .and_then(|r| r.split_once(", "))
        .map(|(a, p)| (count(a), count(p)))
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(all > 0 && partly == all, "{scored}");
    assert!(scored.contains("of them partly scored"), "{scored}");
    // The JSON says as much on every DOF's line (review: it had no `partly_scored`, which
    // the docs promised).
    let json = shipcast(&["replay", "--input", &holes, "--json"]);
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&json.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .filter(|v: &serde_json::Value| v.get("dof").is_some())
        .collect();
    assert_eq!(lines.len(), 6);
    for v in &lines {
        assert_eq!(v["scored"].as_u64(), Some(all), "{v}");
        assert_eq!(v["partly_scored"].as_u64(), Some(partly), "{v}");
    }
    // Too short, and no --skip-s was given, so none is named. The length the message asks
    // for is the real boundary (review: it said the first forecast comes 30 s in, and a
    // 55.5 s record was refused): 60 values at 2 Hz after the filter's 17 inputs at 8 Hz come
    // with the input at 31.5 s, stamped 0.5 s before it, and 25 s of steps follow.
    let long = dir.path().join("long.csv").to_str().unwrap().to_string();
    assert!(shipcast(&["simulate", "--duration", "60", "--out", &long])
        .status
        .success());
    let text = std::fs::read_to_string(&long).unwrap();
    let first_rows = |n: usize| -> String {
        let path = dir.path().join(format!("first{n}.csv"));
        let rows: Vec<&str> = text.lines().take(1 + n).collect();
        std::fs::write(&path, rows.join("\n") + "\n").unwrap();
        path.to_str().unwrap().to_string()
    };
    // 0 to 55.5 s at 8 Hz.
    let e = error(&["replay", "--input", &first_rows(445)]);
    assert!(
        e.contains("runs from 0.0 to 55.5 s")
            && e.contains("the first is issued 31.5 s into the record")
            && e.contains("at least 56 s are needed")
            && !e.contains("--skip-s")
            && !e.contains("restarted"),
        "{e}"
    );
    let taken = shipcast(&["replay", "--input", &first_rows(449), "--json"]);
    assert!(taken.status.success(), "{taken:?}");
    // Without holes and long enough, but --skip-s past the last whole forecast: --skip-s
    // is the cause, and the message says so (review: it blamed the gaps of a gappy record).
    let e = error(&["replay", "--input", &csv, "--skip-s", "190"]);
    assert!(
        e.contains("but none at or after --skip-s 190 s") && !e.contains("restarted"),
        "{e}"
    );
}

/// Regression (review): `--out` naming the file read (`simulate --elevation x.csv --out
/// x.csv`, `train --input y.csv --out ./y.csv`) wrote over it: a measured record replaced by
/// its simulated motion, or by a model. Both are refused and the file is left as it was.
#[test]
fn an_output_that_is_the_input_file_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let record = dir.path().join("x.csv");
    let record_str = record.to_str().unwrap();
    assert!(
        shipcast(&["simulate", "--duration", "300", "--out", record_str])
            .status
            .success()
    );
    let before = std::fs::read(&record).unwrap();
    // The same file by another name, and by a hard link.
    let dotted = format!("{}/./x.csv", dir.path().display());
    let hard = dir.path().join("hard.csv");
    std::fs::hard_link(&record, &hard).unwrap();
    let hard = hard.to_str().unwrap();
    let cases: [(&[&str], &str); 3] = [
        (
            &["simulate", "--elevation", record_str, "--out", &dotted],
            "is the --elevation file",
        ),
        (
            &[
                "train", "--input", record_str, "--out", hard, "--order", "25",
            ],
            "is the --input file",
        ),
        (
            &[
                "relative",
                "--crane-record",
                record_str,
                "--target-record",
                record_str,
                "--calls-csv",
                &dotted,
            ],
            "is the --crane-record file",
        ),
    ];
    for (args, reason) in cases {
        assert_one_line_error(&shipcast(args), reason);
        assert_eq!(std::fs::read(&record).unwrap(), before, "{args:?}");
    }
    // Nor the configuration, or the model it names (review: both were written over).
    let model = dir.path().join("m.json");
    std::fs::write(&model, "{}").unwrap();
    let config = dir.path().join("c.toml");
    let config_text = format!("[predictor]\nmodel = {:?}\n", model.to_str().unwrap());
    std::fs::write(&config, &config_text).unwrap();
    let config = config.to_str().unwrap();
    for (calls, reason) in [
        (config, "is the --config file"),
        (model.to_str().unwrap(), "is the predictor.model file"),
    ] {
        let args = [
            "relative",
            "--crane-record",
            record_str,
            "--target-record",
            hard,
            "--config",
            config,
            "--calls-csv",
            calls,
        ];
        assert_one_line_error(&shipcast(&args), reason);
        assert_eq!(std::fs::read_to_string(config).unwrap(), config_text);
        assert_eq!(std::fs::read_to_string(&model).unwrap(), "{}");
    }
}

/// Regressions (review): `relative --calls-csv` emptied the file as the study began, so a
/// study that scored nothing lost the calls of the one before; and a directory given as the
/// file was found only after the study.
#[test]
fn a_lift_study_that_scores_nothing_keeps_the_calls_file_it_was_given() {
    let dir = tempfile::tempdir().unwrap();
    let record = |name: &str, seed: &str| {
        let path = dir.path().join(name).to_str().unwrap().to_string();
        let made = shipcast(&[
            "simulate",
            "--duration",
            "400",
            "--seed",
            seed,
            "--out",
            &path,
        ]);
        assert!(made.status.success());
        path
    };
    let (crane, target) = (record("a.csv", "1"), record("b.csv", "2"));
    let calls = dir.path().join("calls.csv");
    std::fs::write(&calls, "the calls of an earlier study\n").unwrap();
    let study = |calls: &str| {
        shipcast(&[
            "relative",
            "--crane-record",
            &crane,
            "--target-record",
            &target,
            // Past the last forecast pair whose horizon fits in the records.
            "--skip-s",
            "395",
            "--calls-csv",
            calls,
        ])
    };
    // The study logs its engines' progress before it fails.
    let failed = study(calls.to_str().unwrap());
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert!(!failed.status.success(), "{stderr}");
    assert!(
        stderr
            .lines()
            .last()
            .is_some_and(|l| l.starts_with("error: no forecast pair could be scored")),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read_to_string(&calls).unwrap(),
        "the calls of an earlier study\n"
    );
    assert_one_line_error(
        &study(dir.path().to_str().unwrap()),
        "is a directory, not a file",
    );
    // A pipe is written into (regression, review: the check for a place to write a file
    // beside it refused pipes and /dev/stdout; /proc/self/fd, where no file can be made even
    // by root, is this process's stdout, captured here as a pipe).
    let scored = shipcast(&[
        "relative",
        "--crane-record",
        &crane,
        "--target-record",
        &target,
        "--skip-s",
        "100",
        "--calls-csv",
        "/proc/self/fd/1",
    ]);
    assert!(
        scored.status.success(),
        "{}",
        String::from_utf8_lossy(&scored.stderr)
    );
    let stdout = String::from_utf8_lossy(&scored.stdout);
    assert!(
        stdout.contains("time_s,stated,uncorrected"),
        "the calls' header: {stdout}"
    );
}

/// Regression (review): a record stamped before 0 was refused, as "--skip-s 0 s skips the
/// whole record" although no --skip-s was given; replay now scores from the record's start.
#[test]
fn replay_of_a_record_stamped_before_zero_scores_it_all_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("plain.csv").to_str().unwrap().to_string();
    assert!(shipcast(&["simulate", "--duration", "120", "--out", &csv])
        .status
        .success());
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let mut shifted = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let (t, rest) = line.split_once(',').unwrap();
        let t: f64 = t.parse().unwrap();
        shifted.push_str(&format!("{},{rest}\n", t - 5000.0));
    }
    let early = dir.path().join("early.csv").to_str().unwrap().to_string();
    std::fs::write(&early, shifted).unwrap();
    let scored = |input: &str, extra: &[&str]| {
        let output = shipcast(&[&["replay", "--input", input, "--json"][..], extra].concat());
        let stderr = String::from_utf8_lossy(&output.stderr).to_string();
        assert!(output.status.success(), "{stderr}");
        let first: serde_json::Value = serde_json::from_str(
            String::from_utf8_lossy(&output.stdout)
                .lines()
                .next()
                .unwrap(),
        )
        .unwrap();
        first["scored"].as_u64().unwrap()
    };
    // The same forecasts are scored, 5000 s earlier.
    let n = scored(&csv, &[]);
    assert!(n > 0);
    assert_eq!(scored(&early, &[]), n);
    assert_eq!(scored(&early, &["--skip-s", "-5000"]), n);
}

/// Regression: samples missing from a record (every other one over its second half) were
/// bridged without a count or a word; eval refuses such a file, replay said nothing.
#[test]
fn replay_counts_and_reports_the_samples_missing_from_a_record() {
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("full.csv");
    assert!(shipcast(&[
        "simulate",
        "--duration",
        "400",
        "--rate",
        "8",
        "--out",
        full.to_str().unwrap()
    ])
    .status
    .success());
    let text = std::fs::read_to_string(&full).unwrap();
    let mut lines = text.lines();
    let mut thinned = format!("{}\n", lines.next().unwrap());
    let rows: Vec<&str> = lines.collect();
    let mut removed = 0;
    for (i, row) in rows.iter().enumerate() {
        if i >= rows.len() / 2 && i % 2 == 1 && i + 1 < rows.len() {
            removed += 1;
            continue;
        }
        thinned.push_str(row);
        thinned.push('\n');
    }
    let input = write(dir.path(), "thinned.csv", &thinned);
    let output = shipcast(&["replay", "--input", input.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    let out = String::from_utf8_lossy(&output.stdout);
    let expected = format!(
        "input: {} samples, {removed} missing (gaps), 0 rejected",
        rows.len() - removed
    );
    assert!(out.contains(&expected), "want '{expected}' in:\n{out}");
    assert!(
        stderr.contains(&format!("replay: {removed} samples missing from")),
        "{stderr}"
    );
}

/// A record of heave alone, `rows` at `rate` Hz, two sinusoids; `stamp` writes the time
/// column from the record time t (rounded, shifted to epoch seconds, ...).
fn heave_csv(
    dir: &Path,
    name: &str,
    rate: f64,
    rows: usize,
    stamp: impl Fn(f64) -> String,
) -> PathBuf {
    let mut text = String::from("time_s,heave_m\n");
    for i in 0..rows {
        let t = i as f64 / rate;
        let heave = (0.7 * t).sin() + 0.4 * (1.1 * t + 1.0).sin();
        text.push_str(&format!("{},{heave}\n", stamp(t)));
    }
    write(dir, name, &text)
}

/// Regression: an 8 Hz record whose time stamps were rounded to 2 decimals (steps of 0.12 and
/// 0.13 s) was refused as "config: input rate 7.692308 Hz is not an integer multiple", blaming
/// the configuration for the record's stamps. Stamps rounded to a quarter of the step or less
/// are now read at their rate (eval does the same); rounded more coarsely (a 4 Hz record to
/// 0.1 s: steps of 0.2 and 0.3 s), the record is refused and its stamps named, with the
/// rounding that is too coarse (it used to be read as 3.33 Hz, "rounded or jittered").
#[test]
fn replay_of_a_record_with_rounded_time_stamps_says_so_of_the_record() {
    let dir = tempfile::tempdir().unwrap();
    let input = heave_csv(dir.path(), "rounded.csv", 8.0, 2000, |t| format!("{t:.2}"));
    let output = shipcast(&["replay", "--input", input.to_str().unwrap(), "--json"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    let coarse = heave_csv(dir.path(), "coarse.csv", 4.0, 1000, |t| format!("{t:.1}"));
    let output = shipcast(&["replay", "--input", coarse.to_str().unwrap()]);
    assert_one_line_error(&output, "time stamps rounded to 0.1 s are too coarse");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("typical step 0.3 s"), "{stderr}");
    assert!(stderr.contains("coarse.csv"), "{stderr}");
    assert!(!stderr.contains("config"), "{stderr}");
}

/// Regression: a record without roll or pitch had its deck decisions scored on zeros (a calm
/// deck: hundreds of go calls, none false) without a word.
#[test]
fn replay_of_a_record_without_roll_and_pitch_scores_no_deck_decision() {
    let dir = tempfile::tempdir().unwrap();
    let input = heave_csv(dir.path(), "heave_only.csv", 2.0, 2400, |t| t.to_string());
    let output = shipcast(&[
        "replay",
        "--input",
        input.to_str().unwrap(),
        "--skip-s",
        "0",
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("has no roll_rad, pitch_rad column: the deck's decisions are not scored"),
        "{stderr}"
    );
    let out = String::from_utf8_lossy(&output.stdout);
    assert!(out.contains("\"dof\":\"heave\""), "{out}");
    assert!(!out.contains("decisions"), "{out}");
}

/// Regression: a 10 Hz record stamped in epoch seconds was refused, its median step reading
/// 0.0999999 s (stamps near 1.7e9 s are quantised to 2.4e-7 s) and its rate 10.00001 Hz.
#[test]
fn replay_takes_a_10_hz_record_stamped_in_epoch_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let input = heave_csv(dir.path(), "epoch_10hz.csv", 10.0, 6000, |t| {
        (1.7e9 + t).to_string()
    });
    let output = shipcast(&[
        "replay",
        "--input",
        input.to_str().unwrap(),
        "--skip-s",
        "1700000060",
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    let out = String::from_utf8_lossy(&output.stdout);
    let heave: serde_json::Value = out
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .find(|v| v["dof"] == "heave")
        .expect("a heave line");
    assert!(heave["scored"].as_u64().unwrap() > 500, "{heave}");
}

/// Regression (review): ratios over nothing (a DOF that never moves, no go call) were printed
/// as NaN in replay's table; they are "-".
#[test]
fn replay_table_shows_a_dash_where_a_ratio_has_nothing_to_divide_by() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("sim.csv");
    assert!(shipcast(&[
        "simulate",
        "--duration",
        "400",
        "--out",
        csv.to_str().unwrap()
    ])
    .status
    .success());
    // The heave column held at 0: a dead sensor.
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let heave = header.split(',').position(|c| c == "heave_m").unwrap();
    let mut frozen = format!("{header}\n");
    for line in lines {
        let mut fields: Vec<&str> = line.split(',').collect();
        fields[heave] = "0";
        frozen.push_str(&fields.join(","));
        frozen.push('\n');
    }
    let path = dir.path().join("frozen.csv");
    std::fs::write(&path, frozen).unwrap();
    let output = shipcast(&["replay", "--input", path.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{output:?}");
    assert!(
        !stdout.contains("NaN") && !stdout.contains("inf"),
        "{stdout}"
    );
    assert!(
        stdout.contains("heave   max |error| 0.0000 (- x the motion's std 0.0000)"),
        "{stdout}"
    );
    // Its heave sensor is dead, and the deck says so, counting the forecasts it affected
    // (all but those of the first 30 s of repetition, which is when a sensor counts as frozen).
    let frozen = stdout
        .lines()
        .find_map(|l| {
            l.strip_prefix("deck MOT 10s: a deck sensor repeated its value, to the last bit, at ")
        })
        .unwrap_or_else(|| panic!("{stdout}"));
    let (n, rest) = frozen.split_once(" of ").unwrap();
    let (scored, rest) = rest.split_once(" scored forecasts (heave ").unwrap();
    let (n, scored): (u64, u64) = (n.parse().unwrap(), scored.parse().unwrap());
    assert!(n > scored * 9 / 10 && n < scored, "{frozen}");
    assert!(rest.starts_with(&format!("{n})")), "{frozen}");
}
