//! iceoryx2 plumbing: a node per process (cleaning up after crashed processes), publish-subscribe
//! ports paired with an event service for wake-ups, and two ways to wait for data: event wake-up
//! (the default, no CPU while idle) or busy polling (lowest latency, one core spinning).

use crate::transport::naming::Names;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use shipcast_wire::payload::limits;
use std::fmt::Debug;
use std::time::{Duration, Instant};

/// The iceoryx2 service flavour used everywhere: inter-process, ports stay on their thread.
pub type Ipc = ipc::Service;

/// An iceoryx2 failure, with what was being done.
#[derive(Debug, thiserror::Error)]
#[error("iceoryx2: {context}: {detail}")]
pub struct IoxError {
    pub context: String,
    pub detail: String,
}

fn err<E: Debug>(context: impl Into<String>) -> impl FnOnce(E) -> IoxError {
    move |e| IoxError {
        context: context.into(),
        detail: format!("{e:?}"),
    }
}

/// How a subscriber waits for new samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WaitMode {
    /// Sleep until the publisher's notifier wakes us (or the timeout passes).
    #[default]
    Event,
    /// Spin on the subscriber's queue: lowest latency, one core fully used.
    BusyPoll,
}

/// The iceoryx2 configuration of a pipeline: the file prefix keeps parallel pipelines (tests)
/// apart, and dead nodes are cleaned whenever a node is created.
pub fn config(names: &Names) -> Result<Config, IoxError> {
    let mut config = Config::default();
    let prefix = names.iox_prefix();
    config.global.prefix = FileName::new(prefix.as_bytes()).map_err(err(format!(
        "file prefix '{prefix}' is not a valid file name"
    )))?;
    config.global.node.cleanup_dead_nodes_on_creation = true;
    Ok(config)
}

/// Create this process's node. Resources left by crashed processes (dead nodes) of the same
/// pipeline are removed first, so that a restarted service does not trip over them.
pub fn node(names: &Names, node_name: &str) -> Result<Node<Ipc>, IoxError> {
    let config = config(names)?;
    let name: NodeName = node_name
        .try_into()
        .map_err(err(format!("node name '{node_name}'")))?;
    let node = NodeBuilder::new()
        .name(&name)
        .config(&config)
        // Ctrl-C / SIGTERM are handled by the services themselves (ctrlc crate).
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<Ipc>()
        .map_err(err("create node"))?;
    let state = node.try_cleanup_dead_nodes();
    if state.cleanups > 0 || state.failed_cleanups > 0 {
        tracing::info!(
            cleaned = state.cleanups,
            failed = state.failed_cleanups,
            "removed resources of dead iceoryx2 nodes"
        );
    }
    Ok(node)
}

fn service_name(name: &str) -> Result<ServiceName, IoxError> {
    name.try_into()
        .map_err(err(format!("service name '{name}'")))
}

/// Buffer and history of a pub-sub service, chosen per payload.
#[derive(Debug, Clone, Copy)]
pub struct Sizing {
    pub buffer: usize,
    pub history: usize,
}

impl Sizing {
    pub const MOTION: Sizing = Sizing {
        buffer: limits::MOTION_BUFFER,
        history: limits::MOTION_HISTORY,
    };
    pub const FORECAST: Sizing = Sizing {
        buffer: limits::FORECAST_BUFFER,
        history: limits::FORECAST_HISTORY,
    };
}

type PubSubFactory<T> = iceoryx2::service::port_factory::publish_subscribe::PortFactory<Ipc, T, ()>;
type EventFactory = iceoryx2::service::port_factory::event::PortFactory<Ipc>;

fn open_pubsub<T: Debug + ZeroCopySend + 'static>(
    node: &Node<Ipc>,
    name: &str,
    sizing: Sizing,
) -> Result<(PubSubFactory<T>, EventFactory), IoxError> {
    let pubsub = node
        .service_builder(&service_name(name)?)
        .publish_subscribe::<T>()
        .max_publishers(limits::MAX_PUBLISHERS)
        .max_subscribers(limits::MAX_SUBSCRIBERS)
        .max_nodes(limits::MAX_NODES)
        .subscriber_max_buffer_size(sizing.buffer)
        .history_size(sizing.history)
        // A full subscriber queue overwrites its oldest sample: a slow or dead consumer never
        // blocks the publisher; the consumer sees the gap in seq and counts it as lost.
        .enable_safe_overflow(true)
        .open_or_create()
        .map_err(err(format!("open or create service '{name}'")))?;
    let event_name = Names::event_of(name);
    let event = node
        .service_builder(&service_name(&event_name)?)
        .event()
        .max_notifiers(limits::MAX_NOTIFIERS)
        .max_listeners(limits::MAX_LISTENERS)
        .max_nodes(limits::MAX_NODES)
        .open_or_create()
        .map_err(err(format!("open or create event service '{event_name}'")))?;
    Ok((pubsub, event))
}

