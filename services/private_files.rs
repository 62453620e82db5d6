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
