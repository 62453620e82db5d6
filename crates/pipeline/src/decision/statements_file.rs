//! The deck's verified statements kept across runs (`[deck] statements_file`).
//!
//! Why: statements are corrected by what happened to earlier ones like them
//! ([`super::recalibrate`]), and a deck that starts from nothing has no such evidence for
//! hours. Replayed, the first calm spells of every 4-hour paper-sea record over-stated their
//! 30 s windows (0.22 stated, 0.01-0.09 held) before any earlier call near 0.22 had been
//! verified; a deck that started with the statements of an earlier 4-hour run of another
//! realisation of the same sea had none of those bins off (docs/decisions.md). So the deck
//! reads the file at start and writes it as it runs, as a ship's deck would keep it from one
//! sortie to the next.
//!
//! Format (JSON): `{"format": "shipcast-deck-statements/1", "dt_s": 0.5, "records":
//! [{"window_steps": 20, "bins": [[bin, calls, sum of stated p, held], ...]}, ...]}`, one
//! record per window length (in forecast steps of `dt_s`), bins of
//! [`super::recalibrate::RESOLUTION`] over [0, 1]. Written to a temporary file beside it and
//! renamed, so a crash never leaves half a file.

use super::recalibrate::StatementRecord;
use super::{Decider, MAX_RECORDS};
use serde::{Deserialize, Serialize};
use shipcast_series::atomic_file::{check_writable_beside, directory_of, write_atomically};
use shipcast_wire::payload::MAX_STEPS;
use std::path::{Path, PathBuf};

pub const FORMAT: &str = "shipcast-deck-statements/1";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StatementsFile {
    pub format: String,
    /// Forecast step the window lengths are counted in [s].
    pub dt_s: f64,
    pub records: Vec<WindowRecord>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindowRecord {
    pub window_steps: usize,
    pub bins: Vec<[f64; 4]>,
}

impl StatementsFile {
    /// The records of a decider, for forecasts of step `dt_s`.
    pub fn of<'a>(dt_s: f64, records: impl Iterator<Item = (usize, &'a StatementRecord)>) -> Self {
        Self {
            format: FORMAT.to_string(),
            dt_s,
            records: records
                .map(|(window_steps, r)| WindowRecord {
                    window_steps,
                    bins: r.bins().collect(),
                })
                .collect(),
        }
    }

    /// The checked records for forecasts of step `dt_s`: an error if the file was written for
    /// another step (its window lengths would mean other windows) or a record is malformed.
    pub fn records(&self, dt_s: f64) -> Result<Vec<(usize, StatementRecord)>, String> {
        if self.format != FORMAT {
            return Err(format!("format '{}' is not '{FORMAT}'", self.format));
        }
        // Written so that a non-finite dt_s in the file fails too.
        let same_step = (self.dt_s - dt_s).abs() <= 1e-9 * dt_s.abs();
        if !same_step {
            return Err(format!(
                "written for forecast steps of {} s, these are {dt_s} s",
                self.dt_s
            ));
        }
        // A deck keeps at most MAX_RECORDS window lengths; more could only be kept by
        // dropping some, and the next write would lose them from the file for good.
        if self.records.len() > MAX_RECORDS {
            return Err(format!(
                "{} window lengths, a deck keeps at most {MAX_RECORDS}",
                self.records.len()
            ));
        }
        let mut out: Vec<(usize, StatementRecord)> = Vec::with_capacity(self.records.len());
        for w in &self.records {
            if w.window_steps == 0 || w.window_steps > MAX_STEPS {
                return Err(format!(
                    "window of {} steps is not one of 1..={MAX_STEPS}",
                    w.window_steps
                ));
            }
            if out.iter().any(|(n, _)| *n == w.window_steps) {
                return Err(format!("window of {} steps is given twice", w.window_steps));
            }
            let r = StatementRecord::from_bins(&w.bins)
                .map_err(|e| format!("window of {} steps: {e}", w.window_steps))?;
            out.push((w.window_steps, r));
        }
        Ok(out)
    }
}

