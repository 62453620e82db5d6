//! Fleet benchmark (`shipcast bench fleet`): N vessels publish forecast-sized JSON at 2 Hz
//! through one `shipcast router` process to one shore subscriber on `shipcast/*/forecast`.
//! Measures delivery latency (from the issue stamp in the payload, one clock: one machine),
//! loss, the router's CPU, and how long the shore takes to hear every vessel again after the
//! router is killed and restarted on the same endpoint.

use crate::LatencyRecorder;
use anyhow::Context;
use shipcast_pipeline::child::ChildProcess;
use shipcast_pipeline::pacing::{poll_until, Pacer};
use shipcast_pipeline::transport::monotonic_ns;
use shipcast_pipeline::transport::zenoh::{self as zn, Mode, ZenohSettings};
use shipcast_wire::payload::Forecast;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// What one run measures.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FleetReport {
    pub vessels: usize,
    pub seconds: f64,
    pub rate_hz: f64,
    pub payload_bytes: usize,
    pub sent: u64,
    pub received: u64,
    pub lost: u64,
    pub p50_us: f64,
    pub p99_us: f64,
    pub max_us: f64,
    /// Router CPU over the measured window, in % of one core.
    pub router_cpu_pct: f64,
    /// Seconds from killing the router until the shore had a forecast from every vessel again
    /// (the new router is started right after the kill); None if not measured or not reached.
    pub restart_recovery_s: Option<f64>,
}

/// The `shipcast router` child; killed and reaped when dropped.
struct RouterProcess {
    child: ChildProcess,
}

impl RouterProcess {
    fn start(exe: &Path, endpoint: &str, log: &Path) -> anyhow::Result<Self> {
        let file =
            std::fs::File::create(log).with_context(|| format!("create {}", log.display()))?;
        let mut cmd = Command::new(exe);
        cmd.args(["router", "--listen", endpoint])
            .stdin(Stdio::null())
            .stdout(file.try_clone()?)
            .stderr(file);
        // Killed at once: the benchmark measures recovery from a crashed router.
        let child = ChildProcess::spawn("router", &mut cmd)
            .context("start shipcast router")?
            .with_stop_grace(Duration::ZERO);
        Ok(Self { child })
    }

    /// User + system CPU time of the router so far.
    fn cpu_time(&self) -> anyhow::Result<Duration> {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.child.id()))?;
        // Fields after the command name (which is in parentheses and may hold spaces).
        let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
        let fields: Vec<&str> = rest.split_whitespace().collect();
        let ticks = |i: usize| {
            fields
                .get(i)
                .and_then(|v| v.parse::<u64>().ok())
                .unwrap_or(0)
        };
        // utime and stime are fields 14 and 15 of stat(5), 12 and 13 after the name.
        // SAFETY: sysconf has no preconditions.
        let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) }.max(1) as f64;
        Ok(Duration::from_secs_f64((ticks(11) + ticks(12)) as f64 / hz))
    }

    fn kill(&mut self) {
        let _ = self.child.kill();
    }
}

/// What the shore has received, per vessel.
#[derive(Default)]
struct ShoreTally {
    latency: LatencyRecorder,
    received: u64,
    /// Monotonic time of the last forecast from each vessel.
    last_ns: Vec<u64>,
    measuring: bool,
}

/// The fields the shore reads from a forecast.
#[derive(serde::Deserialize)]
struct Stamp {
    issued_stamp_ns: u64,
}

/// A forecast JSON of the pipeline's default shape (50 steps, six DOF), for the size.
fn forecast_json(seq: u64, issued_ns: u64, out: &mut Vec<u8>) {
    let mut f = Forecast {
        seq,
        issued_stamp_ns: issued_ns,
        time_s: seq as f64 * 0.5,
        dt_s: 0.5,
        steps: 50,
        ..Forecast::default()
    };
    for d in 0..6 {
        for k in 0..50 {
            f.mean[d][k] = ((seq as f32) * 0.37 + (d * 50 + k) as f32 * 0.011).sin();
            f.sigma[d][k] = 0.01 + k as f32 * 0.003;
        }
    }
    // Serialising a plain struct into a Vec cannot fail.
    let _ = f.write_json(out);
}

