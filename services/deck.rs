//! `shipcast deck`: the co-located helideck consumer. Reads forecasts over iceoryx2, prints the
//! landing advisory (windows where roll, pitch and deck vertical velocity stay within limits,
//! with confidence) and publishes it as JSON on zenoh `.../advisory/deck`. Only forecasts from
//! the publisher it follows, with increasing seq and sound content, are used
//! (`IoxForecastGate`); rejections are counted, logged on one line each, and published with
//! the deck's counters on `.../status/deck`.
//!
//! The decision also goes to local readers over iceoryx2 on `.../advisory/deck`
//! (`DecisionSample`). The deck also reads the motion samples: once a forecast's horizon has
//! happened, the decider verifies it against them, and its window probabilities come from the
//! errors that really happened, as `shipcast replay`'s do from the record (docs/decisions.md).
//! Motion samples count only from the port the deck follows (`IoxFollowedPort`, as for the
//! forecasts); others are counted (`motion_rejected` in the status) and logged.

use crate::common_args::CommonArgs;
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::decision::outcomes::{OutcomeCounts, Outcomes};
use shipcast_pipeline::decision::statements_file::{self, StatementsKeeper};
use shipcast_pipeline::decision::withdrawn_sample;
use shipcast_pipeline::deck::DeckAdvisor;
use shipcast_pipeline::limits as value_limits;
use shipcast_pipeline::transport::clock::monotonic_ns;
use shipcast_pipeline::transport::counters::SeqCheck;
use shipcast_pipeline::transport::forecast_check::{
    IoxFollowedPort, IoxForecastGate, RejectionCounts,
};
use shipcast_pipeline::transport::iox::{self, IoxPublisher, IoxSubscriber, Sizing, WaitMode};
use shipcast_pipeline::transport::silence::{ForecastSilence, NO_FORECAST_AFTER};
use shipcast_pipeline::transport::zenoh::{self as zn, JsonPublisher};
use shipcast_pipeline::transport::{shutdown, Names};
use shipcast_wire::payload::{limits, DecisionSample, Forecast, MotionSample};
use std::io::Write;
use std::time::{Duration, Instant};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub common: CommonArgs,
    /// Print every N-th advisory (all are published).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub print_every: u64,
    /// Do not publish the advisory on zenoh.
    #[arg(long)]
    pub no_publish: bool,
}

