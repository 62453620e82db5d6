//! Writing a file so that a failure never destroys what was there: the bytes go to a
//! temporary file beside it, are flushed to the disk, and the temporary file is
//! renamed over the old one; then the directory is flushed so that the rename survives a power
//! cut too (a rename of unflushed data can leave an empty file after one). A write that fails
//! leaves the old file as it was and removes its temporary file.
//!
//! The temporary file has a name no other writer uses (`.<name>.<pid>.<n>.tmp`) and is made
//! with `create_new`, which never follows a symbolic link nor opens a file that exists.
//! Regression (review): it was `<name>.tmp`, opened with `File::create`, so a link planted
//! there redirected the write, and two processes saving the same path truncated each other's
//! temporary file.
//!
//! Used for the files a long run produces and a later run depends on: model files (`shipcast
//! train`) and the deck's statements file.
//!
//! A character device or a named pipe (`/dev/null`, a terminal's `/dev/stdout`) is written
//! into, not replaced; a symbolic link's target is replaced, never the link; a block device or
//! a socket is refused. Regression: a file written to `/dev/null` by a process running as root
//! renamed a regular file over it, and every later reader of `/dev/null` (cargo's own probe of
//! rustc among them) read back what had been written there.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// What failed, and on which path.
#[derive(Debug, thiserror::Error)]
pub enum AtomicWriteError {
    #[error("creating a temporary file in {path}: {error}")]
    CreateTemporary {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("writing the temporary file {path}: {error}")]
    Temporary {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{error}")]
    Rename { error: std::io::Error },
    #[error("writing {path}: {error}")]
    Special {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("flushing its directory {path}: {error}")]
    Directory {
        path: PathBuf,
        error: std::io::Error,
    },
}

/// The directory `path` is in (`.` for a bare file name).
pub fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Tells apart the temporary files of one process's writes (threads may save at once).
static NEXT_TEMPORARY: AtomicU64 = AtomicU64::new(0);

/// `.<name>.`: what every temporary file of `path` (named `name`) starts with, followed by
/// `<pid>.<n>.tmp`.
fn temporary_prefix(name: &std::ffi::OsStr) -> std::ffi::OsString {
    let mut prefix = std::ffi::OsString::from(".");
    prefix.push(name);
    prefix.push(".");
    prefix
}

/// A new temporary file beside `path`, made by this call: a name that exists (another
/// writer's, a planted link) is never opened but skipped for the next one.
fn create_temporary(path: &Path) -> std::io::Result<(PathBuf, File)> {
    create_temporary_numbered(path, &NEXT_TEMPORARY)
}

/// [`create_temporary`] numbering its names from `next` (tests give their own counter: the
/// process's is shared by every test that writes).
fn create_temporary_numbered(path: &Path, next: &AtomicU64) -> std::io::Result<(PathBuf, File)> {
    let name = path.file_name().unwrap_or(path.as_os_str());
    let dir = directory_of(path);
    let mut last_error = None;
    // A few names taken at once is a crowded directory; more is something else (a full
    // directory, a loop), reported with the last error.
    for _ in 0..16 {
        let n = next.fetch_add(1, Ordering::Relaxed);
        let mut file_name = temporary_prefix(name);
        file_name.push(format!("{}.{n}.tmp", std::process::id()));
        let tmp = dir.join(file_name);
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(file) => return Ok((tmp, file)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last_error = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last_error.unwrap_or_else(|| std::io::Error::other("no temporary name is free")))
}

/// Remove the temporary files of `path` that writers killed before their rename left (their
/// process is gone: no `/proc/<pid>`). Regression (review): each name is unique, so nothing
/// else ever reused or removed them, and model files are large. Best effort: a file that
/// cannot be listed or removed stays; where there is no `/proc`, nothing is removed.
fn remove_stale_temporaries(path: &Path) {
    let proc_root = Path::new("/proc/self");
    if !proc_root.exists() {
        return;
    }
    let (Some(name), Ok(entries)) = (path.file_name(), std::fs::read_dir(directory_of(path)))
    else {
        return;
    };
    let prefix = temporary_prefix(name).to_string_lossy().into_owned();
    let own = std::process::id();
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let file_name = file_name.to_string_lossy();
        let Some(middle) = file_name
            .strip_prefix(&prefix)
            .and_then(|rest| rest.strip_suffix(".tmp"))
        else {
            continue;
        };
        let Some(pid) = middle.split('.').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if pid != own && !Path::new("/proc").join(pid.to_string()).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Whether a file can be written beside `path` (in its directory): a temporary file is made
/// and removed, as [`write_atomically`] would. For a long run that writes `path` only at its
/// end, so that it is refused at start and not after hours of work.
pub fn check_writable_beside(path: &Path) -> std::io::Result<()> {
    let (tmp, file) = create_temporary(path)?;
    drop(file);
    std::fs::remove_file(&tmp)
}

/// Replace `path` by `bytes`, or leave it as it was. A symbolic link is followed: the file it
/// leads to is replaced, never the link (a link to `/proc/self/fd/1`, as `/dev/stdout` is, was
/// replaced by a regular file). A character device or a pipe is written into; a block device or
/// a socket is refused.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), AtomicWriteError> {
    let target = match what_is_at(path) {
        Target::Stream => return write_into_special(path, bytes),
        Target::Refused(kind) => {
            return Err(AtomicWriteError::Special {
                path: path.to_path_buf(),
                error: std::io::Error::other(format!("{kind}, not a file to write into")),
            })
        }
        Target::File(target) => target,
    };
    let path = target.as_path();
    let (tmp, mut out) =
        create_temporary(path).map_err(|error| AtomicWriteError::CreateTemporary {
            path: directory_of(path).to_path_buf(),
            error,
        })?;
    if let Err(error) = out.write_all(bytes).and_then(|()| out.sync_all()) {
        // A half-written temporary file is no use to anyone.
        drop(out);
        let _ = std::fs::remove_file(&tmp);
        return Err(AtomicWriteError::Temporary { path: tmp, error });
    }
    drop(out);
    if let Err(error) = std::fs::rename(&tmp, path) {
        let _ = std::fs::remove_file(&tmp);
        return Err(AtomicWriteError::Rename { error });
    }
    remove_stale_temporaries(path);
    // Flushing a directory is a Unix notion; elsewhere the rename is left to the OS.
    #[cfg(unix)]
    {
        let dir = directory_of(path);
        std::fs::File::open(dir)
            .and_then(|d| d.sync_all())
            .map_err(|error| AtomicWriteError::Directory {
                path: dir.to_path_buf(),
                error,
            })?;
    }
    Ok(())
}

/// What a write to a path meets.
enum Target {
    /// A regular file, or nothing yet: replaced atomically at this path (a link's target).
    File(PathBuf),
    /// A character device or a pipe: written into.
    Stream,
    /// Anything else that exists and is no directory (a directory fails at the rename).
    Refused(&'static str),
}

fn what_is_at(path: &Path) -> Target {
    let Ok(meta) = std::fs::metadata(path) else {
        return Target::File(path.to_path_buf());
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let kind = meta.file_type();
        if kind.is_char_device() || kind.is_fifo() {
            return Target::Stream;
        }
        if kind.is_block_device() {
            return Target::Refused("a block device");
        }
        if kind.is_socket() {
            return Target::Refused("a socket");
        }
    }
    if !meta.is_file() {
        return Target::File(path.to_path_buf());
    }
    // The file itself, wherever links lead: the rename replaces it, not a link to it.
    Target::File(std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()))
}

/// Write `bytes` into the device or pipe at `path`: there is nothing to keep safe there, and
/// replacing it would break it for every other user of the system.
fn write_into_special(path: &Path, bytes: &[u8]) -> Result<(), AtomicWriteError> {
    OpenOptions::new()
        .write(true)
        .open(path)
        .and_then(|mut out| out.write_all(bytes))
        .map_err(|error| AtomicWriteError::Special {
            path: path.to_path_buf(),
            error,
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression (review): a link to a regular file (as `/dev/stdout` is when stdout goes to a
    /// file) was replaced by a regular file; the file it leads to is replaced now.
    #[cfg(unix)]
    #[test]
    fn a_link_to_a_file_keeps_its_link_and_the_file_gets_the_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.json");
        std::fs::write(&real, b"old").unwrap();
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_atomically(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
    }

    /// Regression: a device or pipe given as the path (`--out /dev/null`) was replaced by a
    /// regular file. A named pipe stands in for the device: the bytes reach its reader, and it
    /// is still a pipe afterwards.
    #[cfg(unix)]
    #[test]
    fn a_pipe_or_device_is_written_into_not_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo runs");
        assert!(made.success());
        let reader = std::thread::spawn({
            let fifo = fifo.clone();
            move || std::fs::read(fifo).unwrap()
        });
        write_atomically(&fifo, b"model").unwrap();
        // Checked before the reader is joined: had the pipe been replaced, the reader would wait
        // on it for ever.
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
        assert_eq!(reader.join().unwrap(), b"model");
        // Nothing was left beside it.
        assert_eq!(files_in(dir.path()), ["pipe".to_string()]);
    }

    /// The names of the files in `dir`, sorted.
    fn files_in(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_write_replaces_the_file_and_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.json");
        std::fs::write(&path, b"old").unwrap();
        write_atomically(&path, b"new contents").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new contents");
        check_writable_beside(&path).unwrap();
        assert_eq!(files_in(dir.path()), ["model.json"]);
    }

    #[test]
    fn a_write_that_fails_leaves_the_old_file_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        // A name that fits the file system's limit (255 bytes) while its temporary file's
        // does not: no temporary file can be made, even by root.
        let path = dir.path().join("m".repeat(250));
        std::fs::write(&path, b"the only copy").unwrap();
        let e = write_atomically(&path, b"new").unwrap_err();
        assert!(matches!(e, AtomicWriteError::CreateTemporary { .. }), "{e}");
        assert!(
            e.to_string().starts_with("creating a temporary file in"),
            "{e}"
        );
        assert!(check_writable_beside(&path).is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"the only copy");
        // A rename that fails (onto a directory) leaves no temporary file behind.
        let onto_dir = dir.path().join("a_directory");
        std::fs::create_dir(&onto_dir).unwrap();
        std::fs::write(onto_dir.join("inside"), b"x").unwrap();
        assert!(matches!(
            write_atomically(&onto_dir, b"new"),
            Err(AtomicWriteError::Rename { .. })
        ));
        assert_eq!(
            files_in(dir.path()),
            ["a_directory".to_string(), "m".repeat(250)]
        );
    }

    /// Regression (review): the temporary file was `<name>.tmp` opened with `File::create`,
    /// which follows a link planted there and truncates another writer's temporary file.
    #[cfg(unix)]
    #[test]
    fn a_link_or_file_at_any_temporary_name_is_left_alone() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("statements.json");
        let victim = dir.path().join("victim");
        std::fs::write(&victim, b"not yours").unwrap();
        // A link at the old fixed name.
        std::os::unix::fs::symlink(&victim, dir.path().join("statements.json.tmp")).unwrap();
        write_atomically(&path, b"statements").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"statements");
        assert_eq!(std::fs::read(&victim).unwrap(), b"not yours");
        assert!(!std::fs::symlink_metadata(&path).unwrap().is_symlink());
        // Links at the first 8 names a writer picks (fewer than the 16 it tries: more and it
        // gives up, rightly), with a counter of the test's own so that no other test's write
        // moves it past them: each is skipped, and the ninth name is made.
        let next = AtomicU64::new(0);
        for n in 0..8 {
            let name = format!(".statements.json.{}.{n}.tmp", std::process::id());
            std::os::unix::fs::symlink(&victim, dir.path().join(name)).unwrap();
        }
        let (tmp, mut file) = create_temporary_numbered(&path, &next).unwrap();
        let expected = format!(".statements.json.{}.8.tmp", std::process::id());
        assert_eq!(tmp, dir.path().join(expected));
        file.write_all(b"mine").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"not yours");
        assert!(!std::fs::symlink_metadata(&tmp).unwrap().is_symlink());
    }

