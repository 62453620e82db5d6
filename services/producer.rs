//! `shipcast producer`: publishes MotionSample over iceoryx2 from the simulator or a motion CSV,
//! paced in real time, faster by `--speed F`, or as fast as possible (`--speed 0`).

use crate::checked;
use crate::common_args::CommonArgs;
use anyhow::Context;
use shipcast_pipeline::config::{PipelineConfig, ProducerConfig};
use shipcast_pipeline::limits;
use shipcast_pipeline::pacing;
use shipcast_pipeline::transport::iox::{self, IoxPublisher, Sizing};
use shipcast_pipeline::transport::{monotonic_ns, shutdown};
use shipcast_series::motion_csv::MotionData;
use shipcast_sim::{MotionStream, Scenario, ShipMotion, SimConfig};
use shipcast_wire::payload::MotionSample;
use shipcast_wire::Dof;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub common: CommonArgs,
    /// Replay this motion CSV instead of simulating.
    #[arg(long, value_name = "FILE.csv")]
    pub input: Option<PathBuf>,
    /// Simulated sea state.
    #[arg(long)]
    pub scenario: Option<Scenario>,
    /// Seed of the simulated sea.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Simulator sample rate [Hz] (producer.rate_hz). The predictor takes its input for the
    /// producer.rate_hz of its own configuration: give both the same (a predictor that finds
    /// the motion faster restarts its history and says so).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Stop after this much record time [s].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub record_s: Option<f64>,
    /// Publish the first S seconds of record at the backfill speed (see the config).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub backfill_s: Option<f64>,
    /// Wait up to S seconds for a subscriber before publishing the first sample.
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub wait_subscriber_s: f64,
    /// Fault injection (tests): every N-th sample carries a NaN heave.
    #[arg(long, value_name = "N")]
    pub fault_nan_every: Option<u64>,
    /// Fault injection (tests): every N-th sample is followed by a repeat of the one before it.
    #[arg(long, value_name = "N")]
    pub fault_reorder_every: Option<u64>,
}

/// Where motion comes from: one (record time, six DOF) per call, `None` at the end.
trait MotionSource {
    fn next_motion(&mut self) -> Option<(f64, [f64; 6])>;
}

/// The simulator, endless.
struct SimSource<'a> {
    stream: MotionStream<&'a ShipMotion>,
}

impl MotionSource for SimSource<'_> {
    fn next_motion(&mut self) -> Option<(f64, [f64; 6])> {
        self.stream.next().map(|p| (p.time_s, p.dof))
    }
}

/// A motion CSV, row by row. DOF columns missing from the file are sent as 0.
struct CsvSource {
    data: MotionData,
    columns: [Option<usize>; 6],
    row: usize,
}

impl CsvSource {
    /// The record at `path`, which must be sampled at `rate_hz`: the predictor takes the
    /// producer's configured rate for the rate of what it receives, so a record at another
    /// rate would be decimated wrongly and its forecasts' steps would not be `dt_s` apart.
    fn open(path: &std::path::Path, rate_hz: f64, forecast_hz: f64) -> anyhow::Result<Self> {
        let data =
            MotionData::read_path(path).with_context(|| format!("reading {}", path.display()))?;
        // The rate as replay and eval read it (regular steps, within the same tolerance of a
        // multiple of the forecast rate); the producer took anything within 1 % of its rate.
        let rate = shipcast_pipeline::engine::replay::record_rate(&data.time, forecast_hz)
            .with_context(|| format!("{}: sample rate", path.display()))?;
        if ((rate - rate_hz) / rate_hz).abs() > shipcast_series::RATE_TOLERANCE {
            anyhow::bail!(
                "{} is sampled at {rate:.4} Hz but producer.rate_hz is {rate_hz} Hz: set producer.rate_hz to the record's rate (a multiple of the predictor's sample_rate_hz)",
                path.display()
            );
        }
        let columns = Dof::ALL.map(|d| data.columns.iter().position(|c| c.name == d.csv_column()));
        let missing: Vec<&str> = Dof::ALL
            .iter()
            .zip(&columns)
            .filter(|(_, c)| c.is_none())
            .map(|(d, _)| d.csv_column())
            .collect();
        if missing.len() == 6 {
            data.motion_dofs()
                .with_context(|| path.display().to_string())?;
        }
        if !missing.is_empty() {
            tracing::warn!("{}: columns {missing:?} missing, sent as 0", path.display());
        }
        Ok(Self {
            data,
            columns,
            row: 0,
        })
    }
}

impl MotionSource for CsvSource {
    fn next_motion(&mut self) -> Option<(f64, [f64; 6])> {
        let t = *self.data.time.get(self.row)?;
        let dof = self
            .columns
            .map(|c| c.map_or(0.0, |i| self.data.columns[i].values[self.row]));
        self.row += 1;
        Some((t, dof))
    }
}

