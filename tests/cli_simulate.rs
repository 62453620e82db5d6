//! `shipcast simulate` end to end: files written, determinism, figures and clear errors.

mod fixtures;

use shipcast::motion_csv::MotionData;
use shipcast::Dof;
use std::process::{Command, Output};

fn simulate(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shipcast"))
        .arg("simulate")
        .args(args)
        .env("RUST_LOG", "info")
        .output()
        .expect("shipcast runs")
}

fn std_dev(x: &[f64]) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
}

#[test]
fn writes_a_motion_csv_with_all_channels_at_the_requested_rate() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let o = simulate(&[
        "--scenario",
        "ss4",
        "--duration",
        "60",
        "--rate",
        "8",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(
        text.lines().next().unwrap(),
        "time_s,surge_m,sway_m,heave_m,roll_rad,pitch_rad,yaw_rad,wave_m"
    );
    let data = MotionData::read_path(&out).unwrap();
    assert_eq!(data.len(), 480);
    let t = &data.time;
    assert!((t[1] - t[0] - 0.125).abs() < 1e-12);
    for dof in Dof::ALL {
        assert!(std_dev(data.dof(dof).unwrap()) > 0.0, "{dof} is flat");
    }
    assert!(std_dev(data.column("wave_m").unwrap()) > 0.1);
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(
        log.contains("heave_m") && log.contains("peak encounter period"),
        "{log}"
    );
}

#[test]
fn same_seed_gives_the_same_file_and_another_seed_another() {
    let dir = tempfile::tempdir().unwrap();
    let run = |seed: &str, name: &str| {
        let out = dir.path().join(name);
        let o = simulate(&[
            "--duration",
            "20",
            "--seed",
            seed,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success());
        std::fs::read(out).unwrap()
    };
    let a = run("3", "a.csv");
    assert_eq!(a, run("3", "b.csv"));
    assert_ne!(a, run("4", "c.csv"));
}

#[test]
fn line_spectrum_table_rao_and_plot_options_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let svg = dir.path().join("m.svg");
    let table = fixtures::s175_rao_table();
    let o = simulate(&[
        "--scenario",
        "ss5",
        "--components",
        "16",
        "--spreading",
        "none",
        "--heading-deg",
        "180",
        "--speed-kn",
        "10",
        "--rao-table",
        table.to_str().unwrap(),
        "--rao-table-length",
        "175",
        "--hull-length",
        "142",
        "--duration",
        "30",
        "--rate",
        "2",
        "--out",
        out.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(MotionData::read_path(&out).unwrap().len(), 60);
    let figure = std::fs::read_to_string(&svg).unwrap();
    assert!(figure.starts_with("<svg") && figure.contains("heave"));
    assert!(String::from_utf8_lossy(&o.stderr).contains("16 wave components"));
}

#[test]
fn bad_input_exits_with_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let out = out.to_str().unwrap();
    let bad_table = dir.path().join("bad.csv");
    std::fs::write(
        &bad_table,
        "speed_mps,heading_deg,omega_rad_s,dof,amplitude,phase_rad\n0,180,x,heave,1,0\n",
    )
    .unwrap();
    let cases: [(&[&str], &str); 6] = [
        (&["--scenario", "ss9"], "unknown scenario 'ss9'"),
        (&["--hs", "-1"], "significant wave height must be positive"),
        (&["--spreading", "cos3"], "unknown spreading 'cos3'"),
        (&["--rate", "0"], "--rate must be positive"),
        (
            &["--rao-table", "/nonexistent.csv"],
            "cannot open /nonexistent.csv",
        ),
        (
            &["--rao-table", bad_table.to_str().unwrap()],
            "column omega_rad_s: 'x' is not a number",
        ),
    ];
    for (args, reason) in cases {
        let mut all = args.to_vec();
        all.extend(["--duration", "10", "--out", out]);
        let o = simulate(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        let lines: Vec<&str> = err.lines().collect();
        assert_eq!(lines.len(), 1, "{args:?}: {err}");
        assert!(
            lines[0].starts_with("error: ") && lines[0].contains(reason),
            "{args:?}: {err}"
        );
    }
}
