//! Raw zenoh floor between two processes: this process pings from the first core, a child
//! `shipcast bench zenoh-pong` answers from the second.
//!
//! Why a second floor: shipcast's zenoh path crosses a process boundary (predictor -> consumer),
//! and so does every real zenoh deployment. Two sessions in one process share one zenoh runtime,
//! whose worker thread can carry a message from the sending session's socket straight to the
//! receiving one without a wake-up; between processes the receiver's runtime must be woken. On a
//! two-vCPU virtual machine that wake-up is tens of microseconds, so the in-process floor would
//! flatter zenoh and blame shipcast for zenoh's own cost. Both floors are reported.
//!
//! The child records the ping leg of every measured exchange; at the end this side sends
//! [`STOP`] and the child writes the legs to a file that this side merges with its pong legs.

use super::children::Children;
use super::pingpong::{ping_loop, Endpoint, PingPongOutcome, HANDSHAKE, POLL_SLICE};
use super::pingpong_zenoh::ZenohEndpoint;
use super::pinning::{pin_current, PinOutcome};
use super::plan::{Mode, Plan};
use crate::histogram::LatencyRecorder;
use anyhow::{anyhow, Context};
use shipcast_pipeline::transport::monotonic_ns;
use shipcast_pipeline::transport::zenoh::{free_loopback_endpoint, open, ZenohSettings};
use std::io::Write as _;
use std::path::{Path as FsPath, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// seq that tells the pong process to write its legs and exit.
pub const STOP: u64 = u64::MAX - 1;
/// The pong process gives up when no ping arrived for this long (its parent is gone).
const IDLE_LIMIT: Duration = Duration::from_secs(60);
/// How long the pong process gets to write its legs and exit after [`STOP`].
const STOP_TIMEOUT: Duration = Duration::from_secs(10);

/// What the pong process is told on its command line.
#[derive(Debug, Clone, PartialEq)]
pub struct PongArgs {
    /// The ping side's listen endpoint, e.g. `tcp/127.0.0.1:7447`.
    pub connect: String,
    /// Key prefix of this exchange: pings on `<prefix>/ping`, answers on `<prefix>/pong`.
    pub prefix: String,
    pub bytes: usize,
    pub mode: Mode,
    pub core: usize,
    /// Exchanges with a smaller seq are warm-up and not recorded.
    pub warmup: u64,
    /// Where the recorded legs are written (one latency in ns per line after a header line).
    pub out: PathBuf,
}

impl PongArgs {
    fn command_line(&self) -> Vec<String> {
        vec![
            "bench".into(),
            "zenoh-pong".into(),
            "--connect".into(),
            self.connect.clone(),
            "--prefix".into(),
            self.prefix.clone(),
            "--bytes".into(),
            self.bytes.to_string(),
            "--mode".into(),
            self.mode.name().into(),
            "--core".into(),
            self.core.to_string(),
            "--warmup".into(),
            self.warmup.to_string(),
            "--out".into(),
            self.out.display().to_string(),
        ]
    }
}

/// The pong process: connect, answer every ping, record the ping leg of measured exchanges, and
/// on [`STOP`] write them to `args.out`.
pub fn serve_pong(args: &PongArgs) -> anyhow::Result<()> {
    let session = open(&ZenohSettings::connect_to(&args.connect))?;
    // Pinned after the session exists: zenoh's own threads keep every core, as in the services.
    let pin = pin_current("zenoh pong process", args.core);
    let (ping_key, pong_key) = keys(&args.prefix);
    let mut ep = ZenohEndpoint::new(session, &pong_key, &ping_key, args.mode, args.bytes)?;
    let mut legs: Vec<u64> = Vec::with_capacity(1 << 16);
    let mut last = Instant::now();
    loop {
        match ep.recv(POLL_SLICE)? {
            Some((STOP, _)) => break,
            Some((seq, stamp)) => {
                let now = monotonic_ns();
                if seq != HANDSHAKE && seq >= args.warmup {
                    legs.push(now.saturating_sub(stamp));
                }
                ep.send(seq, monotonic_ns())?;
                last = Instant::now();
            }
            None if last.elapsed() > IDLE_LIMIT => {
                anyhow::bail!("no ping for {IDLE_LIMIT:?}: the benchmark is gone")
            }
            None => {}
        }
    }
    write_legs(&args.out, pin.pinned, &legs)
}

fn keys(prefix: &str) -> (String, String) {
    (format!("{prefix}/ping"), format!("{prefix}/pong"))
}

fn write_legs(path: &FsPath, pinned: bool, legs: &[u64]) -> anyhow::Result<()> {
    let mut text = String::with_capacity(legs.len() * 8 + 16);
    text.push_str(if pinned { "pinned\n" } else { "unpinned\n" });
    for ns in legs {
        text.push_str(&ns.to_string());
        text.push('\n');
    }
    let mut file =
        std::fs::File::create(path).with_context(|| format!("create {}", path.display()))?;
    file.write_all(text.as_bytes())
        .with_context(|| format!("write {}", path.display()))
}

/// Read what [`write_legs`] wrote: whether the pong was pinned, and its legs.
fn read_legs(path: &FsPath) -> anyhow::Result<(bool, LatencyRecorder)> {
    let text = std::fs::read_to_string(path).with_context(|| format!("read {}", path.display()))?;
    let mut lines = text.lines();
    let pinned = match lines.next() {
        Some("pinned") => true,
        Some("unpinned") => false,
        other => anyhow::bail!("{}: bad header {other:?}", path.display()),
    };
    let mut rec = LatencyRecorder::new();
    for (i, line) in lines.enumerate() {
        let ns: u64 = line.parse().map_err(|_| {
            anyhow!(
                "{}: line {}: '{line}' is not a latency",
                path.display(),
                i + 2
            )
        })?;
        rec.record_ns(ns);
    }
    Ok((pinned, rec))
}

/// Ping-pong `bytes`-byte messages over zenoh with a `shipcast bench zenoh-pong` child (the
/// executable `exe`) in `mode`.
pub fn run(plan: &Plan, mode: Mode, bytes: usize, exe: &FsPath) -> anyhow::Result<PingPongOutcome> {
    let endpoint = free_loopback_endpoint()?;
    let session = open(&ZenohSettings::listen_on(&endpoint))?;
    let dir = std::env::temp_dir();
    let tag = format!("{}-zenoh-pong-{bytes}-{}", plan.instance, mode.name());
    let args = PongArgs {
        connect: endpoint,
        prefix: format!("{}/zenoh-ipc-{bytes}-{}", plan.instance, mode.name()),
        bytes,
        mode,
        core: plan.cores.1,
        warmup: plan.warmup,
        out: dir.join(format!("{tag}.legs")),
    };
    let (ping_key, pong_key) = keys(&args.prefix);
    let mut children = Children::default();
    // The child pins its own answering thread; its zenoh threads stay free (see serve_pong).
    children.spawn_unpinned(
        "zenoh pong",
        exe,
        &args.command_line(),
        dir.join(format!("{tag}.log")),
    )?;
    let done = AtomicBool::new(false);
    let (pinged, ping_pin) = std::thread::scope(|s| {
        let ping = s.spawn(|| {
            let pin = pin_current("zenoh ping (processes)", plan.cores.0);
            let mut ep = ZenohEndpoint::new(session, &ping_key, &pong_key, mode, bytes)?;
            let result = ping_loop(&mut ep, plan, &done);
            // Stop the child whether or not the exchanges succeeded.
            let _ = ep.send(STOP, monotonic_ns());
            done.store(true, Ordering::Release);
            result.map(|rec| (rec, pin))
        });
        // A child that dies must not leave the ping side waiting for answers.
        while !done.load(Ordering::Acquire) {
            if children.check_running("zenoh pong").is_err() {
                done.store(true, Ordering::Release);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        ping.join()
            .map_err(|_| anyhow!("zenoh ping thread panicked"))
            .and_then(|r| r)
    })
    .context("zenoh ping side (processes)")?;
    children.wait_exit("zenoh pong", STOP_TIMEOUT)?;
    let (pong_pinned, pong_legs) = read_legs(&args.out)?;
    let _ = std::fs::remove_file(&args.out);
    let mut recorder = pinged;
    recorder.merge(&pong_legs);
    Ok(PingPongOutcome {
        recorder,
        expected: 2 * plan.samples,
        pins: vec![
            ping_pin,
            PinOutcome {
                role: "zenoh pong process".into(),
                core: plan.cores.1,
                pinned: pong_pinned,
            },
        ],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legs_file_round_trips_and_bad_files_are_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.legs");
        write_legs(&path, true, &[100, 200, 300]).unwrap();
        let (pinned, rec) = read_legs(&path).unwrap();
        assert!(pinned);
        assert_eq!(rec.count(), 3);
        assert_eq!(rec.quantile_ns(0.5), 200);
        std::fs::write(&path, "unpinned\n12\nx\n").unwrap();
        let err = read_legs(&path).unwrap_err().to_string();
        assert!(err.contains("line 3") && err.contains("'x'"), "{err}");
        std::fs::write(&path, "").unwrap();
        assert!(read_legs(&path).is_err());
    }

    #[test]
    fn command_line_names_every_argument() {
        let args = PongArgs {
            connect: "tcp/127.0.0.1:1".into(),
            prefix: "p".into(),
            bytes: 72,
            mode: Mode::Poll,
            core: 1,
            warmup: 5,
            out: "/tmp/x.legs".into(),
        };
        let line = args.command_line().join(" ");
        assert_eq!(
            line,
            "bench zenoh-pong --connect tcp/127.0.0.1:1 --prefix p --bytes 72 --mode poll --core 1 --warmup 5 --out /tmp/x.legs"
        );
    }
}
