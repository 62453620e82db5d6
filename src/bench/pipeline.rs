//! shipcast's own paths, one way from the payload stamps:
//! producer -> predictor receive, sample -> forecast published, -> received by a co-located
//! iceoryx2 consumer, -> received by a zenoh consumer over tcp/127.0.0.1.
//!
//! Producer and local consumers run on the first core, the predictor on the second. All traffic
//! uses the middleware's public transport API (`transport::iox`, `transport::zenoh`) and names
//! under a unique instance prefix. The forecasting step is [`super::stand_in::ForecastStep`].

use super::histogram::LatencyRecorder;
use super::latency::{ReportBuilder, FORECAST_BYTES, MOTION_BYTES};
use super::pingpong_zenoh::free_port;
use super::pinning::{pin_current, PinOutcome};
use super::plan::{Mode, Pacer, Path, Plan};
use super::stand_in::{swell, ForecastStep, RECORD_RATE_HZ};
use crate::payload::{Forecast, MotionSample};
use crate::transport::iox::{self, IoxPublisher, IoxSubscriber, Sizing, WaitMode};
use crate::transport::zenoh::{open, JsonPublisher, ZenohSettings};
use crate::transport::{monotonic_ns, Names};
use anyhow::{anyhow, Context};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// How long receivers wait per call before checking whether the run is over.
const SLICE: Duration = Duration::from_millis(20);
/// Time for the last messages to arrive after the producer stops.
const DRAIN: Duration = Duration::from_millis(500);
/// How long to wait for every port and the zenoh subscriber to be connected.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(15);

/// Consumers whose subscribers exist (local iceoryx2, zenoh) before the predictor may start.
const CONSUMERS: usize = 2;

/// What the predictor side measured and counted.
#[derive(Default)]
struct PredictorTally {
    received: LatencyRecorder,
    published: LatencyRecorder,
    /// Forecasts due from measured samples, and forecasts published from them.
    due: u64,
    sent: u64,
}

fn wait_mode(mode: Mode) -> WaitMode {
    match mode {
        Mode::Event => WaitMode::Event,
        Mode::Poll => WaitMode::BusyPoll,
    }
}

/// Shared state of one pipeline run.
struct Run<'a> {
    plan: &'a Plan,
    mode: Mode,
    names: Names,
    /// Set by the producer after the drain time (or by any failing part): every thread stops.
    done: AtomicBool,
    /// Consumers whose subscribers exist.
    consumers_ready: AtomicUsize,
    /// Set by the predictor once every receiver is connected: the producer may send.
    started: AtomicBool,
}

impl Run<'_> {
    fn is_done(&self) -> bool {
        self.done.load(Ordering::Acquire)
    }

    fn fail(&self) {
        self.done.store(true, Ordering::Release);
    }

    fn measured(&self, source_seq: u64) -> bool {
        source_seq >= self.plan.warmup
    }
}

