//! What one host can take of the display's server: at most [`MAX_CONNECTIONS`] connections
//! at once, and [`MAX_CONNECTIONS_PER_HOST`] of them from one address (a further one is closed
//! as soon as it is accepted, and reported at most once per [`REPORT_PERIOD`]), a connection that does not send a complete request head within
//! [`HEAD_TIMEOUT`] is closed, and so is one whose client takes nothing sent for
//! [`WRITE_TIMEOUT`] (also reported at most once per period). Each connection is its own task,
//! so a stalled one holds only its own slot. The HTTP routes themselves are in
//! [`crate::server`].

use crate::tally::{Report, Tally};
use crate::write_timeout::{is_write_stall, WriteTimeout};
use axum::Router;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use std::collections::HashMap;
use std::convert::Infallible;
use std::future::Future;
use std::io::ErrorKind;
use std::net::{IpAddr, SocketAddr};
use std::time::Duration;
use tokio::net::TcpStream;
use tokio::task::{JoinError, JoinSet};
use tokio::time::Instant;

/// The most connections served at once. Each holds a file descriptor, which the process
/// shares with its zenoh sockets (the usual soft limit is 1024), and a task with its buffers. A
/// page takes one event stream plus, for a few seconds after it loads, the connection that
/// fetched it, so 64 serves far more screens than a bridge has, while a host that opens
/// connections without end takes no more than 64 descriptors.
pub const MAX_CONNECTIONS: usize = 64;

/// The most connections served at once to one client address. A browser opens at most six
/// to one server over HTTP/1.1, so a screen never needs more; without this bound one host
/// that opened 64 event streams and kept reading them locked every other screen out (review).
pub const MAX_CONNECTIONS_PER_HOST: usize = 16;

/// How long a connection may take to send a complete request head (request line and headers),
/// counted from when it connects or from the end of its previous response. Any client on a
/// working network needs well under a second; one that sends nothing, or a byte at a time,
/// is closed before it can hold its slot for long.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// How long a write to a client may wait before its connection is closed. A write waits when
/// the connection's buffers are full: the client has stopped reading what it is sent (a script
/// that opens the event stream and never reads, a page whose machine went to sleep or off the
/// network), and an event stream would otherwise keep its slot for ever. A page that reads
/// takes each snapshot within milliseconds; 30 s also rides out a short network outage (the
/// page reconnects by itself after a longer one, as after any closed stream). The timer starts
/// only once the buffers are full and stops at any progress, so a client that reads is not cut
/// however slow its network: only 30 s without any progress closes a connection.
///
/// Measured on loopback, a client that never reads had some 270 kB waiting for it before a
/// write waited ([`SEND_BUFFER`] and its own receive window), and was closed 31 s after it
/// connected with 64 vessels on the page, 35 s with 8 and 69 s with one (some 7 kB/s of
/// snapshots); an empty page sends so little that it was still open after 25 minutes.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(30);

/// The send buffer asked of the operating system for each connection, in bytes (Linux doubles
/// it for its bookkeeping). Left to the system, Linux grew the send buffer of a client that takes
/// nothing to 4 MiB, so that the write timeout started only after some 4 MB of snapshots had
/// piled up: with one vessel on the page, ten minutes. Some 100 kB a round trip still carries a
/// page of 64 vessels with full forecasts (some 0.5 MB twice a second) over a ship's LAN or
/// Wi-Fi, whose round trips take milliseconds; a slower client skips snapshots.
pub const SEND_BUFFER: usize = 64 << 10;

/// Connections closed for the cap, and those closed for the write timeout, are reported at
/// most once per this period (the first at once), with how many there were: a flood of
/// connections must not become a flood of lines. Accept errors are reported as seldom.
pub const REPORT_PERIOD: Duration = Duration::from_secs(10);

/// How long the accept loop pauses after an error other than a connection's own (out of file
/// descriptors or memory): such an error repeats until something is freed, and retrying at
/// once would only spin.
const ACCEPT_RETRY: Duration = Duration::from_secs(1);

