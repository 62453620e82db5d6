//! The HTTP side: `/` the page (with `/page.js` and `/page.css`), `/events` a
//! server-sent-event stream of board snapshots, `/snapshot.json` the current snapshot once
//! (for scripts).
//!
//! Every response forbids what the page does not need (a Content-Security-Policy that allows
//! only this server's own script, style and event stream, no framing, no content sniffing),
//! and a request whose `Host` is neither an IP address, `localhost` nor a name the display
//! was told to serve is refused (421): a web page elsewhere whose name was made to resolve to
//! this address (DNS rebinding) cannot read the snapshots.
//!
//! Each `/events` client gets the newest snapshot every [`EVENT_PERIOD`]; a snapshot is made
//! only when the client's connection takes the next one, so a slow or stalled client skips
//! snapshots instead of queueing them, and holds up neither the other clients nor the feed.
//!
//! The page may be offered to the ship's network, so what one host can take is bounded: at
//! most [`MAX_CONNECTIONS`] connections are served at once (a further one is closed as soon as
//! it is accepted, and reported at most once per [`REPORT_PERIOD`]), a connection that does
//! not send a complete request head within [`HEAD_TIMEOUT`] is closed, and so is one whose
//! client takes nothing sent for [`WRITE_TIMEOUT`] (an event stream whose client stopped
//! reading). Each connection is its own task, so a stalled one holds only its own slot, and
//! for a limited time ([`crate::connections`]).

use crate::board::Board;
use axum::extract::{Request, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::middleware::{self, Next};
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
pub use crate::connections::{
    HEAD_TIMEOUT, MAX_CONNECTIONS, MAX_CONNECTIONS_PER_HOST, REPORT_PERIOD, SEND_BUFFER,
    WRITE_TIMEOUT,
};

/// How often a connected page gets a snapshot: the forecast rate (2 Hz).
pub const EVENT_PERIOD: Duration = Duration::from_millis(500);

/// The page, its script and its styles, built into the binary (nothing fetched from
/// elsewhere).
pub const PAGE: &str = include_str!("../assets/index.html");
pub const PAGE_JS: &str = include_str!("../assets/page.js");
pub const PAGE_CSS: &str = include_str!("../assets/page.css");

/// What a page of this server may load: its own script, style and event stream, nothing
/// else, and it may not be framed by another page.
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'none'; script-src 'self'; \
     style-src 'self'; connect-src 'self'; img-src 'self'; base-uri 'none'; \
     form-action 'none'; frame-ancestors 'none'";

/// The names a request's `Host` may carry besides IP addresses and `localhost`
/// (`shipcast display --allow-host`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AllowedHosts {
    names: Vec<String>,
}

impl AllowedHosts {
    pub fn new(names: impl IntoIterator<Item = String>) -> Self {
        AllowedHosts {
            names: names.into_iter().map(|n| n.to_ascii_lowercase()).collect(),
        }
    }

    /// Whether a `Host` header value (a name or address, with or without a port) is served.
    pub fn admits(&self, host: &str) -> bool {
        let name = match host.strip_prefix('[') {
            // [v6]:port or [v6]
            Some(rest) => match rest.split_once(']') {
                Some((v6, port)) if port.is_empty() || port.starts_with(':') => {
                    return v6.parse::<std::net::Ipv6Addr>().is_ok();
                }
                _ => return false,
            },
            None => host.rsplit_once(':').map_or(host, |(name, _port)| name),
        };
        // A fully qualified name may end in a dot (`localhost.`): the same host.
        let name = name.strip_suffix('.').unwrap_or(name).to_ascii_lowercase();
        name.parse::<std::net::Ipv4Addr>().is_ok()
            || name == "localhost"
            || self.names.contains(&name)
    }
}

pub fn router(board: Arc<Board>, hosts: AllowedHosts) -> Router {
    let hosts = Arc::new(hosts);
    let board = Arc::new(SharedSnapshot::new(board));
    Router::new()
        .route("/", get(page))
        .route("/page.js", get(page_js))
        .route("/page.css", get(page_css))
        .route("/events", get(events))
        .route("/snapshot.json", get(snapshot))
        .with_state(board)
        .layer(middleware::from_fn(move |request, next| {
            guard(hosts.clone(), request, next)
        }))
}

