//! `shipcast predictor`: subscribes to motion over iceoryx2 (event wake-up, or `--busy-poll`),
//! decimates 8 -> 2 Hz with the evaluation's filter, forecasts all six DOF at every new 2 Hz
//! value, and publishes the Forecast over iceoryx2 and as JSON over zenoh, and the motion
//! samples it receives as JSON on zenoh `.../motion` (remote verifiers). A background thread
//! retrains from recent live data and hands over new models without pausing the forecasts.

use crate::checked;
use crate::common_args::CommonArgs;
use shipcast_bench::pinning::pin_current;
use shipcast_bench::stamps::{PublishStages, ReceiveStamp, StampPublisher};
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::engine::models::ModelSet;
use shipcast_pipeline::engine::retrain::Retrainer;
use shipcast_pipeline::engine::Engine;
use shipcast_pipeline::limits;
use shipcast_pipeline::transport::forecast_check::IoxFollowedPort;
use shipcast_pipeline::transport::iox::{self, IoxPublisher, IoxSubscriber, Sizing, WaitMode};
use shipcast_pipeline::transport::status::PredictorStatus;
use shipcast_pipeline::transport::zenoh::{self as zn, JsonPublisher};
use shipcast_pipeline::transport::{monotonic_ns, shutdown, Names};
use shipcast_wire::payload::{Forecast, MotionSample};
use shipcast_wire::payload_json::{ForecastJsonEncoder, MotionJsonEncoder};
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub common: CommonArgs,
    /// Start from this model file (`shipcast train`) instead of training on simulated history.
    #[arg(long, value_name = "MODEL.json")]
    pub model: Option<PathBuf>,
    /// Spin on the subscriber instead of sleeping until woken (lowest latency, one core busy).
    #[arg(long)]
    pub busy_poll: bool,
    /// Past values per forecast (overrides the config).
    #[arg(long, value_name = "N")]
    pub order: Option<usize>,
    /// Retrain every S seconds of record time (0 = never; overrides the config).
    #[arg(long, value_name = "S")]
    pub retrain_every_s: Option<f64>,
    /// Pin the forecasting thread to this core once the transports are open; zenoh's threads
    /// and the retraining thread keep every core, so they never preempt it.
    #[arg(long, value_name = "CORE")]
    pub pin_core: Option<usize>,
    /// Publish when each motion sample was received on iceoryx2 `.../bench/receive`, for
    /// `shipcast bench latency` (off: no cost).
    #[arg(long)]
    pub bench_stamps: bool,
}

/// Busy poll spins this long on the subscriber, then yields the core once: threads that share
/// the core (zenoh's, on a two-core machine) then run within microseconds, not at the next
/// scheduler tick, while a sample still finds the loop spinning almost all of the time.
const SPIN_SLICE: Duration = Duration::from_micros(20);

/// Shortest wall-clock silence reported as stale.
const MIN_STALE_WALL: Duration = Duration::from_millis(100);

/// What the predictor runs with, every value checked: built from [`Args`] by
/// [`Config::try_from`] (the configuration file, the flags over it, then the checks).
#[derive(Debug, Clone)]
pub struct Config {
    pub pipeline: PipelineConfig,
    /// Wall-clock limit (`--duration`).
    pub limit: Option<Duration>,
    /// Core of the forecasting thread; a core id the CPU set can hold.
    pub pin_core: Option<usize>,
    pub bench_stamps: bool,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        // Validated once its own flags (--model, --order, ...) are applied, below.
        let mut pipeline = args.common.load_unvalidated()?;
        if let Some(core) = args.pin_core {
            checked(limits::core("--pin-core", core))?;
        }
        let q = &mut pipeline.predictor;
        if args.model.is_some() {
            q.model = args.model;
        }
        q.busy_poll |= args.busy_poll;
        if let Some(o) = args.order {
            q.order = o;
        }
        if let Some(r) = args.retrain_every_s {
            q.retrain_every_s = r;
        }
        pipeline.validate()?;
        Ok(Config {
            pipeline,
            limit: args.common.duration()?,
            pin_core: args.pin_core,
            bench_stamps: args.bench_stamps,
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        pipeline: config,
        limit,
        pin_core,
        bench_stamps,
    } = Config::try_from(args)?;
    let limit = shutdown::RunLimit::new(limit);
    let names = config.names()?;
    // Before the start-up fit: a second predictor under these names is refused at once.
    let _lock = shipcast_pipeline::transport::host_lock::HostLock::acquire(&names, "predictor")?;

    let models = shipcast_pipeline::engine::startup::initial_models(&config)?;
    if let Some(m) = &models {
        tracing::info!(
            models = %m.describe(),
            version = m.version,
            "predictor: start-up models ready (unverified on this sea: forecasts say no skill until verified)"
        );
    }
    let node = iox::node(&names, "predictor")?;
    let mode = if config.predictor.busy_poll {
        WaitMode::BusyPoll
    } else {
        WaitMode::Event
    };
    let motion = IoxSubscriber::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION, mode)?;
    let forecasts = IoxPublisher::<Forecast>::new(&node, &names.forecast(), Sizing::FORECAST)?;
    let stamps = match bench_stamps {
        true => Some(StampPublisher::new(&node, &names.bench_receive())?),
        false => None,
    };
    let session = zn::open(&config.zenoh.publisher_side())?;
    let forecast_json = JsonPublisher::new(&session, &names.forecast())?;
    let status_json = JsonPublisher::new(&session, &names.status("predictor"))?;
    let verification_json = JsonPublisher::new(&session, &names.verification())?;
    // The motion it forecasts from, for remote verifiers (the two-ship relative service):
    // nothing crosses the network unless someone subscribes.
    let motion_json = JsonPublisher::new(&session, &names.motion())?;
    let mut motion_encoder = MotionJsonEncoder::new();
    let _alive = zn::liveliness_token(&session, &Names::liveliness(&names.forecast()))?;
    tracing::info!(
        mode = ?mode,
        "predictor: {} -> {} (iceoryx2 and zenoh)",
        names.motion(),
        names.forecast()
    );