/// Publishes `T` on a service and wakes its listeners after each sample.
pub struct IoxPublisher<T: Debug + ZeroCopySend + 'static> {
    publisher: Publisher<Ipc, T, ()>,
    notifier: Notifier<Ipc>,
    services: (PubSubFactory<T>, EventFactory),
}

impl<T: Debug + ZeroCopySend + Copy + 'static> IoxPublisher<T> {
    pub fn new(node: &Node<Ipc>, name: &str, sizing: Sizing) -> Result<Self, IoxError> {
        let (pubsub, event) = open_pubsub::<T>(node, name, sizing)?;
        let publisher = pubsub
            .publisher_builder()
            .create()
            .map_err(err(format!("create publisher on '{name}'")))?;
        let notifier = event
            .notifier_builder()
            .create()
            .map_err(err(format!("create notifier on '{name}'")))?;
        Ok(Self {
            publisher,
            notifier,
            services: (pubsub, event),
        })
    }

    /// The id of this publisher port, as subscribers see it in each sample's origin.
    pub fn id(&self) -> u128 {
        self.publisher.id().value()
    }

    /// Subscribers currently connected to the service (any process).
    pub fn subscribers(&self) -> usize {
        self.services.0.dynamic_config().number_of_subscribers()
    }

    /// Write `value` into a loaned shared-memory sample, send it and wake the subscribers.
    /// Returns the number of subscribers reached.
    ///
    /// The value is copied once, straight from `value` into the loaned sample
    /// (`send_copy(*value)` would copy it twice: onto the stack for the call, then into the
    /// sample; for a 6 KB forecast that doubles the publisher's share of the path). The one
    /// allocation per send left is iceoryx2 0.10's own: every loan creates the sample's shared
    /// state behind an `Arc` (`ChunkMutSharedState::new`), whichever way the sample is written.
    pub fn send(&self, value: &T) -> Result<usize, IoxError> {
        let mut sample = self.publisher.loan_uninit().map_err(err("loan sample"))?;
        // SAFETY: the loaned chunk holds one `T`, sized and aligned for it by iceoryx2, and
        // lies in the service's shared memory, so it cannot overlap `value`; `T: Copy`, so a
        // bitwise copy of a valid `T` is a valid `T` and the payload is initialised after the
        // copy, as `assume_init` requires.
        let sample = unsafe {
            std::ptr::copy_nonoverlapping(value, sample.payload_mut().as_mut_ptr(), 1);
            sample.assume_init()
        };
        let n = sample.send().map_err(err("send sample"))?;
        self.notifier.notify().map_err(err("notify listeners"))?;
        Ok(n)
    }
}

/// Receives `T` from a service, waiting by event wake-up or busy polling.
pub struct IoxSubscriber<T: Debug + ZeroCopySend + 'static> {
    subscriber: Subscriber<Ipc, T, ()>,
    listener: Listener<Ipc>,
    mode: WaitMode,
    services: (PubSubFactory<T>, EventFactory),
}

impl<T: Debug + ZeroCopySend + Copy + 'static> IoxSubscriber<T> {
    pub fn new(
        node: &Node<Ipc>,
        name: &str,
        sizing: Sizing,
        mode: WaitMode,
    ) -> Result<Self, IoxError> {
        let (pubsub, event) = open_pubsub::<T>(node, name, sizing)?;
        let subscriber = pubsub
            .subscriber_builder()
            .buffer_size(sizing.buffer)
            .create()
            .map_err(err(format!("create subscriber on '{name}'")))?;
        let listener = event
            .listener_builder()
            .create()
            .map_err(err(format!("create listener on '{name}'")))?;
        Ok(Self {
            subscriber,
            listener,
            mode,
            services: (pubsub, event),
        })
    }

    /// Wait until data may be available or `timeout` passes. Spurious returns are allowed:
    /// callers drain with [`Self::receive`] until it returns `None`.
    pub fn wait(&self, timeout: Duration) -> Result<(), IoxError> {
        match self.mode {
            WaitMode::Event => match self.listener.timed_wait(|_| {}, timeout) {
                // A signal (Ctrl-C, SIGTERM) ends the wait early; the caller checks its stop flag.
                Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                Err(e) => return Err(err("wait for event")(e)),
            },
            WaitMode::BusyPoll => {
                let deadline = Instant::now() + timeout;
                while !self.subscriber.has_samples().map_err(err("poll"))? {
                    if Instant::now() >= deadline {
                        break;
                    }
                    std::hint::spin_loop();
                }
            }
        }
        Ok(())
    }

    /// Take the oldest unread sample, copied out of shared memory.
    pub fn receive(&self) -> Result<Option<T>, IoxError> {
        Ok(self
            .subscriber
            .receive()
            .map_err(err("receive sample"))?
            .map(|sample| *sample.payload()))
    }

    /// Take the oldest unread sample with the id of the publisher port that sent it (recorded
    /// by iceoryx2, not by the sender).
    pub fn receive_with_origin(&self) -> Result<Option<(T, u128)>, IoxError> {
        Ok(self
            .subscriber
            .receive()
            .map_err(err("receive sample"))?
            .map(|sample| (*sample.payload(), sample.origin().value())))
    }

    /// The ids of the publisher ports connected to the service now, into `out` (cleared
    /// first; its capacity is reused).
    pub fn publishers(&self, out: &mut Vec<u128>) {
        out.clear();
        self.services.0.dynamic_config().list_publishers(|details| {
            out.push(details.publisher_id.value());
            CallbackProgression::Continue
        });
    }

    /// Take every unread sample and keep only the newest (consumers that want the latest).
    pub fn latest(&self) -> Result<Option<T>, IoxError> {
        let mut newest = None;
        while let Some(v) = self.receive()? {
            newest = Some(v);
        }
        Ok(newest)
    }
}

