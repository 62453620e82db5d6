//! shipcast's forecast paths measured through the real services: `shipcast predictor` (its
//! forecasting thread pinned to the second core) and `shipcast producer` (pinned to the first)
//! run as child processes under a unique instance, with the measuring consumers of
//! [`super::consumers`] in this process.
//!
//! The predictor needs `order` values of 2 Hz history before its first forecast: the producer
//! backfills that much record at high speed (`--backfill-s`), then paces at the plan's rate
//! (`--speed rate/8`). Samples and forecasts from the backfill and the warm-up are not
//! recorded. producer -> predictor comes from the receive stamps the predictor publishes with
//! `--bench-stamps` ([`super::stamps`]).

use super::children::Children;
use super::consumers::{self, Shared, CONSUMERS, SLICE};
use super::pinning::{child_pinned, PinOutcome};
use super::pipeline::{
    add_consumer_rows, await_until, backfill_s, join, record_rate_hz, zenoh_pair, DRAIN,
};
use super::plan::{Mode, Path, Plan, Source};
use super::report_builder::{ReportBuilder, FORECAST_BYTES, MOTION_BYTES};
use super::stamps::{StampReader, StampTally};
use anyhow::Context;
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::transport::zenoh::LivelinessWatch;
use shipcast_pipeline::transport::Names;
use std::path::{Path as FsPath, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Speed of the backfill (record seconds per wall second).
const BACKFILL_SPEED: f64 = 200.0;
/// Start-up of the predictor (model training on simulated history) may take this long.
const START_TIMEOUT: Duration = Duration::from_secs(120);
/// How long the services get to shut down cleanly before they are killed.
const STOP_TIMEOUT: Duration = Duration::from_secs(5);
/// Readers in this process that report ready: the forecast consumers and the stamp reader.
const READERS: usize = CONSUMERS + 1;
/// Extra time the producer may take beyond its schedule before it is considered hung.
const RUN_SLACK: Duration = Duration::from_secs(60);

impl Drop for Children {
    fn drop(&mut self) {
        self.kill_all();
    }
}

/// Measure the forecast paths of the real services in `mode` and add their rows to `out`.
pub fn measure(
    plan: &Plan,
    mode: Mode,
    exe: &FsPath,
    out: &mut ReportBuilder,
) -> anyhow::Result<()> {
    let defaults = PipelineConfig::default();
    let q = &defaults.predictor;
    let backfill_s = backfill_s(q);
    let record_rate_hz = record_rate_hz();
    let backfill_samples = (backfill_s * record_rate_hz).round() as u64;
    // The run's instance, a vessel name per mode: one iceoryx2 file prefix per run.
    let instance = &plan.instance;
    let vessel = format!("svc-{}", mode.name());
    let names = Names::new(Some(instance), &vessel).context("benchmark names")?;
    let shared = Shared::new(names, mode, plan.cores.0, backfill_samples + plan.warmup);
    let (endpoint, _, consumer_session) = zenoh_pair(false)?;
    let dir = std::env::temp_dir();
    let config = dir.join(format!("{instance}-{vessel}.toml"));
    std::fs::write(
        &config,
        format!("[producer]\nbackfill_speed = {BACKFILL_SPEED:.1}\n"),
    )
    .with_context(|| format!("write {}", config.display()))?;
    let common = |service: &str| -> Vec<String> {
        vec![
            service.to_string(),
            "--instance".into(),
            instance.clone(),
            "--vessel".into(),
            vessel.clone(),
            "--config".into(),
            config.display().to_string(),
            "--zenoh-listen".into(),
            endpoint.clone(),
        ]
    };
    let mut children = Children::default();
    let mut predictor_args = common("predictor");
    predictor_args.extend([
        "--retrain-every-s".into(),
        "0".into(),
        "--bench-stamps".into(),
    ]);
    if mode == Mode::Poll {
        predictor_args.push("--busy-poll".into());
    }
    // The predictor pins its forecasting thread itself, once its transports are open: zenoh's
    // threads and the retraining thread keep every core, as they would in a deployment.
    predictor_args.extend(["--pin-core".into(), plan.cores.1.to_string()]);
    let log = |role: &str| dir.join(format!("{instance}-{vessel}-{role}.log"));
    let predictor_pid =
        children.spawn_unpinned("predictor", exe, &predictor_args, log("predictor"))?;

    let record_s = backfill_s + (plan.warmup + plan.samples) as f64 / record_rate_hz;
    let mut producer_args = common("producer");
    producer_args.extend([
        "--speed".into(),
        format!("{}", plan.rate_hz / record_rate_hz),
        "--record-s".into(),
        format!("{record_s}"),
        "--backfill-s".into(),
        format!("{backfill_s}"),
        "--wait-subscriber-s".into(),
        "10".into(),
    ]);
    let schedule = Duration::from_secs_f64(
        backfill_s / BACKFILL_SPEED + (plan.warmup + plan.samples) as f64 / plan.rate_hz,
    );

    let result = std::thread::scope(|s| {
        let local = s.spawn(|| stop_on_err(&shared, consumers::local(&shared)));
        let remote =
            s.spawn(|| stop_on_err(&shared, consumers::remote(&shared, &consumer_session)));
        let stamps = s.spawn(|| stop_on_err(&shared, read_stamps(&shared)));
        let driven = drive(
            &shared,
            &consumer_session,
            &mut children,
            exe,
            &producer_args,
            plan.cores.0,
            log("producer"),
            schedule,
        );
        shared.stop();
        // The forecasting thread is the main thread, whose id is the process id.
        let pin_pred = child_pinned("predictor forecasting thread", predictor_pid, plan.cores.1);
        (
            driven,
            pin_pred,
            join(local, "local consumer"),
            join(remote, "zenoh consumer"),
            join(stamps, "receive stamp reader"),
        )
    });
    children.stop_all(STOP_TIMEOUT);
    let _ = std::fs::remove_file(&config);
    // Creating a node of this instance removes whatever a killed service left behind.
    drop(shipcast_pipeline::transport::iox::node(
        &shared.names,
        "bench-cleanup",
    ));
    let (driven, pin_pred, local, remote, stamps) = result;
    let pin_prod = driven?;
    let (local, pin_l) = local?;
    let (remote, pin_z) = remote?;
    let stamps = stamps?;
    out.add_stages(mode, &stamps.stages);
    out.add_pins([pin_prod, pin_pred, pin_l, pin_z]);
    let src = Source::Services;
    out.add(
        Path::ProducerToPredictor,
        mode,
        src,
        &stamps.latency,
        plan.samples.max(stamps.seen()),
        MOTION_BYTES,
    );
    out.add(
        Path::SampleToForecastPublished,
        mode,
        src,
        &local.published,
        local.latency.count() + local.lost,
        FORECAST_BYTES,
    );
    let published = local.latency.count() + local.lost;
    let remote_expected = published.max(remote.latency.count() + remote.lost);
    add_consumer_rows(
        out,
        mode,
        src,
        [(&local, published), (&remote, remote_expected)],
    );
    Ok(())
}

/// Drain the predictor's receive stamps until the run is over. The stamps carry their own
/// receive time, so a slow drain (every [`SLICE`], on the producer's core) costs no accuracy.
fn read_stamps(shared: &Shared) -> anyhow::Result<StampTally> {
    let node = shipcast_pipeline::transport::iox::node(&shared.names, "bench-stamps")?;
    let reader = StampReader::new(&node, &shared.names.bench_receive())?;
    shared.ready.fetch_add(1, Ordering::AcqRel);
    let mut tally = StampTally::new(shared.first_measured);
    while !shared.is_done() {
        reader.drain(&mut tally)?;
        std::thread::sleep(SLICE);
    }
    reader.drain(&mut tally)?;
    Ok(tally)
}

fn stop_on_err<T>(shared: &Shared, r: anyhow::Result<T>) -> anyhow::Result<T> {
    if r.is_err() {
        shared.stop();
    }
    r
}

/// Wait for the consumers and the predictor, run the producer to its end, let the last
/// forecasts arrive. The children are killed by the caller's guard afterwards.
#[allow(clippy::too_many_arguments)]
fn drive(
    shared: &Shared,
    watch_session: &zenoh::Session,
    children: &mut Children,
    exe: &FsPath,
    producer_args: &[String],
    core: usize,
    log: PathBuf,
    schedule: Duration,
) -> anyhow::Result<PinOutcome> {
    await_until(shared, "the consumers", || {
        shared.ready.load(Ordering::Acquire) == READERS
    })?;
    // The predictor is ready when its liveliness token reaches the consumer's own session:
    // models trained, ports created, and the consumer connected to it.
    let watch = LivelinessWatch::new(watch_session, &Names::liveliness(&shared.names.forecast()))?;
    let deadline = Instant::now() + START_TIMEOUT;
    while watch.poll() != Some(true) {
        children.check_running("predictor")?;
        if Instant::now() > deadline {
            anyhow::bail!("predictor not alive within {START_TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let pin = children.spawn("producer", exe, producer_args, core, log)?;
    children.wait_exit("producer", schedule + RUN_SLACK)?;

    std::thread::sleep(DRAIN);
    children.check_running("predictor")?;
    Ok(pin)
}
