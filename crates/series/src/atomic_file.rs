//! Writing a file so that a failure never destroys what was there: the bytes go to a
//! temporary file beside it (`<name>.tmp`), are flushed to the disk, and the temporary file is
//! renamed over the old one; then the directory is flushed so that the rename survives a power
//! cut too (a rename of unflushed data can leave an empty file after one). A write that fails
//! leaves the old file as it was and removes its temporary file.
//!
//! Used for the files a long run produces and a later run depends on: model files (`shipcast
//! train`) and the deck's statements file.

use std::io::Write;
use std::path::{Path, PathBuf};

/// What failed, and on which path.
#[derive(Debug, thiserror::Error)]
pub enum AtomicWriteError {
    #[error("writing its temporary file {path}: {error}")]
    Temporary {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{error}")]
    Rename { error: std::io::Error },
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

/// The temporary file a write of `path` goes through.
pub fn temporary_path(path: &Path) -> PathBuf {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    PathBuf::from(tmp)
}

/// Replace `path` by `bytes`, or leave it as it was.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), AtomicWriteError> {
    let tmp = temporary_path(path);
    let written = std::fs::File::create(&tmp).and_then(|mut out| {
        out.write_all(bytes)?;
        out.sync_all()
    });
    if let Err(error) = written {
        // A half-written temporary file is no use to anyone.
        let _ = std::fs::remove_file(&tmp);
        return Err(AtomicWriteError::Temporary { path: tmp, error });
    }
    if let Err(error) = std::fs::rename(&tmp, path) {
        let _ = std::fs::remove_file(&tmp);
        return Err(AtomicWriteError::Rename { error });
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_write_replaces_the_file_and_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.json");
        std::fs::write(&path, b"old").unwrap();
        write_atomically(&path, b"new contents").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new contents");
        assert!(!temporary_path(&path).exists());
    }

    #[test]
    fn a_write_that_fails_leaves_the_old_file_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.json");
        std::fs::write(&path, b"the only copy").unwrap();
        // The temporary file's name taken by a directory: no write can succeed, even as root.
        std::fs::create_dir(temporary_path(&path)).unwrap();
        let e = write_atomically(&path, b"new").unwrap_err();
        assert!(matches!(e, AtomicWriteError::Temporary { .. }), "{e}");
        assert!(
            e.to_string().starts_with("writing its temporary file"),
            "{e}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"the only copy");
        // A rename that fails (onto a directory) leaves no temporary file behind.
        std::fs::remove_dir(temporary_path(&path)).unwrap();
        let onto_dir = dir.path().join("a_directory");
        std::fs::create_dir(&onto_dir).unwrap();
        std::fs::write(onto_dir.join("inside"), b"x").unwrap();
        assert!(matches!(
            write_atomically(&onto_dir, b"new"),
            Err(AtomicWriteError::Rename { .. })
        ));
        assert!(!temporary_path(&onto_dir).exists());
    }
}
