//! Logging setup shared by every subcommand: `tracing` to stderr, level from `RUST_LOG`
//! (default `info`, zenoh's own start-up chatter at `warn`).

use tracing_subscriber::EnvFilter;

pub fn init() {
    let filter =
        EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info,zenoh=warn"));
    // A second init (tests calling main twice) is harmless, so the error is ignored.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}
