//! Shared helpers of the pipeline integration tests: spawn the real `shipcast` binary with a
//! unique instance prefix, capture its output, and always kill and reap it (Drop), also when a
//! test fails.

#![allow(dead_code)]

use shipcast_pipeline::child::ChildProcess;
use shipcast_pipeline::pacing::poll_until;
use shipcast_wire::payload::Forecast;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub const BIN: &str = env!("CARGO_BIN_EXE_shipcast");

/// Upper bound for waiting on an expected event; a hang guard, not a performance threshold.
pub const PATIENCE: Duration = Duration::from_secs(60);

/// How often a waiting test looks again.
const POLL: Duration = Duration::from_millis(20);

/// An instance name no other test (or test run) uses.
pub fn unique_instance(tag: &str) -> String {
    shipcast_pipeline::transport::unique_instance(&format!("t{tag}"))
}

/// A pipeline config for tests: small order, fast start-up training, no scouting, explicit
/// loopback endpoint on a free port.
pub struct TestPipeline {
    pub dir: tempfile::TempDir,
    pub config: PathBuf,
    pub instance: String,
    pub endpoint: String,
}

impl TestPipeline {
    pub fn new(tag: &str, extra_toml: &str) -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let instance = unique_instance(tag);
        let endpoint =
            shipcast_pipeline::transport::zenoh::free_loopback_endpoint().expect("a free port");
        let text = format!(
            "instance = \"{instance}\"\n{extra_toml}\n[zenoh]\nlisten = [\"{endpoint}\"]\nmulticast_scouting = false\n"
        );
        let text = if text.contains("[predictor]") {
            text
        } else {
            format!("{text}\n[predictor]\norder = 100\nholdout = 300\nretrain_window = 1000\nwarmup_s = 900.0\nretrain_every_s = 0.0\n")
        };
        let config = dir.path().join("pipeline.toml");
        std::fs::write(&config, text).expect("write config");
        Self {
            dir,
            config,
            instance,
            endpoint,
        }
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Start `shipcast <service> --config <this config> <args>`.
    pub fn spawn(&self, service: &str, args: &[&str]) -> Proc {
        let mut all = vec![
            service,
            "--config",
            self.config.to_str().expect("utf-8 path"),
        ];
        all.extend_from_slice(args);
        Proc::spawn(service, &all)
    }

    pub fn names(&self) -> shipcast_pipeline::transport::Names {
        shipcast_pipeline::transport::Names::new(Some(&self.instance), "ddg51")
            .expect("valid names")
    }
}

impl TestPipeline {
    /// Subscribe to the predictor's status JSON (zenoh `.../status/predictor`), the facts the
    /// predictor reports about itself: counters, staleness, model version, engine counts.
    pub fn watch_status(&self) -> StatusWatch {
        self.watch_status_of("predictor")
    }

    /// Subscribe to `service`'s status JSON (zenoh `.../status/<service>`).
    pub fn watch_status_of(&self, service: &'static str) -> StatusWatch {
        let config =
            shipcast_pipeline::config::PipelineConfig::load(Some(&self.config)).expect("config");
        let session = shipcast_pipeline::transport::zenoh::open(&config.zenoh.consumer_side())
            .expect("zenoh session");
        let sub = shipcast_pipeline::transport::zenoh::LatestSubscriber::new(
            &session,
            &self.names().status(service),
        )
        .expect("status subscriber");
        StatusWatch {
            service,
            _session: session,
            sub,
            last: Mutex::new(None),
        }
    }
}

/// A service's status JSON as it arrives (the predictor's every 500 ms and on every change).
pub struct StatusWatch {
    service: &'static str,
    _session: zenoh::Session,
    sub: shipcast_pipeline::transport::zenoh::LatestSubscriber,
    last: Mutex<Option<serde_json::Value>>,
}

impl StatusWatch {
    /// The first status for which `holds` is true; panics after PATIENCE with the last one.
    pub fn wait_until(
        &self,
        what: &str,
        holds: impl Fn(&serde_json::Value) -> bool,
    ) -> serde_json::Value {
        let found = poll_until(PATIENCE, Duration::ZERO, || {
            let bytes = self.sub.recv_timeout(Duration::from_millis(100)).ok()??;
            let status: serde_json::Value = serde_json::from_slice(&bytes).expect("status is JSON");
            let ok = holds(&status);
            *self.last.lock().expect("last") = Some(status.clone());
            ok.then_some(status)
        });
        found.unwrap_or_else(|| {
            panic!(
                "no {} status with {what}; last: {:?}",
                self.service,
                self.last.lock().expect("last")
            )
        })
    }
}

