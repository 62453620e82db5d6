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
//! its own task, so a stalled one holds only its own slot ([`crate::connections`]).

use crate::board::Board;
use axum::extract::State;
use axum::http::header;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse};
use axum::routing::get;
use axum::Router;
use futures_util::stream::{self, Stream};
use std::convert::Infallible;
use std::future::Future;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::time::MissedTickBehavior;

use crate::connections::accept_loop;
pub(crate) use crate::connections::ConnectionLimits;
pub use crate::connections::{HEAD_TIMEOUT, MAX_CONNECTIONS, REPORT_PERIOD};

/// How often a connected page gets a snapshot: the forecast rate (2 Hz).
pub const EVENT_PERIOD: Duration = Duration::from_millis(500);

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::Limits;
    use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
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
}