    let retrainer = Retrainer::background(config.predictor.clone())?;
    let mut engine = Engine::new(
        config.predictor.clone(),
        config.producer.rate_hz,
        models,
        retrainer,
    )?;
    let mut json = ForecastJsonEncoder::new();
    let mut producer_port = IoxFollowedPort::default();
    let mut connected = Vec::with_capacity(shipcast_wire::payload::limits::MAX_PUBLISHERS);
    let stale_after = stale_timeout(&config);
    let mut last_sample: Option<Instant> = None;
    let mut stale = false;
    let mut last_status = Instant::now();
    let mut last_verification = Instant::now();
    let mut last_log = Instant::now();
    let busy_poll = config.predictor.busy_poll;
    let nap = match busy_poll {
        true => SPIN_SLICE,
        false => (stale_after / 2).clamp(Duration::from_millis(1), Duration::from_millis(100)),
    };
    // Last, after every helper thread has been started with the full set of cores.
    if let Some(core) = pin_core {
        if pin_current("predictor forecasting thread", core).pinned {
            tracing::info!(core, "predictor: forecasting thread pinned");
        }
    }
    loop {
        if limit.reached() {
            break;
        }
        motion.wait(nap)?;
        let mut changed = false;
        let mut idle = true;
        while let Some((sample, origin)) = motion.receive_with_origin()? {
            idle = false;
            // Only the producer's port: a second publisher on the motion service (a stale
            // producer, an intruder) must not feed the forecasts.
            if let Err(e) =
                producer_port.admit_listing(origin, &mut connected, |c| motion.publishers(c))
            {
                engine.counters.received += 1;
                engine.counters.rejected_source += 1;
                if engine.counters.rejected_source == 1
                    || last_log.elapsed() >= Duration::from_secs(10)
                {
                    tracing::warn!(
                        rejected = engine.counters.rejected_source,
                        "predictor: motion sample rejected: {e}"
                    );
                }
                continue;
            }
            let received_ns = stamps.as_ref().map(|_| monotonic_ns());
            last_sample = Some(Instant::now());
            if stale {
                stale = false;
                changed = true;
                tracing::info!(
                    time_s = sample.time_s,
                    seq = sample.seq,
                    "predictor: motion resumed"
                );
            }
            let mut stages = PublishStages::default();
            let mut published = false;
            // Each step's end is stamped only for the benchmark (`--bench-stamps`).
            let mark = |at: &mut u64| {
                if stamps.is_some() {
                    *at = monotonic_ns();
                }
            };
            if let Some(forecast) = engine.push(&sample)? {
                stages.issued_ns = forecast.issued_stamp_ns;
                forecasts.send(forecast)?;
                mark(&mut stages.local_sent_ns);
                let encoded = json.encode_shared(forecast)?;
                mark(&mut stages.encoded_ns);
                forecast_json.put_shared(encoded)?;
                mark(&mut stages.zenoh_put_ns);
                engine.counters.published += 1;
                published = true;
            }
            // After the forecast, so the stamps never delay it.
            if let (Some(p), Some(received_ns)) = (&stamps, received_ns) {
                p.send(ReceiveStamp {
                    seq: sample.seq,
                    stamp_ns: sample.stamp_ns,
                    received_ns,
                    stages,
                })?;
            }
            // Last of all: the motion goes out as received, sound samples only (the engine
            // counts and skips the others: non-finite or beyond MAX_ABS_MOTION).
            if sample.is_sound() {
                motion_json.put_shared(motion_encoder.encode_shared(&sample)?)?;
            }
            // The models prepare the next forecast on a sample that completes none (three in
            // four at 8 -> 2 Hz), so the preparation never delays a forecast or its consumers.
            if !published {
                engine.prepare_next()?;
            }
        }
        if !stale && last_sample.is_some_and(|t| t.elapsed() >= stale_after) {
            stale = true;
            changed = true;
            tracing::warn!(
                last_time_s = engine.last_time_s(),
                "predictor: motion stale (no sample for {:.2} s of wall time, predictor.stale_after_s)",
                stale_after.as_secs_f64()
            );
        }
        engine.poll_models();
        // Also when no sample came during the wait (no decimation, or the input paused).
        if idle {
            engine.prepare_next()?;
        }
        if changed || last_status.elapsed() >= Duration::from_millis(500) {
            status_json.put_serialize(&status(&engine, stale))?;
            last_status = Instant::now();
        }
        if last_verification.elapsed() >= Duration::from_secs(1) {
            verification_json.put_serialize(&engine.verification())?;
            last_verification = Instant::now();
        }
        if last_log.elapsed() >= Duration::from_secs(10) {
            tracing::info!("predictor: {}", engine.counters.summary());
            last_log = Instant::now();
        }
        if busy_poll && idle {
            std::thread::yield_now();
        }
    }
    tracing::info!("predictor: stopped; {}", engine.counters.summary());
    Ok(())
}

