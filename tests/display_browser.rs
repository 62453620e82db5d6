//! The live display in a real headless browser: Chromium (from the distribution's packages)
//! loads the page served by `shipcast display`, connects to its event stream, and shows a
//! forecast whose seq rises as forecasts arrive; a client that never reads holds nothing up;
//! when the display stops, every vessel is shown stale with nothing drawn; when the
//! predictor stops, the display forgets the vessel and the page drops its card.
//!
//! Needs Chromium (`apt-get install chromium` on Debian; `.ci/run` installs it). Without it the
//! test fails with one line saying so: it is never skipped silently. Set SHIPCAST_SCREENSHOT=FILE
//! to also save a PNG of the page (docs/display.png is made this way).

mod pipeline_support;

use pipeline_support::{http_get, TestPipeline, PATIENCE};
use std::io::Write;
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

/// The Chromium binary on PATH, or a one-line failure naming what to install.
fn chromium() -> PathBuf {
    let names = [
        "chromium",
        "chromium-browser",
        "google-chrome",
        "google-chrome-stable",
    ];
    let path = std::env::var_os("PATH").unwrap_or_default();
    for dir in std::env::split_paths(&path) {
        for name in names {
            let candidate = dir.join(name);
            if candidate.is_file() {
                return candidate;
            }
        }
    }
    panic!(
        "the display test needs Chromium on PATH (one of {names:?}): on Debian `apt-get install chromium`"
    );
}

/// A free TCP port on 127.0.0.1, outside the ephemeral range: the display is restarted on it
/// while Chromium keeps opening connections, whose source ports an ephemeral one could collide
/// with ("Address already in use").
fn free_port() -> u16 {
    shipcast_pipeline::transport::zenoh::free_port(std::net::Ipv4Addr::LOCALHOST.into())
        .expect("a free port")
}

/// A headless Chromium with one page, driven over its DevTools protocol; killed on drop.
struct Browser {
    _child: BrowserProcess,
    socket: WebSocket<MaybeTlsStream<TcpStream>>,
    next_id: u64,
    _profile: tempfile::TempDir,
}

