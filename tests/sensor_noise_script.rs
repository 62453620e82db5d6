//! scripts/add_sensor_noise.py, which the measurements in docs/forecasting.md and
//! docs/results/replay_study.md rely on: it adds noise of the stated size to the DOF columns
//! only, keeps a gap's values, repeats itself for a seed, and refuses a bad size. Needs python3
//! (README: the test command's requirements).

use std::path::Path;
use std::process::Command;

fn script() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/add_sensor_noise.py")
}

fn run(input: &Path, out: &Path, pct: &str, seed: &str) -> std::process::Output {
    Command::new("python3")
        .arg(script())
        .args([
            "--input",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--pct", pct, "--seed", seed])
        .output()
        .expect("python3 runs (README: the test command needs python3)")
}

fn read(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn noise_of_the_stated_size_on_the_dof_columns_only() {
    let dir = tempfile::tempdir().unwrap();
    let (input, out, again) = (
        dir.path().join("in.csv"),
        dir.path().join("out.csv"),
        dir.path().join("again.csv"),
    );
    // heave: a 2 m sinusoid (std sqrt(2)); roll: one value is a gap (NaN).
    let n = 20_000;
    let mut text = String::from("time_s,heave_m,roll_rad,wave_m\n");
    for i in 0..n {
        let t = i as f64 * 0.125;
        let roll = if i == 500 {
            "NaN".to_string()
        } else {
            format!("{}", 0.01 * (0.3 * t).cos())
        };
        text += &format!("{t},{},{roll},{}\n", 2.0 * (0.5 * t).sin(), (0.4 * t).sin());
    }
    std::fs::write(&input, text).unwrap();
    let status = run(&input, &out, "1", "7");
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let (before, after) = (read(&input), read(&out));
    assert_eq!(before[0], after[0], "header");
    let mut diffs = Vec::new();
    for (b, a) in before[1..].iter().zip(&after[1..]) {
        assert_eq!(
            (&b[0], &b[3]),
            (&a[0], &a[3]),
            "time_s and wave_m are copied"
        );
        diffs.push(a[1].parse::<f64>().unwrap() - b[1].parse::<f64>().unwrap());
    }
    assert_eq!(after[501][2], "NaN", "a gap stays a gap");
    // The heave noise: mean 0, std 1 % of sqrt(2), within Monte Carlo error (n = 20000:
    // the std's relative error is about 0.5 %, the mean's about 1e-4 of the std).
    let mean = diffs.iter().sum::<f64>() / n as f64;
    let std = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
    let stated = 0.01 * 2f64.sqrt();
    assert!(
        (std / stated - 1.0).abs() < 0.03,
        "noise std {std} against {stated}"
    );
    assert!(mean.abs() < 0.05 * stated, "noise mean {mean}");
    // The same seed gives the same file.
    assert!(run(&input, &again, "1", "7").status.success());
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&again).unwrap());
}

#[test]
fn a_negative_size_is_refused_with_a_one_line_reason() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.csv");
    std::fs::write(&input, "time_s,heave_m\n0,1\n0.125,2\n").unwrap();
    let status = run(&input, &dir.path().join("out.csv"), "-1", "1");
    assert!(!status.status.success());
    let err = String::from_utf8_lossy(&status.stderr);
    assert!(err.contains("--pct must be a finite number >= 0"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}
