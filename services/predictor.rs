//! `shipcast predictor`: subscribes to motion over iceoryx2 (event wake-up, or `--busy-poll`),
//! decimates 8 -> 2 Hz with the evaluation's filter, forecasts all six DOF at every new 2 Hz
//! value, and publishes the Forecast over iceoryx2 and as JSON over zenoh. A background thread
//! retrains from recent live data and hands over new models without pausing the forecasts.

mod history;
mod models;
mod retrain;

use anyhow::Context;
use history::{Ingest, NewValue};
use models::ModelSet;
use serde::Serialize;
use shipcast::bench::pinning::pin_current;
use shipcast::bench::stamps::{PublishStages, ReceiveStamp, StampPublisher};
use shipcast::config::{CommonArgs, PipelineConfig};
use shipcast::payload::{Forecast, MotionSample, MAX_STEPS, NUM_DOF};
use shipcast::payload_json::ForecastJsonEncoder;
use shipcast::predict::Predictor;
use shipcast::signal::decimate;
use shipcast::sim::{ShipMotion, SimConfig};
use shipcast::transport::iox::{self, IoxPublisher, IoxSubscriber, Sizing, WaitMode};
use shipcast::transport::zenoh::{self as zn, JsonPublisher};
use shipcast::transport::{monotonic_ns, shutdown, Counters, Names};
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

/// Longest run of lost or rejected input samples bridged by holding the last value (1 s at
/// 8 Hz); longer gaps restart the history.
const MAX_FILL: u64 = 8;

/// Busy poll spins this long on the subscriber, then yields the core once: threads that share
/// the core (zenoh's, on a two-core machine) then run within microseconds, not at the next
/// scheduler tick, while a sample still finds the loop spinning almost all of the time.
const SPIN_SLICE: Duration = Duration::from_micros(20);

/// Shortest wall-clock silence reported as stale.
const MIN_STALE_WALL: Duration = Duration::from_millis(100);

/// What the predictor reports about itself on zenoh `.../status/predictor` (the live view of
/// `shipcast run` shows it).
#[derive(Debug, Serialize)]
struct Status {
    counters: Counters,
    stale: bool,
    model_version: u32,
    forecasts: u64,
    history: usize,
    order: usize,
    last_time_s: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = args.common.load()?;
    let q = &mut config.predictor;
    if args.model.is_some() {
        q.model = args.model.clone();
    }
    q.busy_poll |= args.busy_poll;
    if let Some(o) = args.order {
        q.order = o;
    }
    if let Some(r) = args.retrain_every_s {
        q.retrain_every_s = r;
    }
    config.validate()?;
    let limit = shutdown::RunLimit::new(args.common.duration()?);
    let factor = config.decimation_factor()?;
    let names = config.names()?;

    let models = initial_models(&config)?;
    let (order, horizon) = (models.order(), models.horizon());
    // Retraining fits what is running: a model file's method, order and horizon win over the
    // configured ones.
    let q = &mut config.predictor;
    if (q.method, q.order, q.horizon) != (models.predictors[0].method(), order, horizon) {
        tracing::info!(
            "predictor: the model file's {} order {order} horizon {horizon} replaces the configured {} order {} horizon {}",
            models.predictors[0].method(),
            q.method,
            q.order,
            q.horizon
        );
        q.method = models.predictors[0].method();
        q.order = order;
        q.horizon = horizon;
        if let Err(e) = config.validate() {
            tracing::warn!("predictor: retraining disabled: {e}");
            config.predictor.retrain_every_s = 0.0;
        }
    }
    tracing::info!(
        method = %models.predictors[0].method(),
        order,
        horizon,
        version = models.version,
        sigma_at_horizon = %sigma_summary(&models, horizon),
        "predictor: models ready"
    );

