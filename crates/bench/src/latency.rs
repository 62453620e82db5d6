//! `shipcast bench latency`: runs every measurement of one report in sequence (so they never
//! compete for the two cores) and collects the rows.

use super::plan::{Mode, Path, Plan, Source};
use super::report::LatencyReport;
use super::report_builder::{forecast_json_bytes, ReportBuilder, FORECAST_BYTES, MOTION_BYTES};
use super::{pingpong_iox, pingpong_zenoh, pingpong_zenoh_processes};
use shipcast_eval::progress::Progress;
use shipcast_wire::payload::{Forecast, MotionSample};

/// How the shipcast paths were measured, stated in every report.
pub const SOURCES_NOTE: &str = "source 'services' = `shipcast producer` (pinned to the first core) and \
`shipcast predictor` (its forecasting thread pinned to the second with --pin-core) as child processes, measured by consumers in this process, producer-to-predictor from the \
receive stamps the predictor publishes with --bench-stamps; source 'in-process' = producer, \
predictor and consumers as threads of this process over the same transport API, the predictor thread \
running the service's own engine (shipcast_pipeline::engine::Engine, default configuration, the service's start-up \
models, retraining off as in the services rows) and publishing steps, recording receive stamps itself; source 'raw' = ping-pong between two threads of this process, 'raw-processes' = zenoh ping-pong between this process and a child `shipcast bench zenoh-pong` (the process boundary the services' zenoh path crosses); zenoh consumers always block on their channel (mode applies to iceoryx2 receivers); \
poll = spinning on the queue; shipcast receivers and the zenoh floor yield the core after 20 µs without \
data so that zenoh's threads on the same core run (the iceoryx2 floor never yields)";

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
        let names = shipcast_pipeline::transport::Names::new(Some(&sub.instance), "any")?;
        shipcast_pipeline::transport::iox::remove_leftovers(&names.iox_prefix());
    }
    Ok(out.finish())
}
