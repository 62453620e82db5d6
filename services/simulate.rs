//! `shipcast simulate`: draws a seeded irregular sea, passes it through the ship's RAOs and
//! writes the 6-DOF motion (plus the wave elevation at the CG) as a motion CSV.

use anyhow::Context;
use shipcast::motion_csv::MotionCsvWriter;
use shipcast::sim::plot::plot_overview;
use shipcast::sim::{Channel, Hull, RaoSpec, Scenario, ShipMotion, SimConfig};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
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
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// The simulator configuration the arguments describe.
pub fn config_from_args(args: &Args) -> anyhow::Result<SimConfig> {
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
    if !(args.duration.is_finite() && args.duration > 0.0) {
        anyhow::bail!("--duration must be positive, got {}", args.duration);
    }
    if !(args.rate.is_finite() && args.rate > 0.0) {
        anyhow::bail!("--rate must be positive, got {}", args.rate);
    }
    let cfg = config_from_args(&args)?;
    let started = Instant::now();
    let motion = ShipMotion::new(&cfg)?;
    let rows = (args.duration * args.rate).round().max(1.0) as u64;
    let columns: Vec<&str> = Channel::ALL.iter().map(|c| c.column()).collect();
    let mut writer = MotionCsvWriter::create(&args.out, &columns)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    let progress = indicatif::ProgressBar::new(rows);
    let mut sum_sq = [0.0; 7];
    let mut values = [0.0; 7];
    for (i, p) in motion
        .stream(args.rate, 0.0)?
        .take(rows as usize)
        .enumerate()
    {
        values[..6].copy_from_slice(&p.dof);
        values[6] = p.wave_m;
        for (s, v) in sum_sq.iter_mut().zip(&values) {
            *s += v * v;
        }
        writer
            .write_row(p.time_s, &values)
            .with_context(|| format!("writing {}", args.out.display()))?;
        if i % 8192 == 0 {
            progress.set_position(i as u64);
        }
    }
    writer
        .finish()
        .with_context(|| format!("writing {}", args.out.display()))?;
    progress.finish_and_clear();
    tracing::info!(
        "wrote {rows} rows ({} s at {} Hz, {} wave components) to {} in {:.2} s",
        args.duration,
        args.rate,
        motion.components().len(),
        args.out.display(),
        started.elapsed().as_secs_f64()
    );
    for ch in Channel::ALL {
        let rms = (sum_sq[ch.index()] / rows as f64).sqrt();
        let exact = motion.variance(ch).sqrt();
        let deg = match ch {
            Channel::Motion(d) if d.is_rotation() => format!(" ({:.3} deg)", rms.to_degrees()),
            _ => String::new(),
        };
        tracing::info!(
            "{:<10} RMS {rms:.4}{deg}, exact {exact:.4}; peak encounter period {}",
            ch.column(),
            motion
                .peak_encounter_period(ch)
                .map_or("none (not excited)".to_string(), |t| format!("{t:.1} s"))
        );
    }
    if let Some(svg) = &args.plot {
        plot_overview(&motion, svg, 60.0, args.rate)?;
        tracing::info!("figure written to {}", svg.display());
    }
    Ok(())
}
