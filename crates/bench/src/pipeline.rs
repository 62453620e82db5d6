//! shipcast's paths measured in-process, one way from the payload stamps: producer -> predictor
//! receive, sample -> forecast published, -> received by a co-located iceoryx2 consumer,
//! -> received by a zenoh consumer over tcp/127.0.0.1.
//!
//! Producer and consumers are threads on the first core, the predictor on the second. All
//! traffic uses the middleware's public transport API (`transport::iox`, `transport::zenoh`)
//! under a unique instance prefix. The predictor thread runs the service's own forecasting
//! [`Engine`] and publishing steps as `shipcast predictor` does (same defaults, same start-up
//! models, `--retrain-every-s 0` as in the services rows); [`super::services`] measures the
//! real `shipcast producer` and `shipcast predictor` processes.

use super::consumers::{self, ConsumerTally, Shared, CONSUMERS};
use super::histogram::LatencyRecorder;
use super::pinning::{pin_current, PinOutcome};
use super::plan::{Mode, Pacer, Path, Plan, Source};
use super::report_builder::{forecast_json_bytes, ReportBuilder, FORECAST_BYTES, MOTION_BYTES};
use anyhow::{anyhow, Context};
use shipcast_pipeline::config::{PipelineConfig, PredictorServiceConfig};
use shipcast_pipeline::engine::models::ModelSet;
use shipcast_pipeline::engine::retrain::Retrainer;
use shipcast_pipeline::engine::{startup, Engine};
use shipcast_pipeline::transport::iox::{self, IoxPublisher, IoxSubscriber, Sizing};
use shipcast_pipeline::transport::zenoh::{
    free_loopback_endpoint, open, JsonPublisher, ZenohSettings,
};
use shipcast_pipeline::transport::{monotonic_ns, Names};
use shipcast_sim::{ShipMotion, SimConfig};
use shipcast_wire::payload::{Forecast, MotionSample, NUM_DOF};
use shipcast_wire::payload_json::ForecastJsonEncoder;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// Time for the last messages to arrive after the producer stops.
pub const DRAIN: Duration = Duration::from_millis(500);
/// How long to wait for every port and the zenoh subscriber to be connected.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(15);
/// Record seconds of history beyond `order / sample_rate` (decimation filter, margin).
const BACKFILL_MARGIN_S: f64 = 30.0;

/// Input rate of the motion record (the producer's 8 Hz), whatever the wall-clock send rate.
pub fn record_rate_hz() -> f64 {
    PipelineConfig::default().producer.rate_hz
}

/// Record seconds the predictor receives before the measured samples, so that its models have
/// their full history from the first one: `order` values at the decimated rate, plus the
/// decimation filter and a margin.
pub fn backfill_s(q: &PredictorServiceConfig) -> f64 {
    (q.order as f64 / q.sample_rate_hz + BACKFILL_MARGIN_S).ceil()
}

/// The motion the in-process producer sends: the first `len` samples of the sea that
/// `shipcast producer` simulates by default (its scenario, seed and rate).
pub fn motion_record(config: &PipelineConfig, len: u64) -> anyhow::Result<Vec<[f64; NUM_DOF]>> {
    let p = &config.producer;
    let mut sim = SimConfig::scenario(p.scenario);
    sim.seed = p.seed;
    let motion = ShipMotion::new(&sim)?;
    Ok(motion
        .stream(p.rate_hz, 0.0)?
        .take(len as usize)
        .map(|point| point.dof)
        .collect())
}

/// The start-up models of `shipcast predictor` with `config` (fitted on simulated history of
/// the configured sea, seconds of work), kept for the next call with the same configuration:
/// every round and mode of a run starts its engine from a copy of one fit.
fn startup_models(config: &PipelineConfig) -> anyhow::Result<Option<ModelSet>> {
    type Fitted = Option<(PipelineConfig, Option<ModelSet>)>;
    static LAST: Mutex<Fitted> = Mutex::new(None);
    let mut last = LAST
        .lock()
        .map_err(|_| anyhow!("bench start-up models: lock poisoned"))?;
    if let Some((c, models)) = last.as_ref() {
        if c == config {
            return Ok(models.clone());
        }
    }
    let models = startup::initial_models(config).context("bench start-up models")?;
    *last = Some((config.clone(), models.clone()));
    Ok(models)
}

/// The predictor's engine as `shipcast predictor` runs it with `config` (the services rows:
/// the default configuration and `--retrain-every-s 0`, which the caller sets), retraining
/// on a background thread, fed the first `backfill` samples of `record` directly, as the
/// services' producer backfills them before pacing.
pub fn backfilled_engine(
    config: &PipelineConfig,
    record: &[[f64; NUM_DOF]],
    backfill: u64,
) -> anyhow::Result<Engine> {
    let q = config.predictor.clone();
    let retrainer = Retrainer::background(q.clone())?;
    let mut engine = Engine::new(
        q,
        config.producer.rate_hz,
        startup_models(config)?,
        retrainer,
    )?;
    for (seq, dof) in record.iter().take(backfill as usize).enumerate() {
        let sample = MotionSample {
            seq: seq as u64,
            stamp_ns: monotonic_ns(),
            time_s: seq as f64 / config.producer.rate_hz,
            dof: *dof,
        };
        if engine.push(&sample)?.is_none() {
            engine.prepare_next()?;
        }
    }
    Ok(engine)
}

