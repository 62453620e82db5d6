//! One service of a kind per vessel and instance on a host.
//!
//! Why: a second predictor under the same names (a second `shipcast run` with the same
//! `--instance`, say) opens the same iceoryx2 services and zenoh keys. It then publishes a
//! second forecast stream that the consumers refuse as not the live publisher's, and it runs
//! uselessly until stopped, without a word. iceoryx2 services are per host, so the lock is a
//! file in the system's temporary directory, locked (`flock`) while the service runs: the
//! kernel lets go of it when the process ends, also when it is killed, so a crashed service
//! never blocks its restart.

use super::naming::Names;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// Why a service may not start.
#[derive(Debug, thiserror::Error)]
pub enum HostLockError {
    #[error(
        "another {service} for vessel '{vessel}'{instance} is running on this host{pid} (lock {path}): stop it first, or give this one another --instance or --vessel"
    )]
    Held {
        service: String,
        vessel: String,
        instance: String,
        pid: String,
        path: PathBuf,
    },
}

/// Held while the service runs; dropping it (or the process ending) lets go.
#[derive(Debug)]
pub struct HostLock {
    _file: Option<File>,
}

impl HostLock {
    /// Take the lock of `service` (e.g. "predictor") for `names`, or say who holds it. A lock
    /// file that cannot be opened at all (another user's, a read-only temporary directory) is
    /// not a reason to refuse to run: the service runs unguarded, with a warning.
    pub fn acquire(names: &Names, service: &str) -> Result<Self, HostLockError> {
        Self::acquire_in(&std::env::temp_dir(), names, service)
    }

    /// [`Self::acquire`] with the lock files in `dir`.
    pub fn acquire_in(dir: &Path, names: &Names, service: &str) -> Result<Self, HostLockError> {
        let path = dir.join(lock_file_name(names, service));
        let opened = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .or_else(|_| File::open(&path));
        let mut file = match opened {
            Ok(f) => f,
            Err(e) => {
                tracing::warn!(
                    "{service}: cannot open its lock file {} ({e}); a second {service} under the same names would not be refused",
                    path.display()
                );
                return Ok(Self { _file: None });
            }
        };
        match file.try_lock() {
            Ok(()) => {
                // For the message a second one gives; the lock itself is what counts.
                let pid = std::process::id().to_string();
                let written = file
                    .set_len(0)
                    .and_then(|()| file.rewind())
                    .and_then(|()| file.write_all(pid.as_bytes()));
                if let Err(e) = written {
                    tracing::debug!("{service}: lock file {}: {e}", path.display());
                }
                Ok(Self { _file: Some(file) })
            }
            Err(TryLockError::WouldBlock) => {
                let mut text = String::new();
                let pid = match file.read_to_string(&mut text) {
                    Ok(_) if text.trim().parse::<u32>().is_ok() => {
                        format!(" (pid {})", text.trim())
                    }
                    _ => String::new(),
                };
                Err(HostLockError::Held {
                    service: service.to_string(),
                    vessel: names.vessel().to_string(),
                    instance: names
                        .instance()
                        .map_or(String::new(), |i| format!(" in instance '{i}'")),
                    pid,
                    path,
                })
            }
            Err(TryLockError::Error(e)) => {
                tracing::warn!(
                    "{service}: cannot lock {} ({e}); a second {service} under the same names would not be refused",
                    path.display()
                );
                Ok(Self { _file: None })
            }
        }
    }
}

/// `shipcast+<instance>+<vessel>+<service>.lock`: '+' is in no name segment
/// (`naming::check_segment`), so two different sets of names never share a file.
fn lock_file_name(names: &Names, service: &str) -> String {
    format!(
        "shipcast+{}+{}+{service}.lock",
        names.instance().unwrap_or(""),
        names.vessel()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_service_under_the_same_names_is_refused_until_the_first_lets_go() {
        let dir = tempfile::tempdir().unwrap();
        let names = Names::new(Some("lock-test"), "ddg").unwrap();
        let first = HostLock::acquire_in(dir.path(), &names, "predictor").unwrap();
        let e = HostLock::acquire_in(dir.path(), &names, "predictor")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!(
                "another predictor for vessel 'ddg' in instance 'lock-test' is running on this host (pid {})",
                std::process::id()
            )),
            "{e}"
        );
        // Other names, or another service, are not held up.
        let other_vessel = Names::new(Some("lock-test"), "tanker").unwrap();
        let no_instance = Names::new(None, "ddg").unwrap();
        let _a = HostLock::acquire_in(dir.path(), &other_vessel, "predictor").unwrap();
        let _b = HostLock::acquire_in(dir.path(), &no_instance, "predictor").unwrap();
        let _c = HostLock::acquire_in(dir.path(), &names, "producer").unwrap();
        // Once the first lets go, a new one starts.
        drop(first);
        let _again = HostLock::acquire_in(dir.path(), &names, "predictor").unwrap();
    }

    #[test]
    fn a_lock_file_that_cannot_be_opened_does_not_stop_the_service() {
        let names = Names::new(Some("lock-test"), "ddg").unwrap();
        let missing = Path::new("/nonexistent/shipcast-lock-dir");
        assert!(HostLock::acquire_in(missing, &names, "predictor").is_ok());
    }
}
