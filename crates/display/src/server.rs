//! The HTTP side: `/` the page, `/events` a server-sent-event stream of board snapshots,
//! `/snapshot.json` the current snapshot once (for scripts).
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
pub use crate::connections::{
    HEAD_TIMEOUT, MAX_CONNECTIONS, REPORT_PERIOD, SEND_BUFFER, WRITE_TIMEOUT,
};

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
/// closed unless it sends a request head within [`HEAD_TIMEOUT`], or once its client has taken
/// nothing sent for [`WRITE_TIMEOUT`]. Event streams never end by
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
mod tests;
