//! `shipcast simulate`: draws a seeded irregular sea (or reads a measured elevation record),
//! passes it through the ship's RAOs and writes the 6-DOF motion (plus the wave elevation at
//! the CG) as a motion CSV. Optional course and sea-state changes make the record
//! non-stationary.

use anyhow::Context;
use shipcast_series::motion_csv::MotionCsvWriter;
use shipcast_sim::plot::plot_overview;
use shipcast_sim::{
    ChangingMotion, Channel, CourseChange, MotionPoint, SeaChange, ShipMotion, Station,
};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Instant;

mod config;
mod measured;
pub use config::{Config, Record};
use measured::run_measured;

/// Shown after the options in `--help`.
const AFTER_HELP: &str = "\
Measured sea (--elevation FILE): FILE is a CSV with columns time_s,wave_m (other columns are
ignored); NaN in wave_m or a time jump above 1.5 sample intervals is a gap. Each NaN-free
segment is Fourier-analysed (mean removed, ends tapered), every Fourier line is taken as a
long-crested wave from --heading-deg with the elevation measured at the centre of gravity, and
the linear response is summed at --rate (band-limited interpolation). The first and last
--edge-s seconds of every segment are not written, so a gap becomes a longer time jump in the
output, reported in the log. At zero speed this is exact for that model; at speed the ship is
taken to cross the long-crested field whose fixed-point record is the segment, each line met
at its encounter frequency (an approximation; wave_m is then the elevation at the moving CG).
With --vessel-x-m/--vessel-y-m/--vessel-heading-offset-deg the vessel is that far from the CG
the record describes (the reference vessel): every line reaches it shifted by its wave number
times the distance along its travel, from the direction seen from its own bow.
scripts/fetch_wafo.py fetches two measured records (non-commercial licence, never commit them).

Non-stationary records: --course-change-s T --new-heading-deg D [--turn-s R] turns the ship
(same wave field) so that the mean relative wave direction ramps linearly from --heading-deg to
D over R s from record time T, through every direction in between as written (from 170 to -170
the ship turns 340 deg through following seas; give 190 for the 20 deg turn through head
seas). --sea-change-s T --new-hs M --new-tp S [--ramp-s R] cross-fades (power-preserving) to
an independent sea (seed + 1, the same spectrum; a JONSWAP takes the DNV gamma of the new Hs
and Tp) of Hs M and Tp S over R s from T. Both may be combined. Before T the record equals the stationary simulation; the producer
uses such a record through `simulate --out F.csv` then `producer --input F.csv`.

Two vessels in one sea: run simulate twice with the same sea options and seed, the second time
with --vessel-x-m X --vessel-y-m Y [--vessel-heading-offset-deg D] [--hull-length L]: that vessel keeps
station X m forward and Y m to starboard of the first, its bow D deg to starboard of the first's
heading, and meets the same wave components, each phase-shifted by k (X cos b + Y sin b) (b its
direction relative to the first vessel) and from the direction b - D (docs/two_ships.md).";