/// What the predictor side measured and counted.
#[derive(Default)]
struct PredictorTally {
    received: LatencyRecorder,
    published: LatencyRecorder,
    /// Forecasts due from measured samples, and forecasts published from them.
    due: u64,
    sent: u64,
}

struct Run<'a> {
    plan: &'a Plan,
    shared: Shared,
    /// Set by the predictor once every receiver is connected: the producer may send.
    started: AtomicBool,
    /// The motion record; the engine has had the first `backfill` samples, the producer sends
    /// the rest (warm-up, then measured).
    record: Vec<[f64; NUM_DOF]>,
    backfill: u64,
}

/// Open a listening and a connecting zenoh peer on a free 127.0.0.1 port, on the calling
/// (unpinned) thread: zenoh's runtime threads inherit the affinity of the thread that starts
/// them and must not all end up on one measured core. Returns (endpoint, listener, connector).
pub fn zenoh_pair(
    listen: bool,
) -> anyhow::Result<(String, Option<zenoh::Session>, zenoh::Session)> {
    let endpoint = free_loopback_endpoint()?;
    let listener = match listen {
        true => Some(open(&ZenohSettings::listen_on(&endpoint))?),
        false => None,
    };
    let connector = open(&ZenohSettings::connect_to(&endpoint))?;
    Ok((endpoint, listener, connector))
}

/// Measure the four shipcast paths in `mode` and add their rows to `out`.
pub fn measure(plan: &Plan, mode: Mode, out: &mut ReportBuilder) -> anyhow::Result<()> {
    // The run's instance, a vessel name per mode: one iceoryx2 file prefix per run.
    let vessel = format!("pipe-{}", mode.name());
    let names = Names::new(Some(&plan.instance), &vessel).context("benchmark names")?;
    let mut config = PipelineConfig::default();
    config.predictor.retrain_every_s = 0.0;
    let backfill = (backfill_s(&config.predictor) * config.producer.rate_hz).round() as u64;
    let record = motion_record(&config, backfill + plan.warmup + plan.samples)?;
    let engine = backfilled_engine(&config, &record, backfill)?;
    let run = Run {
        plan,
        shared: Shared::new(names, mode, plan.cores.0, backfill + plan.warmup),
        started: AtomicBool::new(false),
        record,
        backfill,
    };
    let (_, predictor_session, consumer_session) = zenoh_pair(true)?;
    let predictor_session =
        predictor_session.ok_or_else(|| anyhow!("zenoh listener was not opened"))?;
    let (tally, local, remote, pin_s) = std::thread::scope(|s| {
        let predictor = s.spawn(|| with_fail(&run, predictor(&run, predictor_session, engine)));
        let local = s.spawn(|| with_fail(&run, consumers::local(&run.shared)));
        let remote = s.spawn(|| with_fail(&run, consumers::remote(&run.shared, &consumer_session)));
        let producer = s.spawn(|| with_fail(&run, producer(&run)));
        (
            join(predictor, "predictor"),
            join(local, "local consumer"),
            join(remote, "zenoh consumer"),
            join(producer, "producer"),
        )
    });
    let (tally, pin_p) = tally?;
    let (local, pin_l) = local?;
    let (remote, pin_z) = remote?;
    out.add_pins([pin_s?, pin_p, pin_l, pin_z]);
    let src = Source::InProcess;
    out.add(
        Path::ProducerToPredictor,
        mode,
        src,
        &tally.received,
        plan.samples,
        MOTION_BYTES,
    );
    out.add(
        Path::SampleToForecastPublished,
        mode,
        src,
        &tally.published,
        tally.due,
        FORECAST_BYTES,
    );
    add_consumer_rows(
        out,
        mode,
        src,
        [(&local, tally.sent), (&remote, tally.sent)],
    );
    Ok(())
}

/// Add the rows of the local and the zenoh consumer, each with the number of measured
/// forecasts published to it.
pub fn add_consumer_rows(
    out: &mut ReportBuilder,
    mode: Mode,
    source: Source,
    [local, remote]: [(&ConsumerTally, u64); 2],
) {
    let rows = [
        (Path::SampleToForecastLocal, local, FORECAST_BYTES),
        (Path::SampleToForecastZenoh, remote, forecast_json_bytes()),
    ];
    for (path, (tally, expected), bytes) in rows {
        out.add(path, mode, source, &tally.latency, expected, bytes);
        if tally.rejected > 0 {
            out.note(format!(
                "{path} {mode}: {} forecast payloads could not be decoded",
                tally.rejected
            ));
        }
    }
}

