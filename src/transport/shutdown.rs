//! Stop requests: Ctrl-C and SIGTERM set one process-wide flag that service loops poll.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// The process's stop flag; the first call installs the Ctrl-C / SIGTERM handler. If a handler
/// cannot be installed (another one exists) the flag still works for programmatic stops.
pub fn stop_flag() -> Arc<AtomicBool> {
    STOP.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let handler_flag = flag.clone();
        if let Err(e) = ctrlc::set_handler(move || handler_flag.store(true, Ordering::SeqCst)) {
            tracing::warn!("cannot install the Ctrl-C handler: {e}");
        }
        flag
    })
    .clone()
}

/// True once a stop was requested.
pub fn stop_requested() -> bool {
    stop_flag().load(Ordering::Relaxed)
}