/// Read a statements file; `Ok(None)` if there is none yet (a deck's first run).
pub fn load(path: &Path) -> anyhow::Result<Option<StatementsFile>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => anyhow::bail!("statements file {}: {e}", path.display()),
    };
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| anyhow::anyhow!("statements file {}: {e}", path.display()))
}

/// Write a statements file atomically (`shipcast_series::atomic_file`): a failed write
/// leaves the old file as it was.
pub fn save(path: &Path, file: &StatementsFile) -> anyhow::Result<()> {
    let text = serde_json::to_string(file)?;
    write_atomically(path, text.as_bytes())
        .map_err(|e| anyhow::anyhow!("statements file {}: {e}", path.display()))
}

/// Whether a statements file can be kept at `path`: found at start, not at the first write
/// after hours of calls (or, in replay, after the whole record). The directory must exist and
/// take a file: a temporary file like the one `save` writes is made and removed again. Regression
/// (review): only the directory's existence was checked, so a deck whose directory it could
/// not write ran its whole watch and lost every statement at the end.
pub fn check_writable(path: &Path) -> anyhow::Result<()> {
    if path.as_os_str().is_empty() {
        anyhow::bail!("statements file: the path is empty");
    }
    if path.is_dir() {
        anyhow::bail!("statements file {}: is a directory", path.display());
    }
    let dir = directory_of(path);
    if !dir.is_dir() {
        anyhow::bail!(
            "statements file {}: its directory {} does not exist",
            path.display(),
            dir.display()
        );
    }
    check_writable_beside(path).map_err(|e| {
        anyhow::anyhow!(
            "statements file {}: cannot be written in {} ({e})",
            path.display(),
            dir.display()
        )
    })
}

/// A deck's statements file: read into its decider at start, written as statements are
/// verified.
#[derive(Debug)]
pub struct StatementsKeeper {
    path: PathBuf,
    dt_s: f64,
    /// Verified statements when last read or written (nothing new: nothing to write).
    written_calls: f64,
}

impl StatementsKeeper {
    /// Start `decider` from the statements in `path` (none if there is no file yet) for
    /// forecasts of step `dt_s`. An error says why the file cannot be kept there
    /// ([`check_writable`]) or why an existing file cannot be used; in the second case the
    /// deck runs without a keeper, so that file is never overwritten (it may be the only copy
    /// of a long run's statements).
    pub fn open(path: &Path, dt_s: f64, decider: &mut Decider) -> anyhow::Result<Self> {
        check_writable(path)?;
        Self::open_checked(path, dt_s, decider)
    }

    /// [`Self::open`] for a `path` that [`check_writable`] has passed already (the deck
    /// checks first, because it refuses to start where open's other errors let it run on).
    pub fn open_checked(path: &Path, dt_s: f64, decider: &mut Decider) -> anyhow::Result<Self> {
        let mut keeper = Self {
            path: path.to_path_buf(),
            dt_s,
            written_calls: 0.0,
        };
        if let Some(file) = load(path)? {
            let records = file
                .records(dt_s)
                .map_err(|e| anyhow::anyhow!("statements file {}: {e}", path.display()))?;
            decider.adopt_statements(records);
            keeper.written_calls = decider.statement_calls();
            tracing::info!(
                "deck: starting from {} verified statements in {}",
                keeper.written_calls,
                path.display()
            );
        }
        Ok(keeper)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Write the decider's statements if any were verified since the last write; true if
    /// written.
    pub fn save(&mut self, decider: &Decider) -> anyhow::Result<bool> {
        let calls = decider.statement_calls();
        if calls == self.written_calls {
            return Ok(false);
        }
        save(
            &self.path,
            &StatementsFile::of(self.dt_s, decider.statement_records()),
        )?;
        self.written_calls = calls;
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(calls: &[(f64, bool)]) -> StatementRecord {
        let mut r = StatementRecord::default();
        for &(p, held) in calls {
            r.add(p, held);
        }
        r
    }

    #[test]
    fn a_saved_file_loads_the_same_records_and_a_missing_one_is_none() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("statements.json");
        assert!(load(&path).unwrap().is_none());
        let a = record(&[(0.2, false), (0.21, true), (0.8, true)]);
        let b = record(&[(0.05, false)]);
        let file = StatementsFile::of(0.5, [(20, &a), (60, &b)].into_iter());
        save(&path, &file).unwrap();
        let back = load(&path).unwrap().unwrap();
        assert_eq!(back, file);
        let records = back.records(0.5).unwrap();
        assert_eq!(records.len(), 2);
        assert_eq!(records[0].0, 20);
        for p in [0.2, 0.8] {
            assert_eq!(records[0].1.correct(p, 0.95), a.correct(p, 0.95));
        }
        assert_eq!(records[1].1.calls(), 1.0);
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temporary file"
        );
    }