/// Wall-clock schedule of record times: `backfill_s` of record at `backfill_speed`, then
/// `speed`; a speed of 0 means no pacing.
struct RecordSchedule {
    start: Instant,
    t0: Option<f64>,
    backfill_s: f64,
    backfill_speed: f64,
    speed: f64,
}

impl RecordSchedule {
    fn new(config: &ProducerConfig) -> Self {
        Self {
            start: Instant::now(),
            t0: None,
            backfill_s: config.backfill_s,
            backfill_speed: config.backfill_speed,
            speed: config.speed,
        }
    }

    /// Wall-clock offset at which the sample of record time `t` is due, None if unpaced.
    fn due(&mut self, t: f64) -> Option<Duration> {
        let elapsed = t - *self.t0.get_or_insert(t);
        let fast = elapsed.min(self.backfill_s);
        let slow = elapsed - fast;
        let wall = |record: f64, speed: f64| if speed > 0.0 { record / speed } else { 0.0 };
        if self.speed <= 0.0 && slow > 0.0 {
            return None;
        }
        // A record whose clock jumps by ages (a CSV's times are outside input) waits "for
        // ever" (until stopped) rather than overflowing the conversion.
        let secs = wall(fast, self.backfill_speed) + wall(slow, self.speed);
        Some(Duration::try_from_secs_f64(secs).unwrap_or(Duration::MAX))
    }

    /// Sleep until the sample at record time `t` is due (in short naps, to notice a stop).
    fn wait(&mut self, t: f64) {
        let Some(due) = self.due(t) else { return };
        pacing::sleep_until(
            self.start.checked_add(due),
            Duration::from_millis(100),
            shutdown::stop_requested,
        );
    }
}

/// What the producer publishes, every value checked: built from [`Args`] by
/// [`Config::try_from`] (the configuration file, the flags over it, then the checks).
#[derive(Debug, Clone)]
pub struct Config {
    pub pipeline: PipelineConfig,
    /// Wall-clock limit (`--duration`).
    pub limit: Option<Duration>,
    pub wait_subscriber: Duration,
    faults: Faults,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let mut pipeline = args.common.load()?;
        let p = &mut pipeline.producer;
        if let Some(i) = args.input {
            p.input = Some(i);
        }
        if let Some(s) = args.scenario {
            p.scenario = s;
        }
        if let Some(s) = args.seed {
            p.seed = s;
        }
        if let Some(r) = args.rate {
            p.rate_hz = r;
        }
        if let Some(r) = args.record_s {
            p.record_s = Some(r);
        }
        if let Some(b) = args.backfill_s {
            p.backfill_s = b;
        }
        pipeline.validate()?;
        // Regression (review): a rate no predictor can decimate (3 Hz for 2 Hz forecasts) was
        // taken, and the predictor then read every sample for its own rate.
        pipeline
            .decimation_factor()
            .map_err(|e| anyhow::anyhow!("producer.rate_hz: {e}"))?;
        let every = |name: &str, n: Option<u64>| {
            n.map(|n| checked(limits::count(name, n, 1, u64::MAX)))
                .transpose()
        };
        Ok(Config {
            pipeline,
            limit: args.common.duration()?,
            wait_subscriber: checked(limits::seconds_or_zero(
                "--wait-subscriber-s",
                args.wait_subscriber_s,
            ))?,
            faults: Faults {
                nan_every: every("--fault-nan-every", args.fault_nan_every)?,
                reorder_every: every("--fault-reorder-every", args.fault_reorder_every)?,
            },
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        pipeline: config,
        limit,
        wait_subscriber,
        faults,
    } = Config::try_from(args)?;
    let limit = shutdown::RunLimit::new(limit);
    let p = config.producer.clone();
    // A record that cannot be sent is refused before anything waits for a subscriber.
    let csv = p
        .input
        .as_ref()
        .map(|path| {
            CsvSource::open(path, p.rate_hz, config.predictor.sample_rate_hz)
                .map(|source| (path, source))
        })
        .transpose()?;
    let names = config.names()?;
    // One producer per vessel and instance on a host: a second one under these names would
    // only disturb the first (review: a second deck blanked the first's advisory, a second
    // producer's samples were all refused).
    let _lock = shipcast_pipeline::transport::host_lock::HostLock::acquire(&names, "producer")?;
    let node = iox::node(&names, "producer")?;
    let publisher = IoxPublisher::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION)?;

    let waited = pacing::poll_until(wait_subscriber, Duration::from_millis(10), || {
        (publisher.subscribers() > 0 || shutdown::stop_requested()).then_some(())
    });
    if waited.is_some() && shutdown::stop_requested() {
        return Ok(());
    }

