//! `shipcast simulate` end to end: files written, determinism, figures and clear errors; motion
//! driven by a measured wave record (`--elevation`) and the non-stationary options
//! (`--course-change-s`, `--sea-change-s`).

mod fixtures;

use shipcast_series::motion_csv::MotionData;
use shipcast_sim::{ClosedFormRao, Hull, Rao, Scenario, ShipMotion, SimConfig};
use shipcast_wire::Dof;
use std::f64::consts::TAU;
use std::path::Path;
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
    let missing = dir.path().join("missing.csv");
    let missing = missing.to_str().unwrap();
    let cannot_open = format!("cannot open {missing}");
    let cases: [(&[&str], &str); 7] = [
        (&["--scenario", "ss9"], "unknown scenario 'ss9'"),
        (
            &["--hs", "-1"],
            "significant wave height must be in (0, 30] m",
        ),
        (&["--spreading", "cos3"], "unknown spreading 'cos3'"),
        (&["--rate", "0"], "--rate must be a number in"),
        // Slower than any reader takes (a step of at most 5 s).
        (&["--rate", "0.1"], "--rate must be a number in [0.2, "),
        (&["--rao-table", missing], &cannot_open),
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

/// The one stderr line of a refused `simulate`, which must exit with status 2.
fn refused_line(args: &[&str]) -> String {
    let o = simulate(args);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{args:?}: {err}");
    lines[0].to_string()
}

#[test]
fn file_errors_print_the_os_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let out = out.to_str().unwrap();
    let table = dir.path().join("absent-rao.csv");
    let io = std::fs::File::open(&table).unwrap_err().to_string();
    let table = table.to_str().unwrap();
    let line = refused_line(&["--rao-table", table, "--duration", "10", "--out", out]);
    assert_eq!(line, format!("error: RAO table: cannot open {table}: {io}"));
    assert_eq!(line.matches(&io).count(), 1, "{line}");

    // A figure in a missing directory is refused before the record is simulated.
    let svg = dir.path().join("missing").join("m.svg");
    let svg = svg.to_str().unwrap();
    let line = refused_line(&["--plot", svg, "--duration", "10", "--out", out]);
    assert_eq!(
        line,
        format!(
            "error: --plot {svg}: the directory {} does not exist",
            dir.path().join("missing").display()
        )
    );
    assert!(!Path::new(out).exists());
}

/// The text of an elevation CSV of `n` samples `dt` apart in its time unit, `wave(t)`.
fn elevation_text(n: usize, dt: f64, wave: impl Fn(f64) -> f64) -> String {
    let mut text = String::from("time_s,wave_m\n");
    for i in 0..n {
        let t = i as f64 * dt;
        text.push_str(&format!("{t},{}\n", wave(t)));
    }
    text
}