    /// A writer killed between its temporary file and the rename leaves the file; the next
    /// save removes it once its process is gone, and leaves a live writer's alone.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_dead_writers_temporary_file_goes_with_the_next_save() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.json");
        // Beyond any pid the kernel hands out (pid_max is at most 2^22).
        let dead = dir.path().join(".model.json.999999999.0.tmp");
        let live = dir
            .path()
            .join(format!(".model.json.{}.999.tmp", std::process::id()));
        let other = dir.path().join(".other.json.999999999.0.tmp");
        for f in [&dead, &live, &other] {
            std::fs::write(f, b"half a model").unwrap();
        }
        write_atomically(&path, b"model").unwrap();
        assert!(!dead.exists());
        assert!(live.exists() && other.exists());
    }

    #[test]
    fn writers_of_one_path_at_once_each_leave_a_whole_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.json");
        let texts: Vec<Vec<u8>> = (0..8u8).map(|i| vec![b'a' + i; 100_000]).collect();
        std::thread::scope(|scope| {
            for text in &texts {
                let path = &path;
                scope.spawn(move || {
                    for _ in 0..5 {
                        write_atomically(path, text).unwrap();
                    }
                });
            }
        });
        let end = std::fs::read(&path).unwrap();
        assert!(texts.contains(&end), "one writer's whole text, not a mix");
        assert_eq!(files_in(dir.path()), ["model.json"]);
    }
}
