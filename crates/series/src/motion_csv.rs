//! The motion CSV format (docs/contracts.md section 2.3): a header row of unit-carrying column
//! names (`time_s,surge_m,sway_m,heave_m,roll_rad,pitch_rad,yaw_rad`), then one row per sample.
//!
//! Readers accept any subset of the six DOF columns, in any order, plus the wave elevation
//! `wave_m`, and ignore every other column (a UTC stamp, a quality flag, a note): those are the
//! file's own business and are neither parsed nor kept. `time_s` is required and must increase
//! strictly. Every value of the columns read must be a finite number. Errors name the line
//! (1-based, the header is line 1) and the column. Regression (review): every column was
//! parsed, so a record with a text column was refused whole, against the contract.
//!
//! [`MotionCsvWriter`] writes the same format row by row (the simulator streams hours of data),
//! with values printed in Rust's shortest round-trip form, so reading back gives the same `f64`s.

use shipcast_wire::dof::Dof;
use shipcast_wire::payload::MAX_ABS_MOTION;

/// Largest time stamp a record may carry [s]: Unix epoch seconds (1.7e9 today) with room to
/// spare; beyond it a stamp is corrupt, and the gap before it has no sample count.
pub const MAX_ABS_TIME_S: f64 = 1e12;
use std::fs::File;
use std::io::{self, BufWriter, Read, Write};
use std::path::Path;

/// Name of the time column.
pub const TIME_COLUMN: &str = "time_s";

/// Name of the wave elevation column (`simulate` writes it; `simulate --elevation` reads it).
pub const WAVE_COLUMN: &str = "wave_m";

/// Whether a column other than time is read: a DOF's or the wave elevation's.
fn is_read_column(name: &str) -> bool {
    name == WAVE_COLUMN || Dof::ALL.iter().any(|d| d.csv_column() == name)
}

/// Why a motion CSV could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum MotionCsvError {
    #[error(transparent)]
    Io(#[from] io::Error),
    #[error("empty file: no header row")]
    Empty,
    #[error("no data rows after the header")]
    NoRows,
    #[error("line 1: no '{TIME_COLUMN}' column (columns: {columns})")]
    MissingTime { columns: String },
    #[error("line 1: column '{column}' appears twice")]
    DuplicateColumn { column: String },
    #[error("line 1: the file is UTF-16 text: save it as UTF-8 (or ASCII)")]
    Utf16,
    #[error("line {line}: truncated row: {got} of {expected} fields")]
    Truncated {
        line: u64,
        expected: usize,
        got: usize,
    },
    #[error("line {line}: {got} fields, the header has {expected}")]
    TooManyFields {
        line: u64,
        expected: usize,
        got: usize,
    },
    #[error("line {line}: the last row does not end with a line break, so the file may have been cut off inside it (if the file is complete, end it with a line break)")]
    Unterminated { line: u64 },
    #[error("line {line}, column '{column}': value '{text}' is beyond +-{MAX_ABS_MOTION:e}, which no motion reaches")]
    OutOfRange {
        line: u64,
        column: String,
        text: String,
    },
    #[error("line {line}, column '{TIME_COLUMN}': time '{text}' is beyond +-{MAX_ABS_TIME_S:e} s, more than 30000 years even from the Unix epoch: {hint}")]
    TimeOutOfRange {
        line: u64,
        text: String,
        /// Epoch time in which unit the stamp looks like, or a corrupt stamp.
        hint: String,
    },
    #[error("line {line}, column '{column}': missing value")]
    Missing { line: u64, column: String },
    #[error("line {line}, column '{column}': not UTF-8 text (a number is ASCII)")]
    NotText { line: u64, column: String },
    #[error("line {line}, column '{column}': '{text}' is not a number")]
    NotANumber {
        line: u64,
        column: String,
        text: String,
    },
    #[error("line {line}, column '{column}': non-finite value '{text}'")]
    NonFinite {
        line: u64,
        column: String,
        text: String,
    },
    #[error("line {line}, column '{TIME_COLUMN}': time {} does not increase (previous row: {})", shown_number(*.time), shown_number(*.previous))]
    TimeNotIncreasing { line: u64, time: f64, previous: f64 },
    #[error("line {line}, column '{column}': a quoted field holds what look like rows of the file, which would be lost in it (an unclosed quote?)")]
    FieldOverLines { line: u64, column: String },
    #[error("line {line}: malformed CSV: {message}")]
    Malformed { line: u64, message: String },
    #[error("no motion column: none of surge_m, sway_m, heave_m, roll_rad, pitch_rad, yaw_rad (columns: {columns})")]
    NoMotion { columns: String },
    #[error("no '{column}' column for {dof} (columns: {columns})")]
    DofAbsent {
        dof: Dof,
        column: &'static str,
        columns: String,
    },
    #[error("column name '{0}' cannot be written (empty, or holds a comma, quote or line break)")]
    BadColumnName(String),
    #[error("row {row}: {got} values for {expected} columns")]
    RowWidth {
        row: u64,
        expected: usize,
        got: usize,
    },
    #[error("row {row}: non-finite value {value} in column '{column}'")]
    WriteNonFinite {
        row: u64,
        column: String,
        value: f64,
    },
    #[error("row {row}: value {} in column '{column}' is beyond +-{limit:e}, which no reader takes back", shown_number(*.value))]
    WriteOutOfRange {
        row: u64,
        column: String,
        value: f64,
        limit: f64,
    },
    #[error("row {row}: time {} does not increase (previous row: {})", shown_number(*.time), shown_number(*.previous))]
    WriteTimeNotIncreasing { row: u64, time: f64, previous: f64 },
}

