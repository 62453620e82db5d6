//! `shipcast run`: the whole pipeline from one config. Starts predictor, deck, crane and
//! producer as child processes of this executable, shows a compact live view (latest forecast,
//! deck advisory, predictor counters), and stops them all on Ctrl-C or after `--duration`.

use anyhow::Context;
use shipcast::config::CommonArgs;
use shipcast::deck::Advisory;
use shipcast::payload::Forecast;
use shipcast::transport::shutdown;
use shipcast::transport::zenoh::{self as zn, LatestSubscriber};
use std::io::{IsTerminal, Write};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub common: CommonArgs,
    /// Directory for the children's logs (default: a new directory under the temp dir).
    #[arg(long, value_name = "DIR")]
    pub log_dir: Option<PathBuf>,
}

/// Grace period between SIGTERM and SIGKILL when stopping children.
const STOP_GRACE: Duration = Duration::from_secs(5);

/// The children, stopped (SIGTERM, then SIGKILL) and reaped when dropped, whatever happened.
struct Children {
    list: Vec<(&'static str, Child)>,
}

impl Children {
    fn spawn(
        &mut self,
        name: &'static str,
        args: &[&str],
        config: &Path,
        logs: &Path,
    ) -> anyhow::Result<()> {
        let exe = std::env::current_exe().context("locating the shipcast executable")?;
        let log = std::fs::File::create(logs.join(format!("{name}.log")))
            .with_context(|| format!("creating the log of {name} in {}", logs.display()))?;
        let mut cmd = Command::new(exe);
        cmd.arg(name)
            .arg("--config")
            .arg(config)
            .args(args)
            .stdin(Stdio::null())
            .stdout(log.try_clone()?)
            .stderr(log);
        // SAFETY: prctl is async-signal-safe; it only asks the kernel to send SIGTERM to the
        // child if this process dies (e.g. kill -9), so no child outlives `shipcast run`.
        unsafe {
            cmd.pre_exec(|| {
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
                Ok(())
            });
        }
        let child = cmd
            .spawn()
            .with_context(|| format!("starting the {name} process"))?;
        self.list.push((name, child));
        Ok(())
    }

    /// The first child that has exited, with its status.
    fn exited(&mut self) -> Option<(&'static str, std::process::ExitStatus)> {
        self.list
            .iter_mut()
            .find_map(|(name, c)| c.try_wait().ok().flatten().map(|s| (*name, s)))
    }

    /// SIGTERM every child (producer first, so the others see the end of the data), wait for
    /// them up to the grace period, SIGKILL the rest, and reap all.
    fn stop(&mut self) {
        for (_, child) in self.list.iter().rev() {
            // SAFETY: plain kill(2) on our own child's pid.
            unsafe {
                libc::kill(child.id() as libc::pid_t, libc::SIGTERM);
            }
        }
        let deadline = Instant::now() + STOP_GRACE;
        for (name, child) in &mut self.list {
            loop {
                match child.try_wait() {
                    Ok(Some(status)) => {
                        tracing::debug!("{name} exited: {status}");
                        break;
                    }
                    Ok(None) if Instant::now() < deadline => {
                        std::thread::sleep(Duration::from_millis(20))
                    }
                    _ => {
                        tracing::warn!("{name} did not stop in time: killed");
                        let _ = child.kill();
                        let _ = child.wait();
                        break;
                    }
                }
            }
        }
        self.list.clear();
    }
}

impl Drop for Children {
    fn drop(&mut self) {
        self.stop();
    }
}

/// What the live view shows, updated from zenoh.
#[derive(Default)]
struct View {
    forecast: Option<Forecast>,
    advisory: Option<Advisory>,
    status: Option<serde_json::Value>,
}

impl View {
    fn lines(&self, header: &str) -> Vec<String> {
        let mut lines = vec![header.to_string()];
        lines.push(match &self.status {
            None => "predictor  starting (training on simulated history)".into(),
            Some(s) => {
                let c = &s["counters"];
                format!(
                    "predictor  model v{}  forecasts {}  history {}/{}  received {} lost {} rejected {}  {}",
                    s["model_version"],
                    s["forecasts"],
                    s["history"],
                    s["order"],
                    c["received"],
                    c["lost"],
                    c["rejected_nonfinite"].as_u64().unwrap_or(0)
                        + c["rejected_order"].as_u64().unwrap_or(0),
                    if s["stale"] == true { "STALE" } else { "live" }
                )
            }
        });
        lines.push(match &self.forecast {
            None => "forecast   none yet (the history fills first)".into(),
            Some(f) if f.valid_steps() == 0 => "forecast   empty (0 steps)".into(),
            Some(f) => {
                let at = |d: usize, step_s: f64| {
                    let k = ((step_s / f.dt_s).round() as usize).clamp(1, f.valid_steps()) - 1;
                    (f.mean[d][k], f.sigma[d][k])
                };
                let mut line = format!("forecast   t={:.1}s", f.time_s);
                for (name, d, scale, unit) in [
                    ("heave", 2, 1.0, "m"),
                    ("roll", 3, 180.0 / std::f32::consts::PI, "deg"),
                    ("pitch", 4, 180.0 / std::f32::consts::PI, "deg"),
                ] {
                    let (m5, s5) = at(d, 5.0);
                    let (m20, s20) = at(d, 20.0);
                    line.push_str(&format!(
                        "  {name} +5s {:+.2}±{:.2} +20s {:+.2}±{:.2} {unit}",
                        m5 * scale,
                        s5 * scale,
                        m20 * scale,
                        s20 * scale
                    ));
                }
                line
            }
        });
        lines.push(match &self.advisory {
            None => "deck       no advisory yet".into(),
            Some(a) => a.summary(),
        });
        lines
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = args.common.load()?;
    let limit = shutdown::RunLimit::new(args.common.duration()?);
    let names = config.names()?;
    let logs = match &args.log_dir {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("shipcast-run-{}", std::process::id())),
    };
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let config_path = logs.join("pipeline.toml");
    std::fs::write(&config_path, config.to_toml()?)
        .with_context(|| format!("writing {}", config_path.display()))?;

