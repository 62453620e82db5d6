//! `shipcast simulate`: draws a seeded irregular sea (or reads a measured elevation record),
//! passes it through the ship's RAOs and writes the 6-DOF motion (plus the wave elevation at
//! the CG) as a motion CSV. Optional course and sea-state changes make the record
//! non-stationary.

use crate::checked;
use anyhow::Context;
use shipcast_pipeline::config::MAX_PRODUCER_RATE_HZ;
use shipcast_pipeline::limits;
use shipcast_series::motion_csv::MotionCsvWriter;
use shipcast_sim::plot::plot_overview;
use shipcast_sim::{
    ChangingMotion, Channel, CourseChange, Hull, MotionPoint, RaoSpec, Scenario, SeaChange,
    ShipMotion, SimConfig, Spectrum, SpectrumKind,
};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Instant;

mod measured;
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
scripts/fetch_wafo.py fetches two measured records (non-commercial licence, never commit them).

Non-stationary records: --course-change-s T --new-heading-deg D [--turn-s R] turns the ship
(same wave field) so that the mean relative wave direction ramps linearly from --heading-deg to
D over R s from record time T. --sea-change-s T --new-hs M --new-tp S [--ramp-s R] cross-fades
(power-preserving) to an independent sea (seed + 1, DNV gamma) of Hs M and Tp S over R s from
T. Both may be combined. Before T the record equals the stationary simulation; the producer
uses such a record through `simulate --out F.csv` then `producer --input F.csv`.";

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
    /// JONSWAP peak enhancement factor.
    #[arg(long, allow_negative_numbers = true)]
    pub gamma: Option<f64>,
    /// Ship speed [kn].
    #[arg(long = "speed-kn", allow_negative_numbers = true)]
    pub speed_kn: Option<f64>,
    /// Mean wave direction relative to the ship [deg], 180 = head seas, 0 = following seas.
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
    /// Sample rate [Hz].
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
    #[arg(long = "rao-table-length")]
    pub rao_table_length: Option<f64>,
    /// Length of the simulated hull [m]: scales the default DTMB 5415 hull, or Froude-scales
    /// the RAO table from --rao-table-length.
    #[arg(long = "hull-length")]
    pub hull_length: Option<f64>,
    /// Also draw an SVG figure of the spectra and the first minute of motion.
    #[arg(long, conflicts_with_all = ["elevation", "course_change_s", "sea_change_s"])]
    pub plot: Option<PathBuf>,
    /// Drive the RAOs with this measured wave-elevation CSV (time_s,wave_m) instead of a
    /// simulated sea: long-crested waves from --heading-deg, elevation at the CG (see below).
    #[arg(long, conflicts_with_all = ["hs", "tp", "gamma", "components", "spreading", "spectrum", "seed", "duration"])]
    pub elevation: Option<PathBuf>,
    /// With --elevation: seconds at each end of every segment that are tapered (outer half)
    /// and not written.
    #[arg(
        long = "edge-s",
        default_value_t = 120.0,
        allow_negative_numbers = true
    )]
    pub edge_s: f64,
    /// Record time [s] at which the ship starts turning (needs --new-heading-deg).
    #[arg(
        long = "course-change-s",
        requires = "new_heading_deg",
        conflicts_with = "elevation",
        allow_negative_numbers = true
    )]
    pub course_change_s: Option<f64>,
    /// Mean relative wave direction after the turn [deg] (90 = beam seas).
    #[arg(
        long = "new-heading-deg",
        requires = "course_change_s",
        allow_negative_numbers = true
    )]
    pub new_heading_deg: Option<f64>,
    /// Duration of the turn [s].
    #[arg(long = "turn-s", default_value_t = 60.0, allow_negative_numbers = true)]
    pub turn_s: f64,
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
    /// Duration of the sea-state cross-fade [s].
    #[arg(
        long = "ramp-s",
        default_value_t = 300.0,
        allow_negative_numbers = true
    )]
    pub ramp_s: f64,
}

/// What `simulate` writes, every value checked: built from [`Args`] by [`Config::try_from`],
/// the only place that validates them, so the writers below see checked values only.
#[derive(Debug, Clone)]
pub struct Config {
    /// The sea, the ship and its RAOs (checked with `SimConfig::validate`).
    pub sim: SimConfig,
    /// Output sample rate [Hz].
    pub rate_hz: f64,
    /// Output motion CSV.
    pub out: PathBuf,
    /// What drives the ship.
    pub record: Record,
    /// SVG overview to draw (stationary records only); its directory exists.
    pub plot: Option<PathBuf>,
}

/// The three kinds of record `simulate` writes.
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    /// A stationary simulated sea of `duration_s`.
    Stationary { duration_s: f64 },
    /// A simulated sea with a course and/or a sea-state change (at least one).
    Changing {
        duration_s: f64,
        course: Option<CourseChange>,
        sea: Option<SeaChange>,
    },
    /// The ship driven by a measured elevation record.
    Measured { elevation: PathBuf, edge_s: f64 },
}

