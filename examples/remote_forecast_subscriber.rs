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

#[path = "common/checks.rs"]
mod checks;
#[path = "common/options.rs"]
mod options;

use shipcast_wire::payload::{limits, Forecast};
use shipcast_wire::Dof;
use std::process::ExitCode;
use std::time::Duration;
use zenoh::handlers::RingChannel;
use zenoh::Wait;

/// zenoh's own error type (its results are `Box<dyn Error + Send + Sync>`).
type Error = Box<dyn std::error::Error + Send + Sync>;

/// The default endpoint: where `shipcast run` listens.
const DEFAULT_CONNECT: &str = "tcp/127.0.0.1:17447";

/// Where this peer itself listens: loopback only, a port of the system's choosing. Without it
/// zenoh listens on every interface. Regression (review).
const OWN_LISTEN: &str = "tcp/127.0.0.1:0";

/// How long to wait for the predictor's liveliness token before saying it is not heard.
const ALIVE_PATIENCE: Duration = Duration::from_secs(5);

fn zenoh_config(options: &options::Options) -> Result<zenoh::Config, Error> {
    // A zenoh client configuration (JSON5) replaces the endpoint.
    if let Some(path) = options.get("--config") {
        return zenoh::Config::from_file(path).map_err(|e| format!("--config {path}: {e}").into());
    }
    let connect = options.get("--connect").unwrap_or(DEFAULT_CONNECT);
    let mut config = zenoh::Config::default();
    config.insert_json5("mode", r#""peer""#)?;
    config
        .insert_json5("connect/endpoints", &serde_json::to_string(&[connect])?)
        .map_err(|e| format!("--connect {connect}: {e}"))?;
    config.insert_json5("listen/endpoints", &serde_json::to_string(&[OWN_LISTEN])?)?;
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
    // Said at once when the predictor is not there (a wrong endpoint, a stopped pipeline)
    // rather than waiting in silence. Regression (review).
    let alive = format!("{key}/alive");
    let replies = session
        .liveliness()
        .get(&alive)
        .timeout(ALIVE_PATIENCE)
        .wait()?;
    if !std::iter::from_fn(|| replies.recv().ok()).any(|r| r.result().is_ok()) {
        eprintln!(
            "no predictor heard on {alive} after {} s (is it running, and is this its endpoint?): waiting for it",
            ALIVE_PATIENCE.as_secs()
        );
    }

    let mut received = 0;
    while options.count == 0 || received < options.count {
        let sample = subscriber.recv()?;
        let bytes = sample.payload().to_bytes();
        // The JSON's own checks (fields, shapes) by the wire type; a bad one is skipped.
        let forecast = match Forecast::from_json(&bytes) {
            Ok(f) => f,
            Err(e) => {
                eprintln!("skipped a message that is not a forecast: {e}");
                continue;
            }
        };
        let (heave, roll) = (Dof::Heave.index(), Dof::Roll.index());
        let k20 = match checks::step_at(&forecast, 20.0, &[heave, roll]) {
            Ok(k) => k,
            Err(why) => {
                eprintln!("skipped forecast seq {}: {why}", forecast.seq);
                continue;
            }
        };
        received += 1;
        println!(
            "seq {} t={:.1}s model v{}: in {:.1} s heave {:+.2} m (sigma {:.2}), roll {:+.1} deg  [{}]",
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