/// Measure the four shipcast paths in `mode` and add their rows to `out`.
pub fn measure(plan: &Plan, mode: Mode, out: &mut ReportBuilder) -> anyhow::Result<()> {
    let instance = format!("{}-pipe-{}", plan.instance, mode.name());
    let run = Run {
        plan,
        mode,
        names: Names::new(Some(&instance), "bench").context("benchmark instance name")?,
        done: AtomicBool::new(false),
        consumers_ready: AtomicUsize::new(0),
        started: AtomicBool::new(false),
    };
    // The predictor listens on zenoh and the consumer connects to it. Both sessions are opened
    // here, on the unpinned caller: zenoh's runtime threads inherit the affinity of the thread
    // that starts them, and must not all end up on one measured core.
    let endpoint = format!("tcp/127.0.0.1:{}", free_port()?);
    let settings = |listen: bool| ZenohSettings {
        listen: if listen {
            vec![endpoint.clone()]
        } else {
            Vec::new()
        },
        connect: if listen {
            Vec::new()
        } else {
            vec![endpoint.clone()]
        },
        multicast_scouting: false,
    };
    let predictor_session = open(&settings(true))?;
    let consumer_session = open(&settings(false))?;
    let (tally, local, remote, pins) = std::thread::scope(|s| {
        let predictor = s.spawn(|| with_fail(&run, predictor(&run, predictor_session)));
        let local = s.spawn(|| with_fail(&run, local_consumer(&run)));
        let remote = s.spawn(|| with_fail(&run, zenoh_consumer(&run, consumer_session)));
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
    let ((remote, rejected), pin_z) = remote?;
    if rejected > 0 {
        out.note(format!(
            "{mode}: the zenoh consumer rejected {rejected} malformed forecast JSON payloads"
        ));
    }
    let pin_s = pins?;
    out.pins().extend([pin_s, pin_p, pin_l, pin_z]);
    out.add(
        Path::ProducerToPredictor,
        mode,
        &tally.received,
        plan.samples,
        MOTION_BYTES,
    );
    out.add(
        Path::SampleToForecastPublished,
        mode,
        &tally.published,
        tally.due,
        FORECAST_BYTES,
    );
    out.add(
        Path::SampleToForecastLocal,
        mode,
        &local,
        tally.sent,
        FORECAST_BYTES,
    );
    out.add(
        Path::SampleToForecastZenoh,
        mode,
        &remote,
        tally.sent,
        super::latency::forecast_json_bytes(),
    );
    Ok(())
}

fn with_fail<T>(run: &Run<'_>, r: anyhow::Result<T>) -> anyhow::Result<T> {
    if r.is_err() {
        run.fail();
    }
    r
}

fn join<T>(
    h: std::thread::ScopedJoinHandle<'_, anyhow::Result<T>>,
    role: &str,
) -> anyhow::Result<T> {
    h.join()
        .map_err(|_| anyhow!("pipeline {role} thread panicked"))?
        .with_context(|| format!("pipeline {role}"))
}

/// Wait until `ready()` holds, the run failed, or the connect timeout passes.
fn await_until(run: &Run<'_>, what: &str, ready: impl Fn() -> bool) -> anyhow::Result<()> {
    let deadline = Instant::now() + CONNECT_TIMEOUT;
    while !ready() {
        if run.is_done() {
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
    let node = iox::node(&run.names, "bench-producer")?;
    let publisher = IoxPublisher::<MotionSample>::new(&node, &run.names.motion(), Sizing::MOTION)?;
    await_until(run, "the predictor", || run.started.load(Ordering::Acquire))?;
    let mut pacer = Pacer::new(run.plan);
    let mut sample = MotionSample::default();
    for seq in 0..run.plan.warmup + run.plan.samples {
        if run.is_done() {
            anyhow::bail!("stopped early: another part of the pipeline failed");
        }
        pacer.wait();
        let t = seq as f64 / RECORD_RATE_HZ;
        sample.seq = seq;
        sample.time_s = t;
        for (d, v) in sample.dof.iter_mut().enumerate() {
            *v = swell(d, t);
        }
        sample.stamp_ns = monotonic_ns();
        publisher.send(&sample)?;
    }
    std::thread::sleep(DRAIN);
    run.done.store(true, Ordering::Release);
    Ok(pin)
}

/// Predictor, on the second core: receive, forecast every 4th sample, publish over iceoryx2
/// and zenoh.
fn predictor(
    run: &Run<'_>,
    session: zenoh::Session,
) -> anyhow::Result<(PredictorTally, PinOutcome)> {
    let pin = pin_current("predictor", run.plan.cores.1);
    let mut step = ForecastStep::new()?;
    let node = iox::node(&run.names, "bench-predictor")?;
    let motion = IoxSubscriber::<MotionSample>::new(
        &node,
        &run.names.motion(),
        Sizing::MOTION,
        wait_mode(run.mode),
    )?;
    let forecasts = IoxPublisher::<Forecast>::new(&node, &run.names.forecast(), Sizing::FORECAST)?;
    let remote = JsonPublisher::new(&session, &run.names.forecast())?;
    // The consumers' subscribers must exist before the first send (iceoryx2 ports connect on
    // send), and zenoh declarations propagate asynchronously: wait for the match.
    await_until(run, "the consumers", || {
        run.consumers_ready.load(Ordering::Acquire) == CONSUMERS
    })?;
    await_until(run, "the zenoh subscriber", || remote.has_subscribers())?;
    run.started.store(true, Ordering::Release);
    let mut tally = PredictorTally::default();
    let mut json = Vec::with_capacity(16 * 1024);
    while !run.is_done() {
        motion.wait(SLICE)?;
        while let Some(sample) = motion.receive()? {
            let received = monotonic_ns();
            let measured = run.measured(sample.seq);
            if measured {
                tally.received.record_between(sample.stamp_ns, received);
            }
            let Some(f) = step.push(&sample)? else {
                continue;
            };
            if measured {
                tally.due += 1;
            }
            f.issued_stamp_ns = monotonic_ns();
            forecasts.send(f)?;
            f.write_json(&mut json).context("encode forecast JSON")?;
            remote.put(&json)?;
            if measured {
                tally.sent += 1;
                tally
                    .published
                    .record_between(f.source_stamp_ns, f.issued_stamp_ns);
            }
        }
    }
    drop(session.close().wait());
    Ok((tally, pin))
}

/// Co-located iceoryx2 consumer, on the first core.
fn local_consumer(run: &Run<'_>) -> anyhow::Result<(LatencyRecorder, PinOutcome)> {
    let pin = pin_current("local consumer", run.plan.cores.0);
    let node = iox::node(&run.names, "bench-local")?;
    let sub = IoxSubscriber::<Forecast>::new(
        &node,
        &run.names.forecast(),
        Sizing::FORECAST,
        wait_mode(run.mode),
    )?;
    run.consumers_ready.fetch_add(1, Ordering::AcqRel);
    let mut rec = LatencyRecorder::new();
    while !run.is_done() {
        sub.wait(SLICE)?;
        while let Some(f) = sub.receive()? {
            let now = monotonic_ns();
            if run.measured(f.source_seq) {
                rec.record_between(f.source_stamp_ns, now);
            }
        }
    }
    Ok((rec, pin))
}

/// zenoh consumer over tcp/127.0.0.1, on the first core. It always blocks on its channel:
/// zenoh delivers from its own threads, and a spinning consumer would take the core they need.
fn zenoh_consumer(
    run: &Run<'_>,
    session: zenoh::Session,
) -> anyhow::Result<((LatencyRecorder, u64), PinOutcome)> {
    let pin = pin_current("zenoh consumer", run.plan.cores.0);
    let key = run.names.forecast();
    let sub = session
        .declare_subscriber(key.clone())
        .wait()
        .map_err(|e| anyhow!("zenoh: declare subscriber '{key}': {e}"))?;
    run.consumers_ready.fetch_add(1, Ordering::AcqRel);
    let mut rec = LatencyRecorder::new();
    let mut rejected = 0u64;
    while !run.is_done() {
        let Some(sample) = sub
            .recv_timeout(SLICE)
            .map_err(|e| anyhow!("zenoh: receive: {e}"))?
        else {
            continue;
        };
        let now = monotonic_ns();
        match Forecast::from_json(&sample.payload().to_bytes()) {
            Ok(f) if run.measured(f.source_seq) => rec.record_between(f.source_stamp_ns, now),
            Ok(_) => {}
            Err(e) => {
                rejected += 1;
                tracing::warn!(rejected, "zenoh consumer rejected a forecast: {e}");
            }
        }
    }
    drop(session.close().wait());
    Ok(((rec, rejected), pin))
}
