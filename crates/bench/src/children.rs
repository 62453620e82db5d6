//! Child processes of a benchmark run (the services, the pong side of the inter-process
//! floor): started pinned to a core, logging to a file, and killed and reaped when dropped, also
//! when the run fails, so that none outlives the benchmark and iceoryx2 sees their nodes as dead.

use super::pinning::{child_pinned, pin_command, PinOutcome};
use anyhow::{anyhow, Context};
use shipcast_pipeline::child::{stop_all, ChildProcess};
use std::path::{Path as FsPath, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

/// Child processes, killed and reaped when dropped (also when the run fails), so that no
/// service outlives the benchmark and iceoryx2 sees their nodes as dead.
#[derive(Default)]
pub struct Children {
    list: Vec<(ChildProcess, PathBuf)>,
}

impl Children {
    /// Start `exe args` with every thread it will ever start pinned to `core`.
    pub fn spawn(
        &mut self,
        role: &str,
        exe: &FsPath,
        args: &[String],
        core: usize,
        log: PathBuf,
    ) -> anyhow::Result<PinOutcome> {
        let id = self.start(role, exe, args, Some(core), log)?;
        Ok(child_pinned(role, id, core))
    }

    /// Start `exe args` on any core (it may pin threads of its own); returns its process id.
    pub fn spawn_unpinned(
        &mut self,
        role: &str,
        exe: &FsPath,
        args: &[String],
        log: PathBuf,
    ) -> anyhow::Result<u32> {
        self.start(role, exe, args, None, log)
    }

    fn start(
        &mut self,
        role: &str,
        exe: &FsPath,
        args: &[String],
        core: Option<usize>,
        log: PathBuf,
    ) -> anyhow::Result<u32> {
        let file = std::fs::File::create(&log)
            .with_context(|| format!("create log file {}", log.display()))?;
        let mut cmd = Command::new(exe);
        cmd.args(args)
            .stdin(Stdio::null())
            .stdout(file.try_clone().context("duplicate log file handle")?)
            .stderr(file);
        if let Some(core) = core {
            pin_command(&mut cmd, core);
        }
        let child = ChildProcess::spawn(role, &mut cmd)
            .with_context(|| format!("start {role}: {} {}", exe.display(), args.join(" ")))?;
        let id = child.id();
        self.list.push((child, log));
        Ok(id)
    }

    /// Fail if the child `role` has exited, naming its log.
    pub fn check_running(&mut self, role: &str) -> anyhow::Result<()> {
        for (child, log) in self.list.iter_mut().filter(|(c, _)| c.name() == role) {
            if let Some(status) = child.try_exit().context("check child")? {
                anyhow::bail!("{role} exited early ({status}); see {}", log.display());
            }
        }
        Ok(())
    }

    /// Wait for `role` to exit by itself within `timeout`.
    pub fn wait_exit(&mut self, role: &str, timeout: Duration) -> anyhow::Result<()> {
        let (child, log) = self
            .list
            .iter_mut()
            .find(|(c, _)| c.name() == role)
            .ok_or_else(|| anyhow!("no child '{role}'"))?;
        match child.wait_timeout(timeout) {
            Some(status) if status.success() => Ok(()),
            Some(status) => anyhow::bail!("{role} failed ({status}); see {}", log.display()),
            None => anyhow::bail!(
                "{role} did not finish within {timeout:?}; see {}",
                log.display()
            ),
        }
    }
}

impl Children {
    /// Ask every running child to stop (SIGTERM: the services shut down cleanly and remove
    /// their iceoryx2 resources), wait up to `timeout`, then kill what is left.
    pub fn stop_all(&mut self, timeout: Duration) {
        stop_all(self.list.iter_mut().map(|(c, _)| c), timeout);
        self.kill_all();
    }

    /// Kill and reap every child; remove the logs of those that exited successfully.
    pub fn kill_all(&mut self) {
        for (mut child, log) in self.list.drain(..) {
            // Reaped, so it is not a zombie that iceoryx2 still counts as alive.
            match child.kill() {
                Ok(status) if status.success() => {
                    let _ = std::fs::remove_file(&log);
                }
                _ => tracing::info!(role = child.name(), "service log kept: {}", log.display()),
            }
        }
    }
}