/// Refuse a request for a host this server does not serve; set the headers that forbid what
/// the page does not need on every response.
async fn guard(hosts: Arc<AllowedHosts>, request: Request, next: Next) -> axum::response::Response {
    let host = request
        .headers()
        .get(header::HOST)
        .map(|h| h.to_str().unwrap_or("?"));
    let mut response = match host {
        Some(h) if hosts.admits(h) => next.run(request).await,
        _ => {
            let shown: String = host.unwrap_or("(none)").chars().take(80).collect();
            tracing::debug!("display: refused a request for Host {shown}");
            (
                StatusCode::MISDIRECTED_REQUEST,
                format!(
                    "shipcast display: Host '{shown}' is not served; start the display with \
                     --allow-host NAME to serve a name other than an IP address or localhost\n"
                ),
            )
                .into_response()
        }
    };
    let headers = response.headers_mut();
    headers.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(CONTENT_SECURITY_POLICY),
    );
    headers.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    headers.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    headers.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    response
}

async fn page() -> Html<&'static str> {
    Html(PAGE)
}

async fn page_js() -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
        PAGE_JS,
    )
}

async fn page_css() -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "text/css; charset=utf-8")],
        PAGE_CSS,
    )
}

/// How old a snapshot's JSON may be when it is served again instead of made anew.
pub const SNAPSHOT_REUSE: Duration = Duration::from_millis(100);

/// The board's snapshot as JSON, made at most once per [`SNAPSHOT_REUSE`] and shared by every
/// request and event stream: each one made it anew, and 16 keep-alive connections asking for
/// `/snapshot.json` of 64 vessels (535 kB) drew 247 MB/s from the display (review).
pub struct SharedSnapshot {
    board: Arc<Board>,
    made: std::sync::Mutex<Option<(Instant, Arc<str>)>>,
}

impl SharedSnapshot {
    pub fn new(board: Arc<Board>) -> Self {
        Self {
            board,
            made: std::sync::Mutex::new(None),
        }
    }

    /// The snapshot at `now`, or one made less than [`SNAPSHOT_REUSE`] before it.
    pub fn json(&self, now: Instant) -> Arc<str> {
        let mut made = self.made.lock().unwrap_or_else(|p| p.into_inner());
        match &*made {
            Some((at, json)) if now.saturating_duration_since(*at) < SNAPSHOT_REUSE => json.clone(),
            _ => {
                let json: Arc<str> = self.board.snapshot_json(now).into();
                *made = Some((now, json.clone()));
                json
            }
        }
    }
}

async fn snapshot(State(shared): State<Arc<SharedSnapshot>>) -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "application/json")],
        shared.json(Instant::now()).to_string(),
    )
}

async fn events(
    State(board): State<Arc<SharedSnapshot>>,
) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let mut ticks = tokio::time::interval(EVENT_PERIOD);
    // A client that fell behind gets the newest snapshot next, not a burst of old ones.
    ticks.set_missed_tick_behavior(MissedTickBehavior::Skip);
    let stream = stream::unfold((board, ticks), |(board, mut ticks)| async move {
        ticks.tick().await;
        let event = Event::default().data(&*board.json(Instant::now()));
        Some((Ok(event), (board, ticks)))
    });
    Sse::new(stream).keep_alive(KeepAlive::default())
}

/// Serve until `shutdown` completes, at most [`MAX_CONNECTIONS`] connections at once, each
/// closed unless it sends a request head within [`HEAD_TIMEOUT`], or once its client has taken
/// nothing sent for [`WRITE_TIMEOUT`]. Event streams never end by
/// themselves, so shutdown drops the connections instead of waiting for them (graceful shutdown
/// would wait forever). Accept errors are retried, never returned: the result is always `Ok`
/// once `shutdown` completes.
pub async fn serve(
    listener: tokio::net::TcpListener,
    board: Arc<Board>,
    hosts: AllowedHosts,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    serve_with(
        listener,
        router(board, hosts),
        ConnectionLimits::default(),
        shutdown,
    )
    .await
}

/// [`serve`] with its limits given (tests make them small).
pub(crate) async fn serve_with(
    listener: tokio::net::TcpListener,
    app: Router,
    limits: ConnectionLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    tokio::select! {
        // Dropping the accept loop drops its set of connection tasks, which aborts them all.
        never = accept_loop(listener, app, limits) => match never {},
        () = shutdown => Ok(()),
    }
}

#[cfg(test)]
mod tests;
