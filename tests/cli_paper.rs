//! `shipcast paper --quick` end to end: the report has its tables and figures, the figures are
//! SVG, and every number in the report is finite.

use std::path::Path;
use std::process::Command;

fn shipcast() -> Command {
    Command::new(env!("CARGO_BIN_EXE_shipcast"))
}

/// Every Markdown table in `report`: (header cells, body rows).
fn tables(report: &str) -> Vec<(usize, Vec<usize>)> {
    let mut out = Vec::new();
    let mut current: Option<(usize, Vec<usize>)> = None;
    for line in report.lines() {
        let cells = line.matches(" |").count();
        match (&mut current, line.starts_with('|')) {
            (None, true) => current = Some((cells, Vec::new())),
            (Some((_, rows)), true) => rows.push(cells),
            (Some(_), false) => out.extend(current.take()),
            (None, false) => {}
        }
    }
    out.extend(current);
    out
}

/// A failed run that printed exactly one error line, naming `needle`, and no panic.
fn assert_one_line_error(output: &std::process::Output, needle: &str) {
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    assert!(errors[0].contains(needle), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn quick_paper_study_writes_a_complete_finite_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let status = shipcast()
        .args(["paper", "--quick", "--seed", "3", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success(), "shipcast paper --quick failed: {status}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();

    for heading in [
        "## Table 1:",
        "## Table 2:",
        "## Table 3:",
        "## Line-spectrum sea against realistic dense sea",
        "## Improvements to MCA",
        "tested on another realisation",
        "| paper: 0.5 s / 5 s / 20 s |",
        "## Useful horizon",
        "## Figures",
        "## Appendix",
        "### yaw",
        "## Averaged forecasts",
    ] {
        assert!(report.contains(heading), "report lacks '{heading}'");
    }
    // shipcast's eigenvalue-weighted MCA is in the improvements and the horizon table, and
    // labelled as not the paper's method.
    let horizons = report
        .split("## Useful horizon")
        .nth(1)
        .and_then(|s| s.split("## Figures").next())
        .unwrap();
    assert!(
        horizons.contains("| shipcast MCA-150, 1/lambda weighting"),
        "no weighted-MCA column:\n{horizons}"
    );
    assert!(report.contains("1/lambda weighting, shift 2, validated ridge (not the paper's)"));
    // The averaged forecasts: every combination on the dense sea and on the other realisation.
    let averaged = report
        .split("## Averaged forecasts")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .unwrap();
    for row in [
        "| other realisation | MCA-150, paper settings | weighted 10 |",
        "| dense sea | MCA-150, shipcast weighted",
        "- other realisation, weighted MCA: uniform",
    ] {
        assert!(
            averaged.contains(row),
            "averaged section lacks '{row}':\n{averaged}"
        );
    }
    assert!(
        !averaged.contains("measured sea"),
        "no measured record was given"
    );
    assert!(
        !report.contains("## Measured sea"),
        "no measured record was given"
    );
    for part in [
        "| all steps, same realisation |",
        "**Same realisation against another.**",
        "**How close it gets, out of sample.**",
        "**Why the paper's rule fails",
        "**Why weighting by 1/lambda",
        "**Caveat.**",
    ] {
        assert!(report.contains(part), "report lacks '{part}'");
    }
    // Tables: Table 1 (heave), 2, 3, line sea, improvements (heave, other DOF), horizons, std,
    // six appendix tables.
    let tables = tables(&report);
    assert!(tables.len() >= 14, "{} tables", tables.len());
    for (header, rows) in &tables {
        assert!(rows.len() >= 2, "a table without body rows");
        assert!(
            rows.iter().all(|r| r == header),
            "ragged table: {header} vs {rows:?}"
        );
    }

    // Figures: every one the report links exists and is SVG; the paper's figures 1-6 and 8 and
    // the error-against-lead figures are among them.
    let linked: Vec<&str> = report
        .lines()
        .filter_map(|l| l.strip_prefix("!["))
        .filter_map(|l| l.split("](").nth(1))
        .map(|l| l.trim_end_matches(')'))
        .collect();
    for name in [
        "fig1_surge.svg",
        "fig3_heave.svg",
        "fig6_yaw.svg",
        "fig8_noisy_heave.svg",
        "rms_vs_lead_dense.svg",
        "rms_vs_lead_line.svg",
    ] {
        assert!(linked.contains(&name), "report does not link {name}");
    }
    let dense = std::fs::read_to_string(out.join("rms_vs_lead_dense.svg")).unwrap();
    assert!(
        dense.contains("shipcast MCA-150"),
        "dense figure lacks the weighted MCA"
    );
    for name in &linked {
        let svg = std::fs::read_to_string(Path::new(&out).join(name)).unwrap();
        assert!(svg.trim_start().starts_with("<svg"), "{name} is not SVG");
        assert!(
            svg.contains("polyline") || svg.contains("<path"),
            "{name} has no curve"
        );
    }

    // Every number is finite: Rust parses "NaN", "inf" and "-inf", so a token that parses to
    // a non-finite value is one.
    let mut finite = 0;
    for token in report.split(|c: char| c.is_whitespace() || "|()[]`,:;/".contains(c)) {
        let token = token.trim_end_matches(['.', 'x', 's']);
        if let Ok(v) = token.parse::<f64>() {
            assert!(v.is_finite(), "non-finite number '{token}' in the report");
            finite += 1;
        }
    }
    assert!(finite > 500, "only {finite} numbers in the report");
    assert!(!report.contains("failed:"), "a method failed:\n{report}");
}

#[test]
fn unwritable_output_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "not a directory").unwrap();
    let output = shipcast()
        .args(["paper", "--quick", "--out"])
        .arg(file.join("sub"))
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(2));
    assert_one_line_error(&output, "a-file");
}