/// Most rows one record may have (about 10 GB of CSV).
const MAX_ROWS: u64 = 100_000_000;

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let rate_hz = checked(limits::rate("--rate", args.rate, MAX_PRODUCER_RATE_HZ))?;
        let record = match &args.elevation {
            Some(elevation) => Record::Measured {
                elevation: elevation.clone(),
                edge_s: checked(limits::non_negative(
                    "--edge-s",
                    args.edge_s,
                    limits::MAX_SECONDS,
                ))?,
            },
            None => {
                let duration_s = checked(limits::positive(
                    "--duration",
                    args.duration,
                    limits::MAX_SECONDS,
                ))?;
                // Checked before the sea is built: a record of billions of rows would run for
                // days.
                let rows = duration_s * rate_hz;
                if rows > MAX_ROWS as f64 {
                    anyhow::bail!("--duration x --rate = {rows:.0} rows, at most {MAX_ROWS}");
                }
                changes(&args, duration_s)?
            }
        };
        let sim = sim_config(&args)?;
        sim.validate()?;
        if !matches!(record, Record::Measured { .. }) {
            Spectrum::new(sim.spectrum, sim.hs_m, sim.tp_s, sim.gamma)?;
        }
        if let Record::Changing { sea: Some(s), .. } = &record {
            // The new sea is a JONSWAP with the DNV gamma (see AFTER_HELP).
            Spectrum::new(SpectrumKind::Jonswap, s.hs_m, s.tp_s, None)
                .context("--new-hs/--new-tp")?;
        }
        if let Some(svg) = &args.plot {
            // Checked now: the figure is drawn after the whole record is written.
            crate::output_in_existing_dir("--plot", svg)?;
        }
        Ok(Config {
            sim,
            rate_hz,
            out: args.out,
            record,
            plot: args.plot,
        })
    }
}

/// The course and sea-state changes of a simulated record (clap enforces that each comes with
/// its companion options).
fn changes(args: &Args, duration_s: f64) -> anyhow::Result<Record> {
    let seconds = |name: &str, v: f64| checked(limits::non_negative(name, v, limits::MAX_SECONDS));
    let course = match (args.course_change_s, args.new_heading_deg) {
        (Some(at_s), Some(new_heading_deg)) => Some(CourseChange {
            at_s: seconds("--course-change-s", at_s)?,
            new_heading_deg,
            turn_s: seconds("--turn-s", args.turn_s)?,
        }),
        _ => None,
    };
    let sea = match (args.sea_change_s, args.new_hs, args.new_tp) {
        (Some(at_s), Some(hs_m), Some(tp_s)) => Some(SeaChange {
            at_s: seconds("--sea-change-s", at_s)?,
            hs_m,
            tp_s,
            ramp_s: seconds("--ramp-s", args.ramp_s)?,
        }),
        _ => None,
    };
    Ok(if course.is_some() || sea.is_some() {
        Record::Changing {
            duration_s,
            course,
            sea,
        }
    } else {
        Record::Stationary { duration_s }
    })
}

/// The simulator configuration the arguments describe: the scenario with the options that
/// override it.
fn sim_config(args: &Args) -> anyhow::Result<SimConfig> {
    let scenario: Scenario = args.scenario.parse()?;
    let mut cfg = SimConfig::scenario(scenario);
    cfg.spectrum = args.spectrum.parse()?;
    cfg.spreading = args.spreading.parse()?;
    cfg.hs_m = args.hs.unwrap_or(cfg.hs_m);
    cfg.tp_s = args.tp.unwrap_or(cfg.tp_s);
    cfg.gamma = args.gamma;
    cfg.speed_kn = args.speed_kn.unwrap_or(cfg.speed_kn);
    cfg.heading_deg = args.heading_deg.unwrap_or(cfg.heading_deg);
    cfg.components = args.components;
    cfg.seed = args.seed;
    cfg.rao = match (&args.rao_table, args.rao_table_length, args.hull_length) {
        (Some(path), table_length_m, hull_length_m) => RaoSpec::Table {
            path: path.clone(),
            table_length_m,
            hull_length_m,
        },
        (None, Some(_), _) => anyhow::bail!("--rao-table-length needs --rao-table"),
        (None, None, Some(l)) => RaoSpec::ClosedForm {
            hull: Hull::dtmb5415().scaled_to_length(l)?,
        },
        (None, None, None) => RaoSpec::ClosedForm {
            hull: Hull::dtmb5415(),
        },
    };
    Ok(cfg)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let config = Config::try_from(args)?;
    match &config.record {
        Record::Measured { elevation, edge_s } => run_measured(&config, elevation, *edge_s),
        Record::Changing {
            duration_s,
            course,
            sea,
        } => run_changing(&config, *duration_s, *course, *sea),
        Record::Stationary { duration_s } => run_stationary(&config, *duration_s),
    }
}

