//! Receive stamps of the predictor service (`shipcast predictor --bench-stamps`): for every
//! MotionSample it takes from its subscriber, the service publishes `{seq, stamp_ns,
//! received_ns}` on `<instance>/shipcast/<vessel>/bench/receive`, so the benchmark measures
//! producer -> predictor through the real process. For a sample that completed a forecast, the
//! stamp also says when each step of publishing it ended ([`PublishStages`]), so the report can
//! show where the predictor's share of the forecast paths goes.
//!
//! The stamps go out without an event notification: nobody waits on them with low latency
//! (the latency is inside the payload), and a notify would cost the predictor a system call
//! per sample. The reader drains them periodically, so the queue holds a few seconds of samples.

use super::histogram::LatencyRecorder;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use shipcast_pipeline::transport::iox::{IoxError, Ipc};
use std::fmt::Debug;

/// When the predictor took one MotionSample from its subscriber, and what it did with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[type_name("shipcast::ReceiveStamp")]
#[repr(C)]
pub struct ReceiveStamp {
    /// `MotionSample::seq`.
    pub seq: u64,
    /// `MotionSample::stamp_ns` (CLOCK_MONOTONIC at the producer).
    pub stamp_ns: u64,
    /// CLOCK_MONOTONIC right after the sample was taken from the subscriber.
    pub received_ns: u64,
    /// Set when this sample completed a forecast; all zero otherwise.
    pub stages: PublishStages,
}

/// When each step of publishing one forecast ended (CLOCK_MONOTONIC, ns).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[type_name("shipcast::PublishStages")]
#[repr(C)]
pub struct PublishStages {
    /// Forecast computed (`Forecast::issued_stamp_ns`).
    pub issued_ns: u64,
    /// Sent on iceoryx2, listeners notified.
    pub local_sent_ns: u64,
    /// JSON encoded.
    pub encoded_ns: u64,
    /// zenoh put returned.
    pub zenoh_put_ns: u64,
}

/// Number of steps in [`PublishStages`].
pub const STAGES: usize = 4;

/// The steps of the predictor's work on a sample that completes a forecast, in order.
pub const STAGE_NAMES: [&str; STAGES] = [
    "receive -> forecast computed (decimation, six-DOF forecast)",
    "iceoryx2 send + notify",
    "JSON encoding",
    "zenoh put",
];

impl PublishStages {
    /// Duration of each step of [`STAGE_NAMES`] after `received_ns`, or None if this sample
    /// completed no forecast.
    pub fn durations_ns(&self, received_ns: u64) -> Option<[u64; STAGES]> {
        if self.issued_ns == 0 {
            return None;
        }
        let marks = [
            received_ns,
            self.issued_ns,
            self.local_sent_ns,
            self.encoded_ns,
            self.zenoh_put_ns,
        ];
        Some(std::array::from_fn(|i| {
            marks[i + 1].saturating_sub(marks[i])
        }))
    }
}

/// Stamps a reader can hold between two drains (about 4 s at 1 kHz).
pub const STAMP_BUFFER: usize = 4096;
const MAX_PORTS: usize = 4;

/// The error of a failed call; `context` becomes a `String` only then (a `&str` context
/// allocates nothing on success: stamps are sent for every sample).
fn err<E: Debug>(context: impl Into<String>) -> impl FnOnce(E) -> IoxError {
    move |e| IoxError {
        context: context.into(),
        detail: format!("{e:?}"),
    }
}

type Factory =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Ipc, ReceiveStamp, ()>;

/// Both sides open the service with the same limits, whichever comes first creates it.
fn open(node: &Node<Ipc>, name: &str) -> Result<Factory, IoxError> {
    let service: ServiceName = name
        .try_into()
        .map_err(err(format!("service name '{name}'")))?;
    node.service_builder(&service)
        .publish_subscribe::<ReceiveStamp>()
        .max_publishers(MAX_PORTS)
        .max_subscribers(MAX_PORTS)
        .subscriber_max_buffer_size(STAMP_BUFFER)
        .history_size(0)
        // A reader that falls behind loses the oldest stamps (counted as gaps), the predictor
        // never blocks.
        .enable_safe_overflow(true)
        .open_or_create()
        .map_err(err(format!("open or create service '{name}'")))
}

/// The predictor's side.
pub struct StampPublisher {
    publisher: Publisher<Ipc, ReceiveStamp, ()>,
    _service: Factory,
}

impl StampPublisher {
    pub fn new(node: &Node<Ipc>, name: &str) -> Result<Self, IoxError> {
        let service = open(node, name)?;
        let publisher = service
            .publisher_builder()
            .create()
            .map_err(err(format!("create publisher on '{name}'")))?;
        Ok(Self {
            publisher,
            _service: service,
        })
    }

    pub fn send(&self, stamp: ReceiveStamp) -> Result<(), IoxError> {
        self.publisher
            .send_copy(stamp)
            .map_err(err("send receive stamp"))?;
        Ok(())
    }
}