/// `--measured FILE`: the averaged forecasts also run on that record (here a sum of
/// sinusoids written at 8 Hz, standing in for measured motion); a file without heave is a
/// one-line error before any study work.
#[test]
fn measured_record_gets_its_averaged_rows_and_a_bad_one_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("measured.csv");
    let mut text = String::from("time_s,heave_m\n");
    for i in 0..(3000 * 4) {
        let t = i as f64 / 8.0;
        let v = (0.61 * t).sin() + 0.4 * (0.93 * t + 1.0).sin() + 0.2 * (0.37 * t).cos();
        text.push_str(&format!("{t},{v}\n"));
    }
    std::fs::write(&csv, text).unwrap();
    let out = dir.path().join("study");
    let status = shipcast()
        .args(["paper", "--quick", "--measured"])
        .arg(&csv)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("'measured sea': measured.csv"),
        "no measured note"
    );
    assert!(
        report.contains("| measured sea | MCA-150, paper settings | uniform 5 |"),
        "no measured rows"
    );
    // The measured-sea section: every method and the engine, with finite numbers.
    let section = report
        .split("## Measured sea: measured.csv")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("no measured-sea section");
    for row in [
        "| MCA-150, paper settings |",
        "| shipcast MCA-150, 1/lambda weighting, shift 2, validated ridge (not the paper's) |",
        "| Wiener-100 |",
        "| Wiener-150 |",
        "| persistence |",
        "| zero |",
        "| engine as the service runs it (default configuration, delivered) |",
        "| within +-1 sigma (nominal 68.3 %) |",
        "| within +-2 sigma (nominal 95.4 %) |",
        "**Which method wins.** On this record",
    ] {
        assert!(
            section.contains(row),
            "measured section lacks '{row}':\n{section}"
        );
    }
    assert!(!section.contains("failed:"), "{section}");
    let numbers: Vec<f64> = section
        .lines()
        .filter(|l| {
            l.starts_with("| ")
                && !l.starts_with("| :")
                && !l.starts_with("| method")
                && !l.starts_with("| engine, heave")
        })
        .flat_map(|l| {
            l.split('|')
                .skip(2)
                .take(3)
                .map(str::to_string)
                .collect::<Vec<_>>()
        })
        .map(|c| {
            let c = c.trim().trim_end_matches(" %");
            c.parse::<f64>()
                .unwrap_or_else(|_| panic!("'{c}' is not a number:\n{section}"))
        })
        .collect();
    assert_eq!(numbers.len(), 9 * 3, "{section}");
    assert!(
        numbers.iter().all(|v| v.is_finite() && *v >= 0.0),
        "{numbers:?}"
    );

    let pitch_only = dir.path().join("pitch.csv");
    std::fs::write(&pitch_only, "time_s,pitch_rad\n0,1\n0.125,2\n").unwrap();
    let output = shipcast()
        .args(["paper", "--quick", "--measured"])
        .arg(&pitch_only)
        .arg("--out")
        .arg(dir.path().join("other"))
        .output()
        .unwrap();
    assert_one_line_error(&output, "pitch.csv");

    // A record with a value that is not a number: one line, before any study work, also for
    // the measured-sea section alone.
    let garbled = dir.path().join("garbled.csv");
    std::fs::write(&garbled, "time_s,heave_m\n0,1\n0.125,abc\n0.25,2\n").unwrap();
    for extra in [None, Some("--measured-only")] {
        let output = shipcast()
            .args(["paper", "--quick", "--measured"])
            .arg(&garbled)
            .args(extra)
            .arg("--out")
            .arg(dir.path().join("garbled"))
            .output()
            .unwrap();
        assert_one_line_error(&output, "garbled.csv");
    }
    assert!(!dir.path().join("garbled").join("report.md").exists());

    // Regression (review): a record too short for the study gave rows of "MCA-0", all
    // failed, and exit 0. 200 s at 8 Hz is 400 values at 2 Hz, below the 600 it needs.
    let short = dir.path().join("short.csv");
    let mut text = String::from("time_s,heave_m\n");
    for i in 0..1600 {
        text.push_str(&format!(
            "{},{}\n",
            i as f64 / 8.0,
            (0.6 * i as f64 / 8.0).sin()
        ));
    }
    std::fs::write(&short, text).unwrap();
    let output = shipcast()
        .args(["paper", "--quick", "--measured-only", "--measured"])
        .arg(&short)
        .arg("--out")
        .arg(dir.path().join("short"))
        .output()
        .unwrap();
    assert_one_line_error(&output, "are too few for the study: it needs at least 600");

    // Regression (review): a dead heave channel gave a report of NaN and inf rows with 100 %
    // coverage, and exit 0. 20 minutes of motion held at one value after its first 5.
    let frozen = dir.path().join("frozen.csv");
    let mut text = String::from("time_s,heave_m\n");
    for i in 0..9600 {
        let t = i as f64 / 8.0;
        let h = if i < 2400 { (0.6 * t).sin() } else { 0.5 };
        text.push_str(&format!("{t},{h}\n"));
    }
    std::fs::write(&frozen, text).unwrap();
    let output = shipcast()
        .args(["paper", "--quick", "--measured-only", "--measured"])
        .arg(&frozen)
        .arg("--out")
        .arg(dir.path().join("frozen"))
        .output()
        .unwrap();
    assert_one_line_error(
        &output,
        "heave_m does not move in the second half of the record",
    );
    assert!(!dir.path().join("frozen").join("measured.md").exists());

    // Regression (review): a report name taken by a directory failed only after the study.
    let taken = dir.path().join("taken");
    std::fs::create_dir_all(taken.join("report.md")).unwrap();
    let output = shipcast()
        .args(["paper", "--quick", "--out"])
        .arg(&taken)
        .output()
        .unwrap();
    assert_one_line_error(&output, "report.md is a directory");
}

