//! `shipcast display --listen 127.0.0.1:PORT`: the live display, a web page served by this
//! process and fed over zenoh by every vessel of the instance (crates/display).

use crate::checked;
use crate::common_args::CommonArgs;
use anyhow::Context;
use shipcast_display::board::{Board, Limits};
use shipcast_display::{feed, server};
use shipcast_pipeline::config::PipelineConfig;
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
    /// A host name the page may be asked for (repeatable). IP addresses and localhost are
    /// always served; a request for any other name is refused (DNS rebinding).
    #[arg(long, value_name = "NAME")]
    pub allow_host: Vec<String>,
}

/// What the display serves, every value checked: built from [`Args`] by [`Config::try_from`].
#[derive(Debug, Clone)]
pub struct Config {
    pub pipeline: PipelineConfig,
    /// Wall-clock limit (`--duration`).
    pub limit: Option<Duration>,
    /// HOST:PORT of the web page.
    pub listen: String,
    pub stale_after: Duration,
    /// Host names served besides IP addresses and localhost.
    pub hosts: server::AllowedHosts,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let pipeline = args.common.load()?;
        let stale_after = checked(limits::seconds("--stale-after-s", args.stale_after_s))?;
        let limit = args.common.duration()?;
        // The host may be a name (resolved when the port is bound); the port must be a port.
        let port = args
            .listen
            .rsplit_once(':')
            .map(|(host, port)| (host, port.parse::<u16>()));
        if !matches!(port, Some((host, Ok(_))) if !host.is_empty()) {
            anyhow::bail!("--listen '{}' is not HOST:PORT", args.listen);
        }
        for name in &args.allow_host {
            let label =
                |l: &str| !l.is_empty() && l.chars().all(|c| c.is_ascii_alphanumeric() || c == '-');
            if name.len() > 253 || !name.split('.').all(label) {
                anyhow::bail!(
                    "--allow-host '{name}' is not a host name (letters, digits, '-' and '.')"
                );
            }
        }
        Ok(Config {
            pipeline,
            limit,
            listen: args.listen,
            stale_after,
            hosts: server::AllowedHosts::new(args.allow_host),
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        pipeline: config,
        limit,
        listen,
        stale_after,
        hosts,
    } = Config::try_from(args)?;
    let limit = shutdown::RunLimit::new(limit);
    let names = config.names()?;
    let prefix = names.fleet_prefix();
    let board = Arc::new(Board::new(
        Limits {
            roll_deg: config.deck.roll_limit_deg,
            pitch_deg: config.deck.pitch_limit_deg,
        },
        stale_after,
    ));
    let Some(session) = zn::open_until(&config.zenoh.consumer_side(), &limit)? else {
        tracing::info!("display: stopped before the zenoh session opened");
        return Ok(());
    };
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
        let listener = tokio::net::TcpListener::bind(&listen)
            .await
            .with_context(|| format!("display: cannot listen on {listen}"))?;
        let address = listener.local_addr().context("display: local address")?;
        tracing::info!("display: http://{address}/ (every vessel under {prefix}*)");
        if !address.ip().is_loopback() {
            tracing::warn!(
                "display: the page is offered beyond this machine on {address}: anyone who reaches it sees every vessel's forecasts and decisions (it is read-only and unencrypted; docs/display.md)"
            );
        }
        let stop = async move {
            while !limit.reached() {
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
        };
        server::serve(listener, board, hosts, stop)
            .await
            .context("display: HTTP server")
    })?;
    tracing::info!("display: stopped");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(argv: &[&str]) -> String {
        crate::refused::<Args, Config>(argv)
    }

    #[test]
    fn the_page_address_and_the_stale_time_are_checked() {
        let c = crate::validated::<Args, Config>(&["--listen", "localhost:0"]).unwrap();
        assert_eq!(c.listen, "localhost:0");
        assert_eq!(c.stale_after, Duration::from_secs(3));
        for bad in ["nonsense", ":8090", "127.0.0.1:http", "127.0.0.1:70000"] {
            assert_eq!(
                refused(&["--listen", bad]),
                format!("--listen '{bad}' is not HOST:PORT")
            );
        }
        assert_eq!(
            refused(&["--stale-after-s", "0"]),
            format!(
                "--stale-after-s must be a number in (0, {}], got 0",
                limits::MAX_SECONDS
            )
        );
    }

    #[test]
    fn allowed_host_names_are_checked_and_kept() {
        let c = crate::validated::<Args, Config>(&[
            "--allow-host",
            "bridge.local",
            "--allow-host",
            "Crane-2",
        ])
        .unwrap();
        assert!(c.hosts.admits("bridge.local:8090") && c.hosts.admits("crane-2"));
        assert!(!c.hosts.admits("other.local"));
        for bad in ["", "a..b", "a b", "evil.example/x", "x:80"] {
            assert_eq!(
                refused(&["--allow-host", bad]),
                format!("--allow-host '{bad}' is not a host name (letters, digits, '-' and '.')")
            );
        }
    }
}
