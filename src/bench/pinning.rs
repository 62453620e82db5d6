//! Pinning the measuring threads to cores. A failure (core missing, no permission) is not fatal:
//! it is logged as a warning and recorded, so the report says the run was not pinned.

use serde::Serialize;

/// What happened when a thread asked for a core.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PinOutcome {
    /// The thread's role, e.g. "producer" or "iceoryx2 pong".
    pub role: String,
    pub core: usize,
    pub pinned: bool,
}

/// Pin the calling thread to `core`; warn and record if that is not possible.
pub fn pin_current(role: &str, core: usize) -> PinOutcome {
    let available = core_affinity::get_core_ids().unwrap_or_default();
    let pinned = match available.iter().find(|c| c.id == core) {
        Some(&id) => core_affinity::set_for_current(id),
        None => false,
    };
    if !pinned {
        tracing::warn!(
            role,
            core,
            available = available.len(),
            "could not pin thread to core; latencies are measured unpinned"
        );
    }
    PinOutcome {
        role: role.to_string(),
        core,
        pinned,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_core_is_recorded_not_fatal() {
        let outcome = std::thread::spawn(|| pin_current("test", 1 << 20))
            .join()
            .unwrap();
        assert!(!outcome.pinned);
        assert_eq!((outcome.role.as_str(), outcome.core), ("test", 1 << 20));
    }
}
