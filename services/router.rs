//! `shipcast router`: the zenoh router of a fleet. Vessels run `shipcast run --vessel NAME
//! --zenoh-connect ENDPOINT`; a shore consumer connects to the same endpoint and subscribes to
//! `shipcast/*/forecast`. With `--config`, the `[zenoh]` security settings of that file (TLS,
//! authentication, access rules) apply to the router's links.

use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::limits;
use shipcast_pipeline::transport::shutdown;
use shipcast_pipeline::transport::zenoh::Downsampling;
use shipcast_pipeline::transport::zenoh_router::{FleetRouter, FLEET_FORECASTS};
use std::path::PathBuf;
use std::time::Duration;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Endpoint to listen on (repeatable), e.g. tcp/0.0.0.0:7447 or tls/shore.example:7447;
    /// default: the `listen` of `--config`.
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Take TLS, authentication and access rules from this file's [zenoh] section (e.g. the
    /// router.toml of `shipcast certs --router`), and its endpoints unless `--listen` is given.
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// At most this many forecasts per second per vessel towards consumers (zenoh
    /// downsampling); 0 passes every forecast.
    #[arg(long, value_name = "HZ", default_value_t = 0.0)]
    pub downsample_hz: f64,
    /// Forecast key expression whose latest sample per vessel is kept and answers queries
    /// (default `shipcast/*/forecast`, under the `instance` of `--config` if it has one).
    #[arg(long, value_name = "KEYEXPR")]
    pub forecasts: Option<String>,
    /// Stop after this many seconds.
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    limits::non_negative("--downsample-hz", args.downsample_hz, limits::MAX_RATE_HZ)
        .map_err(anyhow::Error::msg)?;
    let duration = args
        .duration
        .map(|s| limits::seconds("--duration", s))
        .transpose()
        .map_err(anyhow::Error::msg)?;
    if args.listen.is_empty() && args.config.is_none() {
        anyhow::bail!("give the endpoints to listen on (--listen) or a --config that has them");
    }
    let config = PipelineConfig::load(args.config.as_deref())?;
    let mut settings = config.zenoh.publisher_side();
    if !args.listen.is_empty() {
        settings.listen = args.listen.clone();
    }
    settings.connect = Vec::new();
    let forecasts = match (&args.forecasts, &config.instance) {
        (Some(f), _) => f.clone(),
        (None, Some(instance)) => format!("{instance}/{FLEET_FORECASTS}"),
        (None, None) => FLEET_FORECASTS.to_string(),
    };
    settings.multicast_scouting = false;
    if args.downsample_hz > 0.0 {
        settings.downsample_egress = Some(Downsampling {
            key_exprs: vec![forecasts.clone()],
            max_hz: args.downsample_hz,
        });
    }
    let router = FleetRouter::start(&settings, &forecasts)?;
    tracing::info!(
        listen = ?settings.listen,
        tls = settings.tls.is_some(),
        access = settings.access.is_some(),
        "router: up, serving the latest of {forecasts}"
    );
    let limit = shutdown::RunLimit::new(duration);
    while !limit.reached() {
        std::thread::sleep(Duration::from_millis(100));
    }
    tracing::info!("router: stopped, {} forecast keys seen", router.keys_seen());
    Ok(())
}
