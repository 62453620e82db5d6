//! The HTTP side: `/` the page, `/events` a server-sent-event stream of board snapshots,
//! `/snapshot.json` the current snapshot once (for scripts).
//!
//! Each `/events` client gets the newest snapshot every [`EVENT_PERIOD`]; a snapshot is made
//! only when the client's connection takes the next one, so a slow or stalled client skips
//! snapshots instead of queueing them, and holds up neither the other clients nor the feed.
//!
//! The page may be offered to the ship's network, so what one host can take is bounded: at
//! most [`MAX_CONNECTIONS`] connections are served at once (a further one is closed as soon as
//! it is accepted, and reported at most once per [`REPORT_PERIOD`]), and a connection that
//! does not send a complete request head within [`HEAD_TIMEOUT`] is closed. Each connection is
//! its own task, so a stalled one holds only its own slot.

use crate::board::Board;
use axum::extract::State;
use axum::http::header;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse};
use axum::routing::get;
use axum::Router;
use futures_util::stream::{self, Stream};
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use std::convert::Infallible;
use std::future::Future;
use std::io::ErrorKind;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::task::JoinSet;
use tokio::time::MissedTickBehavior;

/// How often a connected page gets a snapshot: the forecast rate (2 Hz).
pub const EVENT_PERIOD: Duration = Duration::from_millis(500);

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

/// The page: one file with its styles and script inline (nothing fetched from elsewhere).
pub const PAGE: &str = include_str!("../assets/index.html");

pub fn router(board: Arc<Board>) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/events", get(events))
        .route("/snapshot.json", get(snapshot))
        .with_state(board)
}

async fn page() -> Html<&'static str> {
    Html(PAGE)
}

async fn snapshot(State(board): State<Arc<Board>>) -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "application/json")],
        board.snapshot_json(Instant::now()),
    )
}

async fn events(
    State(board): State<Arc<Board>>,
) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let mut ticks = tokio::time::interval(EVENT_PERIOD);
    // A client that fell behind gets the newest snapshot next, not a burst of old ones.
    ticks.set_missed_tick_behavior(MissedTickBehavior::Skip);
    let stream = stream::unfold((board, ticks), |(board, mut ticks)| async move {
        ticks.tick().await;
        let event = Event::default().data(board.snapshot_json(Instant::now()));
        Some((Ok(event), (board, ticks)))
    });
    Sse::new(stream).keep_alive(KeepAlive::default())
}

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

/// Serve until `shutdown` completes, at most [`MAX_CONNECTIONS`] connections at once, each
/// closed unless it sends a request head within [`HEAD_TIMEOUT`]. Event streams never end by
/// themselves, so shutdown drops the connections instead of waiting for them (graceful shutdown
/// would wait forever). Accept errors are retried, never returned: the result is always `Ok`
/// once `shutdown` completes.
pub async fn serve(
    listener: tokio::net::TcpListener,
    board: Arc<Board>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    serve_with(listener, board, ConnectionLimits::default(), shutdown).await
}

/// [`serve`] with its limits given (tests make them small).
pub(crate) async fn serve_with(
    listener: tokio::net::TcpListener,
    board: Arc<Board>,
    limits: ConnectionLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    tokio::select! {
        // Dropping the accept loop drops its set of connection tasks, which aborts them all.
        never = accept_loop(listener, router(board), limits) => match never {},
        () = shutdown => Ok(()),
    }
}

