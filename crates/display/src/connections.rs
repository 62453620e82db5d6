//! What one host can take of the display's server: at most [`MAX_CONNECTIONS`] connections
//! at once (a further one is closed as soon as it is accepted, and reported at most once per
//! [`REPORT_PERIOD`]), and a connection that does not send a complete request head within
//! [`HEAD_TIMEOUT`] is closed. Each connection is its own task, so a stalled one holds only its
//! own slot. The HTTP routes themselves are in [`crate::server`].

use axum::Router;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use std::convert::Infallible;
use std::io::ErrorKind;
use std::time::Duration;
use tokio::task::JoinSet;

/// The most connections served at once. Each holds a file descriptor, which the process
/// shares with its zenoh sockets (the usual soft limit is 1024), and a task with its buffers. A
/// page takes one event stream plus, for a few seconds after it loads, the connection that
/// fetched it, so 64 serves far more screens than a bridge has, while a host that opens
/// connections without end takes no more than 64 descriptors.
pub const MAX_CONNECTIONS: usize = 64;

/// How long a connection may take to send a complete request head (request line and headers),
/// counted from when it connects or from the end of its previous response. Any client on a
/// working network needs well under a second; one that sends nothing, or a byte at a time,
/// is closed before it can hold its slot for long.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// Connections closed for the cap are reported at most once per this period (the first at
/// once), with how many there were: a flood of connections must not become a flood of lines.
/// Accept errors are reported as seldom.
pub const REPORT_PERIOD: Duration = Duration::from_secs(10);

/// How long the accept loop pauses after an error other than a connection's own (out of file
/// descriptors or memory): such an error repeats until something is freed, and retrying at
/// once would only spin.
const ACCEPT_RETRY: Duration = Duration::from_secs(1);

/// What one host can take of the server: [`MAX_CONNECTIONS`] and [`HEAD_TIMEOUT`] unless a
/// test needs them small.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct ConnectionLimits {
    pub max_connections: usize,
    pub head_timeout: Duration,
}

impl Default for ConnectionLimits {
    fn default() -> Self {
        ConnectionLimits {
            max_connections: MAX_CONNECTIONS,
            head_timeout: HEAD_TIMEOUT,
        }
    }
}

/// Accept connections forever, each served by its own task in one set: the set's size is the
/// number of open connections, and dropping the set closes them all.
pub(crate) async fn accept_loop(
    listener: tokio::net::TcpListener,
    app: Router,
    limits: ConnectionLimits,
) -> Infallible {
    let mut http = hyper::server::conn::http1::Builder::new();
    // The head timeout needs a timer; without one hyper would wait for a head forever.
    http.timer(TokioTimer::new())
        .header_read_timeout(limits.head_timeout);
    let mut connections = JoinSet::new();
    let mut refusals = Refusals::new(REPORT_PERIOD);
    let mut accept_errors_reported: Option<tokio::time::Instant> = None;
    loop {
        let report_due = refusals.due_at();
        tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, peer)) => {
                    // Connections that ended since the last reap give their slots back first.
                    while connections.try_join_next().is_some() {}
                    if connections.len() >= limits.max_connections {
                        // Closed at once, before anything is read: a refused connection costs
                        // a descriptor only for this moment, and the client is not left queued.
                        drop(stream);
                        if let Some(report) = refusals.refuse(tokio::time::Instant::now()) {
                            report.log(limits.max_connections);
                        }
                        continue;
                    }
                    let service = TowerToHyperService::new(app.clone());
                    let connection = http.serve_connection(TokioIo::new(stream), service);
                    connections.spawn(async move {
                        // Errors here are the client's doing (it went away mid-response, sent
                        // no head in time, or sent garbage): worth a debug line, no more.
                        if let Err(e) = connection.await {
                            tracing::debug!("display: connection from {peer} ended: {e}");
                        }
                    });
                }
                // A connection that failed before it was accepted: the listener is fine.
                Err(e) if is_connection_error(e.kind()) => {
                    tracing::debug!("display: a connection failed before it was accepted: {e}");
                }
                Err(e) => {
                    let now = tokio::time::Instant::now();
                    if accept_errors_reported
                        .is_none_or(|t| now.duration_since(t) >= REPORT_PERIOD)
                    {
                        accept_errors_reported = Some(now);
                        tracing::warn!(
                            "display: cannot accept connections ({e}): retrying every {} s",
                            ACCEPT_RETRY.as_secs()
                        );
                    }
                    tokio::time::sleep(ACCEPT_RETRY).await;
                }
            },
            // Reap connections as they end, so that finished tasks do not pile up in the set.
            Some(_) = connections.join_next(), if !connections.is_empty() => {}
            // Refusals since the last report are reported once they are due, even when no
            // further connection comes to trigger it.
            () = tokio::time::sleep_until(report_due.unwrap_or_else(tokio::time::Instant::now)),
                if report_due.is_some() =>
            {
                if let Some(report) = refusals.report_if_due(tokio::time::Instant::now()) {
                    report.log(limits.max_connections);
                }
            }
        }
    }
}

