//! One vessel's motion as its predictor republishes it on zenoh (`.../motion`), checked
//! sample by sample (`MotionGate`) and kept for the last seconds: what the services that verify
//! their own forecasts against what happened (`shipcast relative`, `shipcast crane`) follow.

use shipcast_pipeline::observed::MotionHistory;
use shipcast_pipeline::transport::forecast_check::PublisherWatch;
use shipcast_pipeline::transport::motion_gate::{Admitted, MotionGate};
use shipcast_pipeline::transport::zenoh::{LatestSubscriber, Received};
use shipcast_pipeline::transport::Names;

/// One vessel's observed motion over zenoh (`.../motion`, from its predictor), checked.
pub struct FollowedMotion {
    /// The service that follows it, for its log lines.
    service: &'static str,
    key: String,
    subscriber: LatestSubscriber,
    publishers: PublisherWatch,
    pub gate: MotionGate,
    pub history: MotionHistory,
    /// The sample being checked, its buffers reused from one to the next.
    received: Received,
}

impl FollowedMotion {
    /// Samples received between two polls (every 20 ms) that the subscriber can hold: 8 s at
    /// 8 Hz, so a poll delayed by a decision loses none.
    const QUEUE: usize = 64;

    pub fn new(
        service: &'static str,
        session: &zenoh::Session,
        names: &Names,
        keep_s: f64,
        rate_hz: f64,
    ) -> anyhow::Result<Self> {
        let key = names.motion();
        Ok(Self {
            service,
            subscriber: LatestSubscriber::keeping(session, &key, Self::QUEUE)?,
            publishers: PublisherWatch::new(session, &key)?,
            gate: MotionGate::new(),
            history: MotionHistory::new(rate_hz, keep_s),
            key,
            received: Received::empty(),
        })
    }

    /// Warns, and returns true, if no sample has arrived: the following service's `consequence`
    /// (what stays unverified) is named in the warning.
    pub fn warn_if_silent(&self, consequence: &str) -> bool {
        let silent = self.history.is_empty();
        if silent {
            tracing::warn!(
                "{}: no motion received on {} (a predictor older than this one publishes none): {consequence}",
                self.service,
                self.key
            );
        }
        silent
    }

    /// Takes what arrived; true if the vessel's record started afresh (a new producer run or
    /// a new predictor), so forecasts waiting on the old record's clock cannot be verified.
    pub fn poll(&mut self) -> anyhow::Result<bool> {
        let mut restarted = false;
        self.publishers.update(&mut self.gate.live);
        while self.subscriber.try_recv_into(&mut self.received)? {
            self.publishers.update(&mut self.gate.live);
            match self.gate.check(&self.received, &mut self.history) {
                Ok(Admitted::Continues) => {}
                Ok(Admitted::Restarted) => {
                    restarted = true;
                    tracing::info!(
                        "{}: the motion on {} started a new record (producer or predictor restarted)",
                        self.service,
                        self.key
                    );
                }
                Err(e) => {
                    shipcast_pipeline::warn_rejected!(
                        self.gate.log,
                        self.gate.rejected,
                        "{}: motion sample on {} rejected: {e}",
                        self.service,
                        self.key
                    );
                }
            }
        }
        Ok(restarted)
    }
}
