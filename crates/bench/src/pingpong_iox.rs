//! Raw iceoryx2 floor: ping-pong of a shipcast payload type between two pinned threads, with no
//! shipcast code in the path. Event mode pairs each pub-sub service with an event service and
//! blocks in the Listener; poll mode spins on the subscriber and sends no notification at all.

use super::pingpong::{self, Endpoint, PingPongOutcome};
use super::plan::{Mode, Plan};
use anyhow::{anyhow, Context};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use shipcast_pipeline::transport::iox::{self, Ipc};
use shipcast_pipeline::transport::Names;
use shipcast_wire::payload::{Forecast, MotionSample};
use std::fmt::Debug;
use std::time::{Duration, Instant};

/// A payload that can carry a ping-pong sequence number and stamp.
pub trait Stamped: Debug + ZeroCopySend + Copy + Default + Send + 'static {
    /// Short name used in service names and logs.
    const TAG: &'static str;
    fn set_stamp(&mut self, seq: u64, stamp_ns: u64);
    fn stamp(&self) -> (u64, u64);
}

impl Stamped for MotionSample {
    const TAG: &'static str = "motion";
    fn set_stamp(&mut self, seq: u64, stamp_ns: u64) {
        self.seq = seq;
        self.stamp_ns = stamp_ns;
    }
    fn stamp(&self) -> (u64, u64) {
        (self.seq, self.stamp_ns)
    }
}

impl Stamped for Forecast {
    const TAG: &'static str = "forecast";
    fn set_stamp(&mut self, seq: u64, stamp_ns: u64) {
        self.seq = seq;
        self.issued_stamp_ns = stamp_ns;
    }
    fn stamp(&self) -> (u64, u64) {
        (self.seq, self.issued_stamp_ns)
    }
}

/// Queue depth of the ping-pong services: one message is in flight at a time.
const BUFFER: usize = 4;

fn io<E: Debug>(what: &'static str) -> impl FnOnce(E) -> anyhow::Error {
    move |e| anyhow!("iceoryx2: {what}: {e:?}")
}

/// One side: publishes on `out`, subscribes to `inp`.
struct IoxEndpoint<T: Stamped> {
    publisher: Publisher<Ipc, T, ()>,
    subscriber: Subscriber<Ipc, T, ()>,
    /// Only in event mode: wakes the other side / is woken by it.
    notifier: Option<Notifier<Ipc>>,
    listener: Option<Listener<Ipc>>,
    message: T,
    // Ports stay valid without them, but keeping the node alive states the intent.
    _node: Node<Ipc>,
}

fn service_name(name: &str) -> anyhow::Result<ServiceName> {
    name.try_into()
        .map_err(|e| anyhow!("iceoryx2: service name '{name}': {e:?}"))
}

impl<T: Stamped> IoxEndpoint<T> {
    fn new(names: &Names, side: &str, out: &str, inp: &str, mode: Mode) -> anyhow::Result<Self> {
        let node = iox::node(names, &format!("bench-{side}"))?;
        let open = |topic: &str| {
            node.service_builder(&service_name(topic)?)
                .publish_subscribe::<T>()
                .subscriber_max_buffer_size(BUFFER)
                .history_size(0)
                .enable_safe_overflow(true)
                .open_or_create()
                .map_err(io("open or create ping-pong service"))
        };
        let publisher = open(out)?
            .publisher_builder()
            .create()
            .map_err(io("create publisher"))?;
        let subscriber = open(inp)?
            .subscriber_builder()
            .buffer_size(BUFFER)
            .create()
            .map_err(io("create subscriber"))?;
        let (notifier, listener) = match mode {
            Mode::Poll => (None, None),
            Mode::Event => {
                let event = |topic: &str| {
                    node.service_builder(&service_name(&Names::event_of(topic))?)
                        .event()
                        .open_or_create()
                        .map_err(io("open or create event service"))
                };
                let notifier = event(out)?
                    .notifier_builder()
                    .create()
                    .map_err(io("create notifier"))?;
                let listener = event(inp)?
                    .listener_builder()
                    .create()
                    .map_err(io("create listener"))?;
                (Some(notifier), Some(listener))
            }
        };
        Ok(Self {
            publisher,
            subscriber,
            notifier,
            listener,
            message: T::default(),
            _node: node,
        })
    }

    fn take(&self) -> anyhow::Result<Option<(u64, u64)>> {
        Ok(self
            .subscriber
            .receive()
            .map_err(io("receive"))?
            .map(|s| s.payload().stamp()))
    }
}

impl<T: Stamped> Endpoint for IoxEndpoint<T> {
    fn send(&mut self, seq: u64, stamp_ns: u64) -> anyhow::Result<()> {
        self.message.set_stamp(seq, stamp_ns);
        self.publisher.send_copy(self.message).map_err(io("send"))?;
        if let Some(n) = &self.notifier {
            n.notify().map_err(io("notify"))?;
        }
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> anyhow::Result<Option<(u64, u64)>> {
        if let Some(v) = self.take()? {
            return Ok(Some(v));
        }
        match &self.listener {
            Some(listener) => {
                listener
                    .timed_wait(|_| {}, timeout)
                    .map_err(io("wait for event"))?;
                self.take()
            }
            None => {
                let deadline = Instant::now() + timeout;
                loop {
                    if let Some(v) = self.take()? {
                        return Ok(Some(v));
                    }
                    if Instant::now() >= deadline {
                        return Ok(None);
                    }
                    std::hint::spin_loop();
                }
            }
        }
    }
}

/// Ping-pong `T` over iceoryx2 between the plan's two cores in `mode`.
pub fn run<T: Stamped>(plan: &Plan, mode: Mode) -> anyhow::Result<PingPongOutcome> {
    // One instance (iceoryx2 file prefix) per run; the measurements run one after the other
    // and differ by service name.
    let names = Names::new(Some(&plan.instance), "bench").context("benchmark instance name")?;
    let base = format!("{}/bench/iox-{}-{}", plan.instance, T::TAG, mode.name());
    let ping_topic = format!("{base}/ping");
    let pong_topic = format!("{base}/pong");
    let label = format!("iceoryx2 {} {}", T::TAG, mode.name());
    pingpong::run(
        plan,
        &label,
        || IoxEndpoint::<T>::new(&names, "ping", &ping_topic, &pong_topic, mode),
        || IoxEndpoint::<T>::new(&names, "pong", &pong_topic, &ping_topic, mode),
    )
}
