//! Latency benchmark harness (`shipcast bench latency`, issue 6).
//!
//! Measures one way, from the stamps carried in the payloads, on two pinned cores:
//! - the raw transport floors: an iceoryx2 ping-pong ([`pingpong_iox`]) and a zenoh ping-pong
//!   ([`pingpong_zenoh`]) driven by the same protocol ([`pingpong`]);
//! - shipcast's own paths: the real `shipcast producer` and `shipcast predictor` processes
//!   ([`services`]), and producer, predictor and consumers as threads of one process over the
//!   same transport API ([`pipeline`]), the predictor thread driving the service's own
//!   [`shipcast_pipeline::engine::Engine`].
//!
//! Everything is recorded into HDR histograms ([`histogram`]) and reported as a table, JSON rows
//! and an SVG of the latency distributions ([`report`]).

pub mod children;
pub mod consumers;
pub mod fleet;
pub mod histogram;
pub mod latency;
pub mod machine;
pub mod pingpong;
pub mod pingpong_iox;
pub mod pingpong_zenoh;
pub mod pingpong_zenoh_processes;
pub mod pinning;
pub mod pipeline;
pub mod plan;
pub mod report;
pub mod report_builder;
pub mod services;
pub mod stamps;

pub use histogram::{LatencyRecorder, PathStats};
pub use plan::{Mode, ModeSelect, Path, Plan, Source};