/// Errors of one connection that `accept` passes on (the peer reset it, the network dropped
/// it): the next connection may be fine, so they neither pause the loop nor warn.
fn is_connection_error(kind: ErrorKind) -> bool {
    matches!(
        kind,
        ErrorKind::ConnectionAborted
            | ErrorKind::ConnectionReset
            | ErrorKind::ConnectionRefused
            | ErrorKind::Interrupted
            | ErrorKind::TimedOut
            | ErrorKind::HostUnreachable
            | ErrorKind::NetworkUnreachable
            | ErrorKind::NetworkDown
    )
}

/// Connections closed for the cap: counted, and reported the first at once, then at most once
/// per period with how many came since the previous report.
#[derive(Debug)]
struct Refusals {
    period: Duration,
    total: u64,
    unreported: u64,
    last_report: Option<tokio::time::Instant>,
}

/// One report: refused since the previous one, and since the server started.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct RefusalReport {
    refused: u64,
    total: u64,
}

impl RefusalReport {
    fn log(self, max_connections: usize) {
        tracing::warn!(
            refused = self.refused,
            refused_total = self.total,
            "display: {max_connections} connections open, the most it serves at once: new connections are closed unserved"
        );
    }
}

impl Refusals {
    fn new(period: Duration) -> Self {
        Refusals {
            period,
            total: 0,
            unreported: 0,
            last_report: None,
        }
    }

    /// Count one refused connection; the report to log, if one is due.
    fn refuse(&mut self, now: tokio::time::Instant) -> Option<RefusalReport> {
        self.total += 1;
        self.unreported += 1;
        self.report_if_due(now)
    }

    /// The report of the refusals not reported yet, if there are any and the period since the
    /// last report has passed.
    fn report_if_due(&mut self, now: tokio::time::Instant) -> Option<RefusalReport> {
        if self.unreported == 0 {
            return None;
        }
        if self
            .last_report
            .is_some_and(|t| now.duration_since(t) < self.period)
        {
            return None;
        }
        self.last_report = Some(now);
        Some(RefusalReport {
            refused: std::mem::take(&mut self.unreported),
            total: self.total,
        })
    }

    /// When the refusals not reported yet will be due (None: none are waiting).
    fn due_at(&self) -> Option<tokio::time::Instant> {
        match (self.unreported, self.last_report) {
            (0, _) => None,
            (_, Some(t)) => Some(t + self.period),
            (_, None) => Some(tokio::time::Instant::now()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_are_reported_at_once_then_at_most_once_per_period() {
        let period = Duration::from_secs(10);
        let mut refusals = Refusals::new(period);
        let t0 = tokio::time::Instant::now();
        assert_eq!(refusals.due_at(), None);
        assert_eq!(
            refusals.refuse(t0),
            Some(RefusalReport {
                refused: 1,
                total: 1
            })
        );
        assert_eq!(refusals.due_at(), None, "nothing waits after a report");
        for k in 1..=5 {
            assert_eq!(refusals.refuse(t0 + Duration::from_secs(k)), None);
        }
        assert_eq!(refusals.due_at(), Some(t0 + period));
        assert_eq!(refusals.report_if_due(t0 + Duration::from_secs(9)), None);
        assert_eq!(
            refusals.report_if_due(t0 + period),
            Some(RefusalReport {
                refused: 5,
                total: 6
            })
        );
        assert_eq!(refusals.report_if_due(t0 + period * 3), None);
        // After a quiet spell, the next refusal is reported at once again.
        assert_eq!(
            refusals.refuse(t0 + period * 3),
            Some(RefusalReport {
                refused: 1,
                total: 7
            })
        );
    }
}
