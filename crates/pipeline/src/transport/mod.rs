//! Transports: service and key naming, iceoryx2 (local, zero-copy) and zenoh (remote) plumbing,
//! message counters and the monotonic clock used for latency stamps.

pub mod cert_validity;
pub mod clock;
pub mod counters;
pub mod forecast_check;
pub mod host_lock;
pub mod iox;
pub mod log_throttle;
pub mod motion_gate;
pub mod naming;
pub mod shutdown;
pub mod silence;
pub mod status;
pub mod zenoh;
pub mod zenoh_refusals;
pub mod zenoh_router;
pub mod zenoh_security;
pub mod zenoh_tls_files;

pub use clock::monotonic_ns;
pub use counters::{Counters, SeqCheck, SeqTracker};
pub use naming::{unique_instance, Names};