fn status(engine: &Engine, stale: bool) -> PredictorStatus {
    PredictorStatus {
        counters: engine.counters,
        engine: engine.counts,
        stale,
        model_version: engine.model_version(),
        forecasts: engine.counters.published,
        history: engine.history_len(),
        order: engine.models().map_or(0, ModelSet::order),
        models: engine
            .models()
            .map_or_else(|| "none".into(), ModelSet::describe),
        last_time_s: engine.last_time_s(),
        delay_s: engine.delay_s(),
        refused_clients: shipcast_pipeline::transport::zenoh_refusals::refusals()
            .into_iter()
            .map(|(reason, n)| (reason.to_string(), n))
            .collect(),
    }
}

/// Wall time without samples after which the producer is reported stale: the configured
/// record time divided by the pacing speed (as fast as possible counts as 100x), but at least
/// `MIN_STALE_WALL`, so that scheduling hiccups on a busy machine are not reported as stale.
fn stale_timeout(config: &PipelineConfig) -> Duration {
    let speed = if config.producer.speed > 0.0 {
        config.producer.speed
    } else {
        100.0
    };
    // Capped: a pacing of 1e-20 (accepted, if absurd) made this overflow the conversion,
    // a panic at start-up instead of a producer that is "never" stale.
    let secs = (config.predictor.stale_after_s / speed).min(limits::MAX_SECONDS);
    Duration::from_secs_f64(secs).max(MIN_STALE_WALL)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(argv: &[&str]) -> String {
        crate::refused::<Args, Config>(argv)
    }

    /// Regression: `--speed 1e-20` panicked at start ("cannot convert float seconds to
    /// Duration") instead of running with a stale limit of at most a year.
    #[test]
    fn a_tiny_pacing_gives_a_capped_stale_limit_not_a_panic() {
        let c = crate::validated::<Args, Config>(&["--speed", "1e-20"]).unwrap();
        assert_eq!(
            stale_timeout(&c.pipeline),
            Duration::from_secs_f64(limits::MAX_SECONDS)
        );
        // As fast as possible counts as 100x: the default 2 s of record is 20 ms, raised to
        // the floor.
        let c = crate::validated::<Args, Config>(&["--speed", "0"]).unwrap();
        assert_eq!(c.pipeline.predictor.stale_after_s, 2.0);
        assert!(MIN_STALE_WALL > Duration::from_millis(20));
        assert_eq!(stale_timeout(&c.pipeline), MIN_STALE_WALL);
        // A pacing that leaves the limit above the floor: 2 s of record at 0.5x is 4 s.
        let c = crate::validated::<Args, Config>(&["--speed", "0.5"]).unwrap();
        assert!(MIN_STALE_WALL < Duration::from_secs(4));
        assert_eq!(stale_timeout(&c.pipeline), Duration::from_secs(4));
    }

    #[test]
    fn flags_override_the_configuration_and_are_checked_with_it() {
        let c = crate::validated::<Args, Config>(&[
            "--order",
            "60",
            "--busy-poll",
            "--retrain-every-s",
            "0",
            "--duration",
            "2",
        ])
        .unwrap();
        assert_eq!(c.pipeline.predictor.order, 60);
        assert!(c.pipeline.predictor.busy_poll);
        assert_eq!(c.pipeline.predictor.retrain_every_s, 0.0);
        assert_eq!(c.limit, Some(Duration::from_secs(2)));
        assert_eq!(
            refused(&["--pin-core", "5000"]),
            format!(
                "--pin-core 5000 is not a core id (at most {})",
                limits::MAX_CORES - 1
            )
        );
        assert_eq!(
            refused(&["--order", "0"]),
            format!(
                "config: predictor.order must be 1..={}, got 0",
                shipcast_pipeline::config::MAX_ORDER
            )
        );
        assert_eq!(
            refused(&["--retrain-every-s", "nan"]),
            format!(
                "config: predictor.retrain_every_s (0 = never) must be a number in [0, {}], got NaN",
                limits::MAX_SECONDS
            )
        );
        assert_eq!(
            refused(&["--duration", "0"]),
            format!(
                "config: --duration must be a number in (0, {}], got 0",
                limits::MAX_SECONDS
            )
        );
    }
}