#[derive(clap::Args, Debug)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// Named scenario: paper (Hs 3.05 m, Tp 9.7 s), ss3, ss4, ss5, ss6 (Bales 1983); all at
    /// 11 kn with waves 15 deg off the bow unless overridden.
    #[arg(long, default_value = "paper")]
    pub scenario: String,
    /// Significant wave height [m] (overrides the scenario).
    #[arg(long, allow_negative_numbers = true)]
    pub hs: Option<f64>,
    /// Peak period [s] (overrides the scenario).
    #[arg(long, allow_negative_numbers = true)]
    pub tp: Option<f64>,
    /// Spectrum: jonswap (DNV, gamma from Tp/sqrt(Hs) unless --gamma) or ittc.
    #[arg(long, default_value = "jonswap")]
    pub spectrum: String,
    /// JONSWAP peak enhancement factor (--spectrum jonswap only).
    #[arg(long, allow_negative_numbers = true)]
    pub gamma: Option<f64>,
    /// Ship speed [kn].
    #[arg(long = "speed-kn", allow_negative_numbers = true)]
    pub speed_kn: Option<f64>,
    /// Mean wave direction relative to the ship [deg], where the waves come from: 180 = head
    /// seas, 0 = following seas, 90 = beam seas from port (travelling to starboard).
    #[arg(long = "heading-deg", allow_negative_numbers = true)]
    pub heading_deg: Option<f64>,
    /// A line spectrum of N components on a fixed frequency grid (default: >= 1000 components
    /// at random frequencies, which no finite linear predictor extrapolates exactly).
    #[arg(long)]
    pub components: Option<usize>,
    /// Directional spreading: cos2 (+-90 deg) or none (long-crested).
    #[arg(long, default_value = "cos2")]
    pub spreading: String,
    /// Seed of the random phases, frequencies and directions.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Length of the record [s].
    #[arg(long, default_value_t = 3600.0, allow_negative_numbers = true)]
    pub duration: f64,
    /// Sample rate [Hz], at least 0.2 (a step of at most 5 s, the longest eval and replay take)
    #[arg(long, default_value_t = 8.0, allow_negative_numbers = true)]
    pub rate: f64,
    /// Output motion CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// RAO table CSV (columns speed_mps,heading_deg,omega_rad_s,dof,amplitude,phase_rad; one row
    /// per DOF of a full speed x heading x frequency grid, 180 deg = head seas) instead of the
    /// closed form.
    #[arg(long = "rao-table")]
    pub rao_table: Option<PathBuf>,
    /// Ship length the RAO table was computed for [m] (needed with --hull-length).
    #[arg(long = "rao-table-length", allow_negative_numbers = true)]
    pub rao_table_length: Option<f64>,
    /// Length of the simulated hull [m]: scales the default DTMB 5415 hull, or Froude-scales
    /// the RAO table from --rao-table-length.
    #[arg(long = "hull-length", allow_negative_numbers = true)]
    pub hull_length: Option<f64>,
    /// Also draw an SVG figure of the spectra and the first minute of motion.
    #[arg(long, conflicts_with_all = ["elevation", "course_change_s", "sea_change_s"])]
    pub plot: Option<PathBuf>,
    /// Drive the RAOs with this measured wave-elevation CSV (time_s,wave_m) instead of a
    /// simulated sea: long-crested waves from --heading-deg, elevation at the CG (see below).
    #[arg(long, conflicts_with_all = ["scenario", "hs", "tp", "gamma", "components", "spreading", "spectrum", "seed", "duration"])]
    pub elevation: Option<PathBuf>,
    /// With --elevation: seconds at each end of every segment that are tapered (outer half)
    /// and not written [default: 120].
    #[arg(long = "edge-s", allow_negative_numbers = true, requires = "elevation")]
    pub edge_s: Option<f64>,
    /// Record time [s] at which the ship starts turning (needs --new-heading-deg).
    #[arg(
        long = "course-change-s",
        requires = "new_heading_deg",
        conflicts_with = "elevation",
        allow_negative_numbers = true
    )]
    pub course_change_s: Option<f64>,
    /// Mean relative wave direction after the turn [deg] (as --heading-deg: 90 = beam seas
    /// from port).
    #[arg(
        long = "new-heading-deg",
        requires = "course_change_s",
        allow_negative_numbers = true
    )]
    pub new_heading_deg: Option<f64>,
    /// Duration of the turn [s] [default: 60].
    #[arg(long = "turn-s", allow_negative_numbers = true)]
    pub turn_s: Option<f64>,
    /// Record time [s] at which the sea state starts changing (needs --new-hs and --new-tp).
    #[arg(long = "sea-change-s", requires_all = ["new_hs", "new_tp"], conflicts_with = "elevation", allow_negative_numbers = true)]
    pub sea_change_s: Option<f64>,
    /// Significant wave height of the new sea [m].
    #[arg(
        long = "new-hs",
        requires = "sea_change_s",
        allow_negative_numbers = true
    )]
    pub new_hs: Option<f64>,
    /// Peak period of the new sea [s].
    #[arg(
        long = "new-tp",
        requires = "sea_change_s",
        allow_negative_numbers = true
    )]
    pub new_tp: Option<f64>,
    /// Duration of the sea-state cross-fade [s] [default: 300].
    #[arg(long = "ramp-s", allow_negative_numbers = true)]
    pub ramp_s: Option<f64>,
    /// Simulate a second vessel of the same sea (same seed, or the same measured record;
    /// --heading-deg relative to the reference vessel) this far forward of the reference
    /// vessel's centre of gravity [m], keeping station with it.
    #[arg(
        long = "vessel-x-m",
        default_value_t = 0.0,
        allow_negative_numbers = true,
        conflicts_with_all = ["course_change_s", "sea_change_s"]
    )]
    pub vessel_x_m: f64,
    /// ... and this far to starboard of it [m].
    #[arg(
        long = "vessel-y-m",
        default_value_t = 0.0,
        allow_negative_numbers = true,
        conflicts_with_all = ["course_change_s", "sea_change_s"]
    )]
    pub vessel_y_m: f64,
    /// Heading of the simulated vessel: its bow turned this many degrees to starboard of the
    /// reference vessel's heading.
    #[arg(
        long = "vessel-heading-offset-deg",
        default_value_t = 0.0,
        allow_negative_numbers = true,
        conflicts_with_all = ["course_change_s", "sea_change_s"]
    )]
    pub vessel_heading_offset_deg: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = Config::try_from(args)?;
    match &config.record {
        Record::Measured {
            elevation,
            edge_s,
            station,
        } => run_measured(&config, elevation, *edge_s, station),
        Record::Changing {
            duration_s,
            course,
            sea,
        } => run_changing(&config, *duration_s, *course, *sea),
        Record::Stationary {
            duration_s,
            station,
        } => run_stationary(&config, *duration_s, *station),
    }
}