/// `--measured-only` writes the measured-sea section alone, as measured.md, and needs
/// `--measured`.
#[test]
fn measured_only_writes_just_that_section() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("swell.csv");
    let mut text = String::from("time_s,heave_m\n");
    for i in 0..(2400 * 4) {
        let t = i as f64 / 8.0;
        let v = 0.8 * (0.55 * t).sin() + 0.3 * (1.1 * t + 0.5).sin();
        text.push_str(&format!("{t},{v}\n"));
    }
    std::fs::write(&csv, text).unwrap();
    let status = shipcast()
        .args(["paper", "--quick", "--measured-only", "--measured"])
        .arg(&csv)
        .arg("--out")
        .arg(dir.path())
        .status()
        .unwrap();
    assert!(status.success());
    let section = std::fs::read_to_string(dir.path().join("measured.md")).unwrap();
    assert!(
        section.starts_with("## Measured sea: swell.csv"),
        "{section}"
    );
    assert!(section.contains("**Which method wins.**"), "{section}");
    assert!(!dir.path().join("report.md").exists());

    let output = shipcast()
        .args(["paper", "--quick", "--measured-only", "--out"])
        .arg(dir.path().join("none"))
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("--measured"), "{stderr}");
}

/// `--averaging-only` writes that section alone, as averaging.md, and no report.md.
#[test]
fn averaging_only_writes_just_that_section() {
    let dir = tempfile::tempdir().unwrap();
    let status = shipcast()
        .args(["paper", "--quick", "--averaging-only", "--out"])
        .arg(dir.path())
        .status()
        .unwrap();
    assert!(status.success());
    let section = std::fs::read_to_string(dir.path().join("averaging.md")).unwrap();
    assert!(section.starts_with("## Averaged forecasts"), "{section}");
    assert_eq!(section.matches("| dense sea |").count(), 14, "{section}");
    assert_eq!(section.matches("| other realisation |").count(), 14);
    assert!(!dir.path().join("report.md").exists());
}
