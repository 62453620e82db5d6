//! `shipcast crane`: the remote consumer. Subscribes to the forecast JSON over zenoh (latest
//! only, ring channel) and prints the crane-tip motion forecast for a configurable tip position.
//! Only forecasts from the live predictor, with increasing seq and sound content, are used
//! (`ForecastGate`); every rejection is counted and logged on one line.
//!
//! It also follows the ship's motion as the predictor republishes it (`.../motion`), verifies
//! each tip forecast once its horizon has passed, and scales the tip's sigma by the verified
//! errors (`crane::verify`): the sigma linearised from the DOF sigmas takes their errors as
//! independent, which the sea does not honour. Until enough are verified the line says
//! "sigma independent DOF errors".

use crate::common_args::CommonArgs;
use crate::followed_motion::FollowedMotion;
use shipcast_pipeline::config::{PipelineConfig, MAX_LEVER_M};
use shipcast_pipeline::crane::verify::{TipVerifier, MAX_PENDING};
use shipcast_pipeline::crane::{summary, tip_track};
use shipcast_pipeline::deck::ShipPoint;
use shipcast_pipeline::relative::PointTrack;
use shipcast_pipeline::sigma_scale::SigmaScale;
use shipcast_pipeline::transport::forecast_check::{ForecastGate, PublisherWatch};
use shipcast_pipeline::transport::silence::{ForecastSilence, NO_FORECAST_AFTER};
use shipcast_pipeline::transport::zenoh::{
    self as zn, LatestSubscriber, LivelinessWatch, Received,
};
use shipcast_pipeline::transport::{shutdown, Names};
use shipcast_wire::payload::MAX_STEPS;
use std::io::Write;
use std::time::{Duration, Instant};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub common: CommonArgs,
    /// Crane tip from the centre of gravity [m] as X,Y,Z (x forward, y starboard, z down).
    // One argument split at its commas: clap counts arguments before splitting, so
    // `num_args = 3` refused `--tip 1,2,3`, and `num_args = 1..=3` with hyphen values took the
    // next flag as a value (`--tip 1,2,3 --duration 5`: "invalid float literal"). Hyphen
    // values are allowed because "-12.5,0,-4" as a whole is not a number to clap; `tip_from`
    // checks the count.
    #[arg(
        long,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        num_args = 1,
        allow_hyphen_values = true
    )]
    pub tip: Option<Vec<f64>>,
}

/// The tip position `--tip` gives: exactly three finite numbers.
fn tip_from(values: &[f64]) -> anyhow::Result<[f64; 3]> {
    match values {
        [x, y, z]
            if values
                .iter()
                .all(|v| v.is_finite() && v.abs() <= MAX_LEVER_M) =>
        {
            Ok([*x, *y, *z])
        }
        _ => anyhow::bail!(
            "--tip must be three finite numbers X,Y,Z within +-{MAX_LEVER_M} m, got {}",
            values
                .iter()
                .map(|&v| shipcast_pipeline::limits::shown(v))
                .collect::<Vec<_>>()
                .join(",")
        ),
    }
}