/// What the deck runs with, every value checked: built from [`Args`] by [`Config::try_from`]
/// (the configuration file, the flags over it, then the checks).
#[derive(Debug, Clone)]
pub struct Config {
    pub pipeline: PipelineConfig,
    /// Wall-clock limit (`--duration`).
    pub limit: Option<Duration>,
    /// Print every N-th advisory, N >= 1.
    pub print_every: u64,
    /// Publish the advisory on zenoh (`[deck] publish` and not `--no-publish`).
    pub publish: bool,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let pipeline = args.common.load()?;
        crate::checked(pipeline.check_mot_fits_horizon("deck.mot_s", pipeline.deck.mot_s))?;
        let print_every = crate::checked(value_limits::count(
            "--print-every",
            args.print_every,
            1,
            u64::MAX,
        ))?;
        Ok(Config {
            publish: pipeline.deck.publish && !args.no_publish,
            pipeline,
            limit: args.common.duration()?,
            print_every,
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        pipeline: config,
        limit,
        print_every,
        publish,
    } = Config::try_from(args)?;
    let limit = shutdown::RunLimit::new(limit);
    let names = config.names()?;
    // One deck per vessel and instance on a host: a second one under these names would
    // only disturb the first (review: a second deck blanked the first's advisory, a second
    // producer's samples were all refused).
    let _lock = shipcast_pipeline::transport::host_lock::HostLock::acquire(&names, "deck")?;
    let node = iox::node(&names, "deck")?;
    let forecasts = IoxSubscriber::<Forecast>::new(
        &node,
        &names.forecast(),
        Sizing::FORECAST,
        WaitMode::Event,
    )?;
    let motion = IoxSubscriber::<MotionSample>::new(
        &node,
        &names.motion(),
        Sizing::MOTION,
        WaitMode::Event,
    )?;
    let local =
        IoxPublisher::<DecisionSample>::new(&node, &names.advisory("deck"), Sizing::FORECAST)?;
    let horizon_s = config.predictor.horizon as f64 / config.predictor.sample_rate_hz;
    let mut outcomes = Outcomes::new(
        config.producer.rate_hz,
        horizon_s,
        config.predictor.sample_rate_hz,
        config.deck.error_correlation,
    );
    let session;
    let publisher = if publish {
        let Some(opened) = zn::open_until(&config.zenoh.consumer_side(), &limit)? else {
            tracing::info!("deck: stopped before the zenoh session opened");
            return Ok(());
        };
        session = opened;
        let key = names.advisory("deck");
        let token = zn::liveliness_token(&session, &Names::liveliness(&key))?;
        let status = JsonPublisher::new(&session, &names.status("deck"))?;
        Some((JsonPublisher::new(&session, &key)?, status, token))
    } else {
        None
    };
    let mut advisor = DeckAdvisor::live(&config.deck);
    let dt_s = 1.0 / config.predictor.sample_rate_hz;
    // A file that cannot be kept where asked stops the deck now, not its statements at the
    // end of the watch; an existing file that cannot be read is left alone (below).
    if let Some(path) = config.deck.statements_file.as_deref() {
        statements_file::check_writable(path).map_err(|e| anyhow::anyhow!("deck: {e:#}"))?;
    }
    let mut statements =
        config.deck.statements_file.as_deref().and_then(
            |path| match StatementsKeeper::open_checked(path, dt_s, advisor.decider_mut()) {
                Ok(keeper) => Some(keeper),
                Err(e) => {
                    tracing::error!("deck: {e:#}; running without it, and it is left as it is");
                    None
                }
            },
        );
    let mut last_save = Instant::now();
    let mut gate = IoxForecastGate::new(dt_s);
    let mut motion_port = IoxFollowedPort::default();
    let mut motion_rejected = 0u64;
    let mut connected = Vec::with_capacity(limits::MAX_PUBLISHERS);
    tracing::info!(
        point_m = ?config.deck.point_m,
        "deck: advising from {}",
        names.forecast()
    );
    let mut silence = ForecastSilence::new("deck", NO_FORECAST_AFTER, Instant::now());
    // (seq, time_s) of the last forecast decided on, for the NO-GO that withdraws it.
    let mut last_decided: Option<(u64, f64)> = None;
    let mut last_status = Instant::now();
    let mut count = 0u64;
    let stdout = std::io::stdout();
    // The loop runs inside a closure so that however it ends (an error from a port or the
    // zenoh session included) the statements verified so far are written before the error
    // is returned: they may be hours of calls.
    let advised = with_statements_saved(&mut statements, &mut advisor, |advisor, statements| {
        while !limit.reached() {
            forecasts.wait(Duration::from_millis(100))?;
            // What happened: forecasts whose horizon is now past teach the decider.
            take_motion(
                &motion,
                &mut motion_port,
                &mut connected,
                &mut outcomes,
                &mut motion_rejected,
            )?;
            outcomes.verify_ready(advisor.decider_mut());
            if last_save.elapsed() >= SAVE_STATEMENTS_EVERY {
                save_statements(statements.as_mut(), advisor);
                last_save = Instant::now();
            }
            if let Some((_, status, _)) = &publisher {
                if last_status.elapsed() >= STATUS_EVERY {
                    let now = DeckStatus::new(count, &gate, outcomes.counts, motion_rejected);
                    status.put_serialize(&now)?;
                    last_status = Instant::now();
                }
            }
            let newest = newest_accepted(&forecasts, &mut gate, &mut connected)?;
            let Some(forecast) = newest else {
                if let (true, Some((seq, time_s))) = (silence.check(Instant::now()), last_decided) {
                    // No forecast for NO_FORECAST_AFTER: a NO-GO replaces the last decision
                    // for local readers, which keep the newest one (the display and zenoh
                    // readers judge by the advisory's age).
                    local.send(&withdrawn_sample(
                        config.deck.mot_s,
                        config.deck.go_probability,
                        seq,
                        time_s,
                        monotonic_ns(),
                    ))?;
                }
                continue;
            };
            last_decided = Some((forecast.seq, forecast.time_s));
            silence.heard(Instant::now());
            // The motion at the forecast's time_s: the deck velocity's first step is then a
            // central difference, like the outcome it is verified against.
            let origin = outcomes.recorded_at(forecast.time_s);
            let advisory = advisor.advise_from(&forecast, origin.as_ref());
            outcomes.push_decision(&forecast, advisor.decider());
            local.send(
                &advisory
                    .decision
                    .sample(forecast.seq, forecast.time_s, monotonic_ns()),
            )?;
            if let Some((p, _, _)) = &publisher {
                p.put_serialize(&advisory)?;
            }
            if count.is_multiple_of(print_every) {
                let mut out = stdout.lock();
                // A closed stdout (e.g. piped into `head`) must not stop the advisory service.
                let _ = writeln!(out, "{}", advisory.summary());
            }
            count += 1;
        }
        Ok(())
    });
    advised?;
    if let Some((_, status, _)) = &publisher {
        let last = DeckStatus::new(count, &gate, outcomes.counts, motion_rejected);
        status.put_serialize(&last)?;
    }
    let r = gate.stream.rejected;
    tracing::info!(
        "deck: stopped after {count} advisories, {} rejected ({} source, {} seq, {} payload), {motion_rejected} motion samples from another port and {} non-finite or out of order rejected",
        r.total(),
        r.source,
        r.seq,
        r.payload,
        outcomes.counts.rejected_samples
    );
    Ok(())
}

/// Hand the new motion samples to `outcomes`, which verifies the decisions against them.
/// Only the producer's port counts: a second publisher on the motion service must not teach
/// the decider what "happened"; its samples are counted in `rejected` and logged.
fn take_motion(
    motion: &IoxSubscriber<MotionSample>,
    port: &mut IoxFollowedPort,
    connected: &mut Vec<u128>,
    outcomes: &mut Outcomes,
    rejected: &mut u64,
) -> anyhow::Result<()> {
    while let Some((sample, origin)) = motion.receive_with_origin()? {
        match port.admit_listing(origin, connected, |c| motion.publishers(c)) {
            Ok(()) => {
                if outcomes.push_sample(&sample) == SeqCheck::NewRun {
                    tracing::info!(
                        restarts = outcomes.counts.restarts,
                        "deck: the producer started a new run: decisions waiting on the old run's clock are dropped as unverifiable"
                    );
                }
            }
            Err(e) => {
                *rejected += 1;
                // At most one line per power of two: a second producer's 8 samples a second
                // must not become 8 lines a second (review); the status counts every one.
                if rejected.is_power_of_two() {
                    tracing::warn!(rejected = *rejected, "deck: motion sample rejected: {e}");
                }
            }
        }
    }
    Ok(())
}

/// The newest waiting forecast that passes the gate. Every one is checked, not only the
/// newest: a foreign one must not hide the predictor's. Only the newest accepted forecast
/// matters to the landing officer.
fn newest_accepted(
    forecasts: &IoxSubscriber<Forecast>,
    gate: &mut IoxForecastGate,
    connected: &mut Vec<u128>,
) -> anyhow::Result<Option<Forecast>> {
    let mut newest = None;
    while let Some((forecast, origin)) = forecasts.receive_with_origin()? {
        forecasts.publishers(connected);
        match gate.check(origin, connected, &forecast) {
            Ok(()) => newest = Some(forecast),
            Err(e) => {
                shipcast_pipeline::warn_rejected!(
                    gate.stream.log,
                    gate.stream.rejected.total(),
                    "deck: rejected: {e}"
                );
            }
        }
    }
    Ok(newest)
}

/// How often the deck publishes its counters.
const STATUS_EVERY: Duration = Duration::from_secs(1);

/// How often the deck writes its verified statements (`[deck] statements_file`): a crash
/// loses at most this much of them.
const SAVE_STATEMENTS_EVERY: Duration = Duration::from_secs(60);

/// Run `body` (the advisory loop), then write the verified statements whatever it returned.
fn with_statements_saved<T>(
    keeper: &mut Option<StatementsKeeper>,
    advisor: &mut DeckAdvisor,
    body: impl FnOnce(&mut DeckAdvisor, &mut Option<StatementsKeeper>) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    let result = body(advisor, keeper);
    let saved = keeper
        .as_mut()
        .map_or(Ok(false), |k| k.save(advisor.decider()));
    match (result, saved) {
        (result, Ok(_)) => result,
        // The watch ended but its statements are lost: not a clean stop (review: the deck
        // exited 0 with one warning).
        (Ok(_), Err(e)) => Err(e.context("deck: the verified statements could not be kept")),
        (Err(e), Err(lost)) => {
            tracing::error!("deck: the verified statements could not be kept: {lost:#}");
            Err(e)
        }
    }
}

/// Write the verified statements if a file keeps them; a failed write is logged and tried
/// again at the next save (the advisory goes on either way).
fn save_statements(keeper: Option<&mut StatementsKeeper>, advisor: &DeckAdvisor) {
    let Some(keeper) = keeper else {
        return;
    };
    match keeper.save(advisor.decider()) {
        Ok(true) => tracing::debug!("deck: statements written to {}", keeper.path().display()),
        Ok(false) => {}
        Err(e) => tracing::warn!("deck: {e:#}"),
    }
}

/// What the deck reports about itself on zenoh `.../status/deck`.
#[derive(serde::Serialize)]
struct DeckStatus {
    advisories: u64,
    accepted: u64,
    rejected: RejectionCounts,
    /// Forecasts verified against the motion (and those that could not be).
    outcomes: OutcomeCounts,
    /// Motion samples from a port other than the producer's.
    motion_rejected: u64,
}

impl DeckStatus {
    fn new(
        advisories: u64,
        gate: &IoxForecastGate,
        outcomes: OutcomeCounts,
        motion_rejected: u64,
    ) -> Self {
        Self {
            advisories,
            accepted: gate.stream.accepted,
            rejected: gate.stream.rejected,
            outcomes,
            motion_rejected,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mot_no_forecast_holds_is_refused_at_start() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("long_mot.toml");
        std::fs::write(&path, "[deck]\nmot_s = 30.0\n").unwrap();
        let e = crate::refused::<Args, Config>(&["--config", path.to_str().unwrap()]);
        assert!(
            e.contains("deck.mot_s (30 s) is longer than the forecast horizon"),
            "{e}"
        );
    }

    #[test]
    fn flags_are_checked_and_no_publish_wins_over_the_configuration() {
        let c = crate::validated::<Args, Config>(&["--print-every", "10"]).unwrap();
        assert_eq!(c.print_every, 10);
        assert!(c.publish, "the default configuration publishes");
        assert!(
            !crate::validated::<Args, Config>(&["--no-publish"])
                .unwrap()
                .publish
        );
        assert!(crate::refused::<Args, Config>(&["--print-every", "0"]).contains("--print-every"));
    }

    /// Regression: an error inside the advisory loop returned before the final write, and
    /// up to a minute of verified statements was lost.
    #[test]
    fn statements_verified_before_an_error_are_written_and_the_error_returned() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("statements.json");
        let config = shipcast_pipeline::config::DeckConfig::default();
        let mut advisor = DeckAdvisor::new(&config);
        let mut keeper = Some(StatementsKeeper::open(&path, 0.5, advisor.decider_mut()).unwrap());
        let result: anyhow::Result<()> =
            with_statements_saved(&mut keeper, &mut advisor, |advisor, _| {
                advisor.decider_mut().add_outcome(20, 0.3, true);
                advisor.decider_mut().add_outcome(20, 0.31, false);
                anyhow::bail!("the forecast port failed")
            });
        assert!(result.unwrap_err().to_string().contains("forecast port"));
        let mut fresh = DeckAdvisor::new(&config);
        StatementsKeeper::open(&path, 0.5, fresh.decider_mut()).unwrap();
        assert_eq!(fresh.decider().statement_calls(), 2.0);
    }

    /// Regression (review): a final write that failed was one warning and exit 0; the
    /// watch's statements were lost without a failing stop.
    #[test]
    fn statements_that_cannot_be_written_at_the_end_make_the_stop_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("statements.json");
        let config = shipcast_pipeline::config::DeckConfig::default();
        let mut advisor = DeckAdvisor::new(&config);
        let mut keeper = Some(StatementsKeeper::open(&path, 0.5, advisor.decider_mut()).unwrap());
        // The directory gone during the watch: no write can succeed, even as root.
        std::fs::remove_dir(dir.path()).unwrap();
        let result: anyhow::Result<u32> =
            with_statements_saved(&mut keeper, &mut advisor, |advisor, _| {
                advisor.decider_mut().add_outcome(20, 0.3, true);
                Ok(7)
            });
        let e = format!("{:#}", result.unwrap_err());
        assert!(
            e.starts_with("deck: the verified statements could not be kept: statements file"),
            "{e}"
        );
        assert!(!path.exists());
    }
}