/// The benchmark's side: drains the stamps and records stamp -> received.
pub struct StampReader {
    subscriber: Subscriber<Ipc, ReceiveStamp, ()>,
    _service: Factory,
}

impl StampReader {
    pub fn new(node: &Node<Ipc>, name: &str) -> Result<Self, IoxError> {
        let service = open(node, name)?;
        let subscriber = service
            .subscriber_builder()
            .buffer_size(STAMP_BUFFER)
            .create()
            .map_err(err(format!("create subscriber on '{name}'")))?;
        Ok(Self {
            subscriber,
            _service: service,
        })
    }

    /// Take every waiting stamp into `tally`.
    pub fn drain(&self, tally: &mut StampTally) -> Result<(), IoxError> {
        while let Some(s) = self.subscriber.receive().map_err(err("receive stamp"))? {
            tally.record(s.payload());
        }
        Ok(())
    }
}

/// Latency of the measured stamps (seq >= `first_measured`) and gaps between them.
#[derive(Debug, Default)]
pub struct StampTally {
    pub first_measured: u64,
    pub latency: LatencyRecorder,
    /// Durations of the steps of [`STAGE_NAMES`], for measured samples that completed a forecast.
    pub stages: [LatencyRecorder; STAGES],
    /// Measured samples missing between received ones (gaps in seq).
    pub lost: u64,
    last_seq: Option<u64>,
}

impl StampTally {
    pub fn new(first_measured: u64) -> Self {
        Self {
            first_measured,
            ..Self::default()
        }
    }

    pub fn record(&mut self, s: &ReceiveStamp) {
        if s.seq < self.first_measured {
            return;
        }
        let expected = self.last_seq.map_or(self.first_measured, |l| l + 1);
        self.lost += s.seq.saturating_sub(expected);
        self.last_seq = Some(s.seq);
        self.latency.record_between(s.stamp_ns, s.received_ns);
        if let Some(durations) = s.stages.durations_ns(s.received_ns) {
            for (rec, ns) in self.stages.iter_mut().zip(durations) {
                rec.record_ns(ns);
            }
        }
    }

    /// Measured seqs seen or lost so far, for the row's expected count.
    pub fn seen(&self) -> u64 {
        self.last_seq.map_or(0, |l| l + 1 - self.first_measured)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shipcast_pipeline::transport::{iox, Names};

    #[test]
    fn warm_up_is_skipped_and_gaps_are_lost() {
        let mut t = StampTally::new(10);
        for seq in [3, 9, 11, 12, 15] {
            t.record(&ReceiveStamp {
                seq,
                stamp_ns: 1_000,
                received_ns: 1_250,
                ..ReceiveStamp::default()
            });
        }
        // 10 (before 11), 13 and 14 are missing; 3 and 9 are warm-up.
        assert_eq!((t.latency.count(), t.lost, t.seen()), (3, 3, 6));
        assert_eq!(t.latency.quantile_ns(0.5), 250);
        assert!(t.stages.iter().all(|r| r.count() == 0));
        // A sample that completed a forecast: each step from the end of the one before.
        t.record(&ReceiveStamp {
            seq: 16,
            stamp_ns: 1_000,
            received_ns: 1_250,
            stages: PublishStages {
                issued_ns: 1_300,
                local_sent_ns: 1_370,
                encoded_ns: 1_450,
                zenoh_put_ns: 1_540,
            },
        });
        let p50: Vec<u64> = t.stages.iter().map(|r| r.quantile_ns(0.5)).collect();
        assert_eq!(p50, [50, 70, 80, 90]);
    }

    #[test]
    fn stamps_round_trip_over_iceoryx2() {
        let instance = shipcast_pipeline::transport::unique_instance("unit-stamps");
        let names = Names::new(Some(&instance), "v").unwrap();
        let node = iox::node(&names, "unit").unwrap();
        let name = names.bench_receive();
        let reader = StampReader::new(&node, &name).unwrap();
        let publisher = StampPublisher::new(&node, &name).unwrap();
        for seq in 0..5 {
            publisher
                .send(ReceiveStamp {
                    seq,
                    stamp_ns: 100 * seq,
                    received_ns: 100 * seq + 40,
                    ..ReceiveStamp::default()
                })
                .unwrap();
        }
        let mut tally = StampTally::new(1);
        reader.drain(&mut tally).unwrap();
        assert_eq!((tally.latency.count(), tally.lost, tally.seen()), (4, 0, 4));
        assert_eq!(tally.latency.quantile_ns(1.0), 40);
        drop((reader, publisher, node));
        // The run's management segment is left behind by iceoryx2 and removed here.
        assert!(shipcast_pipeline::transport::iox::remove_leftovers(&names.iox_prefix()) >= 1);
        assert_eq!(
            shipcast_pipeline::transport::iox::remove_leftovers(&names.iox_prefix()),
            0
        );
    }
}