/// What one host can take of the server: [`MAX_CONNECTIONS`], [`HEAD_TIMEOUT`],
/// [`WRITE_TIMEOUT`] and [`SEND_BUFFER`] unless a test needs them small.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct ConnectionLimits {
    pub max_connections: usize,
    pub max_per_host: usize,
    pub head_timeout: Duration,
    pub write_timeout: Duration,
    pub send_buffer: usize,
}

impl Default for ConnectionLimits {
    fn default() -> Self {
        ConnectionLimits {
            max_connections: MAX_CONNECTIONS,
            max_per_host: MAX_CONNECTIONS_PER_HOST,
            head_timeout: HEAD_TIMEOUT,
            write_timeout: WRITE_TIMEOUT,
            send_buffer: SEND_BUFFER,
        }
    }
}

/// How a connection ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Ended {
    /// Its client closed it, or it failed for another reason (no head in time, garbage).
    Closed,
    /// Closed because its client took nothing sent for the write timeout.
    Stalled,
}

/// Accept connections forever, each served by its own task in one set: the set's size is the
/// number of open connections, and dropping the set closes them all.
pub(crate) async fn accept_loop(
    listener: tokio::net::TcpListener,
    app: Router,
    limits: ConnectionLimits,
) -> Infallible {
    let http = http_builder(limits.head_timeout);
    let mut connections = JoinSet::new();
    let hosts = HostSlots::default();
    let mut closes = Closes::new(limits);
    // Only the first of each period is logged; the next due report waits for the next error.
    let mut accept_errors = Tally::new(REPORT_PERIOD);
    loop {
        let report_due = closes.due_at();
        tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, peer)) => {
                    // Connections that ended since the last reap give their slots back first.
                    while let Some(ended) = connections.try_join_next() {
                        closes.ended(ended);
                    }
                    let slot = (connections.len() < limits.max_connections)
                        .then(|| hosts.take(peer.ip(), limits.max_per_host))
                        .flatten();
                    let Some(slot) = slot else {
                        // Closed at once, before anything is read: a refused connection costs
                        // a descriptor only for this moment, and the client is not left queued.
                        drop(stream);
                        closes.refused();
                        continue;
                    };
                    let served = serve_connection(&http, stream, peer, app.clone(), &limits);
                    // The slot is given back when the task ends, however it ends.
                    connections.spawn(async move {
                        let _slot = slot;
                        served.await
                    });
                }
                // A connection that failed before it was accepted: the listener is fine.
                Err(e) if is_connection_error(e.kind()) => {
                    tracing::debug!("display: a connection failed before it was accepted: {e}");
                }
                Err(e) => {
                    if accept_errors.count(Instant::now()).is_some() {
                        tracing::warn!(
                            "display: cannot accept connections ({e}): retrying every {} s",
                            ACCEPT_RETRY.as_secs()
                        );
                    }
                    tokio::time::sleep(ACCEPT_RETRY).await;
                }
            },
            // Reap connections as they end, so that finished tasks do not pile up in the set.
            Some(ended) = connections.join_next(), if !connections.is_empty() => {
                closes.ended(ended);
            }
            // Closes since the last report are reported once they are due, even when no
            // further connection comes to trigger it.
            () = tokio::time::sleep_until(report_due.unwrap_or_else(Instant::now)),
                if report_due.is_some() =>
            {
                closes.report_due();
            }
        }
    }
}

/// Connections open per client address. A [`HostSlot`] taken from it gives its place back
/// when dropped, with the connection's task.
#[derive(Debug, Default, Clone)]
struct HostSlots(std::sync::Arc<std::sync::Mutex<HashMap<IpAddr, usize>>>);

impl HostSlots {
    /// A slot for one more connection from `host`, or None when it holds `max` already.
    fn take(&self, host: IpAddr, max: usize) -> Option<HostSlot> {
        // Every update is one counter step: a poisoned lock is still consistent.
        let mut open = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let n = open.entry(host).or_insert(0);
        if *n >= max {
            return None;
        }
        *n += 1;
        Some(HostSlot {
            slots: self.clone(),
            host,
        })
    }