/// Run the fleet benchmark with `vessels` load generators for `seconds`, then (if
/// `restart`) kill and restart the router and time the shore's recovery.
pub fn run(
    exe: &Path,
    work_dir: &Path,
    vessels: usize,
    seconds: f64,
    rate_hz: f64,
    restart: bool,
) -> anyhow::Result<FleetReport> {
    anyhow::ensure!(vessels > 0, "--vessels must be at least 1");
    let endpoint = zn::free_loopback_endpoint()?;
    let prefix = shipcast_pipeline::transport::unique_instance(&format!("fleet{vessels}"));
    let log: PathBuf = work_dir.join(format!("router-{vessels}.log"));
    let mut router = RouterProcess::start(exe, &endpoint, &log)?;
    // The router is up once a client can connect.
    let shore = wait_for_client(&endpoint, Duration::from_secs(30))?;
    let tally = Arc::new(Mutex::new(ShoreTally {
        last_ns: vec![0; vessels],
        ..ShoreTally::default()
    }));
    let key_prefix = format!("{prefix}/shipcast/v");
    let sink = tally.clone();
    let _sub = shore
        .declare_subscriber(format!("{prefix}/shipcast/*/forecast"))
        .callback(move |sample| {
            let now = monotonic_ns();
            let vessel = sample
                .key_expr()
                .as_str()
                .strip_prefix(&key_prefix)
                .and_then(|r| r.split('/').next())
                .and_then(|i| i.parse::<usize>().ok());
            let stamp: Option<Stamp> = serde_json::from_slice(&sample.payload().to_bytes()).ok();
            if let (Some(v), Some(s), Ok(mut t)) = (vessel, stamp, sink.lock()) {
                if let Some(last) = t.last_ns.get_mut(v) {
                    *last = now;
                }
                if t.measuring {
                    t.received += 1;
                    t.latency.record_between(s.issued_stamp_ns, now);
                }
            }
        })
        .wait()
        .map_err(|e| anyhow::anyhow!("shore subscriber: {e}"))?;

    // The vessels: one peer session each, connected to the router, as `shipcast run
    // --zenoh-connect` does.
    let mut sessions = Vec::with_capacity(vessels);
    let mut publishers = Vec::with_capacity(vessels);
    for v in 0..vessels {
        let s = zn::open(&ZenohSettings {
            mode: Mode::Peer,
            connect: vec![endpoint.clone()],
            ..ZenohSettings::default()
        })?;
        publishers.push(zn::JsonPublisher::new(
            &s,
            &format!("{prefix}/shipcast/v{v}/forecast"),
        )?);
        sessions.push(s);
    }
    // Declarations propagate asynchronously: wait until every publisher sees the shore.
    let seen = poll_until(Duration::from_secs(60), Duration::from_millis(50), || {
        publishers.iter().all(|p| p.has_subscribers()).then_some(())
    });
    anyhow::ensure!(
        seen.is_some(),
        "not every vessel saw the shore subscriber within 60 s"
    );

    let mut buf = Vec::with_capacity(8192);
    forecast_json(0, 0, &mut buf);
    let payload_bytes = buf.len();
    let publish_for = |until: Instant, seq: &mut u64, buf: &mut Vec<u8>| -> anyhow::Result<u64> {
        let mut sent = 0;
        // One put per slot, the vessels in turn; a late slot is not made up by a burst.
        let mut pacer = Pacer::at_rate(rate_hz * vessels as f64);
        let mut slot = 0u64;
        while Instant::now() < until {
            if slot > 0 {
                pacer.wait();
            }
            let v = (slot % vessels as u64) as usize;
            forecast_json(*seq, monotonic_ns(), buf);
            publishers[v].put(buf)?;
            sent += 1;
            slot += 1;
            if v + 1 == vessels {
                *seq += 1;
            }
        }
        Ok(sent)
    };
    let mut seq = 0u64;
    // Warm-up: one second, not counted.
    publish_for(Instant::now() + Duration::from_secs(1), &mut seq, &mut buf)?;
    std::thread::sleep(Duration::from_millis(200));
    lock(&tally).measuring = true;
    let cpu_before = router.cpu_time()?;
    let t0 = Instant::now();
    let sent = publish_for(t0 + Duration::from_secs_f64(seconds), &mut seq, &mut buf)?;
    let wall = t0.elapsed();
    let cpu = router.cpu_time()? - cpu_before;
    // Let the last ones arrive.
    std::thread::sleep(Duration::from_millis(500));
    let (received, p50, p99, max) = {
        let mut t = lock(&tally);
        t.measuring = false;
        (
            t.received,
            t.latency.quantile_us(0.5),
            t.latency.quantile_us(0.99),
            t.latency.quantile_us(1.0),
        )
    };

    let restart_recovery_s = if restart {
        router.kill();
        let killed_ns = monotonic_ns();
        let killed = Instant::now();
        router = RouterProcess::start(exe, &endpoint, &log)?;
        let deadline = killed + Duration::from_secs(120);
        let mut recovered = None;
        while Instant::now() < deadline {
            for p in &publishers {
                forecast_json(seq, monotonic_ns(), &mut buf);
                // Puts while the router is away are dropped, not errors.
                let _ = p.put(&buf);
            }
            seq += 1;
            if lock(&tally).last_ns.iter().all(|&t| t > killed_ns) {
                recovered = Some(killed.elapsed().as_secs_f64());
                break;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        recovered
    } else {
        None
    };
    drop(router);
    Ok(FleetReport {
        vessels,
        seconds: wall.as_secs_f64(),
        rate_hz,
        payload_bytes,
        sent,
        received,
        lost: sent.saturating_sub(received),
        p50_us: p50,
        p99_us: p99,
        max_us: max,
        router_cpu_pct: 100.0 * cpu.as_secs_f64() / wall.as_secs_f64(),
        restart_recovery_s,
    })
}

fn lock(t: &Mutex<ShoreTally>) -> std::sync::MutexGuard<'_, ShoreTally> {
    // A panic in the callback cannot leave the tally half-updated in a way that matters here.
    t.lock().unwrap_or_else(|e| e.into_inner())
}

/// A client session on `endpoint`, once the router listens (a plain TCP probe first, so
/// zenoh does not log a failed connection per try).
fn wait_for_client(endpoint: &str, patience: Duration) -> anyhow::Result<zenoh::Session> {
    let address = endpoint.strip_prefix("tcp/").unwrap_or(endpoint);
    let listening = poll_until(patience, Duration::from_millis(50), || {
        std::net::TcpStream::connect(address).ok()
    });
    anyhow::ensure!(
        listening.is_some(),
        "the router did not listen on {endpoint} within {patience:?}"
    );
    Ok(zn::open(&ZenohSettings {
        mode: Mode::Client,
        connect: vec![endpoint.to_string()],
        ..ZenohSettings::default()
    })?)
}