    let mut children = Children { list: Vec::new() };
    // The predictor first: the producer waits until it has subscribed (its start-up training
    // takes a moment), so the backfill reaches it.
    children.spawn("predictor", &[], &config_path, &logs)?;
    children.spawn("deck", &["--print-every", "10"], &config_path, &logs)?;
    children.spawn("crane", &[], &config_path, &logs)?;
    children.spawn(
        "producer",
        &["--wait-subscriber-s", "120"],
        &config_path,
        &logs,
    )?;

    let session = zn::open(&config.zenoh.consumer_side())?;
    let forecasts = LatestSubscriber::new(&session, &names.forecast())?;
    let advisories = LatestSubscriber::new(&session, &names.advisory("deck"))?;
    let status = LatestSubscriber::new(&session, &names.status("predictor"))?;

    let tty = std::io::stdout().is_terminal();
    let mut view = View::default();
    let mut drawn = 0usize;
    let mut last_draw = Instant::now() - Duration::from_secs(10);
    let outcome = loop {
        if limit.reached() {
            break Ok(if shutdown::stop_requested() {
                "stopped by Ctrl-C"
            } else {
                "duration reached"
            });
        }
        if let Some((name, status)) = children.exited() {
            break Err(anyhow::anyhow!(
                "{name} exited early ({status}); see {}",
                logs.join(format!("{name}.log")).display()
            ));
        }
        if let Some(b) = forecasts.latest()? {
            view.forecast = Forecast::from_json(&b).ok();
        }
        if let Some(b) = advisories.latest()? {
            view.advisory = serde_json::from_slice(&b).ok();
        }
        if let Some(b) = status.latest()? {
            view.status = serde_json::from_slice(&b).ok();
        }
        if last_draw.elapsed() >= Duration::from_secs(1) {
            let header = format!(
                "shipcast run  {}  +{:.0}s  (Ctrl-C stops; logs in {})",
                names,
                limit.elapsed().as_secs_f64(),
                logs.display()
            );
            let lines = view.lines(&header);
            let mut out = std::io::stdout().lock();
            if tty && drawn > 0 {
                // Redraw the block in place.
                let _ = write!(out, "\x1b[{drawn}A\x1b[J");
            }
            for l in &lines {
                let _ = writeln!(out, "{l}");
            }
            let _ = out.flush();
            drawn = lines.len();
            last_draw = Instant::now();
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    children.stop();
    let _ = std::fs::remove_file(&config_path);
    let reason = outcome?;
    println!(
        "shipcast run: {reason}; all services stopped (logs in {})",
        logs.display()
    );
    Ok(())
}
