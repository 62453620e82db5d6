//! `shipcast crane`: the remote consumer. Subscribes to the forecast JSON over zenoh (latest
//! only, ring channel) and prints the crane-tip motion forecast for a configurable tip position.

use shipcast::config::CommonArgs;
use shipcast::crane::{summary, tip_track};
use shipcast::deck::ShipPoint;
use shipcast::payload::Forecast;
use shipcast::transport::zenoh::{self as zn, LatestSubscriber, LivelinessWatch};
use shipcast::transport::{shutdown, Names};
use std::io::Write;
use std::time::Duration;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub common: CommonArgs,
    /// Crane tip from the centre of gravity [m] as X,Y,Z (x forward, y starboard, z down).
    #[arg(long, value_name = "X,Y,Z", value_delimiter = ',', num_args = 3)]
    pub tip: Option<Vec<f64>>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = args.common.load()?;
    if let Some(t) = &args.tip {
        if t.iter().any(|v| !v.is_finite()) {
            anyhow::bail!("--tip must be three finite numbers");
        }
        config.crane.tip_m = [t[0], t[1], t[2]];
    }
    let limit = shutdown::RunLimit::new(args.common.duration()?);
    let names = config.names()?;
    let session = zn::open(&config.zenoh.consumer_side())?;
    let forecasts = LatestSubscriber::new(&session, &names.forecast())?;
    let alive = LivelinessWatch::new(&session, &Names::liveliness(&names.forecast()))?;
    let tip = ShipPoint::new(config.crane.tip_m);
    tracing::info!(tip_m = ?config.crane.tip_m, "crane: following {} over zenoh", names.forecast());
    let (mut count, mut rejected) = (0u64, 0u64);
    let mut track = Vec::new();
    let stdout = std::io::stdout();
    while !limit.reached() {
        match alive.poll() {
            Some(true) => tracing::info!("crane: predictor alive"),
            Some(false) => tracing::warn!("crane: predictor gone"),
            None => {}
        }
        let Some(bytes) = forecasts.recv_timeout(Duration::from_millis(200))? else {
            continue;
        };
        let forecast = match Forecast::from_json(&bytes) {
            Ok(f) => f,
            Err(e) => {
                rejected += 1;
                tracing::warn!(rejected, "crane: {e}");
                continue;
            }
        };
        tip_track(&tip, &forecast, &mut track);
        if count % config.crane.print_every.max(1) == 0 {
            let _ = writeln!(stdout.lock(), "{}", summary(&forecast, &track));
        }
        count += 1;
    }
    tracing::info!("crane: stopped after {count} forecasts, {rejected} rejected");
    Ok(())
}
