//! The ship-motion simulator: irregular seas from wave spectra, ship responses from RAOs, and
//! streaming 6-DOF time series with their exact statistics.
//!
//! - [`spectrum`]: JONSWAP (DNV) and ITTC spectra.
//! - [`spreading`]: cos^2 or long-crested seas.
//! - [`sea`]: the wave components drawn from a seed.
//! - [`hull`], [`rao`], [`waterline`], [`rao_table`]: closed-form RAOs of a hull (with the
//!   waterline integrals they use), or a loaded RAO table; [`rao_reference`]: reference
//!   curves (a boundary-element solution) to validate them against.
//! - [`scenario`]: the `paper` and ss3..ss6 presets and [`SimConfig`].
//! - [`motion`]: [`ShipMotion`], sampled at any instant or streamed at a fixed rate.
//! - [`station`]: a second vessel in the same sea, at its own position and heading.
//! - [`changes`]: [`ChangingMotion`], a course change and/or a sea-state change in a record.
//! - [`measured`]: the ship's response to a measured wave-elevation record.
//! - [`autocorr`]: exact variance, autocorrelation and encounter spectra of the record.
//! - [`plot`]: an SVG figure of the spectra and the first minute of motion; [`rao_plot`]: RAO
//!   curves compared per DOF.
//!
//! Axes and signs are those of [`rao`] (x forward, y starboard, z down); wave elevation is
//! positive up.

pub mod autocorr;
pub mod changes;
pub mod hull;
pub mod measured;
pub mod motion;
pub mod plot;
pub mod rao;
pub mod rao_plot;
pub mod rao_reference;
pub mod rao_table;
pub mod scenario;
pub mod sea;
pub mod spectrum;
pub mod spreading;
pub mod station;
pub mod waterline;

pub use autocorr::Channel;
pub use changes::{ChangingMotion, CourseChange, SeaChange};
pub use hull::Hull;
pub use measured::{split_segments, ElevationSegment, SegmentResponse};
pub use motion::{build_rao, MotionPoint, MotionStream, ShipMotion};
pub use rao::{encounter_omega, ClosedFormRao, Rao, Response};
pub use rao_table::{RaoTable, ScaledRaoTable};
pub use scenario::{RaoSpec, Scenario, SimConfig, KNOT_MPS};
pub use sea::{Components, WaveComponent};
pub use spectrum::{Spectrum, SpectrumKind};
pub use spreading::Spreading;
pub use station::Station;

use std::path::{Path, PathBuf};

/// Acceleration of gravity [m/s^2].
pub const G: f64 = 9.81;

/// Why a simulation could not be set up.
///
/// A variant with an underlying error keeps it as its `source` and leaves it out of its own
/// message, so the binary's `{:#}` chain prints each cause once.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A parameter is out of its physical range or unknown.
    #[error("invalid simulation setting: {0}")]
    Config(String),
    /// A measured record that cannot be used as it is (an uneven step, too few samples).
    #[error("elevation record: {0}")]
    Record(String),
    /// An RAO table file could not be opened.
    #[error("RAO table: cannot open {}", path.display())]
    TableOpen {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// An RAO table's CSV could not be read (an I/O error, bad UTF-8, a row of the wrong
    /// length); `line` is `None` for the header.
    #[error("RAO table: {table}: {}", line.map_or("header".to_string(), |l| format!("line {l}")))]
    TableCsv {
        table: String,
        line: Option<usize>,
        #[source]
        source: csv::Error,
    },
    /// An RAO table reads as CSV but its content is wrong (a column, a value, the grid).
    #[error("RAO table: {table}: {problem}")]
    TableContent { table: String, problem: String },
    /// A figure could not be drawn or written.
    #[error("plot {}: cannot draw or write the figure", path.display())]
    Plot {
        path: PathBuf,
        #[source]
        source: plotters::drawing::DrawingAreaErrorKind<std::io::Error>,
    },
    /// A figure was asked for without anything to draw.
    #[error("plot {}: {problem}", path.display())]
    NothingToPlot { path: PathBuf, problem: String },
}

impl SimError {
    /// What is wrong in the content of the table `table`.
    pub(crate) fn table(table: &str, problem: String) -> Self {
        SimError::TableContent {
            table: table.to_string(),
            problem,
        }
    }

    /// The table `table` is not readable CSV at `line` (`None`: the header).
    pub(crate) fn table_csv(table: &str, line: Option<usize>, source: csv::Error) -> Self {
        SimError::TableCsv {
            table: table.to_string(),
            line,
            source,
        }
    }

    /// Drawing or writing the figure `path` failed.
    pub(crate) fn plot(
        path: &Path,
    ) -> impl Fn(plotters::drawing::DrawingAreaErrorKind<std::io::Error>) -> Self + Copy + '_ {
        move |source| SimError::Plot {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Parses one of a fixed set of lower-case names (CLI and config values).
pub(crate) fn parse_named<T: Copy>(
    text: &str,
    what: &str,
    names: &[(&str, T)],
) -> Result<T, SimError> {
    let lower = text.trim().to_ascii_lowercase();
    names
        .iter()
        .find(|(n, _)| *n == lower)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let all: Vec<&str> = names.iter().map(|(n, _)| *n).collect();
            SimError::Config(format!(
                "unknown {what} '{}' (expected {})",
                text.trim(),
                all.join(", ")
            ))
        })
}