/// One named column of values.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    pub name: String,
    pub values: Vec<f64>,
}

/// A motion record: strictly increasing times and the columns present in the file, in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionData {
    /// Sample times [s], strictly increasing.
    pub time: Vec<f64>,
    /// Every column read except `time_s`, in file order; each as long as `time`.
    pub columns: Vec<Column>,
    /// The names of the columns the file has that are not read (neither a motion nor
    /// `wave_m`): named in the error for a missing motion column, where a misnamed one
    /// (`heave` for `heave_m`) is the usual cause.
    pub ignored: Vec<String>,
}

impl MotionData {
    /// Read a motion CSV file.
    pub fn read_path(path: impl AsRef<Path>) -> Result<Self, MotionCsvError> {
        Self::read(File::open(path)?)
    }

    /// Read a motion CSV from any reader.
    pub fn read(input: impl Read) -> Result<Self, MotionCsvError> {
        Self::read_impl(input, false)
    }

    /// Read a motion CSV whose value columns may hold `NaN` (any case) for a missing sample,
    /// as measured records mark a gap; `time_s` must still be finite and increasing, and any
    /// other non-finite text is an error as in [`MotionData::read`].
    pub fn read_with_gaps(input: impl Read) -> Result<Self, MotionCsvError> {
        Self::read_impl(input, true)
    }

    fn read_impl(input: impl Read, nan_is_gap: bool) -> Result<Self, MotionCsvError> {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(LastByte::new(input));
        // Bytes, decoded only where a column is read: a note in another column may be in any
        // encoding (review: one Latin-1 'café' in an ignored column refused the whole file).
        let mut record = csv::ByteRecord::new();
        if !read_record(&mut reader, &mut record)? {
            return Err(MotionCsvError::Empty);
        }
        // UTF-16 (a spreadsheet's "Unicode text") reads as names of NUL-separated bytes.
        if record
            .get(0)
            .is_some_and(|f| f.starts_with(&[0xFF, 0xFE]) || f.starts_with(&[0xFE, 0xFF]))
        {
            return Err(MotionCsvError::Utf16);
        }
        // A name that is not UTF-8 is no motion column's: it is shown as best it can be, and
        // ignored.
        let names: Vec<String> = record
            .iter()
            .map(|name| String::from_utf8_lossy(name).into_owned())
            .collect();
        if let Some(i) = record.iter().position(|f| holds_rows(f, record.len())) {
            return Err(MotionCsvError::FieldOverLines {
                line: 1,
                column: shown_name(&names[i]),
            });
        }
        let time_index = check_header(&names)?;

        let mut time = Vec::new();
        let mut values: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
        // The motion and wave columns are read (and bounded); any other column is ignored.
        let read: Vec<bool> = names
            .iter()
            .enumerate()
            .map(|(i, n)| i == time_index || is_read_column(n))
            .collect();
        let mut line = 1;
        while read_record(&mut reader, &mut record)? {
            line = record_line(&mut reader, &record);
            if record.len() < names.len() {
                return Err(MotionCsvError::Truncated {
                    line,
                    expected: names.len(),
                    got: record.len(),
                });
            }
            if record.len() > names.len() {
                return Err(MotionCsvError::TooManyFields {
                    line,
                    expected: names.len(),
                    got: record.len(),
                });
            }
            for (i, bytes) in record.iter().enumerate() {
                if !read[i] {
                    // A stray quote in a note made the reader take thousands of rows as one
                    // ignored field, and they were lost without a word (review). In a column
                    // that is read, the field is not a number, and its error shows it.
                    if holds_rows(bytes, names.len()) {
                        return Err(MotionCsvError::FieldOverLines {
                            line,
                            column: shown_name(&names[i]),
                        });
                    }
                    continue;
                }
                let text = std::str::from_utf8(bytes).map_err(|_| MotionCsvError::NotText {
                    line,
                    column: names[i].clone(),
                })?;
                let value = if nan_is_gap && i != time_index && text.eq_ignore_ascii_case("nan") {
                    f64::NAN
                } else {
                    parse_value(text, line, &names[i])?
                };
                // Regression (review): a stamp of 1e300 was read, and the gap before it
                // counted as 2^64 - 2 missing samples.
                if i == time_index && value.abs() > MAX_ABS_TIME_S {
                    return Err(MotionCsvError::TimeOutOfRange {
                        line,
                        text: shown_field(text),
                        hint: time_unit_hint(value),
                    });
                }
                if i != time_index && value.abs() > MAX_ABS_MOTION {
                    return Err(MotionCsvError::OutOfRange {
                        line,
                        column: names[i].clone(),
                        text: shown_field(text),
                    });
                }
                values[i].push(value);
            }
            let t = values[time_index][values[time_index].len() - 1];
            if let Some(&previous) = time.last() {
                if t <= previous {
                    return Err(MotionCsvError::TimeNotIncreasing {
                        line,
                        time: t,
                        previous,
                    });
                }
            }
            time.push(t);
        }
        if time.is_empty() {
            return Err(MotionCsvError::NoRows);
        }
        if !matches!(reader.get_ref().last, Some(b'\n' | b'\r')) {
            return Err(MotionCsvError::Unterminated { line });
        }
        let ignored = names
            .iter()
            .zip(&read)
            .filter(|(_, &r)| !r)
            .map(|(n, _)| n.clone())
            .collect();
        let columns = names
            .into_iter()
            .zip(values)
            .enumerate()
            .filter(|(i, _)| *i != time_index && read[*i])
            .map(|(_, (name, values))| Column { name, values })
            .collect();
        Ok(Self {
            time,
            columns,
            ignored,
        })
    }

