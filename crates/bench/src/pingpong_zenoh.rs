//! Raw zenoh floor: ping-pong between two peer sessions over tcp/127.0.0.1 on a free port, with
//! multicast scouting disabled and express (unbatched) publishers, as in zenoh's own z_ping.
//! Event mode blocks on the subscriber channel; poll mode spins on `try_recv`, yielding the core
//! every [`SPIN_SLICE`] so zenoh's own threads can deliver.

use super::consumers::SPIN_SLICE;
use super::pingpong::{self, Endpoint, PingPongOutcome};
use super::plan::{Mode, Plan};
use anyhow::anyhow;
use shipcast_pipeline::transport::zenoh::{free_loopback_endpoint, open, ZenohSettings};
use std::time::{Duration, Instant};
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::sample::Sample;
use zenoh::{Session, Wait};

/// Bytes of the header every ping-pong message starts with: seq and stamp, little endian.
const HEADER: usize = 16;

pub(crate) struct ZenohEndpoint {
    publisher: Publisher<'static>,
    subscriber: Subscriber<FifoChannelHandler<Sample>>,
    mode: Mode,
    message: Vec<u8>,
    // The session must outlive its publisher and subscriber.
    _session: Session,
}

impl ZenohEndpoint {
    pub(crate) fn new(
        session: Session,
        out: &str,
        inp: &str,
        mode: Mode,
        bytes: usize,
    ) -> anyhow::Result<Self> {
        let publisher = session
            .declare_publisher(out.to_string())
            .express(true)
            .wait()
            .map_err(|e| anyhow!("zenoh: declare publisher '{out}': {e}"))?;
        let subscriber = session
            .declare_subscriber(inp.to_string())
            .wait()
            .map_err(|e| anyhow!("zenoh: declare subscriber '{inp}': {e}"))?;
        Ok(Self {
            publisher,
            subscriber,
            mode,
            message: vec![0; bytes.max(HEADER)],
            _session: session,
        })
    }
}

fn parse(sample: &Sample) -> anyhow::Result<(u64, u64)> {
    let bytes = sample.payload().to_bytes();
    let field = |at: usize| -> anyhow::Result<u64> {
        let chunk = bytes.get(at..at + 8).ok_or_else(|| {
            anyhow!(
                "zenoh: ping-pong message of {} bytes is too short",
                bytes.len()
            )
        })?;
        let mut raw = [0u8; 8];
        raw.copy_from_slice(chunk);
        Ok(u64::from_le_bytes(raw))
    };
    Ok((field(0)?, field(8)?))
}

impl Endpoint for ZenohEndpoint {
    fn send(&mut self, seq: u64, stamp_ns: u64) -> anyhow::Result<()> {
        self.message[..8].copy_from_slice(&seq.to_le_bytes());
        self.message[8..HEADER].copy_from_slice(&stamp_ns.to_le_bytes());
        // zenoh takes ownership of the bytes it sends, so each message is a fresh copy.
        self.publisher
            .put(self.message.clone())
            .wait()
            .map_err(|e| anyhow!("zenoh: put: {e}"))
    }

    fn recv(&mut self, timeout: Duration) -> anyhow::Result<Option<(u64, u64)>> {
        let received = match self.mode {
            Mode::Event => self
                .subscriber
                .recv_timeout(timeout)
                .map_err(|e| anyhow!("zenoh: receive: {e}"))?,
            Mode::Poll => {
                let deadline = Instant::now() + timeout;
                let mut slice_end = Instant::now() + SPIN_SLICE;
                loop {
                    let got = self
                        .subscriber
                        .try_recv()
                        .map_err(|e| anyhow!("zenoh: receive: {e}"))?;
                    let now = Instant::now();
                    if got.is_some() || now >= deadline {
                        break got;
                    }
                    if now >= slice_end {
                        // zenoh's own threads may share this core: let them deliver.
                        std::thread::yield_now();
                        slice_end = Instant::now() + SPIN_SLICE;
                    }
                    std::hint::spin_loop();
                }
            }
        };
        received.as_ref().map(parse).transpose()
    }
}

/// Ping-pong messages of `bytes` bytes over zenoh between the plan's two cores in `mode`.
pub fn run(plan: &Plan, mode: Mode, bytes: usize) -> anyhow::Result<PingPongOutcome> {
    let endpoint = free_loopback_endpoint()?;
    let listen = open(&ZenohSettings::listen_on(&endpoint))?;
    let connect = open(&ZenohSettings::connect_to(&endpoint))?;
    let prefix = format!("{}/zenoh-{bytes}-{}", plan.instance, mode.name());
    let ping_key = format!("{prefix}/ping");
    let pong_key = format!("{prefix}/pong");
    let label = format!("zenoh {bytes} B {}", mode.name());
    pingpong::run(
        plan,
        &label,
        || ZenohEndpoint::new(listen, &ping_key, &pong_key, mode, bytes),
        || ZenohEndpoint::new(connect, &pong_key, &ping_key, mode, bytes),
    )
}