    /// Regression (review): only the directory's existence was checked at start, so a
    /// file that could not be written was found at the end of the watch.
    #[test]
    fn a_place_no_file_can_be_written_is_refused_at_open() {
        let dir = tempfile::tempdir().unwrap();
        // A name that fits the file system's limit (255 bytes) while its temporary file's
        // does not: no write can succeed, even as root.
        let path = dir.path().join(format!("{}.json", "s".repeat(245)));
        let mut decider = Decider::new(&crate::config::DeckConfig::default());
        let e = StatementsKeeper::open(&path, 0.5, &mut decider).unwrap_err();
        assert!(
            e.to_string().starts_with(&format!(
                "statements file {}: cannot be written in {}",
                path.display(),
                dir.path().display()
            )),
            "{e}"
        );
        let path = dir.path().join("statements.json");
        StatementsKeeper::open(&path, 0.5, &mut decider).unwrap();
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "the check leaves nothing behind"
        );
    }

    /// Regression: a file already holding MAX_RECORDS other window lengths (a deck run with
    /// eight other MOTs before) made the deck drop every outcome of its own window, silently.
    #[test]
    fn a_full_file_still_learns_the_window_in_use_and_gives_up_the_least_used_one() {
        let mut decider = Decider::new(&crate::config::DeckConfig::default());
        let records: Vec<(usize, StatementRecord)> = (1..=MAX_RECORDS)
            .map(|n| (n, record(&vec![(0.5, true); n])))
            .collect();
        decider.adopt_statements(records);
        let in_use = MAX_RECORDS + 12;
        for _ in 0..3 {
            decider.add_outcome(in_use, 0.7, false);
        }
        let kept: Vec<(usize, f64)> = decider
            .statement_records()
            .map(|(n, r)| (n, r.calls()))
            .collect();
        assert_eq!(kept.len(), MAX_RECORDS);
        assert!(kept.contains(&(in_use, 3.0)), "{kept:?}");
        // The window of 1 step had the fewest calls (one); every other one is kept whole.
        assert!(!kept.iter().any(|&(n, _)| n == 1), "{kept:?}");
        for n in 2..=MAX_RECORDS {
            assert!(kept.contains(&(n, n as f64)), "{kept:?}");
        }
        // A second length in use (replay scores two MOTs) takes the least used of the
        // others, and the two never evict each other again, however they alternate.
        let second = in_use + 40;
        for _ in 0..50 {
            decider.add_outcome(second, 0.2, true);
            decider.add_outcome(in_use, 0.7, false);
        }
        let kept: Vec<(usize, f64)> = decider
            .statement_records()
            .map(|(n, r)| (n, r.calls()))
            .collect();
        assert!(kept.contains(&(in_use, 53.0)), "{kept:?}");
        assert!(kept.contains(&(second, 50.0)), "{kept:?}");
        assert!(!kept.iter().any(|&(n, _)| n == 2), "{kept:?}");
        // What it learnt is what a fresh record of those calls says.
        let fresh = record(&[(0.7, false); 53]);
        let (_, r) = decider
            .statement_records()
            .find(|(n, _)| *n == in_use)
            .unwrap();
        assert_eq!(r.correct(0.7, 0.95), fresh.correct(0.7, 0.95));
    }

    #[test]
    fn a_write_that_cannot_be_made_is_an_error_naming_the_file_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no such dir").join("statements.json");
        let file = StatementsFile::of(0.5, std::iter::empty());
        let e = save(&path, &file).unwrap_err().to_string();
        // The message names the configured file first, not only its temporary one.
        assert!(
            e.starts_with(&format!("statements file {}: ", path.display())),
            "{e}"
        );
        assert!(!path.exists());
        // The same write where the directory exists is flushed, renamed and readable.
        let path = dir.path().join("statements.json");
        save(&path, &file).unwrap();
        assert_eq!(load(&path).unwrap(), Some(file));
    }

    /// Regression: a statements file in a directory that does not exist was found out only
    /// at the first write: in replay, after the whole record, whose results were then lost.
    #[test]
    fn a_path_that_cannot_be_written_is_refused_when_opened() {
        let dir = tempfile::tempdir().unwrap();
        let mut decider = Decider::new(&crate::config::DeckConfig::default());
        let mut open = |path: &Path| {
            StatementsKeeper::open(path, 0.5, &mut decider)
                .err()
                .map(|e| e.to_string())
        };
        let missing = dir.path().join("no such dir").join("s.json");
        let e = open(&missing).expect("a missing directory was accepted");
        assert!(e.contains("does not exist") && e.contains("s.json"), "{e}");
        let e = open(dir.path()).expect("a directory was accepted");
        assert!(e.contains("is a directory"), "{e}");
        let e = open(Path::new("")).expect("an empty path was accepted");
        assert!(e.contains("empty"), "{e}");
        // A file not there yet in a directory that is: a deck's first run.
        assert_eq!(open(&dir.path().join("s.json")), None);
    }

    #[test]
    fn files_for_other_steps_or_edited_by_hand_are_refused_with_a_reason() {
        let a = record(&[(0.3, true)]);
        let good = StatementsFile::of(0.5, [(20, &a)].into_iter());
        let err = |f: &StatementsFile| f.records(0.5).unwrap_err();
        assert!(good.records(0.25).unwrap_err().contains("0.5 s"));
        let mut f = good.clone();
        f.format = "other/1".into();
        assert!(err(&f).contains("format"));
        let mut f = good.clone();
        f.records[0].window_steps = MAX_STEPS + 1;
        assert!(err(&f).contains("steps"));
        let mut f = good.clone();
        f.records.push(f.records[0].clone());
        assert!(err(&f).contains("twice"));
        // More window lengths than a deck keeps: refused, not silently cut to the first ones
        // (the next write would have lost the rest). Exactly MAX_RECORDS is fine.
        let mut f = good.clone();
        f.records = (1..=MAX_RECORDS + 1)
            .map(|n| WindowRecord {
                window_steps: n,
                bins: good.records[0].bins.clone(),
            })
            .collect();
        assert!(err(&f).contains("at most"), "{}", err(&f));
        f.records.pop();
        assert_eq!(f.records(0.5).unwrap().len(), MAX_RECORDS);
        let mut f = good.clone();
        f.records[0].bins[0][3] = 2.0;
        assert!(err(&f).contains("window of 20 steps"));
        // Not JSON of this shape: a clear error naming the file, never a panic.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.json");
        for text in [
            "{",
            "{\"format\": 1}",
            "{\"format\":\"x\",\"dt_s\":0.5,\"records\":[],\"extra\":0}",
        ] {
            std::fs::write(&path, text).unwrap();
            let e = load(&path).unwrap_err().to_string();
            assert!(e.contains("s.json"), "{e}");
        }
    }
}