    /// Number of samples (rows).
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True when there are no rows (never for data returned by `read`).
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// The values of a column by name, if present.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .find(|c| c.name == name)
            .map(|c| c.values.as_slice())
    }

    /// The series of one DOF, or an error naming the missing column.
    pub fn dof(&self, dof: Dof) -> Result<&[f64], MotionCsvError> {
        self.column(dof.csv_column())
            .ok_or_else(|| MotionCsvError::DofAbsent {
                dof,
                column: dof.csv_column(),
                columns: self.column_list(),
            })
    }

    /// The DOFs present, in wire order.
    pub fn dofs(&self) -> Vec<Dof> {
        Dof::ALL
            .into_iter()
            .filter(|d| self.column(d.csv_column()).is_some())
            .collect()
    }

    /// The DOFs present, or an error listing the columns the file has (read and not read)
    /// when there is none.
    pub fn motion_dofs(&self) -> Result<Vec<Dof>, MotionCsvError> {
        let dofs = self.dofs();
        if dofs.is_empty() {
            return Err(MotionCsvError::NoMotion {
                columns: self.column_list(),
            });
        }
        Ok(dofs)
    }

    /// Columns that are not one of the six DOFs (`wave_m`, ...).
    pub fn extras(&self) -> impl Iterator<Item = &Column> {
        self.columns
            .iter()
            .filter(|c| !Dof::ALL.iter().any(|d| d.csv_column() == c.name))
    }

    /// Write the record as a motion CSV file.
    pub fn write_path(&self, path: impl AsRef<Path>) -> Result<(), MotionCsvError> {
        let names: Vec<&str> = self.columns.iter().map(|c| c.name.as_str()).collect();
        let mut writer = MotionCsvWriter::create(path, &names)?;
        let mut row = vec![0.0; self.columns.len()];
        for (i, &t) in self.time.iter().enumerate() {
            for (slot, column) in row.iter_mut().zip(&self.columns) {
                *slot = column.values[i];
            }
            writer.write_row(t, &row)?;
        }
        writer.finish()?;
        Ok(())
    }

    fn column_list(&self) -> String {
        let read = std::iter::once(TIME_COLUMN)
            .chain(self.columns.iter().map(|c| c.name.as_str()))
            .collect::<Vec<_>>()
            .join(", ");
        if self.ignored.is_empty() {
            return read;
        }
        // Regression (review): since other columns are ignored, a misnamed motion column
        // (`heave`) vanished from this list, and with it the hint.
        format!("{read}; not read: {}", self.ignored.join(", "))
    }
}

/// The input passed through, its last byte kept: a file whose last row ends without a line
/// break may have been cut off inside its last field, where the cut leaves a shorter number
/// that still parses (`-2.074122e-03` cut to `-2.074122`).
///
/// It also refuses a line longer than [`MAX_LINE_BYTES`]: the CSV reader would buffer one
/// without end (`--input /dev/zero` grew to 24 GB before the system killed it).
struct LastByte<R> {
    inner: R,
    last: Option<u8>,
    line_bytes: usize,
    /// Bytes passed through so far.
    offset: u64,
    /// Offsets of the line breaks passed through that no record asked about yet (a CRLF is one
    /// break, at its CR; a bare CR or LF is one), and how many were dropped from the front:
    /// records are asked about in order, so this holds at most what the CSV reader buffers.
    breaks: std::collections::VecDeque<u64>,
    breaks_before: u64,
    /// Whether the last byte passed through was a CR (a CRLF split between two reads).
    after_cr: bool,
}

/// Longest line a motion CSV may have: some hundred columns of numbers take a few kB.
pub const MAX_LINE_BYTES: usize = 1 << 20;

impl<R> LastByte<R> {
    fn new(inner: R) -> Self {
        Self {
            inner,
            last: None,
            line_bytes: 0,
            offset: 0,
            breaks: std::collections::VecDeque::new(),
            breaks_before: 0,
            after_cr: false,
        }
    }

    /// The line (from 1) the byte at `offset` lies on: one more than the line breaks before
    /// it. Offsets must be asked in increasing order.
    fn line_at(&mut self, offset: u64) -> u64 {
        while self.breaks.front().is_some_and(|&b| b < offset) {
            self.breaks.pop_front();
            self.breaks_before += 1;
        }
        self.breaks_before + 1
    }
}