/// The output file, row count and per-channel sums of squares of a record being written.
pub(crate) struct RecordOut {
    writer: MotionCsvWriter<BufWriter<File>>,
    path: PathBuf,
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
            writer,
            path: path.to_path_buf(),
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
        self.writer
            .write_row(p.time_s, &self.values)
            .with_context(|| format!("writing {}", self.path.display()))?;
        Ok(())
    }

    pub(crate) fn rms(&self, ch: Channel) -> f64 {
        (self.sum_sq[ch.index()] / self.rows.max(1) as f64).sqrt()
    }

    pub(crate) fn finish(self) -> anyhow::Result<()> {
        self.writer
            .finish()
            .with_context(|| format!("writing {}", self.path.display()))?;
        Ok(())
    }
}

/// " (x deg)" for a rotation, nothing otherwise.
pub(crate) fn degrees(ch: Channel, value: f64) -> String {
    match ch {
        Channel::Motion(d) if d.is_rotation() => format!(" ({:.3} deg)", value.to_degrees()),
        _ => String::new(),
    }
}

fn run_stationary(config: &Config, duration_s: f64) -> anyhow::Result<()> {
    let started = Instant::now();
    let motion = ShipMotion::new(&config.sim)?;
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

    fn config(argv: &[&str]) -> anyhow::Result<Config> {
        crate::validated::<Args, Config>(argv)
    }

    fn refused(argv: &[&str]) -> String {
        crate::refused::<Args, Config>(argv)
    }

    #[test]
    fn the_record_kind_follows_the_options() {
        let c = config(&["--out", "m.csv"]).unwrap();
        assert_eq!(c.record, Record::Stationary { duration_s: 3600.0 });
        assert_eq!((c.rate_hz, c.sim.hs_m), (8.0, 3.05));
        let c = config(&[
            "--out",
            "m.csv",
            "--hs",
            "2",
            "--course-change-s",
            "100",
            "--new-heading-deg",
            "90",
        ])
        .unwrap();
        assert_eq!(c.sim.hs_m, 2.0);
        assert_eq!(
            c.record,
            Record::Changing {
                duration_s: 3600.0,
                course: Some(CourseChange {
                    at_s: 100.0,
                    new_heading_deg: 90.0,
                    turn_s: 60.0
                }),
                sea: None
            }
        );
        let c = config(&["--out", "m.csv", "--elevation", "e.csv", "--edge-s", "30"]).unwrap();
        assert_eq!(
            c.record,
            Record::Measured {
                elevation: "e.csv".into(),
                edge_s: 30.0
            }
        );
    }

    #[test]
    fn bad_values_are_refused_with_one_line_naming_the_option() {
        assert_eq!(
            refused(&["--out", "m.csv", "--duration", "1e300"]),
            format!(
                "--duration must be a number in (0, {}], got 1e300",
                limits::MAX_SECONDS
            )
        );
        assert_eq!(
            refused(&["--out", "m.csv", "--duration", "31536000", "--rate", "10"]),
            "--duration x --rate = 315360000 rows, at most 100000000"
        );
        assert_eq!(
            refused(&["--out", "m.csv", "--rao-table-length", "100"]),
            "--rao-table-length needs --rao-table"
        );
        assert_eq!(
            refused(&[
                "--out",
                "m.csv",
                "--course-change-s",
                "100",
                "--new-heading-deg",
                "90",
                "--turn-s",
                "-1"
            ]),
            format!(
                "--turn-s must be a number in [0, {}], got -1",
                limits::MAX_SECONDS
            )
        );
        assert_eq!(
            refused(&["--out", "m.csv", "--hs", "-1"]),
            "invalid simulation setting: significant wave height must be positive, got -1 m"
        );
        assert_eq!(
            refused(&[
                "--out",
                "m.csv",
                "--sea-change-s",
                "100",
                "--new-hs",
                "0",
                "--new-tp",
                "9"
            ]),
            "--new-hs/--new-tp: invalid simulation setting: significant wave height must be \
             positive, got 0 m"
        );
        assert_eq!(
            refused(&["--out", "m.csv", "--elevation", "e.csv", "--edge-s", "nan"]),
            format!(
                "--edge-s must be a number in [0, {}], got NaN",
                limits::MAX_SECONDS
            )
        );
    }

    #[test]
    fn a_figure_in_a_missing_directory_is_refused_before_the_record_is_made() {
        let dir = tempfile::tempdir().unwrap();
        let svg = dir.path().join("missing").join("m.svg");
        let svg = svg.to_str().unwrap();
        assert_eq!(
            refused(&["--out", "m.csv", "--plot", svg]),
            format!(
                "--plot {svg}: the directory {} does not exist",
                dir.path().join("missing").display()
            )
        );
        // A bare file name is in the current directory, which exists.
        assert!(config(&["--out", "m.csv", "--plot", "m.svg"]).is_ok());
    }
}
