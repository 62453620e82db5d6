//! The live display (`shipcast display`): one web page, served by the binary itself (ship
//! networks are offline: no CDN, fonts or scripts from elsewhere), that shows every vessel and
//! station it hears on zenoh, updating as forecasts arrive.
//!
//! - [`board`]: what the page shows, per vessel: the newest accepted forecast of heave, roll and
//!   pitch with sigma, the deck advisory, the live skill, and whether the vessel went stale.
//! - [`feed`]: the zenoh subscriptions that fill the board (every vessel under one key
//!   expression); a message must come from its key's live publisher and a forecast must pass
//!   the receive checks before it is shown.
//! - [`sources`]: which publisher is alive on each key, from the publishers' liveliness tokens.
//! - [`server`]: the HTTP server (axum): the page and a server-sent-event stream of board
//!   snapshots. Each client is sent the newest snapshot at a fixed pace; a client that reads
//!   slowly or never skips snapshots and holds nothing up.
//! - [`connections`]: what one host can take of the server: a cap on connections served at
//!   once, a timeout for a request head and one for a write its client does not take, in the
//!   server's own accept loop.
//! - `write_timeout`: a connection's IO whose writes fail once one has waited too long.
//! - `tally`: events counted and reported at most once per period.

pub mod board;
pub mod connections;
pub mod feed;
pub mod server;
pub mod sources;
mod tally;
mod write_timeout;
