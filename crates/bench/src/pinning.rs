//! Pinning the measuring threads to cores. A failure (core missing, no permission) is not fatal:
//! it is logged as a warning and recorded, so the report says the run was not pinned.

use serde::Serialize;

/// What happened when a thread asked for a core.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PinOutcome {
    /// The thread's role, e.g. "producer" or "iceoryx2 pong".
    pub role: String,
    pub core: usize,
    pub pinned: bool,
}

/// `--cores (a, b)` as asked for: cores this process may run on. Regression (review):
/// `--cores 0,2` on a two-core machine measured the whole run unpinned, with only warnings.
/// (The default cores, on a machine with fewer, still run unpinned and say so.)
pub fn allowed((a, b): (usize, usize)) -> Result<(usize, usize), String> {
    if let Some(ids) = core_affinity::get_core_ids() {
        let allowed: Vec<usize> = ids.iter().map(|c| c.id).collect();
        if let Some(core) = [a, b].into_iter().find(|c| !allowed.contains(c)) {
            return Err(format!(
                "--cores {a},{b}: core {core} is not one this process may run on (allowed: {allowed:?})"
            ));
        }
    }
    Ok((a, b))
}

/// Pin the calling thread to `core`; warn and record if that is not possible.
pub fn pin_current(role: &str, core: usize) -> PinOutcome {
    let available = core_affinity::get_core_ids().unwrap_or_default();
    let pinned = match available.iter().find(|c| c.id == core) {
        Some(&id) => core_affinity::set_for_current(id),
        None => false,
    };
    if !pinned {
        tracing::warn!(
            role,
            core,
            available = available.len(),
            "could not pin thread to core; latencies are measured unpinned"
        );
    }
    PinOutcome {
        role: role.to_string(),
        core,
        pinned,
    }
}

/// Make the child started by `cmd` run on `core` only (set between fork and exec, so every
/// thread it ever starts inherits it). A failure leaves the child unpinned; check with
/// [`child_pinned`].
pub fn pin_command(cmd: &mut std::process::Command, core: usize) {
    use std::os::unix::process::CommandExt;
    if core >= shipcast_pipeline::limits::MAX_CORES {
        // CPU_SET would index past the set (a panic after fork); the child stays unpinned
        // and child_pinned reports it.
        return;
    }
    // SAFETY: the closure runs in the forked child before exec and only calls
    // async-signal-safe functions on stack data (CPU_ZERO/CPU_SET, sched_setaffinity).
    unsafe {
        cmd.pre_exec(move || {
            let mut set: libc::cpu_set_t = std::mem::zeroed();
            libc::CPU_ZERO(&mut set);
            libc::CPU_SET(core, &mut set);
            // Unpinned on failure: the parent checks and records it.
            let _ = libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
            Ok(())
        });
    }
}

/// Whether process `pid` may run on `core` only; warns when not.
pub fn child_pinned(role: &str, pid: u32, core: usize) -> PinOutcome {
    // SAFETY: `set` is a valid, writable cpu_set_t of the size passed.
    let pinned = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::sched_getaffinity(
            pid as libc::pid_t,
            std::mem::size_of::<libc::cpu_set_t>(),
            &mut set,
        ) == 0
            && core < libc::CPU_SETSIZE as usize
            && libc::CPU_ISSET(core, &set)
            && libc::CPU_COUNT(&set) == 1
    };
    if !pinned {
        tracing::warn!(role, core, pid, "child process is not pinned to its core");
    }
    PinOutcome {
        role: role.to_string(),
        core,
        pinned,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cores_asked_for_must_be_ones_the_process_may_run_on() {
        let ids: Vec<usize> = core_affinity::get_core_ids()
            .unwrap()
            .iter()
            .map(|c| c.id)
            .collect();
        let first = ids[0];
        let absent = ids.iter().max().unwrap() + 1;
        assert_eq!(allowed((first, first)), Ok((first, first)));
        let e = allowed((first, absent)).unwrap_err();
        assert!(
            e.starts_with(&format!(
                "--cores {first},{absent}: core {absent} is not one this process may run on"
            )),
            "{e}"
        );
    }

    #[test]
    fn missing_core_is_recorded_not_fatal() {
        let outcome = std::thread::spawn(|| pin_current("test", 1 << 20))
            .join()
            .unwrap();
        assert!(!outcome.pinned);
        assert_eq!((outcome.role.as_str(), outcome.core), ("test", 1 << 20));
    }

    #[test]
    fn child_is_pinned_before_exec_or_reported_unpinned() {
        let mut cmd = std::process::Command::new("sleep");
        cmd.arg("5");
        pin_command(&mut cmd, 0);
        // Killed and reaped when the test ends, also when a check panics.
        struct Killed(std::process::Child);
        impl Drop for Killed {
            fn drop(&mut self) {
                let _ = self.0.kill();
                let _ = self.0.wait();
            }
        }
        let child = Killed(cmd.spawn().unwrap());
        let outcome = child_pinned("sleep", child.0.id(), 0);
        let wrong = child_pinned("sleep", child.0.id(), 1);
        drop(child);
        assert!(outcome.pinned, "{outcome:?}");
        assert!(!wrong.pinned);
    }
}