impl<R: Read> Read for LastByte<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        let read = &buf[..n];
        if let Some(&last) = read.last() {
            self.last = Some(last);
        }
        // One pass finds the line breaks for `line_at` and the last line end for the length
        // of the line now being read (a bare CR ends a line too, as the CSV reader takes it).
        let mut last_end = None;
        for (i, &b) in read.iter().enumerate() {
            match b {
                b'\r' => self.breaks.push_back(self.offset + i as u64),
                b'\n' if !self.after_cr => self.breaks.push_back(self.offset + i as u64),
                _ => {}
            }
            if matches!(b, b'\r' | b'\n') {
                last_end = Some(i);
            }
            self.after_cr = b == b'\r';
        }
        self.offset += n as u64;
        self.line_bytes = match last_end {
            Some(i) => n - i - 1,
            None => self.line_bytes + n,
        };
        if self.line_bytes > MAX_LINE_BYTES {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "a line longer than {} MiB: not a motion CSV",
                    MAX_LINE_BYTES >> 20
                ),
            ));
        }
        Ok(n)
    }
}

/// Read the next record; `Ok(false)` at the end of the input.
fn read_record<R: Read>(
    reader: &mut csv::Reader<LastByte<R>>,
    record: &mut csv::ByteRecord,
) -> Result<bool, MotionCsvError> {
    match reader.read_byte_record(record) {
        Ok(more) => Ok(more),
        Err(e) => {
            let line = e
                .position()
                .map_or(0, |p| reader.get_mut().line_at(p.byte()));
            let message = e.to_string();
            Err(match e.into_kind() {
                csv::ErrorKind::Io(io) => MotionCsvError::Io(io),
                _ => MotionCsvError::Malformed { line, message },
            })
        }
    }
}

/// The line `record` starts on, counted by [`LastByte::line_at`]: the CSV reader's own count
/// is one short after every CRLF line end and never moves with bare CR line ends (csv 1.x,
/// BurntSushi/rust-csv#395), so a CRLF file's errors named the line before the bad one and a
/// CR file's all said line 1 (review).
fn record_line<R: Read>(reader: &mut csv::Reader<LastByte<R>>, record: &csv::ByteRecord) -> u64 {
    record
        .position()
        .map_or(0, |p| reader.get_mut().line_at(p.byte()))
}

/// Whether a field holds what looks like rows of the file: a line after its first with as
/// many commas as a row of `columns` fields has. A quoted note may span lines in CSV, but one
/// that holds rows is a quote left open, and the rows in it would be lost.
fn holds_rows(field: &[u8], columns: usize) -> bool {
    let needed = columns.saturating_sub(1).max(1);
    field
        .split(|&b| b == b'\n' || b == b'\r')
        .skip(1)
        .any(|line| line.iter().filter(|&&b| b == b',').count() >= needed)
}

/// Validate the header; returns the index of the time column.
///
/// Only the columns that are read must be unique: other columns are ignored, so two notes
/// both named `flag`, or a spreadsheet's unnamed index column, are no error (review: they
/// refused the file, against "every other column is ignored").
fn check_header(names: &[String]) -> Result<usize, MotionCsvError> {
    // A set, not a scan of the names before each: a header of 300 000 columns took minutes.
    let mut seen = std::collections::HashSet::with_capacity(names.len());
    for name in names
        .iter()
        .filter(|n| n.as_str() == TIME_COLUMN || is_read_column(n))
    {
        if !seen.insert(name.as_str()) {
            return Err(MotionCsvError::DuplicateColumn {
                column: name.clone(),
            });
        }
    }
    names.iter().position(|n| n == TIME_COLUMN).ok_or_else(|| {
        // At most the first few names: a header of garbage can be a megabyte long.
        const SHOWN: usize = 12;
        let mut columns = names
            .iter()
            .take(SHOWN)
            .map(|n| shown_name(n))
            .collect::<Vec<_>>()
            .join(", ");
        if names.len() > SHOWN {
            columns.push_str(&format!(", ... ({} columns)", names.len()));
        }
        MotionCsvError::MissingTime { columns }
    })
}

/// A column name as an error shows it: on one line, cut short.
fn shown_name(name: &str) -> String {
    match shown_head(name) {
        (head, None) => head,
        (head, Some(_)) => format!("{head}..."),
    }
}

/// What a stamp beyond [`MAX_ABS_TIME_S`] looks like: today's epoch time in milliseconds,
/// microseconds or nanoseconds (as many loggers write it; the size tells the unit), or a
/// corrupt stamp (review: epoch milliseconds were called corrupt without the hint).
fn time_unit_hint(t: f64) -> String {
    // Beyond the bound no stamp is epoch seconds: a unit found is one of the smaller ones.
    crate::resample::epoch_unit(t).map_or("a corrupt stamp?".to_string(), |(per_s, unit)| {
        format!("epoch time in {unit}? time_s is in seconds: divide the column by {per_s:.0}")
    })
}

/// A number as an error shows it: in scientific notation when very large or small, so that a
/// time of 1e300 is not three hundred digits in a one-line message.
fn shown_number(x: f64) -> String {
    shipcast_wire::shown::number(x)
}

/// A field as an error shows it: on one line, and cut short. A stray quote makes the CSV
/// reader take the rest of the file, newlines included, as one field; the message must stay
/// one readable line.
fn shown_field(text: &str) -> String {
    match shown_head(text) {
        (head, None) => head,
        (head, Some(count)) => format!("{head}... ({count} characters: an unclosed quote?)"),
    }
}

