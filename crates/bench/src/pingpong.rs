//! Ping-pong protocol shared by the raw transport floors: a "ping" thread on the first core
//! sends stamped messages at the plan's rate, a "pong" thread on the second core answers each
//! one with a fresh stamp. Both legs are recorded one way from the stamps (receive time minus the
//! stamp carried in the message), so the figures are comparable with shipcast's own paths.

use super::histogram::LatencyRecorder;
use super::pinning::{pin_current, PinOutcome};
use super::plan::{Pacer, Plan};
use anyhow::{anyhow, Context};
use shipcast_pipeline::transport::monotonic_ns;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Barrier;
use std::time::{Duration, Instant};

/// One side of a ping-pong over some transport.
pub trait Endpoint {
    /// Send one message carrying `seq` and `stamp_ns`.
    fn send(&mut self, seq: u64, stamp_ns: u64) -> anyhow::Result<()>;
    /// Wait up to `timeout` for the next message and return its (seq, stamp_ns). May return
    /// `None` early (spurious wake-up); callers loop.
    fn recv(&mut self, timeout: Duration) -> anyhow::Result<Option<(u64, u64)>>;
}

/// seq of the handshake messages that prove both directions are connected.
pub(crate) const HANDSHAKE: u64 = u64::MAX;
/// How long the ping side waits for the pong side to answer the handshake.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(15);
/// How long the ping side waits for one answer before counting the exchange as lost.
const REPLY_TIMEOUT: Duration = Duration::from_secs(1);
/// How often the pong side checks whether the run is over.
pub(crate) const POLL_SLICE: Duration = Duration::from_millis(20);

/// Latencies of both legs of a ping-pong run.
#[derive(Debug)]
pub struct PingPongOutcome {
    pub recorder: LatencyRecorder,
    /// Legs that should have been recorded (two per measured exchange).
    pub expected: u64,
    pub pins: Vec<PinOutcome>,
}

/// Run a ping-pong: `make_ping` and `make_pong` build the endpoints on their own (pinned)
/// threads, because iceoryx2 ports must stay on the thread that created them.
pub fn run<EA, EB>(
    plan: &Plan,
    label: &str,
    make_ping: impl FnOnce() -> anyhow::Result<EA> + Send,
    make_pong: impl FnOnce() -> anyhow::Result<EB> + Send,
) -> anyhow::Result<PingPongOutcome>
where
    EA: Endpoint,
    EB: Endpoint,
{
    let done = AtomicBool::new(false);
    let ready = Barrier::new(2);
    let (ping, pong) = std::thread::scope(|s| {
        let pong = s.spawn(|| {
            let pin = pin_current(&format!("{label} pong"), plan.cores.1);
            let ep = make_pong();
            ready.wait();
            let result = ep.and_then(|ep| pong_loop(ep, plan.warmup, &done));
            // Tell the ping side to stop waiting if this side failed.
            done.store(true, Ordering::Release);
            result.map(|rec| (rec, pin))
        });
        let ping = s.spawn(|| {
            let pin = pin_current(&format!("{label} ping"), plan.cores.0);
            let ep = make_ping();
            ready.wait();
            let result = ep.and_then(|mut ep| ping_loop(&mut ep, plan, &done));
            done.store(true, Ordering::Release);
            result.map(|rec| (rec, pin))
        });
        (join(ping), join(pong))
    });
    // The pong side first: when it fails, the ping side only reports that it stopped.
    let (pong_rec, pong_pin) = pong.with_context(|| format!("{label} pong side"))?;
    let (mut recorder, ping_pin) = ping.with_context(|| format!("{label} ping side"))?;
    recorder.merge(&pong_rec);
    Ok(PingPongOutcome {
        recorder,
        expected: 2 * plan.samples,
        pins: vec![ping_pin, pong_pin],
    })
}

fn join<T>(h: std::thread::ScopedJoinHandle<'_, anyhow::Result<T>>) -> anyhow::Result<T> {
    h.join()
        .map_err(|_| anyhow!("measuring thread panicked"))
        .and_then(|r| r)
}

/// Answer every message; record the ping leg of measured exchanges.
fn pong_loop(
    mut ep: impl Endpoint,
    warmup: u64,
    done: &AtomicBool,
) -> anyhow::Result<LatencyRecorder> {
    let mut rec = LatencyRecorder::new();
    while !done.load(Ordering::Acquire) {
        if let Some((seq, stamp)) = ep.recv(POLL_SLICE)? {
            let now = monotonic_ns();
            if seq != HANDSHAKE && seq >= warmup {
                rec.record_between(stamp, now);
            }
            ep.send(seq, monotonic_ns())?;
        }
    }
    Ok(rec)
}