fn with_fail<T>(run: &Run<'_>, r: anyhow::Result<T>) -> anyhow::Result<T> {
    if r.is_err() {
        run.shared.stop();
    }
    r
}

pub fn join<T>(
    h: std::thread::ScopedJoinHandle<'_, anyhow::Result<T>>,
    role: &str,
) -> anyhow::Result<T> {
    h.join()
        .map_err(|_| anyhow!("pipeline {role} thread panicked"))?
        .with_context(|| format!("pipeline {role}"))
}

/// Wait until `ready()` holds, the run is stopped, or the connect timeout passes.
pub fn await_until(shared: &Shared, what: &str, ready: impl Fn() -> bool) -> anyhow::Result<()> {
    let deadline = Instant::now() + CONNECT_TIMEOUT;
    while !ready() {
        if shared.is_done() {
            anyhow::bail!("another part of the pipeline failed while waiting for {what}");
        }
        if Instant::now() > deadline {
            anyhow::bail!("{what} not ready within {CONNECT_TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok(())
}

/// Producer, on the first core: paced MotionSamples stamped just before sending.
fn producer(run: &Run<'_>) -> anyhow::Result<PinOutcome> {
    let pin = pin_current("producer", run.plan.cores.0);
    let names = &run.shared.names;
    let node = iox::node(names, "bench-producer")?;
    let publisher = IoxPublisher::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION)?;
    await_until(&run.shared, "the predictor", || {
        run.started.load(Ordering::Acquire)
    })?;
    let mut pacer = Pacer::new(run.plan.period());
    let mut sample = MotionSample::default();
    let rate = record_rate_hz();
    for (seq, dof) in (run.backfill..).zip(&run.record[run.backfill as usize..]) {
        if run.shared.is_done() {
            anyhow::bail!("stopped early: another part of the pipeline failed");
        }
        pacer.wait();
        sample.seq = seq;
        sample.time_s = seq as f64 / rate;
        sample.dof = *dof;
        sample.stamp_ns = monotonic_ns();
        publisher.send(&sample)?;
    }
    std::thread::sleep(DRAIN);
    run.shared.stop();
    Ok(pin)
}

/// Predictor, on the second core: the loop of `shipcast predictor` over the same engine:
/// receive, forecast at every decimated value, publish over iceoryx2 and zenoh; prepare the
/// next forecast on the samples that complete none, and do the engine's bookkeeping between
/// samples.
fn predictor(
    run: &Run<'_>,
    session: zenoh::Session,
    mut engine: Engine,
) -> anyhow::Result<(PredictorTally, PinOutcome)> {
    let pin = pin_current("predictor", run.plan.cores.1);
    let shared = &run.shared;
    let node = iox::node(&shared.names, "bench-predictor")?;
    let motion = IoxSubscriber::<MotionSample>::new(
        &node,
        &shared.names.motion(),
        Sizing::MOTION,
        consumers::wait_mode(shared.mode),
    )?;
    let forecasts =
        IoxPublisher::<Forecast>::new(&node, &shared.names.forecast(), Sizing::FORECAST)?;
    let remote = JsonPublisher::new(&session, &shared.names.forecast())?;
    // The consumers' subscribers must exist before the first send (iceoryx2 ports connect on
    // send), and zenoh declarations propagate asynchronously: wait for the match.
    await_until(shared, "the consumers", || {
        shared.ready.load(Ordering::Acquire) == CONSUMERS
    })?;
    await_until(shared, "the zenoh subscriber", || remote.has_subscribers())?;
    run.started.store(true, Ordering::Release);
    let mut tally = PredictorTally::default();
    let mut json = ForecastJsonEncoder::new();
    let slice = consumers::wait_slice(shared.mode);
    while !shared.is_done() {
        motion.wait(slice)?;
        let mut idle = true;
        while let Some(sample) = motion.receive()? {
            let received = monotonic_ns();
            idle = false;
            let measured = shared.measured(sample.seq);
            if measured {
                tally.received.record_between(sample.stamp_ns, received);
            }
            let Some(f) = engine.push(&sample)? else {
                // A sample that completes no forecast: the time to prepare the next one.
                engine.prepare_next()?;
                continue;
            };
            if measured {
                tally.due += 1;
            }
            forecasts.send(f)?;
            remote.put_shared(json.encode_shared(f)?)?;
            if measured {
                tally.sent += 1;
                tally
                    .published
                    .record_between(f.source_stamp_ns, f.issued_stamp_ns);
            }
        }
        engine.poll_models();
        if idle {
            engine.prepare_next()?;
            consumers::after_idle_wait(shared.mode);
        }
    }
    drop(session.close().wait());
    Ok((tally, pin))
}