/// The output file, row count and per-channel sums of squares of a record being written.
/// Dropped before [`Self::finish`] (an error on the way), a regular file is removed: a record
/// cut short must not be taken for a whole one.
pub(crate) struct RecordOut {
    writer: Option<MotionCsvWriter<BufWriter<File>>>,
    path: PathBuf,
    /// Whether `path` is a regular file (not a pipe or a device, which is never removed).
    regular: bool,
    values: [f64; 7],
    sum_sq: [f64; 7],
    pub(crate) rows: u64,
}

impl RecordOut {
    pub(crate) fn create(path: &Path) -> anyhow::Result<Self> {
        let columns: Vec<&str> = Channel::ALL.iter().map(|c| c.column()).collect();
        let writer = MotionCsvWriter::create(path, &columns)
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(RecordOut {
            writer: Some(writer),
            path: path.to_path_buf(),
            // The path itself, not what a symbolic link names: a link (`/dev/stdout`, or one a
            // user made to a file) is never removed (review: both were unlinked).
            regular: path.symlink_metadata().is_ok_and(|m| m.is_file()),
            values: [0.0; 7],
            sum_sq: [0.0; 7],
            rows: 0,
        })
    }

    pub(crate) fn write(&mut self, p: &MotionPoint) -> anyhow::Result<()> {
        self.values[..6].copy_from_slice(&p.dof);
        self.values[6] = p.wave_m;
        for (s, v) in self.sum_sq.iter_mut().zip(&self.values) {
            *s += v * v;
        }
        self.rows += 1;
        let Some(writer) = self.writer.as_mut() else {
            anyhow::bail!("{}: written after it was finished", self.path.display());
        };
        writer
            .write_row(p.time_s, &self.values)
            .with_context(|| format!("writing {}", self.path.display()))?;
        Ok(())
    }