/// What the crane runs with, every value checked: built from [`Args`] by [`Config::try_from`]
/// (the configuration file, `--tip` over it, then the checks).
#[derive(Debug, Clone)]
pub struct Config {
    /// Its `crane.tip_m` is `--tip` when given.
    pub pipeline: PipelineConfig,
    /// Wall-clock limit (`--duration`).
    pub limit: Option<Duration>,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let mut pipeline = args.common.load()?;
        if let Some(t) = &args.tip {
            pipeline.crane.tip_m = tip_from(t)?;
        }
        Ok(Config {
            pipeline,
            limit: args.common.duration()?,
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        pipeline: config,
        limit,
    } = Config::try_from(args)?;
    let limit = shutdown::RunLimit::new(limit);
    let names = config.names()?;
    // One crane per vessel and instance on a host: a second one under these names would
    // only disturb the first (review: a second deck blanked the first's advisory, a second
    // producer's samples were all refused).
    let _lock = shipcast_pipeline::transport::host_lock::HostLock::acquire(&names, "crane")?;
    let Some(session) = zn::open_until(&config.zenoh.consumer_side(), &limit)? else {
        tracing::info!("crane: stopped before the zenoh session opened");
        return Ok(());
    };
    let forecasts = LatestSubscriber::new(&session, &names.forecast())?;
    let alive = LivelinessWatch::new(&session, &Names::liveliness(&names.forecast()))?;
    let publishers = PublisherWatch::new(&session, &names.forecast())?;
    let mut gate = ForecastGate::new(1.0 / config.predictor.sample_rate_hz);
    let tip = ShipPoint::new(config.crane.tip_m);
    // The ship's motion for as long as a forecast waits for its last step, and some more.
    let keep_s = MAX_STEPS as f64 / config.predictor.sample_rate_hz + 10.0;
    let mut motion =
        FollowedMotion::new("crane", &session, &names, keep_s, config.producer.rate_hz)?;
    let c = &config.crane;
    let mut verifier = TipVerifier::new(
        tip,
        SigmaScale::adaptive(c.calibration_halflife, c.calibration_min_verified),
        MAX_PENDING,
    );
    tracing::info!(tip_m = ?config.crane.tip_m, "crane: following {} over zenoh", names.forecast());
    let mut count = 0u64;
    let mut warned_no_motion = false;
    let mut track = Vec::new();
    let mut point = Box::<PointTrack>::default();
    let stdout = std::io::stdout();
    // The forecast being checked, its buffers reused from one to the next.
    let mut received = Received::empty();
    // Regression (review): with the producer dead and the predictor alive the crane said
    // nothing at all, and a paused predictor only after the zenoh lease (10 s).
    let mut silence = ForecastSilence::new("crane", NO_FORECAST_AFTER, Instant::now());
    while !limit.reached() {
        if motion.poll()? {
            verifier.drop_pending();
        }
        if let Some(until) = motion.history.newest_s() {
            verifier.verify_until(until, &motion.history);
        }
        match alive.poll() {
            Some(true) => tracing::info!("crane: predictor alive"),
            Some(false) => tracing::warn!("crane: predictor gone"),
            None => {}
        }
        publishers.update(&mut gate.live);
        // Short, so that the motion is polled often enough for its queue.
        if !forecasts.recv_into(Duration::from_millis(20), &mut received)? {
            silence.check(Instant::now());
            continue;
        }
        // A token may arrive just after the first forecast of its publisher.
        publishers.update(&mut gate.live);
        let forecast = match gate.check(&received) {
            Ok(f) => f,
            Err(e) => {
                shipcast_pipeline::warn_rejected!(
                    gate.stream.log,
                    gate.stream.rejected.total(),
                    "crane: rejected: {e}"
                );
                silence.check(Instant::now());
                continue;
            }
        };
        silence.heard(Instant::now());
        // The tip's track once, for the console line and for verification.
        point.fill(&tip, 0.0, &forecast, 0, forecast.valid_steps());
        tip_track(&point, forecast.dt_s, &verifier, &mut track);
        verifier.push_track(forecast.time_s, forecast.dt_s, &point);
        // Forecasts of two full horizons and still no motion: say why the sigma stays the
        // independent one, once.
        if !warned_no_motion && count >= 4 * forecast.valid_steps() as u64 {
            warned_no_motion =
                motion.warn_if_silent("the tip's sigma stays that of independent DOF errors");
        }
        if count.is_multiple_of(config.crane.print_every) {
            let _ = writeln!(stdout.lock(), "{}", summary(&forecast, &track));
        }
        count += 1;
    }
    let r = gate.stream.rejected;
    tracing::info!(
        "crane: stopped after {count} forecasts ({} verified, {} unverifiable), {} rejected ({} source, {} seq, {} payload), {} motion samples rejected",
        verifier.verified,
        verifier.unverifiable(),
        r.total(),
        r.source,
        r.seq,
        r.payload,
        motion.gate.rejected
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tip_takes_comma_separated_values_including_negative_ones() {
        // Regression: `--tip 1,2,3` used to be refused by clap.
        let a = crate::parse_args::<Args>(&["--tip", "1,2,3"]);
        assert_eq!(tip_from(&a.tip.unwrap()).unwrap(), [1.0, 2.0, 3.0]);
        let a = crate::parse_args::<Args>(&["--tip", "-12.5,0,-4"]);
        assert_eq!(tip_from(&a.tip.unwrap()).unwrap(), [-12.5, 0.0, -4.0]);
        // Regression: with `num_args = 1..=3` the flag after the tip was taken as a value.
        let a = crate::parse_args::<Args>(&["--tip", "1,2,3", "--duration", "4"]);
        assert_eq!(tip_from(&a.tip.unwrap()).unwrap(), [1.0, 2.0, 3.0]);
        assert_eq!(a.common.duration, Some(4.0));
    }

    #[test]
    fn the_tip_flag_overrides_the_configuration_and_is_checked() {
        let c =
            crate::validated::<Args, Config>(&["--tip", "4,-1,-20", "--duration", "3"]).unwrap();
        assert_eq!(c.pipeline.crane.tip_m, [4.0, -1.0, -20.0]);
        assert_eq!(c.limit, Some(Duration::from_secs(3)));
        let c = crate::validated::<Args, Config>(&[]).unwrap();
        assert_eq!(
            c.pipeline.crane.tip_m,
            PipelineConfig::default().crane.tip_m
        );
        assert_eq!(
            crate::refused::<Args, Config>(&["--tip", "1,2"]),
            "--tip must be three finite numbers X,Y,Z within +-1000 m, got 1,2"
        );
    }

    #[test]
    fn tip_with_another_count_or_a_non_finite_value_is_one_line_error() {
        for (argv, shown) in [
            ("1,2", "1,2"),
            ("1,2,3,4", "1,2,3,4"),
            ("1,NaN,3", "1,NaN,3"),
            // Regression: the configuration file refuses a tip this far out; the flag did not.
            ("1000000,0,0", "1000000,0,0"),
            // Review: printed with all its 301 digits.
            ("1e300,0,0", "1e300,0,0"),
        ] {
            let a = crate::parse_args::<Args>(&["--tip", argv]);
            let e = format!("{:#}", tip_from(&a.tip.unwrap()).unwrap_err());
            assert_eq!(
                e,
                format!("--tip must be three finite numbers X,Y,Z within +-1000 m, got {shown}")
            );
        }
    }
}