impl StatusWatch {
    /// The first status for which `holds` is true and was true, with the same counters, in the
    /// status before it (about 500 ms earlier): the state has settled, not just passed by (a
    /// producer paused by a busy machine makes the predictor report "stale" for a moment).
    pub fn wait_settled(
        &self,
        what: &str,
        holds: impl Fn(&serde_json::Value) -> bool,
    ) -> serde_json::Value {
        let previous: Mutex<Option<serde_json::Value>> = Mutex::new(None);
        self.wait_until(what, |s| {
            let mut prev = previous.lock().expect("previous");
            let settled = holds(s)
                && prev
                    .as_ref()
                    .is_some_and(|p| holds(p) && p["counters"] == s["counters"]);
            *prev = Some(s.clone());
            settled
        })
    }
}

/// A number of a status JSON (`path` of keys), panicking if it is not there.
pub fn status_u64(status: &serde_json::Value, path: &[&str]) -> u64 {
    path.iter()
        .fold(status, |v, k| &v[k])
        .as_u64()
        .unwrap_or_else(|| panic!("no number at {path:?} in {status}"))
}

impl Drop for TestPipeline {
    /// iceoryx2 keeps a 16-byte management segment per file prefix after the last node is
    /// gone; the prefix is unique to this test, so remove it once every process has stopped.
    fn drop(&mut self) {
        shipcast_pipeline::transport::iox::remove_leftovers(&self.names().iox_prefix());
    }
}

/// A running child with its output collected line by line.
pub struct Proc {
    pub name: String,
    child: ChildProcess,
    stdout: Arc<Mutex<Vec<String>>>,
    stderr: Arc<Mutex<Vec<String>>>,
    /// The threads reading stdout and stderr; each ends when its pipe closes.
    readers: Vec<std::thread::JoinHandle<()>>,
}

fn strip_ansi(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        if c == '\x1b' {
            for c in chars.by_ref() {
                if c.is_ascii_alphabetic() {
                    break;
                }
            }
        } else {
            out.push(c);
        }
    }
    out
}

fn collect(
    stream: impl std::io::Read + Send + 'static,
    into: Arc<Mutex<Vec<String>>>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        for line in BufReader::new(stream).lines().map_while(Result::ok) {
            into.lock().expect("lines").push(strip_ansi(&line));
        }
    })
}

/// Line counts of a process's two output streams at one moment ([`Proc::mark`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct OutputMark {
    stderr: usize,
    stdout: usize,
}

impl Proc {
    pub fn spawn(name: &str, args: &[&str]) -> Self {
        let mut cmd = Command::new(BIN);
        cmd.args(args)
            .env("RUST_LOG", "info")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mut child = ChildProcess::spawn(name, &mut cmd).expect("spawn shipcast");
        let stdout = Arc::new(Mutex::new(Vec::new()));
        let stderr = Arc::new(Mutex::new(Vec::new()));
        let pipes = child.child_mut();
        let readers = vec![
            collect(pipes.stdout.take().expect("stdout"), stdout.clone()),
            collect(pipes.stderr.take().expect("stderr"), stderr.clone()),
        ];
        Self {
            name: name.to_string(),
            child,
            stdout,
            stderr,
            readers,
        }
    }

    pub fn stdout(&self) -> Vec<String> {
        self.stdout.lock().expect("lines").clone()
    }

    pub fn stderr(&self) -> Vec<String> {
        self.stderr.lock().expect("lines").clone()
    }

    /// Wait until a line of stderr (logs) or stdout contains `needle`; panics with the output
    /// after PATIENCE.
    pub fn wait_for(&self, needle: &str) -> String {
        self.wait_for_after(needle, OutputMark::default())
    }

    /// How many lines each stream holds now: lines from here on are "after" it.
    pub fn mark(&self) -> OutputMark {
        OutputMark {
            stderr: self.stderr.lock().expect("lines").len(),
            stdout: self.stdout.lock().expect("lines").len(),
        }
    }

    /// Wait until a line of stderr or stdout contains one of `needles`; the line found, or
    /// None after PATIENCE.
    pub fn wait_for_any(&self, needles: &[&str]) -> Option<String> {
        self.poll_for(needles, OutputMark::default())
    }

    /// Like `wait_for`, but only lines written after `mark` count, on either stream.
    pub fn wait_for_after(&self, needle: &str, mark: OutputMark) -> String {
        let found = self.poll_for(&[needle], mark);
        found.unwrap_or_else(|| {
            panic!(
                "{}: no line with '{needle}'; stderr:\n{}",
                self.name,
                self.stderr().join("\n")
            )
        })
    }

    /// The first line written after `mark`, on stderr or else stdout, that contains one of
    /// `needles`, polled for up to PATIENCE.
    fn poll_for(&self, needles: &[&str], mark: OutputMark) -> Option<String> {
        poll_until(PATIENCE, POLL, || {
            let after = |lines: Vec<String>, from: usize| {
                lines
                    .into_iter()
                    .skip(from)
                    .find(|l| needles.iter().any(|n| l.contains(n)))
            };
            after(self.stderr(), mark.stderr).or_else(|| after(self.stdout(), mark.stdout))
        })
    }