    pub(crate) fn rms(&self, ch: Channel) -> f64 {
        (self.sum_sq[ch.index()] / self.rows.max(1) as f64).sqrt()
    }

    pub(crate) fn finish(mut self) -> anyhow::Result<()> {
        if let Some(writer) = self.writer.take() {
            // The last flush can fail too (a full disk): the file is then cut short as well
            // (review: it was left).
            if let Err(e) = writer.finish() {
                self.remove();
                return Err(e).with_context(|| format!("writing {}", self.path.display()));
            }
        }
        Ok(())
    }

    fn remove(&self) {
        if self.regular {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

impl Drop for RecordOut {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            self.remove();
        }
    }
}

/// " (x deg)" for a rotation, nothing otherwise.
pub(crate) fn degrees(ch: Channel, value: f64) -> String {
    match ch {
        Channel::Motion(d) if d.is_rotation() => format!(" ({:.3} deg)", value.to_degrees()),
        _ => String::new(),
    }
}

fn run_stationary(config: &Config, duration_s: f64, station: Station) -> anyhow::Result<()> {
    let started = Instant::now();
    let motion = ShipMotion::at_station(&config.sim, station)?;
    if station != Station::REFERENCE {
        tracing::info!(
            "vessel at {} m forward, {} m starboard of the reference vessel, heading {} deg to \
             starboard of it, in its sea (waves from {} deg relative to the reference bow)",
            station.x_m,
            station.y_m,
            station.heading_offset_deg,
            config.sim.heading_deg
        );
    }
    let rows = (duration_s * config.rate_hz).round().max(1.0) as u64;
    let mut out = RecordOut::create(&config.out)?;
    let progress = indicatif::ProgressBar::new(rows);
    for (i, p) in motion
        .stream(config.rate_hz, 0.0)?
        .take(rows as usize)
        .enumerate()
    {
        out.write(&p)?;
        if i % 8192 == 0 {
            progress.set_position(i as u64);
        }
    }
    progress.finish_and_clear();
    tracing::info!(
        "wrote {rows} rows ({} s at {} Hz, {} wave components) to {} in {:.2} s",
        duration_s,
        config.rate_hz,
        motion.components().len(),
        config.out.display(),
        started.elapsed().as_secs_f64()
    );
    for ch in Channel::ALL {
        let rms = out.rms(ch);
        let exact = motion.variance(ch).sqrt();
        tracing::info!(
            "{:<10} RMS {rms:.4}{}, exact {exact:.4}; peak encounter period {}",
            ch.column(),
            degrees(ch, rms),
            motion
                .peak_encounter_period(ch)
                .map_or("none (not excited)".to_string(), |t| format!("{t:.1} s"))
        );
    }
    out.finish()?;
    if let Some(svg) = &config.plot {
        plot_overview(&motion, svg, 60.0, config.rate_hz)?;
        tracing::info!("figure written to {}", svg.display());
    }
    Ok(())
}

/// A record with a course and/or sea-state change; logs the exact std of the conditions
/// before and after next to the record's RMS over the stretches before and after the changes.
fn run_changing(
    config: &Config,
    duration_s: f64,
    course: Option<CourseChange>,
    sea: Option<SeaChange>,
) -> anyhow::Result<()> {
    let (cfg, rate_hz) = (&config.sim, config.rate_hz);
    let started = Instant::now();
    let motion = ChangingMotion::new(cfg, course, sea)?;
    let first_change = [course.map(|c| c.at_s), sea.map(|s| s.at_s)]
        .into_iter()
        .flatten()
        .fold(f64::INFINITY, f64::min);
    let settled = [
        course.map(|c| c.at_s + c.turn_s),
        sea.map(|s| s.at_s + s.ramp_s),
    ]
    .into_iter()
    .flatten()
    .fold(0.0, f64::max);
    if settled >= duration_s {
        tracing::warn!(
            "the record ends at {duration_s} s, before the changes are complete ({settled} s)"
        );
    }
    let rows = (duration_s * rate_hz).round().max(1.0) as u64;
    let mut out = RecordOut::create(&config.out)?;
    let (mut before, mut after) = ([0.0; 7], [0.0; 7]);
    let (mut n_before, mut n_after) = (0u64, 0u64);
    let progress = indicatif::ProgressBar::new(rows);
    for i in 0..rows {
        let p = motion.sample_at(i as f64 / rate_hz);
        out.write(&p)?;
        let (sums, n) = if p.time_s < first_change {
            (&mut before, &mut n_before)
        } else if p.time_s >= settled {
            (&mut after, &mut n_after)
        } else {
            continue;
        };
        *n += 1;
        for (s, v) in sums.iter_mut().zip(&out.values) {
            *s += v * v;
        }
        if i % 8192 == 0 {
            progress.set_position(i);
        }
    }
    progress.finish_and_clear();
    out.finish()?;
    let mut final_cfg = match (&sea, motion.final_sea()) {
        (Some(_), Some(m)) => m.config().clone(),
        _ => cfg.clone(),
    };
    if let Some(c) = &course {
        final_cfg.heading_deg = c.new_heading_deg;
    }
    let final_motion = ShipMotion::new(&final_cfg)?;
    tracing::info!(
        "wrote {rows} rows ({} s at {} Hz) to {} in {:.2} s; changes from {first_change} s, \
         complete at {settled} s{}{}",
        duration_s,
        rate_hz,
        config.out.display(),
        started.elapsed().as_secs_f64(),
        course.map_or(String::new(), |c| format!(
            "; course: heading {} -> {} deg over {} s from {} s",
            cfg.heading_deg, c.new_heading_deg, c.turn_s, c.at_s
        )),
        sea.map_or(String::new(), |s| format!(
            "; sea: Hs {} m, Tp {} s -> Hs {} m, Tp {} s (seed {}) over {} s from {} s",
            cfg.hs_m, cfg.tp_s, s.hs_m, s.tp_s, final_cfg.seed, s.ramp_s, s.at_s
        )),
    );
    for ch in Channel::ALL {
        let j = ch.index();
        let rms = |sum: f64, n: u64| {
            if n == 0 {
                "-".to_string()
            } else {
                format!("{:.4}", (sum / n as f64).sqrt())
            }
        };
        let exact_before = motion.initial().variance(ch).sqrt();
        let exact_after = final_motion.variance(ch).sqrt();
        tracing::info!(
            "{:<10} before: RMS {} exact {exact_before:.4}{}; after: RMS {} exact {exact_after:.4}{}",
            ch.column(),
            rms(before[j], n_before),
            degrees(ch, exact_before),
            rms(after[j], n_after),
            degrees(ch, exact_after),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(time_s: f64, heave: f64) -> MotionPoint {
        MotionPoint {
            time_s,
            dof: [0.0, 0.0, heave, 0.0, 0.0, 0.0],
            wave_m: 0.0,
        }
    }

    /// Regressions (review): a record cut short by an error was left to be taken for a whole
    /// one; then the removal unlinked a symbolic link given as --out (`/dev/stdout` as root).
    #[test]
    fn a_record_cut_short_is_removed_but_never_through_a_link() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.csv");
        let mut out = RecordOut::create(&path).unwrap();
        out.write(&point(0.0, 1.0)).unwrap();
        assert!(out.write(&point(0.5, 1e200)).is_err());
        drop(out);
        assert!(!path.exists());

        let target = dir.path().join("target.csv");
        std::fs::write(&target, "").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let out = RecordOut::create(&link).unwrap();
        drop(out);
        assert!(link.symlink_metadata().unwrap().file_type().is_symlink());

        let whole = dir.path().join("whole.csv");
        let mut out = RecordOut::create(&whole).unwrap();
        out.write(&point(0.0, 1.0)).unwrap();
        out.finish().unwrap();
        assert_eq!(std::fs::read_to_string(&whole).unwrap().lines().count(), 2);
    }
}