    #[cfg(test)]
    fn open(&self, host: IpAddr) -> usize {
        let open = self.0.lock().unwrap_or_else(|p| p.into_inner());
        open.get(&host).copied().unwrap_or(0)
    }
}

/// One connection's place among its host's.
#[derive(Debug)]
struct HostSlot {
    slots: HostSlots,
    host: IpAddr,
}

impl Drop for HostSlot {
    fn drop(&mut self) {
        let mut open = self.slots.0.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(n) = open.get_mut(&self.host) {
            *n -= 1;
            if *n == 0 {
                // A host with no connection left takes no memory.
                open.remove(&self.host);
            }
        }
    }
}

/// HTTP/1 as the server serves it, with its head timeout.
fn http_builder(head_timeout: Duration) -> http1::Builder {
    let mut http = http1::Builder::new();
    // The head timeout needs a timer; without one hyper would wait for a head forever.
    http.timer(TokioTimer::new())
        .header_read_timeout(head_timeout);
    http
}

/// Serve one connection (HTTP/1, its send buffer and write timeout from `limits`) until it
/// ends.
fn serve_connection(
    http: &http1::Builder,
    stream: TcpStream,
    peer: SocketAddr,
    app: Router,
    limits: &ConnectionLimits,
) -> impl Future<Output = Ended> + Send + 'static {
    if let Err(e) = socket2::SockRef::from(&stream).set_send_buffer_size(limits.send_buffer) {
        // The connection still works, only with the system's buffer; the timeout still holds.
        tracing::debug!("display: connection from {peer}: cannot set its send buffer: {e}");
    }
    let io = TokioIo::new(WriteTimeout::new(stream, limits.write_timeout));
    let connection = http.serve_connection(io, TowerToHyperService::new(app));
    async move {
        match connection.await {
            Ok(()) => Ended::Closed,
            Err(e) if is_write_stall(&e) => {
                tracing::debug!("display: connection from {peer} closed: {e}");
                Ended::Stalled
            }
            // Errors here are the client's doing (it went away mid-response, sent no head in
            // time, or sent garbage): worth a debug line, no more.
            Err(e) => {
                tracing::debug!("display: connection from {peer} ended: {e}");
                Ended::Closed
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

/// The connections the server closed on its own, counted and reported (each kind at most once
/// per [`REPORT_PERIOD`]): refused for the cap, and closed for the write timeout.
#[derive(Debug)]
struct Closes {
    limits: ConnectionLimits,
    refused: Tally,
    stalled: Tally,
}

impl Closes {
    fn new(limits: ConnectionLimits) -> Self {
        Closes {
            limits,
            refused: Tally::new(REPORT_PERIOD),
            stalled: Tally::new(REPORT_PERIOD),
        }
    }

    /// A connection was closed unserved for the cap.
    fn refused(&mut self) {
        if let Some(report) = self.refused.count(Instant::now()) {
            self.log_refused(report);
        }
    }

    /// A connection's task ended (a task cannot panic, and the set aborts none but by being
    /// dropped: an error is no close to count).
    fn ended(&mut self, ended: Result<Ended, JoinError>) {
        if let Ok(Ended::Stalled) = ended {
            if let Some(report) = self.stalled.count(Instant::now()) {
                self.log_stalled(report);
            }
        }
    }

    /// When the next report is due (None: nothing waits to be reported).
    fn due_at(&self) -> Option<Instant> {
        match (self.refused.due_at(), self.stalled.due_at()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Log whatever is due.
    fn report_due(&mut self) {
        let now = Instant::now();
        if let Some(report) = self.refused.report_if_due(now) {
            self.log_refused(report);
        }
        if let Some(report) = self.stalled.report_if_due(now) {
            self.log_stalled(report);
        }
    }

    fn log_refused(&self, report: Report) {
        tracing::warn!(
            refused = report.since_last,
            refused_total = report.total,
            "display: {} connections open, or {} from one address, the most it serves at once: new connections are closed unserved",
            self.limits.max_connections,
            self.limits.max_per_host
        );
    }

    fn log_stalled(&self, report: Report) {
        tracing::warn!(
            closed = report.since_last,
            closed_total = report.total,
            "display: connections whose client took nothing sent for {} s are closed, freeing their slots",
            self.limits.write_timeout.as_secs_f64()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::routing::get;
    use std::io::{Read, Write};

    /// The longest a test waits for a connection to end: generous, so that a loaded machine
    /// does not fail it.
    const WAIT: Duration = Duration::from_secs(30);

    /// A connection served as the accept loop serves it, for a route whose response is far
    /// larger than the socket buffers, and the client's end as a blocking socket that has
    /// sent its request (with a small receive buffer, so that a client that does not read
    /// fills it at once).
    async fn connection(
        write_timeout: Duration,
    ) -> (impl Future<Output = Ended>, std::net::TcpStream) {
        let app = Router::new().route("/", get(|| async { "x".repeat(8 << 20) }));
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
            .await
            .expect("a loopback listener");
        let socket = tokio::net::TcpSocket::new_v4().expect("a socket");
        socket
            .set_recv_buffer_size(16 << 10)
            .expect("a small receive buffer");
        let client = socket
            .connect(listener.local_addr().expect("its address"))
            .await
            .expect("connect");
        let (stream, peer) = listener.accept().await.expect("accept");
        let mut client = client.into_std().expect("a std socket");
        client.set_nonblocking(false).expect("blocking");
        client
            .write_all(b"GET / HTTP/1.1\r\nHost: display\r\nConnection: close\r\n\r\n")
            .expect("send the request");
        let limits = ConnectionLimits {
            write_timeout,
            ..ConnectionLimits::default()
        };
        let served = serve_connection(&http_builder(HEAD_TIMEOUT), stream, peer, app, &limits);
        (served, client)
    }

    #[test]
    fn a_host_takes_at_most_its_slots_and_gets_them_back_when_its_connections_end() {
        let hosts = HostSlots::default();
        let (a, b): (IpAddr, IpAddr) = ([10, 0, 0, 1].into(), [10, 0, 0, 2].into());
        let held: Vec<_> = (0..3).map(|_| hosts.take(a, 3).expect("a slot")).collect();
        assert!(hosts.take(a, 3).is_none(), "a fourth from the same host");
        let other = hosts.take(b, 3).expect("another host is served");
        drop(held);
        assert_eq!(hosts.open(a), 0);
        assert_eq!(hosts.open(b), 1);
        let again = hosts.take(a, 3).expect("free again");
        drop(other);
        assert_eq!(
            hosts.0.lock().unwrap().len(),
            1,
            "b's entry went with its last slot"
        );
        drop(again);
        assert!(hosts.0.lock().unwrap().is_empty());
    }

    #[tokio::test]
    async fn a_connection_whose_client_takes_nothing_ends_stalled() {
        let (served, _client) = connection(Duration::from_millis(100)).await;
        let ended = tokio::time::timeout(WAIT, served)
            .await
            .expect("a connection whose client reads nothing is closed");
        assert_eq!(ended, Ended::Stalled);
    }

    #[tokio::test]
    async fn a_connection_whose_client_reads_is_not_cut_by_the_write_timeout() {
        // A write timeout far longer than any pause of the reading thread on a loaded machine.
        let (served, mut client) = connection(Duration::from_secs(6)).await;
        let reader = std::thread::spawn(move || {
            let mut response = Vec::new();
            client.read_to_end(&mut response).map(|_| response.len())
        });
        let ended = tokio::time::timeout(WAIT, served)
            .await
            .expect("the response is sent");
        assert_eq!(ended, Ended::Closed);
        let read = reader.join().expect("the reader").expect("the response");
        assert!(read > 8 << 20, "the whole response: {read} bytes");
    }
}