/// Remove the shared-memory files iceoryx2 leaves under `prefix` once every node of a run is
/// gone (a 16-byte management segment per file prefix); returns how many were removed.
pub fn remove_leftovers(prefix: &str) -> usize {
    let Ok(dir) = std::fs::read_dir("/dev/shm") else {
        return 0;
    };
    dir.flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use shipcast_wire::payload::{Forecast, MotionSample};

    fn unique_names(tag: &str) -> Names {
        let instance = crate::transport::unique_instance(&format!("unit-{tag}"));
        Names::new(Some(&instance), "testvessel").unwrap()
    }

    /// Removes the 16-byte management segment iceoryx2 keeps per file prefix, once the test's
    /// nodes are gone (the prefix is unique to the test).
    struct PrefixCleanup(String);

    impl Drop for PrefixCleanup {
        fn drop(&mut self) {
            remove_leftovers(&self.0);
        }
    }

    #[test]
    fn samples_round_trip_with_event_wake_up() {
        let names = unique_names("rt");
        let _cleanup = PrefixCleanup(names.iox_prefix());
        let node = node(&names, "unit").unwrap();
        let sub = IoxSubscriber::<MotionSample>::new(
            &node,
            &names.motion(),
            Sizing::MOTION,
            WaitMode::Event,
        )
        .unwrap();
        let publ =
            IoxPublisher::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION).unwrap();
        for seq in 0..5 {
            let s = MotionSample {
                seq,
                time_s: seq as f64 * 0.125,
                dof: [seq as f64; 6],
                ..MotionSample::default()
            };
            assert_eq!(publ.send(&s).unwrap(), 1);
        }
        sub.wait(Duration::from_secs(1)).unwrap();
        let got: Vec<u64> = std::iter::from_fn(|| sub.receive().unwrap())
            .map(|s| s.seq)
            .collect();
        assert_eq!(got, vec![0, 1, 2, 3, 4]);
        assert_eq!(sub.receive().unwrap(), None);
    }

    #[test]
    fn samples_name_the_publisher_port_that_sent_them() {
        let names = unique_names("origin");
        let _cleanup = PrefixCleanup(names.iox_prefix());
        let node = node(&names, "unit").unwrap();
        let sub = IoxSubscriber::<MotionSample>::new(
            &node,
            &names.motion(),
            Sizing::MOTION,
            WaitMode::Event,
        )
        .unwrap();
        let mut connected = Vec::new();
        sub.publishers(&mut connected);
        assert!(connected.is_empty());
        let a = IoxPublisher::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION).unwrap();
        let b = IoxPublisher::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION).unwrap();
        assert_ne!(a.id(), b.id());
        sub.publishers(&mut connected);
        connected.sort_unstable();
        let mut both = vec![a.id(), b.id()];
        both.sort_unstable();
        assert_eq!(connected, both);
        a.send(&MotionSample::default()).unwrap();
        b.send(&MotionSample::default()).unwrap();
        assert_eq!(
            sub.receive_with_origin().unwrap().map(|r| r.1),
            Some(a.id())
        );
        assert_eq!(
            sub.receive_with_origin().unwrap().map(|r| r.1),
            Some(b.id())
        );
        drop(b);
        sub.publishers(&mut connected);
        assert_eq!(connected, vec![a.id()]);
    }

    #[test]
    fn full_queue_overwrites_oldest_instead_of_blocking() {
        let names = unique_names("ovf");
        let _cleanup = PrefixCleanup(names.iox_prefix());
        let node = node(&names, "unit").unwrap();
        let sub = IoxSubscriber::<Forecast>::new(
            &node,
            &names.forecast(),
            Sizing::FORECAST,
            WaitMode::BusyPoll,
        )
        .unwrap();
        let publ =
            IoxPublisher::<Forecast>::new(&node, &names.forecast(), Sizing::FORECAST).unwrap();
        let n = limits::FORECAST_BUFFER as u64 * 3;
        for seq in 0..n {
            publ.send(&Forecast {
                seq,
                ..Forecast::default()
            })
            .unwrap();
        }
        sub.wait(Duration::from_millis(100)).unwrap();
        let first = sub.receive().unwrap().unwrap().seq;
        assert_eq!(first, n - limits::FORECAST_BUFFER as u64);
        assert_eq!(sub.latest().unwrap().unwrap().seq, n - 1);
    }
}