impl Browser {
    fn open(url: &str) -> Self {
        let profile = tempfile::tempdir().expect("profile dir");
        let mut command = Command::new(chromium());
        // Its own process group, so the guard can stop chromium's helper processes too.
        std::os::unix::process::CommandExt::process_group(&mut command, 0);
        let child = command
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--no-first-run",
                "--window-size=1280,800",
                "--remote-debugging-port=0",
            ])
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg(url)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start chromium");
        // Guarded from here on: any panic below still stops the whole group.
        let child = BrowserProcess(child);
        let Some(port) = Self::devtools_port(profile.path()) else {
            panic!("chromium did not open its DevTools port within {PATIENCE:?}");
        };
        let deadline = Instant::now() + PATIENCE;
        let page_url = loop {
            let list: serde_json::Value = http_get(port, "/json/list")
                .and_then(|body| serde_json::from_str(&body).ok())
                .unwrap_or_default();
            let page = list.as_array().and_then(|targets| {
                targets
                    .iter()
                    .find(|t| t["type"] == "page" && t["url"].as_str() == Some(url))
                    .and_then(|t| t["webSocketDebuggerUrl"].as_str().map(str::to_string))
            });
            if let Some(page) = page {
                break page;
            }
            assert!(
                Instant::now() < deadline,
                "no page target for {url}: {list}"
            );
            std::thread::sleep(Duration::from_millis(100));
        };
        let (socket, _) = tungstenite::connect(page_url.as_str()).expect("DevTools WebSocket");
        Browser {
            _child: child,
            socket,
            next_id: 1,
            _profile: profile,
        }
    }

    /// Chromium writes its DevTools port into the profile once it listens.
    fn devtools_port(profile: &Path) -> Option<u16> {
        let deadline = Instant::now() + PATIENCE;
        while Instant::now() < deadline {
            if let Ok(text) = std::fs::read_to_string(profile.join("DevToolsActivePort")) {
                if let Some(port) = text.lines().next().and_then(|l| l.trim().parse().ok()) {
                    return Some(port);
                }
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        None
    }

    /// Call a DevTools method and return its result.
    fn call(&mut self, method: &str, params: serde_json::Value) -> serde_json::Value {
        let id = self.next_id;
        self.next_id += 1;
        let request = serde_json::json!({ "id": id, "method": method, "params": params });
        self.socket
            .send(Message::text(request.to_string()))
            .expect("send to chromium");
        loop {
            let message = self.socket.read().expect("read from chromium");
            let Ok(text) = message.to_text() else {
                continue;
            };
            let reply: serde_json::Value = serde_json::from_str(text).unwrap_or_default();
            if reply["id"] == id {
                assert!(reply.get("error").is_none(), "{method}: {reply}");
                return reply["result"].clone();
            }
        }
    }

    /// Evaluate a JavaScript expression in the page; its value.
    fn eval(&mut self, expression: &str) -> serde_json::Value {
        let result = self.call(
            "Runtime.evaluate",
            serde_json::json!({ "expression": expression, "returnByValue": true }),
        );
        result["result"]["value"].clone()
    }

    /// Poll `expression` until `accept` takes its value; panics after PATIENCE.
    fn wait_for<T>(
        &mut self,
        what: &str,
        expression: &str,
        accept: impl Fn(&serde_json::Value) -> Option<T>,
    ) -> T {
        let deadline = Instant::now() + PATIENCE;
        loop {
            let value = self.eval(expression);
            if let Some(t) = accept(&value) {
                return t;
            }
            assert!(
                Instant::now() < deadline,
                "the page never showed {what}; last value {value}; page text: {}",
                self.eval("document.body.innerText")
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    fn screenshot(&mut self, path: &Path) {
        let shot = self.call(
            "Page.captureScreenshot",
            serde_json::json!({ "format": "png" }),
        );
        let data = shot["data"].as_str().expect("screenshot data");
        let png = base64_decode(data);
        std::fs::write(path, png).expect("write screenshot");
    }
}

/// Chromium and its helper processes (one process group), killed and reaped when dropped,
/// also when the test fails.
struct BrowserProcess(Child);

impl Drop for BrowserProcess {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            // SAFETY: kill(2) with a plain signal number on the group our own child leads
            // (process_group(0) made its pid the group id); the child is not reaped yet (just
            // checked), so the id cannot have passed to an unrelated group.
            unsafe {
                libc::kill(-(self.0.id() as libc::pid_t), libc::SIGKILL);
            }
        }
        let _ = self.0.wait();
    }
}

/// Standard base64 (the screenshot's encoding).
fn base64_decode(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    };
    let digits: Vec<u8> = text.bytes().filter_map(value).collect();
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &d)| n | (d as u32) << (18 - 6 * i));
        let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        out.extend_from_slice(&bytes[..chunk.len().saturating_sub(1)]);
    }
    out
}

const FIRST_SEQ: &str =
    "(() => { const c = document.querySelector('.vessel'); return c ? c.dataset.seq : null; })()";

fn seq_of(v: &serde_json::Value) -> Option<u64> {
    v.as_str().and_then(|s| s.parse().ok())
}