    match csv {
        Some((path, mut source)) => {
            tracing::info!(input = %path.display(), rows = source.data.len(), "producer: replaying CSV on {}", names.motion());
            publish_all(&mut source, &publisher, &p, limit, faults)
        }
        None => {
            let mut sim = SimConfig::scenario(p.scenario);
            sim.seed = p.seed;
            let motion = ShipMotion::at_station(&sim, p.station)?;
            let mut source = SimSource {
                stream: motion.stream(p.rate_hz, 0.0)?,
            };
            tracing::info!(scenario = ?p.scenario, seed = p.seed, station = ?p.station, rate_hz = p.rate_hz, speed = p.speed, "producer: simulating on {}", names.motion());
            publish_all(&mut source, &publisher, &p, limit, faults)
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Faults {
    nan_every: Option<u64>,
    reorder_every: Option<u64>,
}

fn publish_all(
    source: &mut dyn MotionSource,
    publisher: &IoxPublisher<MotionSample>,
    config: &ProducerConfig,
    limit: shutdown::RunLimit,
    faults: Faults,
) -> anyhow::Result<()> {
    let mut pacer = RecordSchedule::new(config);
    // Messages sent, including fault-injected repeats.
    let mut published = 0u64;
    let mut last_log = Instant::now();
    let mut previous: Option<MotionSample> = None;
    let mut seq = 0u64;
    let mut t_first = None;
    while let Some((time_s, dof)) = source.next_motion() {
        let t0 = *t_first.get_or_insert(time_s);
        if config.record_s.is_some_and(|r| time_s - t0 >= r) {
            break;
        }
        if limit.reached() {
            break;
        }
        pacer.wait(time_s);
        let mut sample = MotionSample {
            seq,
            stamp_ns: monotonic_ns(),
            time_s,
            dof,
        };
        if faults
            .nan_every
            .is_some_and(|n| seq > 0 && seq.is_multiple_of(n))
        {
            sample.dof[Dof::Heave.index()] = f64::NAN;
        }
        publisher.send(&sample)?;
        published += 1;
        if let Some(prev) = previous.filter(|_| {
            faults
                .reorder_every
                .is_some_and(|n| seq > 0 && seq.is_multiple_of(n))
        }) {
            // A stale sample arriving late: same seq and time as one already sent.
            publisher.send(&prev)?;
            published += 1;
        }
        previous = Some(sample);
        seq += 1;
        if last_log.elapsed() >= Duration::from_secs(10) {
            tracing::info!("producer: t={time_s:.1}s published {published}");
            last_log = Instant::now();
        }
    }
    tracing::info!("producer: stopped after {seq} samples; published {published}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pacer(backfill_s: f64, speed: f64) -> RecordSchedule {
        RecordSchedule::new(&ProducerConfig {
            backfill_s,
            backfill_speed: 50.0,
            speed,
            ..ProducerConfig::default()
        })
    }

    #[test]
    fn pacing_runs_the_backfill_fast_then_at_speed() {
        let mut p = pacer(100.0, 2.0);
        // Times count from the first sample, whatever the record's clock says.
        assert_eq!(p.due(1000.0), Some(Duration::ZERO));
        assert_eq!(p.due(1050.0), Some(Duration::from_secs(1)));
        // 100 s of backfill at 50x = 2 s, then 20 s of record at 2x = 10 s.
        assert_eq!(p.due(1120.0), Some(Duration::from_secs(12)));
        // As fast as possible after the backfill: no pacing at all.
        let mut p = pacer(100.0, 0.0);
        assert_eq!(p.due(0.0), Some(Duration::ZERO));
        assert_eq!(p.due(150.0), None);
    }
}

#[cfg(test)]
mod validation_tests {
    use super::*;

    fn refused(argv: &[&str]) -> String {
        crate::refused::<Args, Config>(argv)
    }

    #[test]
    fn flags_override_the_configuration_and_are_checked_with_it() {
        let c = crate::validated::<Args, Config>(&[
            "--seed",
            "3",
            "--record-s",
            "10",
            "--wait-subscriber-s",
            "1.5",
            "--fault-nan-every",
            "7",
        ])
        .unwrap();
        assert_eq!(
            (c.pipeline.producer.seed, c.pipeline.producer.record_s),
            (3, Some(10.0))
        );
        assert_eq!(c.wait_subscriber, Duration::from_millis(1500));
        assert_eq!(
            (c.faults.nan_every, c.faults.reorder_every),
            (Some(7), None)
        );
        assert_eq!(
            refused(&["--rate", "1e300"]),
            format!(
                "config: producer.rate_hz must be a number in [{}, {}], got 1e300",
                limits::MIN_RATE_HZ,
                shipcast_pipeline::config::MAX_PRODUCER_RATE_HZ
            )
        );
        // Regression (review): a rate the predictor cannot decimate was taken.
        let e = refused(&["--rate", "3"]);
        assert!(
            e.starts_with("producer.rate_hz: ") && e.contains("not an integer multiple"),
            "{e}"
        );
        assert_eq!(
            refused(&["--wait-subscriber-s", "nan"]),
            format!(
                "--wait-subscriber-s must be a number in [0, {}], got NaN",
                limits::MAX_SECONDS
            )
        );
        assert_eq!(
            refused(&["--fault-reorder-every", "0"]),
            format!("--fault-reorder-every must be 1..={}, got 0", u64::MAX)
        );
    }
}
