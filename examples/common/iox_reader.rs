//! What both local examples need to read a shipcast payload over iceoryx2: the node (with the
//! instance's file prefix), the pub-sub service with shipcast's limits, and the listener of its
//! event service, which the publisher notifies after every sample.

use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use shipcast_wire::payload::limits;
use std::fmt::Debug;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Set by Ctrl-C or SIGTERM: the read loop ends and the node and its ports are dropped, which
/// removes their files. Regression (review): no handler was installed, so a signal killed the
/// reader and left its node's files behind.
static STOP: AtomicBool = AtomicBool::new(false);

pub struct Reader<T: Debug + ZeroCopySend + 'static> {
    // Kept alive for as long as the ports are used.
    _node: Node<ipc::Service>,
    pub subscriber: Subscriber<ipc::Service, T, ()>,
    pub listener: Listener<ipc::Service>,
    /// The full service name, instance prefix included.
    pub name: String,
}

impl<T: Debug + ZeroCopySend + 'static> Reader<T> {
    /// Wait up to half a second for the publisher's notification; false once the process was
    /// asked to stop (Ctrl-C).
    pub fn wait(&self) -> Result<bool, Box<dyn std::error::Error>> {
        match self.listener.timed_wait(|_| {}, Duration::from_millis(500)) {
            Ok(_) => Ok(!STOP.load(Ordering::Relaxed)),
            Err(ListenerWaitError::InterruptSignal) => Ok(false),
            Err(e) => Err(e.into()),
        }
    }
}

/// Open `shipcast/<service>` (after `<instance>/` when an instance is given) for reading `T`.
pub fn open<T: Debug + ZeroCopySend + 'static>(
    instance: &str,
    service: &str,
) -> Result<Reader<T>, Box<dyn std::error::Error>> {
    ctrlc::set_handler(|| STOP.store(true, Ordering::Relaxed))?;
    let mut name = format!("shipcast/{service}");
    let mut config = iceoryx2::config::Config::default();
    // A reader killed before (SIGKILL) left its node: removed when the next one starts.
    config.global.node.cleanup_dead_nodes_on_creation = true;
    if !instance.is_empty() {
        name = format!("{instance}/{name}");
        let prefix = format!("iox2_{instance}_");
        config.global.prefix = FileName::new(prefix.as_bytes())?;
    }
    let node = NodeBuilder::new()
        .config(&config)
        // Signals are this reader's own (STOP above).
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()?;
    // The same limits as the publishing service, so whichever process comes first creates a
    // service the other can open.
    let pubsub = node
        .service_builder(&name.as_str().try_into()?)
        .publish_subscribe::<T>()
        .max_publishers(limits::MAX_PUBLISHERS)
        .max_subscribers(limits::MAX_SUBSCRIBERS)
        .max_nodes(limits::MAX_NODES)
        .subscriber_max_buffer_size(limits::FORECAST_BUFFER)
        .history_size(limits::FORECAST_HISTORY)
        .enable_safe_overflow(true)
        .open_or_create()?;
    let subscriber = pubsub.subscriber_builder().create()?;
    let event_name = format!("{name}/event");
    let event = node
        .service_builder(&event_name.as_str().try_into()?)
        .event()
        .max_notifiers(limits::MAX_NOTIFIERS)
        .max_listeners(limits::MAX_LISTENERS)
        .max_nodes(limits::MAX_NODES)
        .open_or_create()?;
    let listener = event.listener_builder().create()?;
    Ok(Reader {
        _node: node,
        subscriber,
        listener,
        name,
    })
}
