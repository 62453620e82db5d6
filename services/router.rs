//! `shipcast router`: the zenoh router of a fleet. Vessels run `shipcast run --vessel NAME
//! --zenoh-connect ENDPOINT`; a shore consumer connects to the same endpoint and subscribes to
//! `shipcast/*/forecast`. With `--config`, the `[zenoh]` security settings of that file (TLS,
//! authentication, access rules) apply to the router's links.

use crate::checked;
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::limits;
use shipcast_pipeline::transport::shutdown;
use shipcast_pipeline::transport::zenoh::{Downsampling, ZenohSettings};
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

/// What the router serves, every value checked: built from [`Args`] by [`Config::try_from`]
/// (the `[zenoh]` section of `--config` with the flags over it).
#[derive(Debug, Clone)]
pub struct Config {
    /// The router's zenoh settings: listen endpoints, no connect, no scouting.
    pub settings: ZenohSettings,
    /// Key expression of the forecasts whose latest sample per vessel is kept.
    pub forecasts: String,
    /// Wall-clock limit (`--duration`).
    pub limit: Option<Duration>,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let downsample_hz = checked(limits::non_negative(
            "--downsample-hz",
            args.downsample_hz,
            limits::MAX_RATE_HZ,
        ))?;
        let limit = args
            .duration
            .map(|s| checked(limits::seconds("--duration", s)))
            .transpose()?;
        if args.listen.is_empty() && args.config.is_none() {
            anyhow::bail!("give the endpoints to listen on (--listen) or a --config that has them");
        }
        // Checked once --listen has replaced the file's endpoints (below).
        let mut config = PipelineConfig::load_unvalidated(args.config.as_deref())?;
        if !args.listen.is_empty() {
            config.zenoh.listen = args.listen;
        }
        // The pipeline's checks of the endpoints (as the router uses them: listening only,
        // no scouting), before zenoh sees them: its errors name its own JSON keys, or come
        // as a debug dump.
        config.zenoh.connect.clear();
        config.zenoh.multicast_scouting = false;
        config.zenoh.validate_with_flag("--listen")?;
        config.validate()?;
        let mut settings = config.zenoh.publisher_side();
        if settings.listen.is_empty() {
            anyhow::bail!("the [zenoh] section of --config has no listen endpoint: give --listen");
        }
        settings.connect = Vec::new();
        let forecasts = match (args.forecasts, &config.instance) {
            (Some(f), _) => f,
            (None, Some(instance)) => format!("{instance}/{FLEET_FORECASTS}"),
            (None, None) => FLEET_FORECASTS.to_string(),
        };
        settings.multicast_scouting = false;
        if downsample_hz > 0.0 {
            settings.downsample_egress = Some(Downsampling {
                key_exprs: vec![forecasts.clone()],
                max_hz: downsample_hz,
            });
        }
        Ok(Config {
            settings,
            forecasts,
            limit,
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        settings,
        forecasts,
        limit,
    } = Config::try_from(args)?;
    let router = FleetRouter::start(&settings, &forecasts)?;
    tracing::info!(
        listen = ?settings.listen,
        tls = settings.tls.is_some(),
        access = settings.access.is_some(),
        "router: up, serving the latest of {forecasts}"
    );
    let limit = shutdown::RunLimit::new(limit);
    while !limit.reached() {
        std::thread::sleep(Duration::from_millis(100));
    }
    tracing::info!(
        "router: stopped, {} forecast keys kept, {} samples on further keys not kept",
        router.keys_seen(),
        router.keys_refused()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(argv: &[&str]) -> String {
        crate::refused::<Args, Config>(argv)
    }

    #[test]
    fn endpoints_come_from_the_flags_or_the_configuration() {
        assert_eq!(
            refused(&[]),
            "give the endpoints to listen on (--listen) or a --config that has them"
        );
        // Regression: the router passed its endpoints to zenoh unchecked, and a bad one came
        // back as a debug dump of zenoh's JSON5 error; port 0 was taken and never told.
        for bad in ["127.0.0.1:7447", "tcp/127.0.0.1", "tcp/127.0.0.1:0"] {
            let e = refused(&["--listen", bad]);
            assert!(
                e.contains(&format!(
                    "zenoh.listen (or --listen) endpoint '{bad}' is not PROTOCOL/HOST:PORT"
                )),
                "{e}"
            );
        }
        let e = refused(&["--listen", "tls/127.0.0.1:7447"]);
        assert!(e.contains("is required for tls/ endpoints"), "{e}");
        // Regression (review): an endpoint given twice failed as "Address already in use".
        let twice = "tcp/127.0.0.1:7447";
        let e = refused(&["--listen", twice, "--listen", twice]);
        assert!(
            e.contains(&format!(
                "zenoh.listen (or --listen) endpoint '{twice}' is given twice (entries 1 and 2)"
            )),
            "{e}"
        );
        assert_eq!(
            refused(&["--listen", "tcp/127.0.0.1:7447", "--downsample-hz", "nan"]),
            format!(
                "--downsample-hz must be a number in [0, {}], got NaN",
                limits::MAX_RATE_HZ
            )
        );
        let c = crate::validated::<Args, Config>(&[
            "--listen",
            "tcp/127.0.0.1:7447",
            "--downsample-hz",
            "2",
        ])
        .unwrap();
        assert_eq!(c.settings.listen, ["tcp/127.0.0.1:7447"]);
        assert!(c.settings.connect.is_empty() && !c.settings.multicast_scouting);
        assert_eq!(c.forecasts, FLEET_FORECASTS);
        let down = c.settings.downsample_egress.unwrap();
        assert_eq!(
            (down.key_exprs, down.max_hz),
            (vec![FLEET_FORECASTS.to_string()], 2.0)
        );

        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("router.toml");
        std::fs::write(
            &file,
            "instance = \"i1\"\n[zenoh]\nlisten = [\"tcp/127.0.0.1:7448\"]\nconnect = [\"tcp/127.0.0.1:9\"]\n",
        )
        .unwrap();
        let c = crate::validated::<Args, Config>(&["--config", file.to_str().unwrap()]).unwrap();
        assert_eq!(c.settings.listen, ["tcp/127.0.0.1:7448"]);
        assert!(c.settings.connect.is_empty());
        assert_eq!(c.forecasts, format!("i1/{FLEET_FORECASTS}"));
        assert!(c.settings.downsample_egress.is_none());
        std::fs::write(&file, "[zenoh]\nlisten = []\n").unwrap();
        assert_eq!(
            refused(&["--config", file.to_str().unwrap()]),
            "the [zenoh] section of --config has no listen endpoint: give --listen"
        );
        // Regression: the file was checked before --listen replaced its endpoints, so a bad one
        // there was refused (and named as --zenoh-listen's) although --listen replaced it.
        std::fs::write(&file, "[zenoh]\nlisten = [\"tcp/127.0.0.1:0\"]\n").unwrap();
        let file = file.to_str().unwrap();
        let e = refused(&["--config", file]);
        assert!(e.contains("zenoh.listen (or --listen) endpoint"), "{e}");
        let c =
            crate::validated::<Args, Config>(&["--config", file, "--listen", "tcp/127.0.0.1:7449"])
                .unwrap();
        assert_eq!(c.settings.listen, ["tcp/127.0.0.1:7449"]);
    }
}
