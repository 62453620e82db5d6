//! The measuring forecast consumers: a co-located iceoryx2 subscriber and a zenoh subscriber
//! over tcp/127.0.0.1. Each records, for every measured forecast, the one-way latency from the
//! source sample's stamp to its own receive time, and counts gaps in the forecast seq as lost.

use super::histogram::LatencyRecorder;
use super::pinning::{pin_current, PinOutcome};
use super::plan::Mode;
use anyhow::anyhow;
use shipcast_pipeline::transport::iox::{self, IoxSubscriber, Sizing, WaitMode};
use shipcast_pipeline::transport::{monotonic_ns, Names};
use shipcast_wire::payload::Forecast;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;
use zenoh::Wait;

/// How long receivers wait per call before checking whether the run is over.
pub const SLICE: Duration = Duration::from_millis(20);

/// Busy polling spins this long, then yields the core once (as `shipcast predictor
/// --busy-poll` does): on two cores, zenoh's threads share a core with a spinner and would
/// otherwise wait for the scheduler tick (milliseconds) before they run.
pub const SPIN_SLICE: Duration = Duration::from_micros(20);

/// How long one wait of a receiver in `mode` lasts before it checks for other work.
pub fn wait_slice(mode: Mode) -> Duration {
    match mode {
        Mode::Event => SLICE,
        Mode::Poll => SPIN_SLICE,
    }
}

/// Called after a wait that brought nothing: a polling receiver lets other threads run.
pub fn after_idle_wait(mode: Mode) {
    if mode == Mode::Poll {
        std::thread::yield_now();
    }
}

/// What the consumers share with the rest of a pipeline run.
pub struct Shared {
    pub names: Names,
    pub mode: Mode,
    /// Core of the consumers (the producer's core: the predictor has the other one).
    pub core: usize,
    /// Forecasts from source samples before this seq are warm-up and not recorded.
    pub first_measured: u64,
    /// Set when the run is over (or failed): every thread stops.
    pub done: AtomicBool,
    /// Consumers whose subscribers exist.
    pub ready: AtomicUsize,
}

impl Shared {
    pub fn new(names: Names, mode: Mode, core: usize, first_measured: u64) -> Self {
        Self {
            names,
            mode,
            core,
            first_measured,
            done: AtomicBool::new(false),
            ready: AtomicUsize::new(0),
        }
    }

    pub fn is_done(&self) -> bool {
        self.done.load(Ordering::Acquire)
    }

    pub fn stop(&self) {
        self.done.store(true, Ordering::Release);
    }

    pub fn measured(&self, source_seq: u64) -> bool {
        source_seq >= self.first_measured
    }
}

/// Number of consumers that report ready.
pub const CONSUMERS: usize = 2;

/// What one consumer measured.
#[derive(Debug, Default)]
pub struct ConsumerTally {
    /// Source stamp -> received here.
    pub latency: LatencyRecorder,
    /// Source stamp -> issued stamp, as carried by the forecasts received here.
    pub published: LatencyRecorder,
    /// Forecasts missing between measured ones (gaps in `Forecast::seq`).
    pub lost: u64,
    /// Payloads that could not be decoded.
    pub rejected: u64,
    last_seq: Option<u64>,
}

impl ConsumerTally {
    fn record(&mut self, f: &Forecast, received_ns: u64) {
        if let Some(last) = self.last_seq {
            self.lost += f.seq.saturating_sub(last + 1);
        }
        self.last_seq = Some(f.seq);
        self.latency.record_between(f.source_stamp_ns, received_ns);
        self.published
            .record_between(f.source_stamp_ns, f.issued_stamp_ns);
    }
}

pub fn wait_mode(mode: Mode) -> WaitMode {
    match mode {
        Mode::Event => WaitMode::Event,
        Mode::Poll => WaitMode::BusyPoll,
    }
}

/// Co-located iceoryx2 consumer: waits in the run's mode.
pub fn local(shared: &Shared) -> anyhow::Result<(ConsumerTally, PinOutcome)> {
    let pin = pin_current("local consumer", shared.core);
    let node = iox::node(&shared.names, "bench-local")?;
    let sub = IoxSubscriber::<Forecast>::new(
        &node,
        &shared.names.forecast(),
        Sizing::FORECAST,
        wait_mode(shared.mode),
    )?;
    shared.ready.fetch_add(1, Ordering::AcqRel);
    let mut tally = ConsumerTally::default();
    let slice = wait_slice(shared.mode);
    while !shared.is_done() {
        sub.wait(slice)?;
        let mut idle = true;
        while let Some(f) = sub.receive()? {
            let now = monotonic_ns();
            idle = false;
            if shared.measured(f.source_seq) {
                tally.record(&f, now);
            }
        }
        if idle {
            after_idle_wait(shared.mode);
        }
    }
    Ok((tally, pin))
}

/// zenoh consumer. It always blocks on its channel: zenoh delivers from its own threads, and a
/// spinning consumer would take the core they need.
pub fn remote(
    shared: &Shared,
    session: &zenoh::Session,
) -> anyhow::Result<(ConsumerTally, PinOutcome)> {
    let pin = pin_current("zenoh consumer", shared.core);
    let key = shared.names.forecast();
    let sub = session
        .declare_subscriber(key.clone())
        .wait()
        .map_err(|e| anyhow!("zenoh: declare subscriber '{key}': {e}"))?;
    shared.ready.fetch_add(1, Ordering::AcqRel);
    let mut tally = ConsumerTally::default();
    while !shared.is_done() {
        let Some(sample) = sub
            .recv_timeout(SLICE)
            .map_err(|e| anyhow!("zenoh: receive: {e}"))?
        else {
            continue;
        };
        let now = monotonic_ns();
        match Forecast::from_json(&sample.payload().to_bytes()) {
            Ok(f) if shared.measured(f.source_seq) => tally.record(&f, now),
            Ok(_) => {}
            Err(e) => {
                tally.rejected += 1;
                tracing::warn!(
                    rejected = tally.rejected,
                    "zenoh consumer rejected a forecast: {e}"
                );
            }
        }
    }
    Ok((tally, pin))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_in_forecast_seq_are_counted_as_lost() {
        let mut t = ConsumerTally::default();
        for seq in [5, 6, 9, 10] {
            let f = Forecast {
                seq,
                source_stamp_ns: 100,
                issued_stamp_ns: 150,
                ..Forecast::default()
            };
            t.record(&f, 400);
        }
        assert_eq!((t.lost, t.latency.count()), (2, 4));
        assert_eq!(t.published.quantile_ns(0.5), 50);
        assert_eq!(t.latency.quantile_ns(0.5), 300);
    }
}
