use super::*;
use crate::board::Limits;
use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};

mod stalls;

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
        Server::start_with(limits, board())
    }

    /// A server of `board`.
    fn start_with(limits: ConnectionLimits, board: Arc<Board>) -> Server {
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
        let app = router(board, AllowedHosts::default());
        let task = runtime.spawn(serve_with(listener, app, limits, shutdown));
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
        self.connect_from([127, 0, 0, 1])
    }

    /// A connection from the loopback address `from` (any 127.x.y.z is this host's on Linux),
    /// so that one test can be several client hosts.
    fn connect_from(&self, from: [u8; 4]) -> TcpStream {
        let socket = tokio::net::TcpSocket::new_v4().expect("a socket");
        socket
            .bind(SocketAddr::from((from, 0)))
            .expect("bind the client's address");
        self.connect_socket(socket)
    }

    /// Connect `socket` to the server: a blocking std stream with the test's timeouts.
    fn connect_socket(&self, socket: tokio::net::TcpSocket) -> TcpStream {
        let stream = self
            .runtime
            .block_on(socket.connect(self.addr))
            .expect("connect");
        let stream = stream.into_std().expect("a std socket");
        stream.set_nonblocking(false).expect("blocking");
        stream.set_read_timeout(Some(WAIT)).expect("read timeout");
        stream.set_write_timeout(Some(WAIT)).expect("write timeout");
        stream
    }

    /// One GET with `Connection: close`: the whole response, or None when the server
    /// closed the connection without one.
    fn get(&self, path: &str) -> Option<String> {
        self.request(self.connect(), path, "127.0.0.1")
    }

    /// One GET of `path` on `stream` with `Host: host` and `Connection: close`, as [`get`].
    fn request(&self, mut stream: TcpStream, path: &str, host: &str) -> Option<String> {
        let request = format!("GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n");
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

    /// A GET of `path` once the server serves one (it closes connections beyond its cap
    /// unserved), polled for at most `wait`.
    fn get_once_served(&self, path: &str, wait: Duration) -> String {
        let deadline = Instant::now() + wait;
        loop {
            if let Some(response) = self.get(path) {
                return response;
            }
            assert!(
                Instant::now() < deadline,
                "no slot came free within {wait:?}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// An event-stream client that has read the response head and its first snapshot.
    fn open_events(&self) -> BufReader<TcpStream> {
        let mut events = request_events(self.connect());
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

/// Asks `stream` for the event stream and reads the response's status line (an OK).
fn request_events(mut stream: TcpStream) -> BufReader<TcpStream> {
    stream
        .write_all(b"GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        .expect("send the request");
    let mut events = BufReader::new(stream);
    let mut status = String::new();
    events.read_line(&mut status).expect("a status line");
    assert!(status.starts_with("HTTP/1.1 200"), "event stream: {status}");
    events
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
    closed_within(stream, WAIT)
}

/// Whether the server closes `stream` within `wait`: whatever it still sends is read and
/// dropped, and a stream still served (it goes on sending) or silent past its read timeout is
/// not closed.
fn closed_within(stream: &mut impl Read, wait: Duration) -> bool {
    let deadline = Instant::now() + wait;
    let mut buf = [0u8; 16 << 10];
    while Instant::now() < deadline {
        match stream.read(&mut buf) {
            Ok(0) => return true,
            Ok(_) => {}
            Err(e) if is_closed(&e) => return true,
            // The read timeout: still open.
            Err(_) => return false,
        }
    }
    false
}

/// Regression (review): one host that opened 64 event streams and kept reading them locked
/// every other screen out.
#[test]
fn one_host_takes_at_most_its_share_and_another_is_still_served() {
    let server = Server::start(ConnectionLimits {
        max_connections: 64,
        max_per_host: 2,
        ..ConnectionLimits::default()
    });
    let first = request_events(server.connect_from([127, 0, 0, 7]));
    let _second = request_events(server.connect_from([127, 0, 0, 7]));
    assert_eq!(
        server.request(
            server.connect_from([127, 0, 0, 7]),
            "/snapshot.json",
            "127.0.0.1"
        ),
        None,
        "a third connection from the same host is closed unserved"
    );
    let other = server.request(
        server.connect_from([127, 0, 0, 8]),
        "/snapshot.json",
        "127.0.0.1",
    );
    assert!(other.is_some_and(|r| r.starts_with("HTTP/1.1 200")));
    // The host's slot comes back once one of its streams ends.
    drop(first);
    let deadline = Instant::now() + WAIT;
    while server
        .request(
            server.connect_from([127, 0, 0, 7]),
            "/snapshot.json",
            "127.0.0.1",
        )
        .is_none()
    {
        assert!(Instant::now() < deadline, "the slot never came back");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The value of header `name` in a whole response (case-insensitive name).
fn header<'a>(response: &'a str, name: &str) -> Option<&'a str> {
    let head = response.split("\r\n\r\n").next()?;
    head.lines().find_map(|l| {
        let (n, v) = l.split_once(':')?;
        n.eq_ignore_ascii_case(name).then(|| v.trim())
    })
}

/// Regression (review): no response forbade framing, sniffing or foreign scripts, and a
/// request for any Host was served (a page elsewhere whose name resolves here could read
/// the snapshots: DNS rebinding).
#[test]
fn responses_forbid_what_the_page_does_not_need_and_a_foreign_host_is_refused() {
    let server = Server::start(ConnectionLimits::default());
    for (path, content_type) in [
        ("/", "text/html"),
        ("/page.js", "text/javascript"),
        ("/page.css", "text/css"),
        ("/snapshot.json", "application/json"),
    ] {
        let r = server.get(path).expect("served");
        assert!(r.starts_with("HTTP/1.1 200"), "{path}: {r:.200}");
        assert!(
            header(&r, "content-type").is_some_and(|v| v.starts_with(content_type)),
            "{path}: {r:.300}"
        );
        assert_eq!(
            header(&r, "content-security-policy"),
            Some(CONTENT_SECURITY_POLICY)
        );
        assert_eq!(header(&r, "x-content-type-options"), Some("nosniff"));
        assert_eq!(header(&r, "x-frame-options"), Some("DENY"));
    }
    for host in [
        "evil.example",
        "evil.example:8090",
        "127.0.0.1.evil.example",
    ] {
        let r = server
            .request(server.connect(), "/snapshot.json", host)
            .expect("answered");
        assert!(r.starts_with("HTTP/1.1 421"), "{host}: {r:.200}");
        assert!(r.contains("--allow-host"), "{r}");
        assert!(!r.contains("vessels"), "no snapshot for {host}");
    }
    for host in ["localhost:8090", "LOCALHOST", "10.1.2.3:80", "[::1]:8090"] {
        let r = server
            .request(server.connect(), "/snapshot.json", host)
            .expect("answered");
        assert!(r.starts_with("HTTP/1.1 200"), "{host}: {r:.200}");
    }
}

#[test]
fn the_allowed_host_names_are_served_with_or_without_a_port() {
    let hosts = AllowedHosts::new(["Bridge-Display".to_string()]);
    for ok in [
        "bridge-display",
        "BRIDGE-DISPLAY:8090",
        "bridge-display.:80",
        "localhost.",
        "192.168.1.20:8090",
        "[fe80::1]",
    ] {
        assert!(hosts.admits(ok), "{ok}");
    }
    for refused in [
        "bridge-display.evil",
        "[fe80::1",
        "[nothost]:80",
        "other:8090",
        "",
    ] {
        assert!(!hosts.admits(refused), "{refused}");
    }
    assert!(!AllowedHosts::default().admits("bridge-display"));
}

#[test]
fn a_connection_without_a_complete_request_head_is_closed_after_the_head_timeout() {
    let server = Server::start(ConnectionLimits {
        max_connections: 64,
        // Long enough that the served client below, on a loaded machine, sends its head in
        // time; the silent ones are closed after it all the same.
        head_timeout: Duration::from_millis(1500),
        ..ConnectionLimits::default()
    });
    // Sends nothing at all.
    let mut silent = server.connect();
    // Sends half a head and then nothing (a byte now and then would do the same).
    let mut partial = server.connect();
    partial
        .write_all(b"GET /snapshot.json HTTP/1.1\r\nHost: 127.0.0.1\r\n")
        .expect("send half a head");
    // Is served once, then keeps its connection open without a next request.
    let mut idle = server.connect();
    idle.write_all(b"GET /snapshot.json HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
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
    const HEAD_TIMEOUT: Duration = Duration::from_millis(1500);
    let server = Server::start(ConnectionLimits {
        max_connections: 2,
        // Long enough for the clients' heads on a loaded machine; the streams are then kept
        // open past it, to show that it does not cut an event stream that runs longer.
        head_timeout: HEAD_TIMEOUT,
        ..ConnectionLimits::default()
    });
    let mut first = server.open_events();
    let mut second = server.open_events();

    assert_eq!(
        server.get("/snapshot.json"),
        None,
        "a third connection is closed unserved"
    );
    // The two streams go on, past the head timeout too.
    std::thread::sleep(HEAD_TIMEOUT + Duration::from_millis(500));
    next_snapshot(&mut first);
    next_snapshot(&mut second);

    // The first client leaves; its slot comes free once the server notices, which it
    // does at the latest when the next snapshot cannot be sent.
    drop(first);
    let response = server.get_once_served("/snapshot.json", WAIT);
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

/// Regression (review): every `/snapshot.json` request and every event made the snapshot anew.
/// Now one is made at most once per `SNAPSHOT_REUSE` and shared; a later one shows what
/// changed.
#[test]
fn the_snapshot_is_made_once_per_reuse_period_and_shared() {
    let board = board();
    let shared = SharedSnapshot::new(board.clone());
    let t0 = Instant::now();
    let first = shared.json(t0);
    assert!(!first.contains("\"v1\""), "{first}");
    let forecast = shipcast_wire::payload::Forecast {
        seq: 1,
        time_s: 0.5,
        dt_s: 0.5,
        steps: 4,
        model_version: 1,
        ..Default::default()
    };
    board.forecast("v1", &forecast, t0).unwrap();
    // Within the period: the same text, not a new one.
    let again = shared.json(t0 + SNAPSHOT_REUSE / 2);
    assert!(Arc::ptr_eq(&first, &again));
    // After it: made anew, with the new vessel.
    let later = shared.json(t0 + SNAPSHOT_REUSE);
    assert!(!Arc::ptr_eq(&first, &later));
    assert!(later.contains("\"v1\""), "{later}");
}