/// The first 40 characters of `text`, escaped onto one line, and its length in characters
/// if it had more.
fn shown_head(text: &str) -> (String, Option<usize>) {
    const MAX_CHARS: usize = 40;
    let head: String = text.chars().take(MAX_CHARS).collect();
    let head = head.escape_debug().to_string();
    let count = text.chars().count();
    (head, (count > MAX_CHARS).then_some(count))
}

fn parse_value(text: &str, line: u64, column: &str) -> Result<f64, MotionCsvError> {
    if text.is_empty() {
        return Err(MotionCsvError::Missing {
            line,
            column: column.to_string(),
        });
    }
    let value: f64 = text.parse().map_err(|_| MotionCsvError::NotANumber {
        line,
        column: column.to_string(),
        text: shown_field(text),
    })?;
    if !value.is_finite() {
        return Err(MotionCsvError::NonFinite {
            line,
            column: column.to_string(),
            text: shown_field(text),
        });
    }
    Ok(value)
}

/// Streaming writer of the motion CSV: `time_s` first, then the given columns.
///
/// Rows are checked as they are written (width, finite values, increasing time), so a file this
/// writer finishes is always readable by [`MotionData::read`]. Writing a row does not allocate.
pub struct MotionCsvWriter<W: Write> {
    out: W,
    columns: Vec<String>,
    previous_time: Option<f64>,
    rows: u64,
}

impl MotionCsvWriter<BufWriter<File>> {
    /// Create (or truncate) `path` and write the header.
    pub fn create(
        path: impl AsRef<Path>,
        columns: &[impl AsRef<str>],
    ) -> Result<Self, MotionCsvError> {
        Self::new(BufWriter::new(File::create(path)?), columns)
    }
}

impl<W: Write> MotionCsvWriter<W> {
    /// Write the header to `out`. `columns` are the names after `time_s`, e.g.
    /// `Dof::ALL.map(Dof::csv_column)` plus extras such as `wave_m`.
    pub fn new(mut out: W, columns: &[impl AsRef<str>]) -> Result<Self, MotionCsvError> {
        let columns: Vec<String> = columns.iter().map(|c| c.as_ref().to_string()).collect();
        let mut names = vec![TIME_COLUMN.to_string()];
        for name in &columns {
            if name.is_empty() || name.contains([',', '"', '\n', '\r']) || name != name.trim() {
                return Err(MotionCsvError::BadColumnName(name.clone()));
            }
            if names.contains(name) {
                return Err(MotionCsvError::DuplicateColumn {
                    column: name.clone(),
                });
            }
            names.push(name.clone());
        }
        writeln!(out, "{}", names.join(","))?;
        Ok(Self {
            out,
            columns,
            previous_time: None,
            rows: 0,
        })
    }

    /// Write one row: the time and one value per column, in header order.
    pub fn write_row(&mut self, time: f64, values: &[f64]) -> Result<(), MotionCsvError> {
        let row = self.rows + 1;
        if values.len() != self.columns.len() {
            return Err(MotionCsvError::RowWidth {
                row,
                expected: self.columns.len(),
                got: values.len(),
            });
        }
        if !time.is_finite() {
            return Err(MotionCsvError::WriteNonFinite {
                row,
                column: TIME_COLUMN.to_string(),
                value: time,
            });
        }
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(MotionCsvError::WriteNonFinite {
                row,
                column: self.columns[bad].clone(),
                value: values[bad],
            });
        }
        // Regression (review): the simulator wrote heave of 8.8e201 (an RAO table of 1e200)
        // into a file that every reader then refused.
        let beyond = |v: f64, limit: f64, column: &str| MotionCsvError::WriteOutOfRange {
            row,
            column: column.to_string(),
            value: v,
            limit,
        };
        if time.abs() > MAX_ABS_TIME_S {
            return Err(beyond(time, MAX_ABS_TIME_S, TIME_COLUMN));
        }
        if let Some(bad) = values.iter().position(|v| v.abs() > MAX_ABS_MOTION) {
            return Err(beyond(values[bad], MAX_ABS_MOTION, &self.columns[bad]));
        }
        if let Some(previous) = self.previous_time {
            if time <= previous {
                return Err(MotionCsvError::WriteTimeNotIncreasing {
                    row,
                    time,
                    previous,
                });
            }
        }
        // `{}` prints the shortest decimal that parses back to the same f64.
        write!(self.out, "{time}")?;
        for v in values {
            write!(self.out, ",{v}")?;
        }
        writeln!(self.out)?;
        self.previous_time = Some(time);
        self.rows = row;
        Ok(())
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Flush and return the underlying writer.
    pub fn finish(mut self) -> Result<W, MotionCsvError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read_str(text: &str) -> Result<MotionData, MotionCsvError> {
        MotionData::read(text.as_bytes())
    }

    fn err(text: &str) -> String {
        read_str(text).unwrap_err().to_string()
    }

    #[test]
    fn reads_subset_in_any_order_with_extras() {
        let data =
            read_str("heave_m, time_s ,wave_m,roll_rad\n1.5,0,2,-0.1\n-2e-3,0.5,3,0.25\n").unwrap();
        assert_eq!(data.time, vec![0.0, 0.5]);
        assert_eq!(data.dof(Dof::Heave).unwrap(), &[1.5, -2e-3]);
        assert_eq!(data.dof(Dof::Roll).unwrap(), &[-0.1, 0.25]);
        assert_eq!(data.dofs(), vec![Dof::Heave, Dof::Roll]);
        let extras: Vec<&str> = data.extras().map(|c| c.name.as_str()).collect();
        assert_eq!(extras, vec!["wave_m"]);
        assert_eq!(data.column("wave_m").unwrap(), &[2.0, 3.0]);
        let absent = data.dof(Dof::Pitch).unwrap_err().to_string();
        assert!(absent.contains("pitch_rad"), "{absent}");
        assert!(absent.contains("heave_m, time_s") || absent.contains("time_s, heave_m"));
    }

