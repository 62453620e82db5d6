//! One service of a kind per vessel and instance on a host.
//!
//! Why: a second predictor under the same names (a second `shipcast run` with the same
//! `--instance`, say) opens the same iceoryx2 services and zenoh keys. It then publishes a
//! second forecast stream that the consumers refuse as not the live publisher's, and it runs
//! uselessly until stopped, without a word. iceoryx2 services are per host, so the lock is a
//! file locked (`flock`) while the service runs: the kernel lets go of it when the process
//! ends, also when it is killed, so a crashed service never blocks its restart.
//!
//! The files live in a directory of the user's own (`$XDG_RUNTIME_DIR`, else
//! `<temp>/shipcast-locks-<uid>`, mode 0700, checked to be the user's): in the shared temporary
//! directory any other user could create and hold the file and keep our predictor from ever
//! starting, or plant a symlink for the truncation of the pid to follow. The file itself is
//! opened without following a symlink.
//!
//! A service removes its lock file as it lets go, still holding the lock, so that runs under
//! unique instance names (tests, `shipcast bench`) leave no files behind. Regression (review):
//! every run left its files for good. A service that took the lock of a file removed in the
//! meantime holds nothing others can see, so it checks after locking that the path still
//! names its file, and opens it afresh if not.

use super::naming::Names;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::os::unix::fs::{DirBuilderExt, MetadataExt, OpenOptionsExt, PermissionsExt};
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
    /// The locked file and its path; none when the service runs unguarded.
    held: Option<(File, PathBuf)>,
}

impl Drop for HostLock {
    fn drop(&mut self) {
        if let Some((file, path)) = self.held.take() {
            // Removed while still locked: whoever opens the path next makes a new file, and
            // whoever opened the old one before finds it gone after locking it.
            let _ = std::fs::remove_file(&path);
            drop(file);
        }
    }
}

/// Whether `path` still names the file `file` is (not removed, not replaced).
fn still_named(file: &File, path: &Path) -> bool {
    match (file.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(open), Ok(named)) => open.dev() == named.dev() && open.ino() == named.ino(),
        _ => false,
    }
}

/// How often a lock is taken again after its file was removed under it: each time, the one
/// who removed it has let go, so a second round is only lost to a third service starting.
const REOPENS: usize = 8;

impl HostLock {
    /// Take the lock of `service` (e.g. "predictor") for `names`, or say who holds it. A lock
    /// file that cannot be opened at all (another user's, a read-only temporary directory) is
    /// not a reason to refuse to run: the service runs unguarded, with a warning.
    pub fn acquire(names: &Names, service: &str) -> Result<Self, HostLockError> {
        match lock_dir() {
            Ok(dir) => Self::acquire_in(&dir, names, service),
            Err(e) => {
                tracing::warn!(
                    "{service}: no directory of this user's for its lock file ({e}); a second {service} under the same names would not be refused"
                );
                Ok(Self { held: None })
            }
        }
    }

    /// [`Self::acquire`] with the lock files in `dir`.
    pub fn acquire_in(dir: &Path, names: &Names, service: &str) -> Result<Self, HostLockError> {
        let path = dir.join(lock_file_name(names, service));
        for _ in 0..REOPENS {
            if let Some(taken) = Self::try_acquire(&path, names, service)? {
                return Ok(taken);
            }
        }
        tracing::warn!(
            "{service}: its lock file {} was removed under it {REOPENS} times; a second {service} under the same names would not be refused",
            path.display()
        );
        Ok(Self { held: None })
    }

    /// One attempt: the lock, an error naming who holds it, or `None` when the file locked
    /// was removed meanwhile (try again).
    fn try_acquire(
        path: &Path,
        names: &Names,
        service: &str,
    ) -> Result<Option<Self>, HostLockError> {
        // Never through a symlink, and readable by this user only.
        let opened = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .mode(0o600)
            .custom_flags(libc::O_NOFOLLOW)
            .open(path);
        let mut file = match opened {
            Ok(f) => f,
            Err(e) => {
                tracing::warn!(
                    "{service}: cannot open its lock file {} ({e}); a second {service} under the same names would not be refused",
                    path.display()
                );
                return Ok(Some(Self { held: None }));
            }
        };
        match file.try_lock() {
            Ok(()) if !still_named(&file, path) => Ok(None),
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
                Ok(Some(Self {
                    held: Some((file, path.to_path_buf())),
                }))
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
                    path: path.to_path_buf(),
                })
            }
            Err(TryLockError::Error(e)) => {
                tracing::warn!(
                    "{service}: cannot lock {} ({e}); a second {service} under the same names would not be refused",
                    path.display()
                );
                Ok(Some(Self { held: None }))
            }
        }
    }
}

/// The user's own directory for lock files, made if needed: `$XDG_RUNTIME_DIR` (made by the
/// system for this user alone), else `<temp>/shipcast-locks-<uid>` with mode 0700. One that
/// another user owns, or that others may write to, is refused.
fn lock_dir() -> std::io::Result<PathBuf> {
    lock_dir_in(std::env::var_os("XDG_RUNTIME_DIR"), &std::env::temp_dir())
}

