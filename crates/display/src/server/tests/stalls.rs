//! The write timeout on real event streams: a client that stops reading is closed and frees
//! its slot; one that reads is served on, past the timeout, next to it.

use super::*;
use shipcast_wire::payload::Forecast;
use std::sync::atomic::{AtomicBool, Ordering};

/// The longest a test waits for a stalled stream to be closed: its buffers must fill and the
/// write timeout pass, on a machine that may be loaded.
const STALL_WAIT: Duration = Duration::from_secs(30);

/// The send buffer of the server's connections, and the receive buffer of a client that stops
/// reading: far below one snapshot of [`busy_board`], so that such a client fills them at once.
const SMALL_BUFFER: usize = 16 << 10;

/// A board of 64 vessels with a full forecast each that stays live for the whole test: each
/// snapshot is far larger than the socket buffers.
fn busy_board() -> Arc<Board> {
    let board = Board::new(
        Limits {
            roll_deg: 2.5,
            pitch_deg: 1.5,
        },
        Duration::from_secs(3600),
    );
    let mut f = Forecast {
        seq: 1,
        time_s: 100.0,
        dt_s: 0.5,
        steps: 128,
        model_version: 1,
        ..Forecast::default()
    };
    for (d, (mean, sigma)) in f.mean.iter_mut().zip(f.sigma.iter_mut()).enumerate() {
        for (k, (m, s)) in mean.iter_mut().zip(sigma.iter_mut()).enumerate() {
            let x = (d * 1000 + k) as f32;
            *m = (x * 0.731).sin() * 0.1234567;
            *s = 0.01 + (x * 0.377).cos().abs() * 0.0123457;
        }
    }
    for v in 0..crate::board::MAX_VESSELS {
        board
            .forecast(&format!("vessel-{v:02}"), &f, Instant::now())
            .expect("on the board");
    }
    let size = board.snapshot_json(Instant::now()).len();
    assert!(size > 32 * SMALL_BUFFER, "a snapshot of {size} bytes");
    Arc::new(board)
}

/// A server of [`busy_board`] whose writes time out after `write_timeout`.
fn busy_server(max_connections: usize, write_timeout: Duration) -> Server {
    Server::start_with(
        ConnectionLimits {
            max_connections,
            max_per_host: MAX_CONNECTIONS_PER_HOST,
            head_timeout: HEAD_TIMEOUT,
            write_timeout,
            send_buffer: SMALL_BUFFER,
        },
        busy_board(),
    )
}

impl Server {
    /// An event-stream client with a small receive buffer that reads the status line and
    /// then nothing more.
    fn open_events_then_stop_reading(&self) -> BufReader<TcpStream> {
        let socket = tokio::net::TcpSocket::new_v4().expect("a socket");
        socket
            .set_recv_buffer_size(SMALL_BUFFER as u32)
            .expect("a small receive buffer");
        request_events(self.connect_socket(socket))
    }
}

/// The stalled stream is closed once its buffers are full and the write timeout has passed,
/// and its slot serves the next client.
fn assert_closed_and_its_slot_served(server: &Server, stalled: &mut impl Read) {
    let response = server.get_once_served("/snapshot.json", STALL_WAIT);
    assert!(response.starts_with("HTTP/1.1 200"), "{response:.200}");
    assert!(
        closed_within(stalled, STALL_WAIT),
        "the stalled event stream is still served"
    );
}

#[test]
fn an_event_stream_whose_client_stops_reading_is_closed_and_its_slot_freed() {
    let server = busy_server(1, Duration::from_millis(200));
    // Takes the only slot, then stops reading.
    let mut stalled = server.open_events_then_stop_reading();

    assert_closed_and_its_slot_served(&server, &mut stalled);
}

#[test]
fn a_client_that_reads_is_served_on_while_a_stalled_one_next_to_it_is_closed() {
    // A timeout far longer than any pause of a reading thread, even on a loaded machine.
    let server = busy_server(2, Duration::from_secs(6));
    let mut reader = server.open_events();
    let stop = Arc::new(AtomicBool::new(false));
    let reading = std::thread::spawn({
        let stop = stop.clone();
        move || {
            let mut snapshots = 0u64;
            while !stop.load(Ordering::Relaxed) {
                next_snapshot(&mut reader);
                snapshots += 1;
            }
            (reader, snapshots)
        }
    });
    let mut stalled = server.open_events_then_stop_reading();

    // The stalled stream is closed after the write timeout, which frees the second slot...
    assert_closed_and_its_slot_served(&server, &mut stalled);
    // ...while the stream of the client that reads went on all along, and goes on.
    stop.store(true, Ordering::Relaxed);
    let (mut reader, snapshots) = reading.join().expect("the reading client's stream went on");
    assert!(snapshots > 0);
    next_snapshot(&mut reader);
}