/// An elevation CSV at 2.5 Hz; `value(i)` is sample i (None = NaN).
fn write_elevation(path: &Path, n: usize, value: impl Fn(usize) -> Option<f64>) {
    let mut text = String::from("time_s,wave_m\n");
    for i in 0..n {
        let z = value(i).map_or("NaN".to_string(), |z| z.to_string());
        text.push_str(&format!("{},{z}\n", i as f64 * 0.4));
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn a_measured_cosine_gives_the_rao_amplitude_and_phase_at_the_output_rate() {
    let dir = tempfile::tempdir().unwrap();
    let (elev, out) = (dir.path().join("e.csv"), dir.path().join("m.csv"));
    let n = 3000; // 1200 s at 2.5 Hz
    let omega = TAU * 150.0 / 1200.0; // on the record's Fourier grid, period 8 s
    let wave = |t: f64| 1.3 * (omega * t - 0.4).cos();
    write_elevation(&elev, n, |i| Some(wave(i as f64 * 0.4)));
    let o = simulate(&[
        "--elevation",
        elev.to_str().unwrap(),
        "--heading-deg",
        "150",
        "--speed-kn",
        "0",
        "--edge-s",
        "0",
        "--rate",
        "8",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let data = MotionData::read_path(&out).unwrap();
    assert_eq!(data.len(), 9597); // 0 .. 1199.5 s at 8 Hz
    assert!((data.time[1] - 0.125).abs() < 1e-12);
    let h = ClosedFormRao::new(Hull::dtmb5415()).response(omega, 150f64.to_radians(), 0.0);
    for (i, &t) in data.time.iter().enumerate() {
        let a = 1.3 * faer::c64::new((omega * t - 0.4).cos(), (omega * t - 0.4).sin());
        assert!((data.column("wave_m").unwrap()[i] - wave(t)).abs() < 1e-9);
        for dof in Dof::ALL {
            let expected = (h[dof.index()] * a).re;
            let got = data.dof(dof).unwrap()[i];
            assert!(
                (got - expected).abs() < 1e-9,
                "{dof} at {t}: {got} vs {expected}"
            );
        }
    }
}

#[test]
fn a_second_vessel_on_a_measured_record_meets_its_waves_shifted_by_its_position() {
    let dir = tempfile::tempdir().unwrap();
    let elev = dir.path().join("e.csv");
    let omega = TAU * 150.0 / 1200.0; // on the record's Fourier grid, period 8 s
    write_elevation(&elev, 3000, |i| {
        Some(1.3 * (omega * i as f64 * 0.4 - 0.4).cos())
    });
    let run_at = |name: &str, heading: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "--elevation",
            elev.to_str().unwrap(),
            "--heading-deg",
            heading,
            "--speed-kn",
            "0",
            "--edge-s",
            "0",
            "--rate",
            "4",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = simulate(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        channels(&out)
    };
    // Head waves travel aft: half a wavelength (deep water) ahead, every channel is reversed;
    // abeam of them, nothing changes; a whole wavelength astern, nothing either.
    let wavelength = TAU * 9.81 / (omega * omega);
    let reference = run_at("a.csv", "180", &[]);
    assert!(reference.iter().any(|r| r[2].abs() > 0.1), "no heave");
    let half = (wavelength / 2.0).to_string();
    let half = run_at("half.csv", "180", &["--vessel-x-m", &half]);
    assert!(mismatch(&reference, &half, -1.0) < 1e-6);
    assert!(mismatch(&reference, &half, 1.0) > 0.5);
    let abeam = (0.37 * wavelength).to_string();
    let abeam = run_at("abeam.csv", "180", &["--vessel-y-m", &abeam]);
    assert!(mismatch(&reference, &abeam, 1.0) < 1e-6);
    let astern = (-wavelength).to_string();
    let astern = run_at("astern.csv", "180", &["--vessel-x-m", &astern]);
    assert!(mismatch(&reference, &astern, 1.0) < 1e-6);
    // At the gauge, a bow turned 30 deg to starboard meets the waves 30 deg further round.
    let turned = run_at("turned.csv", "180", &["--vessel-heading-offset-deg", "30"]);
    assert!(mismatch(&turned, &run_at("direct.csv", "150", &[]), 1.0) < 1e-9);
    assert!(mismatch(&reference, &turned, 1.0) > 0.1);
}

#[test]
fn a_gap_in_the_record_becomes_a_time_jump_in_the_motion() {
    let dir = tempfile::tempdir().unwrap();
    let (elev, out) = (dir.path().join("e.csv"), dir.path().join("m.csv"));
    // 600 s, NaN from 200 s to 300 s.
    write_elevation(&elev, 1500, |i| {
        let t = i as f64 * 0.4;
        (!(200.0..300.0).contains(&t)).then(|| (0.6 * t).sin() + 0.5 * (0.9 * t).cos())
    });
    let o = simulate(&[
        "--elevation",
        elev.to_str().unwrap(),
        "--edge-s",
        "30",
        "--out",
        out.to_str().unwrap(),
    ]);
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{log}");
    let data = MotionData::read_path(&out).unwrap();
    let jumps: Vec<(f64, f64)> = data
        .time
        .windows(2)
        .filter(|p| p[1] - p[0] > 0.2)
        .map(|p| (p[0], p[1]))
        .collect();
    // Segments 0..199.6 s and 300..599.6 s, each without its 30 s edges.
    assert_eq!(jumps, vec![(169.5, 330.0)], "{log}");
    assert_eq!(data.time[0], 30.0);
    assert_eq!(*data.time.last().unwrap(), 569.5);
    assert!(
        log.contains("gap: the output jumps from 169.500 s to 330.000 s"),
        "{log}"
    );
    // The speed (default 11 kn) is stated as an approximation.
    assert!(log.contains("encounter frequency"), "{log}");
    // A clean record has no spike to warn of.
    assert!(!log.contains("robust scales"), "{log}");
}

/// Regression (review): a 500 m spike in a 0.74 m sea was simulated without a word, as waves the
/// ship answered; `eval` and `train` warn of the same.
#[test]
fn a_spike_in_the_elevation_record_is_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    let (elev, out) = (dir.path().join("e.csv"), dir.path().join("m.csv"));
    write_elevation(&elev, 1500, |i| {
        let t = i as f64 * 0.4;
        Some(if i == 700 { 30.0 } else { (0.6 * t).sin() })
    });
    let o = simulate(&[
        "--elevation",
        elev.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{log}");
    assert!(
        log.contains("1 sample(s) of wave_m lie more than 12 robust scales")
            && log.contains("the first at t = 280 s"),
        "{log}"
    );
}

#[test]
fn bad_elevation_files_exit_with_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let not_number = write("a.csv", "time_s,wave_m\n0,1\n0.5,x\n1.0,2\n");
    let no_wave = write("b.csv", "time_s,heave_m\n0,1\n0.5,2\n");
    // 101.5 - 101.1 is 0.4000000000000057 in f64: the message must show it as 0.4.
    let uneven = write(
        "c.csv",
        "time_s,wave_m\n100.1,1\n100.6,2\n101.1,1\n101.5,2\n102.0,1\n102.5,2\n",
    );
    let all_nan = write("d.csv", "time_s,wave_m\n0,NaN\n0.5,nan\n1.0,NaN\n");
    let short = write("e.csv", "time_s,wave_m\n0,1\n0.5,2\n1.0,1\n1.5,0\n");
    let infinite = write("f.csv", "time_s,wave_m\n0,1\n0.5,inf\n");
    // Samples 1e6 s apart: 1.6e7 s of record, more rows at 8 Hz than any file may hold (it
    // used to be written until the disk was full).
    let far: String = (0..16).map(|i| format!("{}e6,{}\n", i, i % 3)).collect();
    let far = write("g.csv", &format!("time_s,wave_m\n{far}"));
    // Regression (review): each of these was written without a word, as a motion of nothing
    // or of metres of roll (wave_m in millimetres), or as 477 081 rows from 480 samples
    // (stamps in milliseconds).
    // Samples 4 s apart (a step that may be a record's): 10 400 s of record, more rows at
    // 10 kHz than any file may hold.
    let long = write("l.csv", &elevation_text(2600, 4.0, |t| (0.01 * t).sin()));
    let zeros = write("h.csv", &elevation_text(600, 0.5, |_| 0.0));
    // Not exactly 0: its computed spread is rounding, not waves (review).
    let constant = write("k.csv", &elevation_text(600, 0.5, |_| 1.37));
    let millimetres = write(
        "i.csv",
        &elevation_text(600, 0.5, |t| 1500.0 * (0.6 * t).sin()),
    );
    let in_ms = write("j.csv", &elevation_text(600, 500.0, |t| (0.6e-3 * t).sin()));
    let missing = dir.path().join("missing.csv");
    let missing = missing.to_str().unwrap();
    let cannot_read = format!("cannot read {missing}");
    let cases: [(&[&str], &str); 14] = [
        (
            &["--elevation", &not_number],
            "line 3, column 'wave_m': 'x' is not a number",
        ),
        (&["--elevation", &no_wave], "line 1: no 'wave_m' column"),
        // Rounded to the microsecond (regression, review: 0.39999999999997726 s).
        (
            &["--elevation", &uneven],
            "elevation record: line 5: time step 0.4 s, but the record is sampled every 0.5 s",
        ),
        (
            &["--elevation", &all_nan],
            "no segment is longer than twice --edge-s",
        ),
        (
            &["--elevation", &short],
            "no segment is longer than twice --edge-s",
        ),
        (
            &["--elevation", &infinite],
            "line 3, column 'wave_m': non-finite value 'inf'",
        ),
        (&["--elevation", missing], &cannot_read),
        // Refused by its step now, before the rows are counted.
        (
            &["--elevation", &far, "--edge-s", "0", "--rate", "8"],
            "typical time step is 1000000 s",
        ),
        (
            &["--elevation", &long, "--edge-s", "0", "--rate", "10000"],
            "rows at --rate 10000 Hz, at most 100000000",
        ),
        (&["--elevation", &zeros], "wave_m is constant (0)"),
        (&["--elevation", &constant], "wave_m is constant (1.37"),
        (
            &["--elevation", &millimetres],
            "is it in millimetres or centimetres?",
        ),
        (
            &["--elevation", &in_ms],
            "looks like milliseconds (divide the column by 1000)",
        ),
        (&["--elevation", &short, "--hs", "2"], "cannot be used with"),
    ];
    for (args, reason) in cases {
        let mut all = args.to_vec();
        all.extend(["--out", out.to_str().unwrap()]);
        let o = simulate(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}: {err}");
        if reason.contains("cannot be used") {
            // clap's own message (with a usage line).
            assert!(err.contains(reason), "{args:?}: {err}");
            continue;
        }
        // One error line (the last), after any log lines.
        let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error")).collect();
        assert_eq!(errors.len(), 1, "{args:?}: {err}");
        assert_eq!(err.lines().last(), Some(errors[0]), "{args:?}: {err}");
        assert!(
            errors[0].starts_with("error: ") && errors[0].contains(reason),
            "{args:?}: {err}"
        );
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        // Regression (review): a refused record left a header-only file to be taken for one.
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
}

fn max_difference(a: &MotionData, b: &MotionData, rows: usize) -> f64 {
    let mut worst = 0.0f64;
    for dof in Dof::ALL {
        let (x, y) = (a.dof(dof).unwrap(), b.dof(dof).unwrap());
        for i in 0..rows {
            worst = worst.max((x[i] - y[i]).abs());
        }
    }
    worst
}

#[test]
fn course_and_sea_changes_keep_the_record_before_and_reach_the_new_condition_after() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let run = |extra: &[&str], out: &str| {
        let mut args = vec!["--scenario", "ss4", "--duration", "2400", "--rate", "2"];
        args.extend(extra);
        args.extend(["--out", out]);
        let o = simulate(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        MotionData::read_path(out).unwrap()
    };
    let stationary = run(&[], &path("s.csv"));
    let turned = run(
        &[
            "--course-change-s",
            "600",
            "--new-heading-deg",
            "90",
            "--turn-s",
            "60",
        ],
        &path("c.csv"),
    );
    let changed = run(
        &[
            "--sea-change-s",
            "600",
            "--new-hs",
            "5.0",
            "--new-tp",
            "12.4",
            "--ramp-s",
            "300",
        ],
        &path("v.csv"),
    );
    // 1200 rows = the first 600 s at 2 Hz.
    assert!(max_difference(&stationary, &turned, 1200) < 1e-8);
    assert!(max_difference(&stationary, &changed, 1200) < 1e-8);
    // Well after the change, the std is that of the new condition (exact, from its components).
    let std_from = |d: &MotionData, dof: Dof, from: usize| {
        let x = &d.dof(dof).unwrap()[from..];
        (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
    };
    let mut beam = SimConfig::scenario(Scenario::Ss4);
    beam.heading_deg = 90.0;
    let beam = ShipMotion::new(&beam).unwrap();
    let roll = shipcast_sim::Channel::Motion(Dof::Roll);
    let got = std_from(&turned, Dof::Roll, 1500);
    let exact = beam.variance(roll).sqrt();
    assert!((got / exact - 1.0).abs() < 0.2, "roll {got} vs {exact}");
    let mut ss6 = SimConfig::scenario(Scenario::Ss4);
    (ss6.hs_m, ss6.tp_s, ss6.seed) = (5.0, 12.4, 2);
    let ss6 = ShipMotion::new(&ss6).unwrap();
    let heave = shipcast_sim::Channel::Motion(Dof::Heave);
    let got = std_from(&changed, Dof::Heave, 2000);
    let exact = ss6.variance(heave).sqrt();
    assert!((got / exact - 1.0).abs() < 0.2, "heave {got} vs {exact}");
    // The options are checked.
    let o = simulate(&["--course-change-s", "10", "--out", &path("x.csv")]);
    assert!(!o.status.success());
    let o = simulate(&[
        "--sea-change-s",
        "10",
        "--new-hs",
        "2",
        "--new-tp",
        "-1",
        "--duration",
        "20",
        "--out",
        &path("x.csv"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("peak period"), "{err}");
}

/// The columns of a record (six DOF and the wave elevation), row-major.
fn channels(path: &Path) -> Vec<[f64; 7]> {
    let data = MotionData::read_path(path).unwrap();
    let cols: Vec<&[f64]> = Dof::ALL
        .iter()
        .map(|&d| data.dof(d).unwrap())
        .chain(std::iter::once(data.column("wave_m").unwrap()))
        .collect();
    (0..data.len())
        .map(|i| std::array::from_fn(|c| cols[c][i]))
        .collect()
}

/// Largest |a - sign * b| over every channel and row, relative to the largest |a|.
fn mismatch(a: &[[f64; 7]], b: &[[f64; 7]], sign: f64) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - sign * y).abs()));
    worst / scale
}

#[test]
fn a_second_vessel_meets_the_same_waves_shifted_by_its_position() {
    let dir = tempfile::tempdir().unwrap();
    // `heading` is the mean wave direction relative to the reference vessel's bow.
    let run_at = |name: &str, heading: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "--tp",
            "30",
            "--components",
            "1",
            "--spreading",
            "none",
            "--speed-kn",
            "0",
            "--heading-deg",
            heading,
            "--duration",
            "40",
            "--rate",
            "4",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = simulate(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        channels(&out)
    };
    let run = |name: &str, extra: &[&str]| run_at(name, "180", extra);
    // Tp 30 s puts the single line (at the middle of the band, 2.7 times the peak frequency)
    // at a wavelength the hull responds to, 2 pi g / w^2; head waves travel aft, along -x.
    let mut cfg = SimConfig::scenario(Scenario::Paper);
    cfg.components = Some(1);
    cfg.spreading = "none".parse().unwrap();
    cfg.speed_kn = 0.0;
    cfg.heading_deg = 180.0;
    cfg.tp_s = 30.0;
    let omega = ShipMotion::new(&cfg).unwrap().components()[0].omega;
    let wavelength = TAU * 9.81 / (omega * omega);
    let reference = run("a.csv", &[]);
    assert!(reference.iter().any(|r| r[2].abs() > 0.1), "no heave");
    // Zero offset and the same heading: the reference record itself.
    assert_eq!(
        run("same.csv", &["--vessel-x-m", "0", "--vessel-y-m", "0"]),
        reference
    );
    // One wavelength ahead: the same record; half a wavelength: every channel reversed.
    let x = |v: f64| ["--vessel-x-m".to_string(), v.to_string()];
    let one = x(wavelength);
    let one = run("one.csv", &[&one[0], &one[1]]);
    assert!(mismatch(&reference, &one, 1.0) < 1e-5);
    let half = x(-wavelength / 2.0);
    let half = run("half.csv", &[&half[0], &half[1]]);
    assert!(mismatch(&reference, &half, -1.0) < 1e-5);
    // Abeam of head waves the phase does not change at all, however far.
    let abeam = (0.37 * wavelength).to_string();
    let abeam = run("abeam.csv", &["--vessel-y-m", &abeam]);
    assert!(mismatch(&reference, &abeam, 1.0) < 1e-5);
    // A quarter wavelength is a quarter period later or earlier: not the same, not reversed.
    let quarter = x(wavelength / 4.0);
    let quarter = run("quarter.csv", &[&quarter[0], &quarter[1]]);
    assert!(mismatch(&reference, &quarter, 1.0) > 0.5);
    assert!(mismatch(&reference, &quarter, -1.0) > 0.5);
    // At zero speed, turning the bow 30 deg to starboard is the same as waves 30 deg further
    // round from the reference bow (150 deg).
    let turned = run("turned.csv", &["--vessel-heading-offset-deg", "30"]);
    assert_eq!(turned, run_at("direct.csv", "150", &[]));
    assert!(
        mismatch(&reference, &turned, 1.0) > 0.1,
        "the turn changed nothing"
    );
    // Bad input is one clear line.
    let x = dir.path().join("x.csv");
    let o = simulate(&["--vessel-y-m", "inf", "--out", x.to_str().unwrap()]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("the vessel's position must be within +-10000 m"),
        "{e}"
    );
}
