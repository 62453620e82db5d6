//! The services `shipcast run` starts: spawned as children of this process, each with its
//! log, stopped stage by stage against the data flow and reaped however the run ends.

use anyhow::Context;
use shipcast_pipeline::child::{stop_all, ChildProcess};
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Grace period between SIGTERM and SIGKILL when stopping children.
const STOP_GRACE: Duration = shipcast_pipeline::child::DEFAULT_STOP_GRACE;

/// Where a child stands in the data flow, which decides when it is stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Stage {
    /// Reads forecasts (deck, crane, relative, display): stopped first.
    Consumer,
    Predictor,
    Producer,
}

impl Stage {
    fn of(command: &str) -> Self {
        match command {
            "producer" => Self::Producer,
            "predictor" => Self::Predictor,
            _ => Self::Consumer,
        }
    }
}

/// The children, stopped (SIGTERM, then SIGKILL) and reaped when dropped, whatever happened.
pub(super) struct Children {
    list: Vec<(Stage, ChildProcess)>,
}

impl Children {
    pub(super) fn new() -> Self {
        Self { list: Vec::new() }
    }

    pub(super) fn spawn(
        &mut self,
        name: &'static str,
        args: &[&str],
        config: &Path,
        logs: &Path,
    ) -> anyhow::Result<()> {
        self.spawn_as(name, name, args, config, logs)
    }

    /// `command` as a child whose log and name are `name` (the target vessel's services).
    pub(super) fn spawn_as(
        &mut self,
        name: &'static str,
        command: &str,
        args: &[&str],
        config: &Path,
        logs: &Path,
    ) -> anyhow::Result<()> {
        let exe = std::env::current_exe().context("locating the shipcast executable")?;
        let (log, kept) = crate::private_files::create_log(&logs.join(format!("{name}.log")))
            .with_context(|| format!("creating the log of {name} in {}", logs.display()))?;
        if let Some(previous) = kept {
            tracing::info!(
                "run: the previous {name} log is kept as {}",
                previous.display()
            );
        }
        let mut cmd = Command::new(exe);
        cmd.arg(command)
            .arg("--config")
            .arg(config)
            .args(args)
            .stdin(Stdio::null())
            .stdout(log.try_clone()?)
            .stderr(log);
        // The parent as the child must see it: if `run` died between the fork and the prctl,
        // the child has been handed to another parent and would outlive it (review).
        let parent = std::process::id() as libc::pid_t;
        // SAFETY: prctl and getppid are async-signal-safe, touch no memory of ours and nothing
        // here allocates (between fork and exec only such calls are sound); prctl
        // only asks the kernel to send SIGTERM to the child if this process dies (e.g. kill
        // -9), so no child outlives `shipcast run`, and a child whose parent is already gone
        // fails its exec instead of running on.
        unsafe {
            cmd.pre_exec(move || {
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
                if libc::getppid() != parent {
                    // No allocation between fork and exec: a raw OS error only.
                    return Err(std::io::Error::from_raw_os_error(libc::ESRCH));
                }
                Ok(())
            });
        }
        let child = ChildProcess::spawn(name, &mut cmd)
            .with_context(|| format!("starting the {name} process"))?
            .with_stop_grace(STOP_GRACE);
        self.list.push((Stage::of(command), child));
        Ok(())
    }

    /// A child that exited, unless it is a producer that finished its record.
    pub(super) fn failed(&mut self) -> Option<(String, std::process::ExitStatus)> {
        self.exited()
            .filter(|(stage, _, status)| !(*stage == Stage::Producer && status.success()))
            .map(|(_, name, status)| (name, status))
    }

    pub(super) fn exited(&mut self) -> Option<(Stage, String, std::process::ExitStatus)> {
        self.list.iter_mut().find_map(|(stage, c)| {
            let status = c.try_exit().ok().flatten()?;
            Some((*stage, c.name().to_string(), status))
        })
    }

    /// Stop every child still running, stage by stage against the data flow: the consumers,
    /// then the predictors, then the producers; each stage gets SIGTERM, the grace period,
    /// then SIGKILL, and all are reaped. A consumer stopped while its predictor is alive never
    /// receives a last forecast after the predictor's liveliness token is gone (stopped all at
    /// once, the crane used to count and log such a forecast as rejected at a plain stop). A
    /// child that has exited already is not signalled: its pid may be another process's by now.
    pub(super) fn stop(&mut self) {
        for stage in [Stage::Consumer, Stage::Predictor, Stage::Producer] {
            stop_all(
                self.list
                    .iter_mut()
                    .filter(|(s, _)| *s == stage)
                    .map(|(_, c)| c),
                STOP_GRACE,
            );
        }
        self.list.clear();
    }
}

/// Why the run stops when service `name` exited on its own: its status and the last error
/// line of its log.
pub(super) fn exited_early(
    name: &str,
    status: std::process::ExitStatus,
    logs: &Path,
) -> anyhow::Error {
    let log = logs.join(format!("{name}.log"));
    let reason = last_error_line(&log).map_or(String::new(), |e| format!(": {e}"));
    anyhow::anyhow!(
        "{name} exited early ({status}){reason}; see {}",
        log.display()
    )
}

impl Drop for Children {
    fn drop(&mut self) {
        self.stop();
    }
}

/// The last `error: ...` line a child wrote to its log (its own one-line reason for stopping).
fn last_error_line(log: &Path) -> Option<String> {
    let text = std::fs::read_to_string(log).ok()?;
    let line = text.lines().rev().find(|l| l.starts_with("error: "))?;
    let line = crate::error_text::without_source_locations(line.trim_start_matches("error: "));
    const MOST: usize = 300;
    Some(if line.chars().count() > MOST {
        format!("{}...", line.chars().take(MOST).collect::<String>())
    } else {
        line
    })
}