    /// Regression (review): a misnamed motion column, ignored as any other, vanished from
    /// the error that a motion column is missing.
    #[test]
    fn a_missing_motion_column_is_told_with_the_columns_not_read() {
        let data = read_str("time_s,heave,roll_deg,wave_m\n0,1,2,3\n0.5,2,3,4\n").unwrap();
        assert_eq!(data.ignored, ["heave", "roll_deg"]);
        assert_eq!(
            data.dof(Dof::Heave).unwrap_err().to_string(),
            "no 'heave_m' column for heave (columns: time_s, wave_m; not read: heave, roll_deg)"
        );
        let plain = read_str("time_s,heave_m\n0,1\n0.5,2\n").unwrap();
        assert!(plain.ignored.is_empty());
        assert_eq!(
            plain.dof(Dof::Roll).unwrap_err().to_string(),
            "no 'roll_rad' column for roll (columns: time_s, heave_m)"
        );
    }

    /// Regression (review): with CRLF line ends every error named the line before the bad one,
    /// and with bare CR line ends every error said line 1 (the CSV reader's own count). The
    /// same file with any line end names the same line, also after a quoted field that holds
    /// a line break and across reads that split a CRLF.
    #[test]
    fn errors_name_the_same_line_whatever_the_line_ends() {
        let lines = [
            "time_s,heave_m,note",
            "0,1,\"two{NL}lines\"",
            "0.5,2,x",
            "1.0,abc,y",
        ];
        for end in ["\n", "\r\n", "\r"] {
            let text = lines.join(end).replace("{NL}", end) + end;
            let e = err(&text);
            assert!(
                e.contains("line 5, column 'heave_m': 'abc' is not a number"),
                "{end:?}: {e}"
            );
            // One byte per read: every CRLF is split between two reads.
            let bytes = text.into_bytes();
            let one_at_a_time = ByteAtATime(&bytes);
            let e = MotionData::read(one_at_a_time).unwrap_err().to_string();
            assert!(
                e.contains("line 5, column 'heave_m'"),
                "{end:?} byte by byte: {e}"
            );
        }
        let truncated = "time_s,heave_m\r\n0,1\r\n0.5\r\n";
        assert!(
            err(truncated).contains("line 3: truncated row"),
            "{}",
            err(truncated)
        );
    }

    /// Regression (review): one Latin-1 'café' in a note column, which is not read, refused
    /// the whole file as malformed CSV naming "field 8". Bytes that are not UTF-8 are an error
    /// only in a column that is read, and a UTF-16 file is told as such.
    #[test]
    fn only_the_columns_read_must_be_text() {
        let latin1 = b"time_s,heave_m,note\n0,1,caf\xe9\n0.5,2,ok\n".to_vec();
        let data = MotionData::read(&latin1[..]).unwrap();
        assert_eq!(data.dof(Dof::Heave).unwrap(), &[1.0, 2.0]);
        let bad = b"time_s,heave_m,note\n0,1,a\n0.5,\xe92,b\n".to_vec();
        let e = MotionData::read(&bad[..]).unwrap_err().to_string();
        assert_eq!(
            e,
            "line 3, column 'heave_m': not UTF-8 text (a number is ASCII)"
        );
        let utf16: Vec<u8> = [0xFF, 0xFE]
            .into_iter()
            .chain(
                "time_s,heave_m\n0,1\n"
                    .encode_utf16()
                    .flat_map(u16::to_le_bytes),
            )
            .collect();
        let e = MotionData::read(&utf16[..]).unwrap_err().to_string();
        assert!(e.contains("UTF-16"), "{e}");
    }