    /// Wait for the process to exit by itself; panics after PATIENCE.
    pub fn wait_exit(&mut self) -> std::process::ExitStatus {
        let Some(status) = self.child.wait_timeout(PATIENCE) else {
            panic!(
                "{} did not exit; stderr:\n{}",
                self.name,
                self.stderr().join("\n")
            );
        };
        // Every line is read once both pipes are closed. A grandchild that inherited them
        // would hold them open, so the wait is bounded; the readers are joined once closed.
        poll_until(Duration::from_secs(10), POLL, || {
            self.readers.iter().all(|r| r.is_finished()).then_some(())
        });
        for reader in std::mem::take(&mut self.readers) {
            if reader.is_finished() {
                let _ = reader.join();
            }
        }
        status
    }

    /// SIGTERM (a clean stop) and wait; a process that has exited already is not signalled.
    pub fn terminate(&mut self) -> std::process::ExitStatus {
        self.child.terminate();
        self.wait_exit()
    }

    /// SIGKILL (a crash) and reap, so iceoryx2 sees the node as dead.
    pub fn kill9(&mut self) {
        let _ = self.child.kill();
    }
}

// Dropping a Proc drops its ChildProcess: SIGTERM, so the process releases its shared memory,
// SIGKILL if it does not exit within a few seconds, and always reaped.

/// The last log line of a service that contains `needle`, parsed for `key N` pairs.
pub fn counter(line: &str, key: &str) -> u64 {
    let words: Vec<&str> = line.split_whitespace().collect();
    words
        .windows(2)
        .find(|w| w[0].trim_start_matches('(') == key)
        .and_then(|w| {
            w[1].trim_end_matches(|c: char| !c.is_ascii_digit())
                .parse()
                .ok()
        })
        .unwrap_or_else(|| panic!("no '{key} N' in: {line}"))
}

/// Run a `shipcast` command to completion, panicking with its output if it fails; returns its
/// stdout.
pub fn run_ok(args: &[&str]) -> String {
    let out = Command::new(BIN).args(args).output().expect("run shipcast");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "shipcast {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Receive forecasts on `sub` until `n` arrived, or none came for [`PATIENCE`] (a hang guard
/// that a long, slowly paced record never trips); the caller asserts on what came.
pub fn collect_forecasts(
    sub: &shipcast_pipeline::transport::iox::IoxSubscriber<shipcast_wire::payload::Forecast>,
    n: usize,
) -> Vec<shipcast_wire::payload::Forecast> {
    let mut got = Vec::with_capacity(n);
    let mut deadline = Instant::now() + PATIENCE;
    while got.len() < n && Instant::now() < deadline {
        sub.wait(Duration::from_millis(50)).unwrap();
        while let Some(f) = sub.receive().unwrap() {
            got.push(f);
            deadline = Instant::now() + PATIENCE;
        }
    }
    got
}

/// The injected forecast of issue 14: an unrelated, repeated seq and 9.99 m heave everywhere.
pub const FAKE_SEQ: u64 = 987654321;

pub fn fake_forecast_json() -> Vec<u8> {
    let mut f = Forecast {
        seq: FAKE_SEQ,
        time_s: 1.0e6,
        dt_s: 0.5,
        steps: 40,
        ..Forecast::default()
    };
    f.mean[2][..40].fill(9.99);
    let mut out = Vec::new();
    f.write_json(&mut out).expect("serialise");
    out
}

/// Wait until the crane has printed `n` more forecast lines than `from`.
pub fn wait_crane_lines(crane: &Proc, from: usize, n: usize) {
    let printed = poll_until(PATIENCE, Duration::from_millis(20), || {
        (crane.stdout().len() >= from + n).then_some(())
    });
    assert!(
        printed.is_some(),
        "crane stopped printing forecasts; stderr:\n{}",
        crane.stderr().join("\n")
    );
}

/// One plain HTTP GET on loopback; the body, or None when the server gave none (yet). Reads
/// `Content-Length` bytes when given (Chromium's DevTools server keeps the connection open),
/// else to the end.
pub fn http_get(port: u16, path: &str) -> Option<String> {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(5))).ok()?;
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
    )
    .ok()?;
    let mut response = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        let n = s.read(&mut buf).ok()?;
        response.extend_from_slice(&buf[..n]);
        let text = String::from_utf8_lossy(&response);
        if let Some((head, body)) = text.split_once("\r\n\r\n") {
            let length = head.lines().find_map(|l| {
                let (name, value) = l.split_once(':')?;
                name.eq_ignore_ascii_case("content-length")
                    .then(|| value.trim().parse::<usize>().ok())
                    .flatten()
            });
            if length.is_some_and(|len| body.len() >= len) || n == 0 {
                return Some(body.to_string());
            }
        } else if n == 0 {
            return None;
        }
    }
}
