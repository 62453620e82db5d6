//! `shipcast bench latency`: runs every measurement of one report in sequence (so they never
//! compete for the two cores) and collects the rows.

use super::histogram::LatencyRecorder;
use super::machine::Machine;
use super::pingpong::PingPongOutcome;
use super::plan::{Mode, Path, Plan, Source};
use super::report::{Curve, LatencyReport, StageStats};
use super::stamps::{STAGES, STAGE_NAMES};
use super::{pingpong_iox, pingpong_zenoh, pingpong_zenoh_processes};
use crate::payload::{Forecast, MotionSample, MAX_STEPS, NUM_DOF};
use crate::predict::PredictorConfig;
use crate::progress::Progress;

/// How the shipcast paths were measured, stated in every report.
pub const SOURCES_NOTE: &str = "source 'services' = `shipcast producer` (pinned to the first core) and \
`shipcast predictor` (its forecasting thread pinned to the second with --pin-core) as child processes, measured by consumers in this process, producer-to-predictor from the \
receive stamps the predictor publishes with --bench-stamps; source 'in-process' = producer, \
predictor and consumers as threads of this process over the same transport API, the predictor thread \
running the service's own engine (shipcast::engine::Engine, default configuration, the service's start-up \
models, retraining off as in the services rows) and publishing steps, recording receive stamps itself; source 'raw' = ping-pong between two threads of this process, 'raw-processes' = zenoh ping-pong between this process and a child `shipcast bench zenoh-pong` (the process boundary the services' zenoh path crosses); zenoh consumers always block on their channel (mode applies to iceoryx2 receivers); \
poll = spinning on the queue; shipcast receivers and the zenoh floor yield the core after 20 µs without \
data so that zenoh's threads on the same core run (the iceoryx2 floor never yields)";

/// Points per percentile curve in the SVG.
const CURVE_POINTS: usize = 60;

/// Size of the iceoryx2 motion payload.
pub const MOTION_BYTES: usize = std::mem::size_of::<MotionSample>();
/// Size of the iceoryx2 forecast payload.
pub const FORECAST_BYTES: usize = std::mem::size_of::<Forecast>();

/// Size of the zenoh JSON of a forecast with the predictor's default number of steps and
/// realistic values: the payload of the raw zenoh floor that the zenoh path is compared with.
pub fn forecast_json_bytes() -> usize {
    let steps = PredictorConfig::default().horizon.min(MAX_STEPS);
    let mut f = Forecast {
        seq: 123_456,
        source_seq: 987_654,
        source_stamp_ns: 1_234_567_890_123,
        issued_stamp_ns: 1_234_567_990_123,
        time_s: 12_345.625,
        dt_s: 0.5,
        steps: steps as u32,
        model_version: 3,
        ..Forecast::default()
    };
    for d in 0..NUM_DOF {
        for k in 0..steps {
            let x = (d * MAX_STEPS + k) as f32;
            f.mean[d][k] = 1.7 * (0.37 * x).sin();
            f.sigma[d][k] = 0.05 + 0.003 * k as f32;
        }
    }
    let mut out = Vec::new();
    // Serialising plain numbers into a Vec cannot fail; an error would only shrink the figure.
    let _ = f.write_json(&mut out);
    out.len()
}

/// Key of one row: the rounds of a run add to the same row.
type RowKey = (Path, Mode, Source, usize);

/// The latencies of one row, over the rounds so far.
struct RowData {
    key: RowKey,
    recorder: LatencyRecorder,
    expected: u64,
}

/// Collects the rows and curves of one run; rows keep the order in which they were first added.
pub struct ReportBuilder {
    report: LatencyReport,
    rows: Vec<RowData>,
    /// The predictor's steps per mode, over the rounds so far.
    stages: Vec<(Mode, [LatencyRecorder; STAGES])>,
}

impl ReportBuilder {
    pub fn new(plan: &Plan, modes: &[Mode]) -> Self {
        Self {
            report: LatencyReport {
                machine: Machine::detect(),
                cores: plan.cores,
                rate_hz: plan.rate_hz,
                samples: plan.samples,
                warmup: plan.warmup,
                rounds: plan.rounds,
                modes: modes.iter().map(|m| m.name()).collect(),
                pins: Vec::new(),
                rows: Vec::new(),
                stages: Vec::new(),
                not_measured: Vec::new(),
                notes: Vec::new(),
                load_avg_end: String::new(),
                curves: Vec::new(),
            },
            rows: Vec::new(),
            stages: Vec::new(),
        }
    }

    /// Add one round's durations of the predictor's steps (see [`STAGE_NAMES`]).
    pub fn add_stages(&mut self, mode: Mode, stages: &[LatencyRecorder; STAGES]) {
        match self.stages.iter_mut().find(|(m, _)| *m == mode) {
            Some((_, acc)) => acc.iter_mut().zip(stages).for_each(|(a, b)| a.merge(b)),
            None => self.stages.push((mode, stages.clone())),
        }
    }

    /// Add what one round measured on one path and mode (merged with earlier rounds).
    pub fn add(
        &mut self,
        path: Path,
        mode: Mode,
        source: Source,
        recorder: &LatencyRecorder,
        expected: u64,
        payload_bytes: usize,
    ) {
        let key = (path, mode, source, payload_bytes);
        tracing::debug!(
            path = path.name(),
            mode = mode.name(),
            count = recorder.count(),
            expected,
            "measured one round"
        );
        match self.rows.iter_mut().find(|r| r.key == key) {
            Some(row) => {
                row.recorder.merge(recorder);
                row.expected += expected;
            }
            None => self.rows.push(RowData {
                key,
                recorder: recorder.clone(),
                expected,
            }),
        }
    }

