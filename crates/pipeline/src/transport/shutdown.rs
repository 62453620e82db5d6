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

/// When a service loop should end: on a stop request, or once its wall-clock limit passed.
#[derive(Debug, Clone, Copy)]
pub struct RunLimit {
    started: std::time::Instant,
    limit: Option<std::time::Duration>,
}

impl RunLimit {
    /// Starts counting now; `None` runs until stopped.
    pub fn new(limit: Option<std::time::Duration>) -> Self {
        stop_flag();
        Self {
            started: std::time::Instant::now(),
            limit,
        }
    }

    /// True if the loop should end.
    pub fn reached(&self) -> bool {
        stop_requested() || self.limit.is_some_and(|l| self.started.elapsed() >= l)
    }

    /// Time since the start.
    pub fn elapsed(&self) -> std::time::Duration {
        self.started.elapsed()
    }
}