/// Accept connections forever, each served by its own task in one set: the set's size is the
/// number of open connections, and dropping the set closes them all.
async fn accept_loop(
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
    use crate::board::Limits;
    use std::io::{BufRead, BufReader, Read, Write};
    use std::net::{SocketAddr, TcpStream};

    /// The longest any test waits for the server to do something. Generous: a slow, loaded
    /// machine must not fail a test, only a server that never does it.
    const WAIT: Duration = Duration::from_secs(10);

    fn board() -> Arc<Board> {
        Arc::new(Board::new(
            Limits {
                roll_deg: 2.5,
                pitch_deg: 1.5,
            },
            Duration::from_secs(3),
        ))
    }

    /// A server on a free loopback port with the given limits, in a runtime of its own (the
    /// clients are plain blocking sockets on the test's thread).
    struct Server {
        addr: SocketAddr,
        stop: Option<tokio::sync::oneshot::Sender<()>>,
        task: Option<tokio::task::JoinHandle<std::io::Result<()>>>,
        runtime: tokio::runtime::Runtime,
    }

    impl Server {
        fn start(limits: ConnectionLimits) -> Server {
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .expect("a runtime");
            let listener = runtime
                .block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))
                .expect("a loopback listener");
            let addr = listener.local_addr().expect("its address");
            let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
            let shutdown = async move {
                // A dropped sender stops the server too.
                let _ = stopped.await;
            };
            let task = runtime.spawn(serve_with(listener, board(), limits, shutdown));
            Server {
                addr,
                stop: Some(stop),
                task: Some(task),
                runtime,
            }
        }

        /// Complete the shutdown future and wait for `serve` to return.
        fn shut_down(&mut self) -> std::io::Result<()> {
            if let Some(stop) = self.stop.take() {
                let _ = stop.send(());
            }
            let task = self.task.take().expect("shut down once");
            self.runtime
                .block_on(async { tokio::time::timeout(WAIT, task).await })
                .expect("serve returns after shutdown")
                .expect("serve does not panic")
        }

        fn connect(&self) -> TcpStream {
            let stream = TcpStream::connect(self.addr).expect("connect");
            stream.set_read_timeout(Some(WAIT)).expect("read timeout");
            stream.set_write_timeout(Some(WAIT)).expect("write timeout");
            stream
        }

        /// One GET with `Connection: close`: the whole response, or None when the server
        /// closed the connection without one.
        fn get(&self, path: &str) -> Option<String> {
            let mut stream = self.connect();
            let request =
                format!("GET {path} HTTP/1.1\r\nHost: display\r\nConnection: close\r\n\r\n");
            if let Err(e) = stream.write_all(request.as_bytes()) {
                assert!(is_closed(&e), "writing the request: {e}");
                return None;
            }
            let mut response = Vec::new();
            match stream.read_to_end(&mut response) {
                Ok(_) => {}
                Err(e) if is_closed(&e) => {}
                Err(e) => panic!("no response and not closed within {WAIT:?}: {e}"),
            }
            (!response.is_empty()).then(|| String::from_utf8_lossy(&response).into_owned())
        }

        /// An event-stream client that has read the response head and its first snapshot.
        fn open_events(&self) -> BufReader<TcpStream> {
            let mut stream = self.connect();
            stream
                .write_all(b"GET /events HTTP/1.1\r\nHost: display\r\n\r\n")
                .expect("send the request");
            let mut events = BufReader::new(stream);
            let mut status = String::new();
            events.read_line(&mut status).expect("a status line");
            assert!(status.starts_with("HTTP/1.1 200"), "event stream: {status}");
            next_snapshot(&mut events);
            events
        }
    }

    impl Drop for Server {
        fn drop(&mut self) {
            if let Some(stop) = self.stop.take() {
                let _ = stop.send(());
            }
        }
    }

    /// Read an event stream up to its next snapshot (a `data:` line).
    fn next_snapshot(events: &mut BufReader<TcpStream>) {
        let mut line = String::new();
        loop {
            line.clear();
            let n = events
                .read_line(&mut line)
                .expect("the event stream goes on");
            assert!(n > 0, "the event stream ended");
            if line.starts_with("data:") {
                return;
            }
        }
    }

    /// The server closed the connection (reset it, when it left unread data behind).
    fn is_closed(e: &std::io::Error) -> bool {
        matches!(
            e.kind(),
            ErrorKind::ConnectionReset | ErrorKind::ConnectionAborted | ErrorKind::BrokenPipe
        )
    }

    /// Whether the server closes `stream` within [`WAIT`]; whatever it still sends is read
    /// and dropped.
    fn closed_by_server(stream: &mut impl Read) -> bool {
        let mut buf = [0u8; 4096];
        loop {
            match stream.read(&mut buf) {
                Ok(0) => return true,
                Ok(_) => {}
                Err(e) if is_closed(&e) => return true,
                // The read timeout: still open after WAIT.
                Err(_) => return false,
            }
        }
    }

    #[test]
    fn serve_uses_the_documented_limits() {
        assert_eq!(
            ConnectionLimits::default(),
            ConnectionLimits {
                max_connections: MAX_CONNECTIONS,
                head_timeout: HEAD_TIMEOUT,
            }
        );
    }

    #[test]
    fn a_connection_without_a_complete_request_head_is_closed_after_the_head_timeout() {
        let server = Server::start(ConnectionLimits {
            max_connections: 64,
            head_timeout: Duration::from_millis(200),
        });
        // Sends nothing at all.
        let mut silent = server.connect();
        // Sends half a head and then nothing (a byte now and then would do the same).
        let mut partial = server.connect();
        partial
            .write_all(b"GET /snapshot.json HTTP/1.1\r\nHost: display\r\n")
            .expect("send half a head");
        // Is served once, then keeps its connection open without a next request.
        let mut idle = server.connect();
        idle.write_all(b"GET /snapshot.json HTTP/1.1\r\nHost: display\r\n\r\n")
            .expect("send a request");
        let mut idle = BufReader::new(idle);
        let mut status = String::new();
        idle.read_line(&mut status).expect("a response");
        assert!(status.starts_with("HTTP/1.1 200"), "{status}");

        assert!(
            closed_by_server(&mut silent),
            "a silent connection stays open"
        );
        assert!(
            closed_by_server(&mut partial),
            "a half-sent head keeps its connection"
        );
        assert!(
            closed_by_server(&mut idle),
            "an idle kept-alive connection stays open"
        );
        // The server still serves.
        let response = server.get("/snapshot.json").expect("served");
        assert!(response.starts_with("HTTP/1.1 200"), "{response}");
    }

    #[test]
    fn the_cap_closes_new_connections_and_a_slot_is_freed_when_a_client_leaves() {
        let server = Server::start(ConnectionLimits {
            max_connections: 2,
            // Short, to show that it does not cut an event stream that runs longer.
            head_timeout: Duration::from_millis(200),
        });
        let mut first = server.open_events();
        let mut second = server.open_events();

        assert_eq!(
            server.get("/snapshot.json"),
            None,
            "a third connection is closed unserved"
        );
        // The two streams go on, past the head timeout too.
        next_snapshot(&mut first);
        next_snapshot(&mut second);

        // The first client leaves; its slot comes free once the server notices, which it
        // does at the latest when the next snapshot cannot be sent.
        drop(first);
        let deadline = Instant::now() + WAIT;
        let response = loop {
            if let Some(response) = server.get("/snapshot.json") {
                break response;
            }
            assert!(
                Instant::now() < deadline,
                "the slot of a client that left never came free"
            );
            std::thread::sleep(Duration::from_millis(50));
        };
        assert!(response.starts_with("HTTP/1.1 200"), "{response}");
        assert!(
            response.contains("application/json"),
            "the snapshot: {response}"
        );
        // The remaining stream was not disturbed.
        next_snapshot(&mut second);
    }

    #[test]
    fn shutdown_drops_open_event_streams() {
        let mut server = Server::start(ConnectionLimits::default());
        let mut events = server.open_events();
        server.shut_down().expect("serve ends with Ok");
        assert!(
            closed_by_server(&mut events),
            "an event stream outlived the shutdown"
        );
    }

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
