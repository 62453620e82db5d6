//! The report of a latency run: a table for people, JSON rows for tools, an SVG of the
//! distributions, and the comparison with the targets of issue 6.

use super::histogram::PathStats;
use super::machine::Machine;
use super::pinning::PinOutcome;
use super::plan::{Mode, Path, Source};
use plotters::prelude::*;
use serde::Serialize;
use std::fmt::Write as _;

/// The percentile curve of one row, for the SVG.
#[derive(Debug, Clone)]
pub struct Curve {
    /// Receive mode: each mode gets its own panel.
    pub mode: &'static str,
    pub label: String,
    /// (number of nines of the quantile, latency in µs); the max is the last point.
    pub points: Vec<(f64, f64)>,
}

/// Duration of one step of the predictor's work on a sample that completes a forecast.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageStats {
    pub mode: &'static str,
    pub stage: &'static str,
    pub count: u64,
    pub p50_us: f64,
    pub p90_us: f64,
    pub p99_us: f64,
}

/// Everything one `shipcast bench latency` run measured, with the conditions it ran under.
#[derive(Debug, Clone, Serialize)]
pub struct LatencyReport {
    pub machine: Machine,
    pub cores: (usize, usize),
    pub rate_hz: f64,
    pub samples: u64,
    pub warmup: u64,
    /// Turns the measurements took, each with its share of the samples.
    pub rounds: u64,
    pub modes: Vec<&'static str>,
    pub pins: Vec<PinOutcome>,
    pub rows: Vec<PathStats>,
    /// Where the predictor service's time goes on a sample that completes a forecast.
    pub stages: Vec<StageStats>,
    /// Paths that were not measured in this run, with the reason.
    pub not_measured: Vec<String>,
    /// How the figures were obtained, where it is not obvious from the path name.
    pub notes: Vec<String>,
    pub load_avg_end: String,
    #[serde(skip)]
    pub curves: Vec<Curve>,
}

impl LatencyReport {
    /// The first row of `path` in `mode` from `source` (any source: rows of the service
    /// processes come before the in-process ones), with the given payload size if any.
    pub fn row(
        &self,
        path: Path,
        mode: Mode,
        source: Option<Source>,
        payload_bytes: Option<usize>,
    ) -> Option<&PathStats> {
        self.rows.iter().find(|r| {
            r.path == path.name()
                && r.mode == mode.name()
                && source.is_none_or(|src| r.source == src.name())
                && payload_bytes.is_none_or(|b| r.payload_bytes == b)
        })
    }

    /// The conditions of the run, one line each.
    pub fn header(&self) -> String {
        let m = &self.machine;
        let unpinned: Vec<&str> = self
            .pins
            .iter()
            .filter(|p| !p.pinned)
            .map(|p| p.role.as_str())
            .collect();
        let mut s = String::new();
        let _ = writeln!(
            s,
            "machine: {} ({} logical cores, Linux {}); load average at start {}, at end {}",
            m.cpu_model, m.logical_cores, m.kernel, m.load_avg, self.load_avg_end
        );
        let _ = writeln!(
            s,
            "cores: sender/producer {}, receiver/predictor {}; pinning {}",
            self.cores.0,
            self.cores.1,
            if unpinned.is_empty() {
                "ok".to_string()
            } else {
                format!("FAILED for {}", unpinned.join(", "))
            }
        );
        let _ = writeln!(
            s,
            "modes: {} (event = blocking wait woken by notify, poll = busy polling); rate {} Hz; {} samples per path in {} interleaved rounds, each after {} warm-up; latencies one way from payload stamps, in µs",
            self.modes.join(", "),
            self.rate_hz,
            self.samples,
            self.rounds,
            self.warmup
        );
        for note in &self.notes {
            let _ = writeln!(s, "note: {note}");
        }
        s
    }

