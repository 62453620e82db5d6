//! Child processes of a benchmark run (the services, the pong side of the inter-process
//! floor): started pinned to a core, logging to a file, and killed and reaped when dropped, also
//! when the run fails, so that none outlives the benchmark and iceoryx2 sees their nodes as dead.

use super::pinning::{child_pinned, pin_command, PinOutcome};
use anyhow::{anyhow, Context};
use std::path::{Path as FsPath, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Child processes, killed and reaped when dropped (also when the run fails), so that no
/// service outlives the benchmark and iceoryx2 sees their nodes as dead.
#[derive(Default)]
pub struct Children {
    list: Vec<(String, Child, PathBuf)>,
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
        let child = cmd
            .spawn()
            .with_context(|| format!("start {role}: {} {}", exe.display(), args.join(" ")))?;
        let id = child.id();
        self.list.push((role.to_string(), child, log));
        Ok(id)
    }

    /// Fail if the child `role` has exited, naming its log.
    pub fn check_running(&mut self, role: &str) -> anyhow::Result<()> {
        for (_, child, log) in self.list.iter_mut().filter(|(r, _, _)| r == role) {
            if let Some(status) = child.try_wait().context("check child")? {
                anyhow::bail!("{role} exited early ({status}); see {}", log.display());
            }
        }
        Ok(())
    }

    /// Wait for `role` to exit by itself within `timeout`.
    pub fn wait_exit(&mut self, role: &str, timeout: Duration) -> anyhow::Result<()> {
        let deadline = Instant::now() + timeout;
        let (_, child, log) = self
            .list
            .iter_mut()
            .find(|(r, _, _)| r == role)
            .ok_or_else(|| anyhow!("no child '{role}'"))?;
        loop {
            if let Some(status) = child.try_wait().context("wait for child")? {
                if !status.success() {
                    anyhow::bail!("{role} failed ({status}); see {}", log.display());
                }
                return Ok(());
            }
            if Instant::now() > deadline {
                anyhow::bail!(
                    "{role} did not finish within {timeout:?}; see {}",
                    log.display()
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Children {
    /// Ask every running child to stop (SIGTERM: the services shut down cleanly and remove
    /// their iceoryx2 resources), wait up to `timeout`, then kill what is left.
    pub fn stop_all(&mut self, timeout: Duration) {
        for (_, child, _) in &mut self.list {
            if let Ok(None) = child.try_wait() {
                // SAFETY: plain kill(2) on the id of a child we have not reaped yet.
                unsafe {
                    libc::kill(child.id() as libc::pid_t, libc::SIGTERM);
                }
            }
        }
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline
            && self
                .list
                .iter_mut()
                .any(|(_, c, _)| matches!(c.try_wait(), Ok(None)))
        {
            std::thread::sleep(Duration::from_millis(20));
        }
        self.kill_all();
    }

    /// Kill and reap every child; remove the logs of those that exited successfully.
    pub fn kill_all(&mut self) {
        for (role, mut child, log) in self.list.drain(..) {
            if let Ok(None) = child.try_wait() {
                if let Err(e) = child.kill() {
                    tracing::warn!(role = role.as_str(), "could not kill child: {e}");
                }
            }
            // Reap it, so it is not a zombie that iceoryx2 still counts as alive.
            match child.wait() {
                Ok(status) if status.success() => {
                    let _ = std::fs::remove_file(&log);
                }
                _ => tracing::info!(role = role.as_str(), "service log kept: {}", log.display()),
            }
        }
    }
}
