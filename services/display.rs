//! `shipcast display --listen 127.0.0.1:PORT`: the live display, a web page served by this
//! process and fed over zenoh by every vessel of the instance (crates/display).

use anyhow::Context;
use shipcast_display::board::{Board, Limits};
use shipcast_display::{feed, server};
use shipcast_pipeline::config::CommonArgs;
use shipcast_pipeline::limits;
use shipcast_pipeline::transport::shutdown;
use shipcast_pipeline::transport::zenoh as zn;
use std::sync::Arc;
use std::time::Duration;

/// Where the display listens unless told otherwise (loopback: the page is not offered to the
/// ship's network unless asked).
pub const DEFAULT_LISTEN: &str = "127.0.0.1:8090";

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub common: CommonArgs,
    /// Address and port of the web page (HOST:PORT).
    #[arg(long, value_name = "HOST:PORT", default_value = DEFAULT_LISTEN)]
    pub listen: String,
    /// A vessel with no forecast for this long is shown as stale [s].
    #[arg(long, value_name = "S", default_value_t = 3.0)]
    pub stale_after_s: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = args.common.load()?;
    let stale_after =
        limits::seconds("--stale-after-s", args.stale_after_s).map_err(anyhow::Error::msg)?;
    let limit = shutdown::RunLimit::new(args.common.duration()?);
    let names = config.names()?;
    let prefix = names.fleet_prefix();
    let board = Arc::new(Board::new(
        Limits {
            roll_deg: config.deck.roll_limit_deg,
            pitch_deg: config.deck.pitch_limit_deg,
        },
        stale_after,
    ));
    let session = zn::open(&config.zenoh.consumer_side())?;
    let _feed = feed::start(
        &session,
        &prefix,
        board.clone(),
        1.0 / config.predictor.sample_rate_hz,
    )?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .thread_name("display-http")
        .enable_all()
        .build()
        .context("start the display's HTTP runtime")?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(&args.listen)
            .await
            .with_context(|| format!("display: cannot listen on {}", args.listen))?;
        let address = listener.local_addr().context("display: local address")?;
        tracing::info!("display: http://{address}/ (every vessel under {prefix}*)");
        let stop = async move {
            while !limit.reached() {
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
        };
        server::serve(listener, board, stop)
            .await
            .context("display: HTTP server")
    })?;
    tracing::info!("display: stopped");
    Ok(())
}