/// [`lock_dir`] with the runtime directory and the temporary directory given (tests).
fn lock_dir_in(runtime: Option<std::ffi::OsString>, temp: &Path) -> std::io::Result<PathBuf> {
    if let Some(dir) = runtime.filter(|d| !d.is_empty()) {
        let dir = PathBuf::from(dir);
        check_own_dir(&dir)?;
        return Ok(dir);
    }
    // SAFETY: geteuid takes no arguments, touches no memory of ours and cannot fail.
    let uid = unsafe { libc::geteuid() };
    let dir = temp.join(format!("shipcast-locks-{uid}"));
    match std::fs::DirBuilder::new().mode(0o700).create(&dir) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => return Err(e),
    }
    check_own_dir(&dir)?;
    Ok(dir)
}

/// `dir` is a real directory (not a symlink) of this user's that no one else may write to.
fn check_own_dir(dir: &Path) -> std::io::Result<()> {
    let meta = std::fs::symlink_metadata(dir)?;
    // SAFETY: as in `lock_dir`.
    let uid = unsafe { libc::geteuid() };
    if !meta.is_dir() || meta.uid() != uid || meta.permissions().mode() & 0o022 != 0 {
        return Err(std::io::Error::other(format!(
            "{} is not a directory of this user's that only it may write to",
            dir.display()
        )));
    }
    Ok(())
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
        let again = HostLock::acquire_in(dir.path(), &names, "predictor").unwrap();
        assert!(again.held.is_some());
        // Regression (review): lock files were left behind for good; each goes with its lock.
        drop((again, _a, _b, _c));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    /// A service that opened the lock file before its holder removed it and let go must not
    /// take a lock on the removed file while a third takes the new one: it opens it afresh.
    #[test]
    fn a_lock_on_a_removed_file_is_not_taken_for_the_lock() {
        let dir = tempfile::tempdir().unwrap();
        let names = Names::new(Some("lock-test"), "ddg").unwrap();
        let path = dir.path().join(lock_file_name(&names, "predictor"));
        let first = HostLock::acquire_in(dir.path(), &names, "predictor").unwrap();
        // Opened by a second starter before the first let go (and removed the file).
        let early = File::open(&path).unwrap();
        drop(first);
        assert!(!path.exists());
        early.try_lock().unwrap();
        assert!(!still_named(&early, &path));
        // A third starts now and makes a new file; the second, retrying, is refused by it.
        let third = HostLock::acquire_in(dir.path(), &names, "predictor").unwrap();
        assert!(still_named(&third.held.as_ref().unwrap().0, &path));
        assert!(HostLock::acquire_in(dir.path(), &names, "predictor").is_err());
    }

    #[test]
    fn locks_live_in_a_directory_of_the_users_own_and_never_follow_a_symlink() {
        // Without a runtime directory, one of the user's own is made under the temporary
        // root, mode 0700, and used again (under a temporary root of the test's own: the
        // real lock directory is not touched).
        let temp = tempfile::tempdir().unwrap();
        let made = lock_dir_in(None, temp.path()).unwrap();
        assert_eq!(made.parent(), Some(temp.path()));
        let mode = std::fs::metadata(&made).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o700);
        assert_eq!(lock_dir_in(Some("".into()), temp.path()).unwrap(), made);
        // A runtime directory is used as it is, if it is the user's own alone.
        let runtime = tempfile::tempdir().unwrap();
        std::fs::set_permissions(runtime.path(), std::fs::Permissions::from_mode(0o700)).unwrap();
        let given = Some(runtime.path().as_os_str().to_owned());
        assert_eq!(
            lock_dir_in(given.clone(), temp.path()).unwrap(),
            runtime.path()
        );
        std::fs::set_permissions(runtime.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
        assert!(lock_dir_in(given, temp.path()).is_err());
        // A directory others may write to is not one.
        let shared = tempfile::tempdir().unwrap();
        std::fs::set_permissions(shared.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
        assert!(check_own_dir(shared.path()).is_err());
        // A lock file that is a planted symlink is not followed (nor truncated): the service
        // runs unguarded, and the file pointed at is left as it was.
        let own = tempfile::tempdir().unwrap();
        let names = Names::new(Some("lock-test"), "ddg").unwrap();
        let victim = own.path().join("victim.txt");
        std::fs::write(&victim, "keep me").unwrap();
        std::os::unix::fs::symlink(
            &victim,
            own.path().join(lock_file_name(&names, "predictor")),
        )
        .unwrap();
        assert!(HostLock::acquire_in(own.path(), &names, "predictor").is_ok());
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep me");
    }

    #[test]
    fn a_lock_file_that_cannot_be_opened_does_not_stop_the_service() {
        let names = Names::new(Some("lock-test"), "ddg").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing");
        assert!(HostLock::acquire_in(&missing, &names, "predictor").is_ok());
    }
}
