//! Files and directories that other local users cannot read or redirect: the keys `certs`
//! writes, the configuration `run` hands its children (it may hold a password or an inline
//! private key), and `run`'s default log directory under the shared temp dir.

use anyhow::Context;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Write `path`; secrets readable by the owner only.
///
/// Whatever is at the path is removed first and the file is created anew (`create_new`, which
/// never follows a symlink): the mode of `open` applies only to a file it creates, so a key
/// written over an existing world-readable file kept that file's mode, and a symlink planted
/// at the name had the text written wherever it pointed.
pub fn write_new(path: &Path, text: &str, secret: bool) -> anyhow::Result<()> {
    let mut file = create_new(path, secret)?;
    file.write_all(text.as_bytes())
        .with_context(|| format!("write {}", path.display()))
}

/// Create `path` anew (see [`write_new`]) and return it open for writing.
pub fn create_new(path: &Path, secret: bool) -> anyhow::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    if path.symlink_metadata().is_ok() {
        std::fs::remove_file(path).with_context(|| format!("replace {}", path.display()))?;
    }
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(if secret { 0o600 } else { 0o644 })
        .open(path)
        .with_context(|| format!("write {}", path.display()))
}

/// Create the log `path` anew (see [`create_new`]), first keeping a regular file already
/// there as `<path>.1` (replacing an older one). Returns the name it was kept under, if any.
///
/// Why: a `run` pointed at a fixed `--log-dir` (as on a ship) deleted the logs of the run
/// before it, the one that crashed or was restarted after days (soak review). Keeping one
/// previous log bounds what a restart loop can fill. A symlink at the name is not kept (it
/// is replaced, as by `create_new`): renaming moves the link, never its target.
pub fn create_log(path: &Path) -> anyhow::Result<(std::fs::File, Option<PathBuf>)> {
    let mut kept = None;
    if path.symlink_metadata().is_ok_and(|m| m.is_file()) {
        let mut previous = path.as_os_str().to_owned();
        previous.push(".1");
        let previous = PathBuf::from(previous);
        std::fs::rename(path, &previous)
            .with_context(|| format!("keeping {} as {}", path.display(), previous.display()))?;
        kept = Some(previous);
    }
    Ok((create_new(path, false)?, kept))
}

/// A new directory `<temp dir>/<prefix>-<pid>-<suffix>` that only this user can enter. Made
/// with `mkdir` (never an existing one, which another user could own or have filled with
/// symlinks), trying another suffix when the name is taken.
pub fn new_private_temp_dir(prefix: &str) -> anyhow::Result<PathBuf> {
    use std::os::unix::fs::DirBuilderExt;
    let base = std::env::temp_dir();
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    for attempt in 0u32..64 {
        let suffix = nanos.wrapping_add(attempt.wrapping_mul(0x9e37_79b9)) % 1_000_000;
        let dir = base.join(format!("{prefix}-{}-{suffix:06}", std::process::id()));
        match std::fs::DirBuilder::new().mode(0o700).create(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(e).with_context(|| format!("creating {}", dir.display()));
            }
        }
    }
    anyhow::bail!(
        "creating a directory {prefix}-{}-* in {}: every name tried is taken",
        std::process::id(),
        base.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn a_planted_symlink_is_replaced_not_followed_and_secrets_are_private() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, "ORIGINAL").unwrap();
        std::os::unix::fs::symlink(&victim, dir.path().join("pipeline.toml")).unwrap();
        let path = dir.path().join("pipeline.toml");
        write_new(&path, "password = \"x\"", true).unwrap();
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "ORIGINAL");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "password = \"x\"");
        let meta = std::fs::symlink_metadata(&path).unwrap();
        assert!(meta.is_file());
        assert_eq!(meta.permissions().mode() & 0o777, 0o600);
    }

    /// Regression (soak review): a second run in the same `--log-dir` deleted the first run's
    /// logs.
    #[test]
    fn a_log_keeps_the_previous_runs_as_dot_1_and_only_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("predictor.log");
        let (mut f, kept) = create_log(&path).unwrap();
        assert_eq!(kept, None);
        f.write_all(b"run 1").unwrap();
        let (mut f, kept) = create_log(&path).unwrap();
        let previous = dir.path().join("predictor.log.1");
        assert_eq!(kept.as_deref(), Some(previous.as_path()));
        f.write_all(b"run 2").unwrap();
        assert_eq!(std::fs::read_to_string(&previous).unwrap(), "run 1");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "run 2");
        create_log(&path).unwrap();
        assert_eq!(std::fs::read_to_string(&previous).unwrap(), "run 2");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        // A link at the name is replaced, its target neither kept nor written.
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, "ORIGINAL").unwrap();
        let link = dir.path().join("deck.log");
        std::os::unix::fs::symlink(&victim, &link).unwrap();
        let (mut f, kept) = create_log(&link).unwrap();
        f.write_all(b"deck").unwrap();
        assert_eq!(kept, None);
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "ORIGINAL");
        assert!(std::fs::symlink_metadata(&link).unwrap().is_file());
    }

    #[test]
    fn each_temp_dir_is_new_and_private() {
        let a = new_private_temp_dir("shipcast-test").unwrap();
        let b = new_private_temp_dir("shipcast-test").unwrap();
        assert_ne!(a, b);
        for d in [&a, &b] {
            let mode = std::fs::metadata(d).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o700, "{}", d.display());
            std::fs::remove_dir(d).unwrap();
        }
    }
}