    fn add_pingpong(
        &mut self,
        path: Path,
        mode: Mode,
        source: Source,
        out: PingPongOutcome,
        bytes: usize,
    ) {
        self.add(path, mode, source, &out.recorder, out.expected, bytes);
        self.add_pins(out.pins);
    }

    /// Record how threads were pinned; every round pins the same roles, so repeats are dropped.
    pub fn add_pins(&mut self, pins: impl IntoIterator<Item = super::pinning::PinOutcome>) {
        for pin in pins {
            if !self.report.pins.contains(&pin) {
                self.report.pins.push(pin);
            }
        }
    }

    pub fn note(&mut self, note: String) {
        self.report.notes.push(note);
    }

    pub fn not_measured(&mut self, what: String) {
        tracing::warn!("not measured: {what}");
        self.report.not_measured.push(what);
    }

    pub fn finish(mut self) -> LatencyReport {
        for row in &self.rows {
            let (path, mode, source, payload_bytes) = row.key;
            let stats = row
                .recorder
                .stats(path, mode, source, row.expected, payload_bytes);
            tracing::info!(
                path = stats.path,
                mode = stats.mode,
                source = stats.source,
                count = stats.count,
                lost = stats.lost,
                p50_us = stats.p50_us,
                p99_us = stats.p99_us,
                "measured"
            );
            self.report.rows.push(stats);
            self.report.curves.push(Curve {
                mode: mode.name(),
                label: format!("{path} {mode} {payload_bytes} B ({})", source.name()),
                points: row.recorder.curve(3.0, CURVE_POINTS),
            });
        }
        for (mode, stages) in &self.stages {
            for (stage, rec) in STAGE_NAMES.iter().zip(stages) {
                self.report.stages.push(StageStats {
                    mode: mode.name(),
                    stage,
                    count: rec.count(),
                    p50_us: rec.quantile_us(0.5),
                    p90_us: rec.quantile_us(0.9),
                    p99_us: rec.quantile_us(0.99),
                });
            }
        }
        self.report.load_avg_end = super::machine::load_avg();
        self.report
    }
}

/// Measure the raw transport floors in `mode`: iceoryx2 with both payload types and zenoh with
/// the motion size and the forecast JSON size between two threads, and, given the shipcast
/// executable, zenoh with the JSON size between two processes.
pub fn measure_raw(plan: &Plan, mode: Mode, out: &mut ReportBuilder) -> anyhow::Result<()> {
    let iox_motion = pingpong_iox::run::<MotionSample>(plan, mode)?;
    out.add_pingpong(
        Path::Iceoryx2Raw,
        mode,
        Source::Raw,
        iox_motion,
        MOTION_BYTES,
    );
    let iox_forecast = pingpong_iox::run::<Forecast>(plan, mode)?;
    out.add_pingpong(
        Path::Iceoryx2Raw,
        mode,
        Source::Raw,
        iox_forecast,
        FORECAST_BYTES,
    );
    let json_bytes = forecast_json_bytes();
    for bytes in [MOTION_BYTES, json_bytes] {
        let z = pingpong_zenoh::run(plan, mode, bytes)?;
        out.add_pingpong(Path::ZenohRaw, mode, Source::Raw, z, bytes);
    }
    if let Some(exe) = &plan.shipcast_exe {
        let z = pingpong_zenoh_processes::run(plan, mode, json_bytes, exe)?;
        out.add_pingpong(Path::ZenohRaw, mode, Source::RawProcesses, z, json_bytes);
    }
    Ok(())
}

/// The whole benchmark: in every round, for each mode, shipcast's paths and the raw floors.
/// The measurements run one after another (never competing for the two cores) and take turns
/// `plan.rounds` times, so the slow drifts and bursts of a shared host reach every row.
pub fn run(plan: &Plan, modes: &[Mode], progress: &dyn Progress) -> anyhow::Result<LatencyReport> {
    plan.validate().map_err(anyhow::Error::msg)?;
    let mut out = ReportBuilder::new(plan, modes);
    out.note(SOURCES_NOTE.to_string());
    progress.start(plan.rounds * modes.len() as u64);
    for round in 0..plan.rounds {
        let sub = plan.round(round);
        for &mode in modes {
            // The services' rows first: the target comparison takes the first row of a path.
            match &sub.shipcast_exe {
                Some(exe) => {
                    if let Err(e) = super::services::measure(&sub, mode, exe, &mut out) {
                        out.not_measured(format!("services {mode} (round {round}): {e:#}"));
                    }
                }
                None if round == 0 => out.not_measured(format!(
                    "services {mode}: no shipcast executable given, only the in-process pipeline"
                )),
                None => {}
            }
            super::pipeline::measure(&sub, mode, &mut out)?;
            measure_raw(&sub, mode, &mut out)?;
            progress.advance(&format!("round {} of {}, {mode}", round + 1, plan.rounds));
        }
        // Every node of the round is dropped by now: only the round's own prefix is removed.
        let names = crate::transport::Names::new(Some(&sub.instance), "any")?;
        super::machine::remove_iox_leftovers(&names.iox_prefix());
    }
    Ok(out.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payload_sizes_match_the_wire_contract() {
        assert_eq!(MOTION_BYTES, 72);
        assert_eq!(FORECAST_BYTES, 56 + 2 * 6 * 128 * 4);
        // 600 floats of a few characters each, plus the header fields.
        let json = forecast_json_bytes();
        assert!((3000..12_000).contains(&json), "{json}");
    }
}