#[test]
fn the_page_shows_live_forecasts_and_marks_a_vanished_vessel_stale() {
    let p = TestPipeline::new("disp", "");
    let mut predictor = p.spawn("predictor", &[]);
    predictor.wait_for("(iceoryx2 and zenoh)");
    let _producer = p.spawn("producer", &["--wait-subscriber-s", "30"]);
    let _deck = p.spawn("deck", &[]);
    let port = free_port();
    let listen = format!("127.0.0.1:{port}");
    let display_args = ["--listen", listen.as_str(), "--stale-after-s", "4"];
    let mut display = p.spawn("display", &display_args);
    display.wait_for("display: http://");

    // A client that opens the event stream and never reads: it must hold nothing up while
    // the test runs (its buffers take about a minute to fill; the server's own tests cover
    // a client whose buffers are full).
    let mut stalled = TcpStream::connect(("127.0.0.1", port)).expect("connect stalled client");
    write!(stalled, "GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n").expect("request");

    let mut browser = Browser::open(&format!("http://{listen}/"));
    let first = browser.wait_for("a forecast", FIRST_SEQ, seq_of);
    let later = browser.wait_for("a newer forecast", FIRST_SEQ, |v| {
        seq_of(v).filter(|&s| s > first)
    });
    // Polled, not read once: a forecast late by more than the stale limit on a loaded machine
    // shows "STALE" for a moment, which is right.
    browser.wait_for(
        "the vessel as live",
        "document.querySelector('.vessel .status').textContent",
        |v| v.as_str().filter(|t| *t == "live").map(str::to_string),
    );
    // The three charts carry a drawn mean line each, and the deck's advisory is shown.
    let lines = browser.eval("document.querySelectorAll('.vessel svg polyline').length");
    assert_eq!(lines, 3, "mean lines drawn");
    browser.wait_for(
        "the deck advisory",
        "document.querySelector('.vessel .advisory').textContent",
        |v| {
            v.as_str()
                .filter(|t| t.starts_with("deck: GO ") || t.starts_with("deck: NO-GO "))
                .map(str::to_string)
        },
    );
    if let Some(path) = std::env::var_os("SHIPCAST_SCREENSHOT") {
        browser.screenshot(Path::new(&path));
    }
    // The stalled client did not stop the display from serving others.
    let snapshot: serde_json::Value = http_get(port, "/snapshot.json")
        .and_then(|body| serde_json::from_str(&body).ok())
        .expect("the display serves its snapshot while a client stalls");
    assert!(
        snapshot["vessels"][0]["forecast"]["seq"]
            .as_u64()
            .unwrap_or(0)
            >= later
    );

    drop(stalled);

    // The display goes away. Regression (review): the page kept showing the vessel live
    // with its last forecast and GO for good.
    display.terminate();
    assert_stale_and_withdrawn(
        &mut browser,
        "the vessel as stale once the display is not heard",
    );

    // The display comes back on the same address: the page reconnects by itself.
    let mut display = p.spawn("display", &display_args);
    display.wait_for("display: http://");
    browser.wait_for(
        "the vessel live again",
        "document.querySelector('.vessel .status').textContent",
        |v| v.as_str().filter(|t| *t == "live").map(str::to_string),
    );

    // The predictor goes away: the vessel turns stale and its forecast is withdrawn.
    predictor.terminate();
    assert_stale_and_withdrawn(&mut browser, "the vessel as stale");

    // A display that never heard the vessel: the page drops its card (regression: cards
    // were never removed, so forged names grew the page without bound).
    display.terminate();
    let display = p.spawn("display", &display_args);
    display.wait_for("display: http://");
    browser.wait_for(
        "no vessel once the display has none",
        "document.querySelectorAll('.vessel').length",
        |v| (v.as_u64() == Some(0)).then_some(()),
    );
    let empty = browser.eval("getComputedStyle(document.getElementById('empty')).display");
    assert_eq!(empty, "block", "the page says no vessel is heard");
}

/// The card turns STALE and shows nothing current: no forecast seq, no drawn chart, no
/// decision.
fn assert_stale_and_withdrawn(browser: &mut Browser, what: &str) {
    browser.wait_for(
        what,
        "document.querySelector('.vessel .status').textContent",
        |v| {
            v.as_str()
                .filter(|t| t.starts_with("STALE"))
                .map(str::to_string)
        },
    );
    assert_eq!(
        browser.eval(FIRST_SEQ),
        "",
        "a stale vessel shows no forecast"
    );
    let drawn = browser.eval("document.querySelectorAll('.vessel svg *').length");
    assert_eq!(drawn, 0, "a stale vessel's charts are not drawn");
    let advisory = browser.eval("document.querySelector('.vessel .advisory').textContent");
    assert_eq!(advisory, "", "a stale vessel shows no decision");
}
