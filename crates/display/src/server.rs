//! The HTTP side: `/` the page, `/events` a server-sent-event stream of board snapshots,
//! `/snapshot.json` the current snapshot once (for scripts).
//!
//! Each `/events` client gets the newest snapshot every [`EVENT_PERIOD`]; a snapshot is made
//! only when the client's connection takes the next one, so a slow or stalled client skips
//! snapshots instead of queueing them, and holds up neither the other clients nor the feed.

use crate::board::Board;
use axum::extract::State;
use axum::http::header;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse};
use axum::routing::get;
use axum::Router;
use futures_util::stream::{self, Stream};
use std::convert::Infallible;
use std::future::{Future, IntoFuture};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::time::MissedTickBehavior;

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

/// Serve until `shutdown` completes. Event streams never end by themselves, so shutdown drops
/// the connections instead of waiting for them (graceful shutdown would wait forever).
pub async fn serve(
    listener: tokio::net::TcpListener,
    board: Arc<Board>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    tokio::select! {
        served = axum::serve(listener, router(board)).into_future() => served,
        () = shutdown => Ok(()),
    }
}
