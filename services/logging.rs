//! Logging setup shared by every subcommand: `tracing` to stderr (coloured on a terminal
//! unless NO_COLOR is set), level from `RUST_LOG` (default `info`, zenoh's own start-up
//! chatter at `warn`), and one shipcast line for each
//! client zenoh refuses (`RefusalLayer`, which sees zenoh's events whatever `RUST_LOG` says).

use shipcast_pipeline::transport::zenoh_refusals::{refusal_events, RefusalLayer};
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::{EnvFilter, Layer};

pub fn init() {
    let filter =
        EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info,zenoh=warn"));
    // Colour only on a terminal: the children's logs under `run`, and stderr piped to grep,
    // carried escape codes around every level and time stamp. NO_COLOR (non-empty, as its
    // convention says) turns it off anywhere.
    let colour = std::io::IsTerminal::is_terminal(&std::io::stderr())
        && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty());
    let printed = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(colour)
        .with_target(false)
        .with_filter(filter);
    // A second init (tests calling main twice) is harmless, so the error is ignored.
    let _ = tracing_subscriber::registry()
        .with(printed)
        .with(RefusalLayer.with_filter(refusal_events()))
        .try_init();
}