    /// The table: one line per path, mode and payload size.
    pub fn table(&self) -> String {
        let mut s = format!(
            "{:<30} {:<6} {:<10} {:>6} {:>7} {:>5} {:>9} {:>9} {:>9} {:>9} {:>9}\n",
            "path", "mode", "source", "bytes", "count", "lost", "p50", "p90", "p99", "p99.9", "max"
        );
        for r in &self.rows {
            let _ = writeln!(
                s,
                "{:<30} {:<6} {:<10} {:>6} {:>7} {:>5} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
                r.path,
                r.mode,
                r.source,
                r.payload_bytes,
                r.count,
                r.lost,
                r.p50_us,
                r.p90_us,
                r.p99_us,
                r.p999_us,
                r.max_us
            );
        }
        if !self.stages.is_empty() {
            let _ = writeln!(
                s,
                "\nthe predictor's steps on a sample that completes a forecast (services, from its --bench-stamps), µs:\n{:<6} {:<62} {:>7} {:>9} {:>9} {:>9}",
                "mode", "step", "count", "p50", "p90", "p99"
            );
            for t in &self.stages {
                let _ = writeln!(
                    s,
                    "{:<6} {:<62} {:>7} {:>9.1} {:>9.1} {:>9.1}",
                    t.mode, t.stage, t.count, t.p50_us, t.p90_us, t.p99_us
                );
            }
        }
        for missing in &self.not_measured {
            let _ = writeln!(s, "not measured: {missing}");
        }
        s
    }

    /// The targets of issues 6 and 12 that this run can judge, as ratios of p99 values.
    pub fn targets(&self, motion_bytes: usize, forecast_bytes: usize, json_bytes: usize) -> String {
        let mut s = String::new();
        let local = |mode| self.row(Path::SampleToForecastLocal, mode, None, None);
        if let Some(r) = local(Mode::Poll) {
            let _ = writeln!(
                s,
                "target poll: sample-to-forecast-local ({}) p99 {:.1} µs vs 30 µs: {}",
                r.source,
                r.p99_us,
                verdict(r.p99_us <= 30.0)
            );
        }
        if let (Some(r), Some(m), Some(f)) = (
            local(Mode::Event),
            self.row(Path::Iceoryx2Raw, Mode::Event, None, Some(motion_bytes)),
            self.row(Path::Iceoryx2Raw, Mode::Event, None, Some(forecast_bytes)),
        ) {
            let floor = m.p99_us + f.p99_us;
            let _ = writeln!(
                s,
                "target event: sample-to-forecast-local ({}) p99 {:.1} µs vs two raw iceoryx2 wake-ups (motion + forecast p99) {:.1} µs: ratio {:.2} (target <= 1.5): {}{}",
                r.source,
                r.p99_us,
                floor,
                r.p99_us / floor,
                verdict(r.p99_us <= 1.5 * floor),
                below_floor(r.p99_us / floor)
            );
        }
        // The zenoh path holds one hop of each transport: the motion sample over iceoryx2 to
        // the predictor, the forecast JSON over zenoh to the consumer. Its floor is the sum of
        // the two raw one-way p99 (issue 12): the iceoryx2 motion hop in the path's mode, and
        // the zenoh hop blocking (zenoh consumers always block on their channel) across the
        // same boundary as the path (processes for the services, threads in-process).
        for mode in [Mode::Event, Mode::Poll] {
            let wake = self.row(Path::Iceoryx2Raw, mode, None, Some(motion_bytes));
            for (source, floor_source, floor_name) in [
                (
                    Source::Services,
                    Source::RawProcesses,
                    "between two processes",
                ),
                (Source::InProcess, Source::Raw, "between two threads"),
            ] {
                let path = self.row(Path::SampleToForecastZenoh, mode, Some(source), None);
                let zenoh = self.row(
                    Path::ZenohRaw,
                    Mode::Event,
                    Some(floor_source),
                    Some(json_bytes),
                );
                if let (Some(r), Some(z), Some(w)) = (path, zenoh, wake) {
                    let floor = w.p99_us + z.p99_us;
                    let _ = writeln!(
                        s,
                        "target zenoh {mode}: sample-to-forecast-zenoh ({}) p99 {:.1} µs vs raw iceoryx2 {mode} p99 ({} B) {:.1} µs + raw zenoh event p99 {floor_name} ({} B) {:.1} µs = {floor:.1} µs: ratio {:.2} (target <= 1.25): {}{}",
                        r.source,
                        r.p99_us,
                        motion_bytes,
                        w.p99_us,
                        json_bytes,
                        z.p99_us,
                        r.p99_us / floor,
                        verdict(r.p99_us <= 1.25 * floor),
                        below_floor(r.p99_us / floor)
                    );
                }
            }
        }
        if s.is_empty() {
            s.push_str("targets: not judged (shipcast paths not measured in this run)\n");
        }
        s
    }

    /// The rows as the JSON array of the `--json` contract.
    pub fn json(&self) -> serde_json::Result<String> {
        serde_json::to_string_pretty(&self.rows)
    }