    /// A reader that hands out one byte per read.
    struct ByteAtATime<'a>(&'a [u8]);

    impl Read for ByteAtATime<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            match (self.0.split_first(), buf.first_mut()) {
                (Some((&b, rest)), Some(slot)) => {
                    *slot = b;
                    self.0 = rest;
                    Ok(1)
                }
                _ => Ok(0),
            }
        }
    }

    #[test]
    fn errors_name_line_and_column() {
        let header = "time_s,heave_m,pitch_rad\n";
        let cases = [
            ("", "empty file"),
            (header, "no data rows"),
            ("heave_m\n1\n", "no 'time_s' column"),
            ("time_s,heave_m,heave_m\n0,1,1\n", "'heave_m' appears twice"),
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n1,,2\n",
                "line 3, column 'heave_m': missing value",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,1,abc\n",
                "line 2, column 'pitch_rad': 'abc' is not a number",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n1,NaN,2\n",
                "line 3, column 'heave_m': non-finite value 'NaN'",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,inf,2\n",
                "line 2, column 'heave_m': non-finite",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n1,2\n",
                "line 3: truncated row: 2 of 3 fields",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,1,2,3\n",
                "line 2: 4 fields, the header has 3",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n1,1,2\n1,1,2\n",
                "line 4, column 'time_s': time 1 does not increase",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n-1,1,2\n",
                "line 3, column 'time_s'",
            ),
            (
                "time_s,heave_m,pitch_rad\n1e11,1,2\n0.5,1,2\n",
                "time 0.5 does not increase (previous row: 100000000000)",
            ),
            // Regression (review): a corrupt last stamp of 1e300 was read, and the gap before
            // it counted as 2^64 - 2 missing samples.
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n0.5,1,2\n1e300,1,2\n",
                "line 4, column 'time_s': time '1e300' is beyond +-1e12 s, more than 30000 years even from the Unix epoch: a corrupt stamp?",
            ),
            (
                "time_s,heave_m,pitch_rad\n-1e13,1,2\n0.5,1,2\n",
                "line 2, column 'time_s': time '-1e13' is beyond",
            ),
            // Regression (review): today's epoch milliseconds were called a corrupt stamp.
            (
                "time_s,heave_m,pitch_rad\n1700000000000.0,1,2\n1700000000125.0,1,2\n",
                "epoch time in milliseconds? time_s is in seconds: divide the column by 1000",
            ),
            (
                "time_s,heave_m,pitch_rad\n1.7e18,1,2\n1.7000000001e18,1,2\n",
                "epoch time in nanoseconds? time_s is in seconds: divide the column by 1000000000",
            ),
            // Regression: epoch time stamps (1.7e9 s) came out as 1.7330000005e9, hard to
            // find in the file: they print as written.
            (
                "time_s,heave_m,pitch_rad\n1733000000.5,1,2\n1733000000.25,1,2\n",
                "time 1733000000.25 does not increase (previous row: 1733000000.5)",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n1,1e200,2\n",
                "line 3, column 'heave_m': value '1e200' is beyond +-1e6",
            ),
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n1,1,-1000000.5\n",
                "line 3, column 'pitch_rad': value '-1000000.5' is beyond",
            ),
            // Regression: a file cut inside its last field parsed the rest as a number
            // (-2.074122e-03 cut to -2.074122, a thousand times too large).
            (
                "time_s,heave_m,pitch_rad\n0,1,2\n0.5,1,-2.074122",
                "line 3: the last row does not end with a line break",
            ),
        ];
        for (text, expected) in cases {
            let message = err(text);
            assert!(
                message.contains(expected),
                "{text:?}: got '{message}', want '{expected}'"
            );
            assert!(!message.contains('\n'), "multi-line error: {message}");
        }
        assert!(read_str(&format!("{header}0,1,2\n")).is_ok());
        assert!(read_str(&format!("{header}0,1,2\r\n")).is_ok());
        // Epoch seconds are a time, not a motion; a value at the bound is still a value.
        let epoch = read_str("time_s,heave_m\n1764860000,1000000\n1764860000.5,-1e6\n").unwrap();
        assert_eq!(epoch.time, vec![1764860000.0, 1764860000.5]);
        assert_eq!(epoch.dof(Dof::Heave).unwrap(), &[1e6, -1e6]);
        // An extra column other than wave_m is not a motion: ignored whatever it holds.
        // Regression (review): a text, empty or NaN cell in one refused the whole record.
        let stamped = read_str(
            "time_s,heave_m,stamp_ns,utc,note\n\
             0,1,1764860000000000000,2024-01-01T00:00:00,\n\
             0.5,2,NaN,2024-01-01T00:00:00.5,gps lost\n",
        )
        .unwrap();
        assert_eq!(stamped.dof(Dof::Heave).unwrap(), &[1.0, 2.0]);
        assert_eq!(stamped.time, vec![0.0, 0.5]);
        assert!(stamped.column("stamp_ns").is_none() && stamped.column("utc").is_none());
        assert_eq!(stamped.extras().count(), 0);
        // The row's shape is still the header's.
        assert!(err("time_s,heave_m,note\n0,1\n").contains("truncated row: 2 of 3 fields"));
        assert!(err("time_s,wave_m\n0,2e6\n").contains("column 'wave_m'"));
        // Bare CR line ends over more than the 1 MiB a line may have are lines, not one.
        let mut cr = String::from("time_s,heave_m\r");
        for i in 0..100_000 {
            cr.push_str(&format!("{i},0.125\r"));
        }
        assert!(cr.len() > 1 << 20);
        assert_eq!(read_str(&cr).unwrap().len(), 100_000);
        // Regression: a line without end (`--input /dev/zero`) was buffered until the system
        // killed the process; a megabyte of header without `time_s` was echoed in full.
        let zeros = std::io::Read::take(std::io::repeat(0), 64 << 20);
        let e = MotionData::read(zeros).unwrap_err().to_string();
        assert!(e.contains("a line longer than 1 MiB"), "{e}");
        let junk: Vec<String> = (0..50_000).map(|i| format!("junk{i}")).collect();
        let e = err(&format!("{}\n1\n", junk.join(",")));
        assert!(
            e.contains("no 'time_s' column") && e.contains("(50000 columns)"),
            "{e}"
        );
        assert!(e.len() < 300, "{} characters", e.len());
        // A duplicate far into a wide header is still found (and quickly: the names are
        // checked against a set, not each against all before it).
        let wide: Vec<String> = (0..100_000).map(|i| format!("c{i}")).collect();
        let message = err(&format!("time_s,heave_m,{},heave_m\n", wide.join(",")));
        assert!(message.contains("'heave_m' appears twice"), "{message}");
        // Columns that are not read may repeat a name or have none (a spreadsheet's index).
        let data = read_str(",time_s,flag,heave_m,flag\n0,0,a,1,b\n1,0.5,c,2,d\n").unwrap();
        assert_eq!(data.dof(Dof::Heave).unwrap(), &[1.0, 2.0]);
        assert_eq!(data.ignored, ["", "flag", "flag"]);
        // Regression: a stray quote made the rest of the file one field, and the whole of it
        // (newlines included) the error message.
        let mut quoted = format!("{header}0,1,2\n1,2,\"3\n");
        for i in 2..1200 {
            quoted.push_str(&format!("{i},1,2\n"));
        }
        let message = err(&quoted);
        assert!(!message.contains('\n'), "multi-line error: {message}");
        assert!(
            message.len() < 200,
            "{} characters: {message}",
            message.len()
        );
        assert!(
            message.contains("line 3, column 'pitch_rad': '3\\n2,1,2\\n3,1,2"),
            "{message}"
        );
        assert!(message.contains("an unclosed quote?"), "{message}");
        // Regression: in a column that is not read (a note), the rows after a stray quote were
        // taken as part of the note and lost without a word; in the header, the error said
        // there were no data rows.
        let mut noted = String::from("time_s,heave_m,note\n0,1,ok\n0.5,2,\"sensor reset\n");
        for i in 2..1200 {
            noted.push_str(&format!("{},1,ok\n", f64::from(i) * 0.5));
        }
        let message = err(&noted);
        assert_eq!(
            message,
            "line 3, column 'note': a quoted field holds what look like rows of the file, which would be lost in it (an unclosed quote?)"
        );
        let message = err("time_s,heave_m,\"note\n0,1,ok\n0.5,2,ok\n");
        assert!(
            message.starts_with("line 1, column 'note\\n0,1,ok"),
            "{message}"
        );
        assert!(message.contains("(an unclosed quote?)"), "{message}");
        // A quoted note on one line is still just ignored.
        let data = read_str("time_s,heave_m,note\n0,1,\"a, b\"\n0.5,2,ok\n").unwrap();
        assert_eq!(data.dof(Dof::Heave).unwrap(), &[1.0, 2.0]);
    }

    #[test]
    fn writer_round_trips_exact_values() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.csv");
        let columns: Vec<&str> = Dof::ALL
            .iter()
            .map(|d| d.csv_column())
            .chain(["wave_m"])
            .collect();
        let mut writer = MotionCsvWriter::create(&path, &columns).unwrap();
        let mut rows = Vec::new();
        for i in 0..200 {
            let t = i as f64 * 0.125;
            let row: Vec<f64> = (0..7)
                .map(|c| (t * (c as f64 + 0.3)).sin() * 10f64.powi(c - 3) / 3.0)
                .collect();
            writer.write_row(t, &row).unwrap();
            rows.push(row);
        }
        assert_eq!(writer.rows(), 200);
        writer.finish().unwrap();

        let data = MotionData::read_path(&path).unwrap();
        assert_eq!(data.len(), 200);
        assert_eq!(data.dofs(), Dof::ALL.to_vec());
        for (c, column) in data.columns.iter().enumerate() {
            assert_eq!(column.name, columns[c]);
            for (i, row) in rows.iter().enumerate() {
                assert_eq!(column.values[i].to_bits(), row[c].to_bits());
            }
        }
        // And the record writes itself back identically.
        let again = dir.path().join("again.csv");
        data.write_path(&again).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            std::fs::read_to_string(&again).unwrap()
        );
    }

    #[test]
    fn writer_rejects_what_the_reader_would_reject() {
        let mut w = MotionCsvWriter::new(Vec::new(), &["heave_m"]).unwrap();
        w.write_row(0.0, &[1.0]).unwrap();
        assert!(matches!(
            w.write_row(1.0, &[1.0, 2.0]),
            Err(MotionCsvError::RowWidth { .. })
        ));
        assert!(matches!(
            w.write_row(1.0, &[f64::NAN]),
            Err(MotionCsvError::WriteNonFinite { .. })
        ));
        assert!(matches!(
            w.write_row(0.0, &[1.0]),
            Err(MotionCsvError::WriteTimeNotIncreasing { .. })
        ));
        // Regression (review): values beyond what the reader takes back were written.
        let e = w.write_row(1.0, &[-8.8e201]).unwrap_err().to_string();
        assert_eq!(
            e,
            "row 2: value -8.8e201 in column 'heave_m' is beyond +-1e6, which no reader takes back"
        );
        assert!(matches!(
            w.write_row(1e300, &[1.0]),
            Err(MotionCsvError::WriteOutOfRange { .. })
        ));
        w.write_row(0.5, &[-1.0]).unwrap();
        let bytes = w.finish().unwrap();
        assert_eq!(
            String::from_utf8(bytes).unwrap(),
            "time_s,heave_m\n0,1\n0.5,-1\n"
        );
        assert!(MotionCsvWriter::new(Vec::new(), &["a,b"]).is_err());
        assert!(MotionCsvWriter::new(Vec::new(), &["time_s"]).is_err());
    }
}