/// Handshake, then paced exchanges; record the pong leg of measured ones.
pub(crate) fn ping_loop(
    ep: &mut impl Endpoint,
    plan: &Plan,
    done: &AtomicBool,
) -> anyhow::Result<LatencyRecorder> {
    handshake(ep, done)?;
    let mut rec = LatencyRecorder::new();
    let mut pacer = Pacer::new(plan.period());
    for seq in 0..plan.warmup + plan.samples {
        pacer.wait();
        ep.send(seq, monotonic_ns())?;
        let deadline = Instant::now() + REPLY_TIMEOUT;
        while !done.load(Ordering::Acquire) {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                tracing::warn!(seq, "no answer within {REPLY_TIMEOUT:?}; counted as lost");
                break;
            }
            if let Some((got, stamp)) = ep.recv(left)? {
                let now = monotonic_ns();
                if got == seq {
                    if seq >= plan.warmup {
                        rec.record_between(stamp, now);
                    }
                    break;
                }
            }
        }
        if done.load(Ordering::Acquire) {
            anyhow::bail!("the pong side stopped early");
        }
    }
    Ok(rec)
}

/// Send handshakes until one comes back (ports and sessions connect lazily), then drain stale
/// answers.
fn handshake(ep: &mut impl Endpoint, done: &AtomicBool) -> anyhow::Result<()> {
    let deadline = Instant::now() + HANDSHAKE_TIMEOUT;
    loop {
        if done.load(Ordering::Acquire) {
            anyhow::bail!("the pong side stopped during the handshake");
        }
        if Instant::now() > deadline {
            anyhow::bail!("no handshake answer within {HANDSHAKE_TIMEOUT:?}");
        }
        ep.send(HANDSHAKE, monotonic_ns())?;
        if let Some((HANDSHAKE, _)) = ep.recv(Duration::from_millis(20))? {
            break;
        }
    }
    while ep.recv(Duration::from_millis(50))?.is_some() {}
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc::{channel, Receiver, Sender};

    /// An in-process channel endpoint: tests the protocol without any transport.
    struct ChannelEndpoint {
        tx: Sender<(u64, u64)>,
        rx: Receiver<(u64, u64)>,
        /// Drop every message with this seq (to test loss accounting).
        drop_seq: Option<u64>,
    }

    impl Endpoint for ChannelEndpoint {
        fn send(&mut self, seq: u64, stamp_ns: u64) -> anyhow::Result<()> {
            if self.drop_seq != Some(seq) {
                self.tx.send((seq, stamp_ns))?;
            }
            Ok(())
        }
        fn recv(&mut self, timeout: Duration) -> anyhow::Result<Option<(u64, u64)>> {
            Ok(self.rx.recv_timeout(timeout).ok())
        }
    }

    fn pair(drop_seq: Option<u64>) -> (ChannelEndpoint, ChannelEndpoint) {
        let (a_tx, b_rx) = channel();
        let (b_tx, a_rx) = channel();
        let a = ChannelEndpoint {
            tx: a_tx,
            rx: a_rx,
            drop_seq,
        };
        let b = ChannelEndpoint {
            tx: b_tx,
            rx: b_rx,
            drop_seq: None,
        };
        (a, b)
    }

    fn plan(samples: u64) -> Plan {
        Plan {
            samples,
            warmup: 3,
            rounds: 1,
            rate_hz: 5000.0,
            cores: (0, 1),
            instance: "unit".into(),
            shipcast_exe: None,
        }
    }

    #[test]
    fn both_legs_of_every_measured_exchange_are_recorded() {
        let (a, b) = pair(None);
        let out = run(&plan(50), "chan", || Ok(a), || Ok(b)).unwrap();
        assert_eq!((out.recorder.count(), out.expected), (100, 100));
        assert_eq!(out.pins.len(), 2);
    }

    #[test]
    fn a_dropped_ping_is_counted_as_two_lost_legs() {
        // seq 5 is measured (warm-up is 3) and never arrives: neither leg is recorded.
        let (a, b) = pair(Some(5));
        let out = run(&plan(10), "chan", || Ok(a), || Ok(b)).unwrap();
        assert_eq!(out.expected - out.recorder.count(), 2);
    }

    #[test]
    fn a_failing_side_is_an_error_not_a_hang() {
        let (a, _b) = pair(None);
        let err = run(
            &plan(10),
            "chan",
            || Ok(a),
            || -> anyhow::Result<ChannelEndpoint> { anyhow::bail!("no transport") },
        )
        .unwrap_err();
        assert!(
            format!("{err:#}").contains("pong side: no transport"),
            "{err:#}"
        );
    }
}
