//! Remote shipcast consumer in Rust: subscribes to the forecast JSON over zenoh and prints the
//! 20 s heave and roll forecast of every one.
//!
//! Depends only on `shipcast-wire` (the JSON form and its checks), `zenoh` and `serde_json`.
//! Start a pipeline (`cargo run --release -- run`, which listens on tcp/127.0.0.1:17447), then:
//!
//! ```sh
//! cargo run --release --example remote_forecast_subscriber -- [--connect tcp/127.0.0.1:17447] \
//!     [--instance NAME] [--vessel ddg51] [--count N]
//! ```
//!
//! Secure setup (docs/security.md): pass the station's configuration written by
//! `shipcast certs`, which holds the endpoint, TLS and the station's certificate:
//! `--config DIR/crane.json5`.

#[path = "common/options.rs"]
mod options;

use shipcast_wire::payload::{limits, Forecast};
use shipcast_wire::Dof;
use std::process::ExitCode;
use zenoh::handlers::RingChannel;
use zenoh::Wait;

/// zenoh's own error type (its results are `Box<dyn Error + Send + Sync>`).
type Error = Box<dyn std::error::Error + Send + Sync>;

/// The default endpoint: where `shipcast run` listens.
const DEFAULT_CONNECT: &str = "tcp/127.0.0.1:17447";

fn zenoh_config(options: &options::Options) -> Result<zenoh::Config, Error> {
    // A zenoh client configuration (JSON5) replaces the endpoint.
    if let Some(path) = options.get("--config") {
        return zenoh::Config::from_file(path);
    }
    let connect = options.get("--connect").unwrap_or(DEFAULT_CONNECT);
    let mut config = zenoh::Config::default();
    config.insert_json5("mode", r#""peer""#)?;
    config.insert_json5("connect/endpoints", &serde_json::to_string(&[connect])?)?;
    // Explicit endpoints only: no multicast discovery on a ship's network.
    config.insert_json5("scouting/multicast/enabled", "false")?;
    Ok(config)
}

fn run(options: &options::Options) -> Result<(), Error> {
    let mut key = format!("shipcast/{}/forecast", options.vessel);
    if !options.instance.is_empty() {
        key = format!("{}/{key}", options.instance);
    }
    let session = zenoh::open(zenoh_config(options)?).wait()?;
    // A ring channel keeps only the newest forecasts: a slow consumer never holds zenoh up.
    let subscriber = session
        .declare_subscriber(&key)
        .with(RingChannel::new(limits::ZENOH_RING))
        .wait()?;
    eprintln!("listening on {key}");

    let mut received = 0;
    while options.count == 0 || received < options.count {
        let sample = subscriber.recv()?;
        let bytes = sample.payload().to_bytes();
        // The JSON's own checks (fields, shapes) by the wire type; a bad one is skipped.
        let forecast = match Forecast::from_json(&bytes) {
            Ok(f) if f.steps > 0 && f.dt_s > 0.0 => f,
            Ok(f) => {
                eprintln!(
                    "skipped a forecast with steps {} and dt_s {}",
                    f.steps, f.dt_s
                );
                continue;
            }
            Err(e) => {
                eprintln!("skipped a message that is not a forecast: {e}");
                continue;
            }
        };
        received += 1;
        let k20 = ((20.0 / forecast.dt_s).round() as usize)
            .min(forecast.steps as usize)
            .max(1)
            - 1;
        let (heave, roll) = (Dof::Heave.index(), Dof::Roll.index());
        println!(
            "seq {} t={:.1}s model v{}: in {:.0} s heave {:+.2} m (sigma {:.2}), roll {:+.1} deg  [{}]",
            forecast.seq,
            forecast.time_s,
            forecast.model_version,
            (k20 + 1) as f64 * forecast.dt_s,
            forecast.mean[heave][k20],
            forecast.sigma[heave][k20],
            forecast.mean[roll][k20].to_degrees(),
            sample.encoding()
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    options::main_with(&["--connect", "--config"], run)
}