    let node = iox::node(&names, "predictor")?;
    let mode = if config.predictor.busy_poll {
        WaitMode::BusyPoll
    } else {
        WaitMode::Event
    };
    let motion = IoxSubscriber::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION, mode)?;
    let forecasts = IoxPublisher::<Forecast>::new(&node, &names.forecast(), Sizing::FORECAST)?;
    let stamps = match args.bench_stamps {
        true => Some(StampPublisher::new(&node, &names.bench_receive())?),
        false => None,
    };
    let session = zn::open(&config.zenoh.publisher_side())?;
    let forecast_json = JsonPublisher::new(&session, &names.forecast())?;
    let status_json = JsonPublisher::new(&session, &names.status("predictor"))?;
    let _alive = zn::liveliness_token(&session, &Names::liveliness(&names.forecast()))?;
    tracing::info!(
        mode = ?mode,
        "predictor: {} -> {} (iceoryx2 and zenoh)",
        names.motion(),
        names.forecast()
    );

    let capacity = config.predictor.retrain_window.max(order + horizon);
    let ingest = Ingest::new(factor, config.producer.rate_hz, capacity, MAX_FILL)?;
    let retrainer = retrain::Retrainer::spawn(config.predictor.clone())?;
    let mut service = Service {
        config: &config,
        ingest,
        models,
        retrainer,
        forecast: Box::new(Forecast::default()),
        out: [0.0; MAX_STEPS],
        json: ForecastJsonEncoder::new(),
        counters: Counters::default(),
        values_since_retrain: 0,
        values_seen: 0,
        prepared_for: None,
        last_time_s: f64::NAN,
    };
    let stale_after = stale_timeout(&config);
    let mut last_sample: Option<Instant> = None;
    let mut stale = false;
    let mut last_status = Instant::now();
    let mut last_log = Instant::now();
    let busy_poll = config.predictor.busy_poll;
    let nap = match busy_poll {
        true => SPIN_SLICE,
        false => (stale_after / 2).clamp(Duration::from_millis(1), Duration::from_millis(100)),
    };
    // Last, after every helper thread has been started with the full set of cores.
    if let Some(core) = args.pin_core {
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
        while let Some(sample) = motion.receive()? {
            idle = false;
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
            if let Some(v) = service.ingest.push(&sample, &mut service.counters) {
                if service.on_new_value(v)? {
                    stages.issued_ns = service.forecast.issued_stamp_ns;
                    forecasts.send(&service.forecast)?;
                    mark(&mut stages.local_sent_ns);
                    let json = service.json.encode(&service.forecast);
                    mark(&mut stages.encoded_ns);
                    forecast_json.put(json)?;
                    mark(&mut stages.zenoh_put_ns);
                    service.counters.published += 1;
                    published = true;
                }
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
            // The models prepare the next forecast on a sample that completes none (three in
            // four at 8 -> 2 Hz), so the preparation never delays a forecast or its consumers.
            if !published {
                service.prepare_next()?;
            }
        }
        if !stale && last_sample.is_some_and(|t| t.elapsed() >= stale_after) {
            stale = true;
            changed = true;
            tracing::warn!(
                last_time_s = service.last_time_s,
                "predictor: motion stale (no sample for {:.2} s of wall time = {} s of record time)",
                stale_after.as_secs_f64(),
                config.predictor.stale_after_s
            );
        }
        service.swap_models();
        // Also when no sample came during the wait (no decimation, or the input paused).
        if idle {
            service.prepare_next()?;
        }
        if changed || last_status.elapsed() >= Duration::from_millis(500) {
            status_json.put_serialize(&service.status(stale))?;
            last_status = Instant::now();
        }
        if last_log.elapsed() >= Duration::from_secs(10) {
            tracing::info!("predictor: {}", service.counters.summary());
            last_log = Instant::now();
        }
        if busy_poll && idle {
            std::thread::yield_now();
        }
    }
    tracing::info!("predictor: stopped; {}", service.counters.summary());
    Ok(())
}

/// sigma of every DOF at the last step, for the logs.
fn sigma_summary(models: &ModelSet, horizon: usize) -> String {
    shipcast::Dof::ALL
        .iter()
        .map(|d| format!("{} {:.3}", d.name(), models.sigma[d.index()][horizon - 1]))
        .collect::<Vec<_>>()
        .join(", ")
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
    Duration::from_secs_f64(config.predictor.stale_after_s / speed).max(MIN_STALE_WALL)
}

/// Models to start with: the model file, or fitted on simulated history of the configured sea
/// (another realisation than the producer's: seed + 1), so forecasts begin as soon as the
/// live history holds `order` values.
fn initial_models(config: &PipelineConfig) -> anyhow::Result<ModelSet> {
    let q = &config.predictor;
    if let Some(path) = &q.model {
        let set = models::load(path, q.sample_rate_hz)?;
        if set.horizon() > MAX_STEPS {
            anyhow::bail!("model horizon {} exceeds {MAX_STEPS}", set.horizon());
        }
        return Ok(set);
    }
    let p = &config.producer;
    let mut sim = SimConfig::scenario(p.scenario);
    sim.seed = p.seed.wrapping_add(1);
    let motion = ShipMotion::new(&sim)?;
    let n = (q.warmup_s * p.rate_hz).ceil() as usize;
    let mut raw: Vec<Vec<f64>> = (0..NUM_DOF).map(|_| Vec::with_capacity(n)).collect();
    for point in motion.stream(p.rate_hz, 0.0)?.take(n) {
        for (d, series) in raw.iter_mut().enumerate() {
            series.push(point.dof[d]);
        }
    }
    let factor = config.decimation_factor()?;
    let series = raw
        .iter()
        .map(|x| decimate(x, factor))
        .collect::<Result<Vec<_>, _>>()?;
    let t = Instant::now();
    let set = models::fit(&series, q, 1).context("training on simulated history")?;
    tracing::info!(
        values = series[0].len(),
        seconds = t.elapsed().as_secs_f64(),
        "predictor: trained on simulated history"
    );
    Ok(set)
}