    /// Draw the percentile curves (log latency against quantile) into an SVG file.
    pub fn write_svg(&self, path: &std::path::Path) -> anyhow::Result<()> {
        let points = self.curves.iter().flat_map(|c| c.points.iter());
        let (lo, hi) = points.fold((f64::INFINITY, 0f64), |(lo, hi), &(_, y)| {
            (lo.min(y), hi.max(y))
        });
        if self.curves.is_empty() || !lo.is_finite() {
            anyhow::bail!("no latencies recorded: nothing to plot");
        }
        let (lo, hi) = ((lo * 0.8).max(0.01), (hi * 1.25).max(lo * 2.0));
        let panels = self.modes.len().max(1);
        let root = SVGBackend::new(path, (820 * panels as u32, 700)).into_drawing_area();
        let areas = root.split_evenly((1, panels));
        for (area, mode) in areas.iter().zip(&self.modes) {
            let curves: Vec<&Curve> = self.curves.iter().filter(|c| c.mode == *mode).collect();
            let title = format!(
                "one-way latency, {mode} mode, cores {},{}",
                self.cores.0, self.cores.1
            );
            draw(area, &curves, lo, hi, &title)
                .map_err(|e| anyhow::anyhow!("draw {}: {e}", path.display()))?;
        }
        root.present()
            .map_err(|e| anyhow::anyhow!("write {}: {e}", path.display()))
    }
}

fn verdict(met: bool) -> &'static str {
    if met {
        "met"
    } else {
        "NOT met"
    }
}

type DrawResult = Result<(), DrawingAreaErrorKind<std::io::Error>>;