/// The forecasting state, owned by the service thread.
struct Service<'a> {
    config: &'a PipelineConfig,
    ingest: Ingest,
    models: ModelSet,
    retrainer: retrain::Retrainer,
    /// Reused for every forecast (6 KB; boxed to keep it off the stack frame).
    forecast: Box<Forecast>,
    out: [f64; MAX_STEPS],
    /// Reused for every forecast; re-encodes sigma only when the model changes.
    json: ForecastJsonEncoder,
    counters: Counters,
    values_since_retrain: usize,
    /// Decimated values so far, and the (values, model version) the models last prepared for.
    values_seen: u64,
    prepared_for: Option<(u64, u32)>,
    last_time_s: f64,
}

impl Service<'_> {
    /// A new decimated value arrived: learn online, forecast if the history is long enough,
    /// and schedule retraining. Returns true if `self.forecast` holds a new forecast.
    fn on_new_value(&mut self, v: NewValue) -> anyhow::Result<bool> {
        self.last_time_s = v.time_s;
        self.values_seen += 1;
        let (order, horizon) = (self.models.order(), self.models.horizon());
        self.values_since_retrain += 1;
        self.maybe_retrain();
        for (d, p) in self.models.predictors.iter_mut().enumerate() {
            if p.is_online() {
                if let Some(recent) = self.ingest.last(d, order + horizon) {
                    p.update(recent)?;
                }
            }
        }
        let f = &mut *self.forecast;
        for (d, p) in self.models.predictors.iter_mut().enumerate() {
            let Some(past) = self.ingest.last(d, order) else {
                return Ok(false);
            };
            p.forecast(past, &mut self.out[..horizon])?;
            for (m, x) in f.mean[d].iter_mut().zip(&self.out[..horizon]) {
                *m = *x as f32;
            }
        }
        f.sigma = self.models.sigma;
        f.seq = self.counters.published;
        f.source_seq = v.source_seq;
        f.source_stamp_ns = v.source_stamp_ns;
        f.time_s = v.time_s;
        f.dt_s = 1.0 / self.config.predictor.sample_rate_hz;
        f.steps = horizon as u32;
        f.model_version = self.models.version;
        f.issued_stamp_ns = monotonic_ns();
        Ok(true)
    }

    /// Hand the recent history to the retraining thread every `retrain_every_s` of record time.
    fn maybe_retrain(&mut self) {
        let q = &self.config.predictor;
        if q.retrain_every_s <= 0.0 {
            return;
        }
        let due = (q.retrain_every_s * q.sample_rate_hz).round() as usize;
        if self.values_since_retrain < due.max(1) {
            return;
        }
        let Some(series) = (0..NUM_DOF)
            .map(|d| self.ingest.last(d, q.retrain_window).map(<[f64]>::to_vec))
            .collect::<Option<Vec<_>>>()
        else {
            return;
        };
        self.values_since_retrain = 0;
        self.retrainer.request(series, self.models.version + 1);
    }

    /// Let every model do ahead the part of the next forecast that the history so far
    /// determines (`Predictor::prepare`); once per new value and model.
    fn prepare_next(&mut self) -> anyhow::Result<()> {
        let now = (self.values_seen, self.models.version);
        if self.prepared_for == Some(now) {
            return Ok(());
        }
        let order = self.models.order();
        for (d, p) in self.models.predictors.iter_mut().enumerate() {
            if let Some(known) = self.ingest.last(d, order) {
                p.prepare(known)?;
            }
        }
        self.prepared_for = Some(now);
        Ok(())
    }

    /// Take a freshly trained model set if one is ready.
    fn swap_models(&mut self) {
        if let Some(set) = self.retrainer.take() {
            if set.order() == self.models.order() && set.horizon() == self.models.horizon() {
                tracing::info!(
                    version = set.version,
                    sigma_at_horizon = %sigma_summary(&set, set.horizon()),
                    "predictor: retrained model in use"
                );
                self.models = set;
            } else {
                tracing::warn!("predictor: retrained model has another order or horizon: ignored");
            }
        }
    }

    fn status(&self, stale: bool) -> Status {
        Status {
            counters: self.counters,
            stale,
            model_version: self.models.version,
            forecasts: self.counters.published,
            history: self.ingest.len(),
            order: self.models.order(),
            last_time_s: self.last_time_s,
        }
    }
}