fn draw(
    root: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    curves: &[&Curve],
    lo: f64,
    hi: f64,
    title: &str,
) -> DrawResult {
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..3.5f64, (lo..hi).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("quantile")
        .y_desc("latency [µs]")
        // Ticks every half nine; only whole nines and the max are labelled.
        .x_labels(8)
        .x_label_formatter(&|x| nines_label(*x))
        .draw()?;
    for (i, c) in curves.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                c.points.iter().copied(),
                color.stroke_width(2),
            ))?
            .label(c.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font(("sans-serif", 11))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// Axis label of a quantile given as its number of nines (2 -> p99); past 3.4, the max;
/// none between whole nines.
fn nines_label(nines: f64) -> String {
    if nines > 3.4 {
        return "max".into();
    }
    if (nines - nines.round()).abs() > 1e-6 {
        return String::new();
    }
    let q = 100.0 * (1.0 - 10f64.powf(-nines));
    format!("p{}", (q * 100.0).round() / 100.0)
}

/// Said of a path faster than its floor (issue 12's sum of the hops' raw p99). Regression
/// (review): such a ratio passed as "met" without a word, though it shows how lenient the
/// floor is: the p99 of a chain of two hops is below the sum of their p99s, and the floor's
/// rows are measured at other moments than the path's.
fn below_floor(ratio: f64) -> &'static str {
    if ratio < 1.0 {
        " (below its floor: a sum of two p99s exceeds the p99 of the chain, and the floor was measured at another moment; compare the raw rows)"
    } else {
        ""
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::histogram::LatencyRecorder;

    fn report() -> LatencyReport {
        let mut rows = Vec::new();
        let mut curves = Vec::new();
        for (path, mode, bytes, base) in [
            (Path::SampleToForecastLocal, Mode::Poll, 6248, 10_000),
            (Path::SampleToForecastLocal, Mode::Event, 6248, 100_000),
            (Path::Iceoryx2Raw, Mode::Event, 72, 40_000),
            (Path::Iceoryx2Raw, Mode::Event, 6248, 40_000),
        ] {
            let mut r = LatencyRecorder::new();
            for i in 0..100 {
                r.record_ns(base + i * 100);
            }
            rows.push(r.stats(path, mode, Source::InProcess, 100, bytes));
            curves.push(Curve {
                mode: mode.name(),
                label: format!("{path} {mode}"),
                points: r.curve(3.0, 30),
            });
        }
        LatencyReport {
            machine: Machine::detect(),
            cores: (0, 1),
            rate_hz: 100.0,
            samples: 100,
            warmup: 10,
            rounds: 1,
            modes: vec!["event", "poll"],
            pins: vec![PinOutcome {
                role: "ping".into(),
                core: 0,
                pinned: false,
            }],
            rows,
            stages: vec![StageStats {
                mode: "event",
                stage: "zenoh put",
                count: 10,
                p50_us: 11.0,
                p90_us: 40.0,
                p99_us: 70.0,
            }],
            not_measured: vec!["sample-to-forecast-zenoh: no zenoh".into()],
            notes: vec!["how measured".into()],
            load_avg_end: "0.00 0.00 0.00".into(),
            curves,
        }
    }

    #[test]
    fn table_json_and_targets_state_what_was_measured() {
        let rep = report();
        let table = rep.table();
        // Header, four rows, the steps' title, header and row, and what was not measured.
        assert_eq!(table.lines().count(), 1 + 4 + 4 + 1, "{table}");
        assert!(table.contains("zenoh put"), "{table}");
        assert!(table.contains("not measured: sample-to-forecast-zenoh"));
        assert!(rep.header().contains("FAILED for ping"));
        assert!(rep.header().contains("note: how measured"));
        let json: serde_json::Value = serde_json::from_str(&rep.json().unwrap()).unwrap();
        let rows = json.as_array().unwrap();
        assert_eq!(rows.len(), 4);
        for key in [
            "path", "mode", "count", "lost", "p50_us", "p90_us", "p99_us", "p999_us", "max_us",
        ] {
            assert!(rows[0].get(key).is_some(), "missing {key}");
        }
        let targets = rep.targets(72, 6248, 3000);
        // Poll p99 is about 19.9 µs (met); event p99 about 110 µs against 2 x 49.9 µs: ratio 1.1.
        assert!(targets.contains("vs 30 µs: met"), "{targets}");
        assert!(targets.contains("ratio 1.1"), "{targets}");
        assert!(!targets.contains("zenoh"), "{targets}");
    }

    fn row_at(path: Path, source: Source, bytes: usize, base: u64) -> PathStats {
        let mut r = LatencyRecorder::new();
        for i in 0..100 {
            r.record_ns(base + i * 100);
        }
        r.stats(path, Mode::Event, source, 100, bytes)
    }

    #[test]
    fn zenoh_targets_compare_each_source_with_the_floor_across_the_same_boundary() {
        let mut rep = report();
        rep.rows.extend([
            // p99 about 160 µs (services) and 300 µs (in-process).
            row_at(Path::SampleToForecastZenoh, Source::Services, 5000, 150_000),
            row_at(
                Path::SampleToForecastZenoh,
                Source::InProcess,
                5000,
                290_000,
            ),
            // Floors: about 130 µs between processes, 100 µs between threads; a 72-byte floor
            // that must not be used.
            row_at(Path::ZenohRaw, Source::RawProcesses, 3000, 120_000),
            row_at(Path::ZenohRaw, Source::Raw, 3000, 90_000),
            row_at(Path::ZenohRaw, Source::Raw, 72, 1_000),
        ]);
        let targets = rep.targets(72, 6248, 3000);
        let lines: Vec<&str> = targets
            .lines()
            .filter(|l| l.starts_with("target zenoh"))
            .collect();
        assert_eq!(lines.len(), 2, "{targets}");
        // Floor of the services: the 72-byte iceoryx2 event floor (p99 about 49.8 µs) plus the
        // zenoh floor between processes (about 129.9 µs): 159.9 / 179.7.
        assert!(lines[0].contains("(services)") && lines[0].contains("between two processes"));
        assert!(
            lines[0]
                .contains("= 179.7 µs: ratio 0.89 (target <= 1.25): met (below its floor: a sum"),
            "{targets}"
        );
        // In-process: 299.9 / (49.8 + 99.9 between threads) = 2.0, beyond 1.25.
        assert!(lines[1].contains("(in-process)") && lines[1].contains("between two threads"));
        assert!(
            lines[1].contains("= 149.7 µs: ratio 2.00") && lines[1].ends_with("NOT met"),
            "{targets}"
        );
        assert!(!lines[1].contains("below its floor"), "{targets}");
        // Without an iceoryx2 floor, the zenoh paths cannot be judged.
        rep.rows.retain(|r| r.path != Path::Iceoryx2Raw.name());
        assert!(!rep.targets(72, 6248, 3000).contains("target zenoh"));
    }

    #[test]
    fn svg_is_written_and_empty_reports_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("lat.svg");
        let mut rep = report();
        rep.write_svg(&file).unwrap();
        let svg = std::fs::read_to_string(&file).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("sample-to-forecast-local poll"));
        rep.curves.clear();
        assert!(rep.write_svg(&file).is_err());
        assert_eq!(nines_label(2.0), "p99");
        assert_eq!(nines_label(3.5), "max");
        assert_eq!(nines_label(1.5), "");
        assert_eq!(nines_label(0.0), "p0");
    }
}
