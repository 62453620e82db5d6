//! `shipcast eval`: the evaluation protocol (docs/contracts.md section 4) on a motion CSV, as a
//! table or one JSON object per (dof, method) line.

use crate::progress;
use anyhow::Context;
use shipcast_eval::{self as eval, report, Entry, EvalSettings};
use shipcast_predict::{AverageMode, Averaging, McaWeighting, Method, PredictorConfig};
use shipcast_series as signal;
use shipcast_series::motion_csv::MotionData;
use shipcast_wire::Dof;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Predictor options shared by `eval` and `train`; defaults are the paper's
/// (`PredictorConfig::default()`).
#[derive(clap::Args, Debug)]
pub struct PredictorArgs {
    /// Past values per forecast (MCA: window length n, of which n - horizon are past values).
    #[arg(long, default_value_t = PredictorConfig::default().order)]
    pub order: usize,
    /// Steps forecast (H).
    #[arg(long, default_value_t = PredictorConfig::default().horizon)]
    pub horizon: usize,
    /// MCA: shift between training windows.
    #[arg(long, default_value_t = PredictorConfig::default().mca_shift)]
    pub shift: usize,
    /// MCA: energy fraction of the minor components.
    #[arg(long, default_value_t = PredictorConfig::default().mca_energy)]
    pub energy: f64,
    /// MCA: ridge on B2^T B2, relative to its mean diagonal (0 = paper); with
    /// --mca-weighting inverse: eps relative to the mean eigenvalue (0 = 1e-3).
    #[arg(long, default_value_t = PredictorConfig::default().mca_ridge)]
    pub ridge: f64,
    /// MCA: choose the energy threshold by validation on the end of the training segment
    /// (inverse weighting: the ridge).
    #[arg(long)]
    pub validate_energy: bool,
    /// MCA: eigen-direction weights, paper (minor components, unweighted) or inverse
    /// (all, 1/(lambda + eps): the conditional mean; --ridge sets eps, 0 = default 1e-3).
    #[arg(long, default_value_t = PredictorConfig::default().mca_weighting)]
    pub mca_weighting: McaWeighting,
    /// AR: normalised LMS instead of plain LMS.
    #[arg(long)]
    pub nlms: bool,
    /// AR: LMS step size.
    #[arg(long, default_value_t = PredictorConfig::default().lms_gain)]
    pub lms_gain: f64,
    /// MLP: Rprop epochs.
    #[arg(long, default_value_t = PredictorConfig::default().mlp_epochs)]
    pub epochs: usize,
    /// MLP: hidden tanh units.
    #[arg(long, default_value_t = PredictorConfig::default().mlp_hidden)]
    pub hidden: usize,
}

impl PredictorArgs {
    pub fn config(&self, seed: u64) -> PredictorConfig {
        PredictorConfig {
            order: self.order,
            horizon: self.horizon,
            mca_shift: self.shift,
            mca_energy: self.energy,
            mca_ridge: self.ridge,
            mca_validate_energy: self.validate_energy,
            mca_weighting: self.mca_weighting,
            lms_gain: self.lms_gain,
            lms_normalized: self.nlms,
            mlp_hidden: self.hidden,
            mlp_epochs: self.epochs,
            seed,
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Motion CSV (time_s plus any of surge_m, sway_m, heave_m, roll_rad, pitch_rad, yaw_rad).
    #[arg(long)]
    pub input: PathBuf,
    /// Degree of freedom, or `all` for every one present in the file.
    #[arg(long, default_value = "all")]
    pub dof: String,
    /// Method (mca, wiener, ar, mlp, persistence, zero), or `all`.
    #[arg(long, default_value = "all")]
    pub method: String,
    /// Length of the training segment, in samples at the evaluation rate.
    #[arg(long, default_value_t = 5000)]
    pub train: usize,
    /// Spacing of forecast origins.
    #[arg(long, default_value_t = 1)]
    pub stride: usize,
    /// Evaluation rate [Hz]; the input is low-pass filtered and decimated to it.
    #[arg(long, default_value_t = 2.0)]
    pub sample_rate: f64,
    /// Gaussian noise added before training and testing, % of the peak amplitude.
    #[arg(long, default_value_t = 0.0)]
    pub noise_pct: f64,
    /// Seed of the noise and of the methods' random choices.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Combine each forecast with those of the same instants from the K - 1 origins before it
    /// (1 = the newest forecast alone; at most the horizon). Forecasts are then made at every
    /// origin, whatever --stride scores.
    #[arg(long, default_value_t = 1)]
    pub average: usize,
    /// How --average combines them: uniform (the paper's mean) or weighted (least-squares
    /// weights per step, fitted on the training segment only).
    #[arg(long, default_value_t = AverageMode::Uniform)]
    pub average_mode: AverageMode,
    /// One JSON object per (dof, method) line instead of the table.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub predictor: PredictorArgs,
}

/// `--dof` as a list: one DOF, or every DOF present in the record for `all`.
pub fn parse_dofs(text: &str, data: &MotionData) -> anyhow::Result<Vec<Dof>> {
    if text.trim().eq_ignore_ascii_case("all") {
        let dofs = data.dofs();
        anyhow::ensure!(!dofs.is_empty(), "no DOF column in the file (expected any of surge_m, sway_m, heave_m, roll_rad, pitch_rad, yaw_rad)");
        return Ok(dofs);
    }
    let dof = text.parse::<Dof>()?;
    data.dof(dof)?;
    Ok(vec![dof])
}

fn parse_methods(text: &str) -> anyhow::Result<Vec<Method>> {
    if text.trim().eq_ignore_ascii_case("all") {
        return Ok(Method::ALL.to_vec());
    }
    Ok(vec![text.parse::<Method>().map_err(anyhow::Error::msg)?])
}

/// Read a motion CSV and bring it to `sample_rate` (shared with `train`).
pub fn load_resampled(path: &Path, sample_rate: f64) -> anyhow::Result<MotionData> {
    let data =
        MotionData::read_path(path).with_context(|| format!("reading {}", path.display()))?;
    let resampled = signal::resample_motion(&data, sample_rate)
        .with_context(|| format!("resampling {}", path.display()))?;
    tracing::debug!(
        input = %path.display(),
        samples = data.len(),
        resampled = resampled.len(),
        sample_rate,
        "motion record loaded"
    );
    Ok(resampled)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let methods = parse_methods(&args.method)?;
    let data = load_resampled(&args.input, args.sample_rate)?;
    let dofs = parse_dofs(&args.dof, &data)?;
    let config = args.predictor.config(args.seed);
    let settings = EvalSettings {
        train: args.train,
        stride: args.stride,
        sample_rate: args.sample_rate,
        noise_pct: args.noise_pct,
        seed: args.seed,
        average: Averaging {
            k: args.average,
            mode: args.average_mode,
        },
    };
    let per_pair = eval::origin_count(data.len(), &config, &settings)?;
    let bar = progress::styled(
        (per_pair * dofs.len() * methods.len()) as u64,
        "{msg:>23} [{bar:40}] {pos}/{len} forecasts, eta {eta}",
    );

    let mut stdout = std::io::stdout().lock();
    let mut write_error = None;
    let entries = eval::evaluate_record(
        &data,
        &dofs,
        &methods,
        &config,
        &settings,
        &|n| bar.inc(n),
        &mut |entry| {
            match entry {
                Entry::Done(r) => {
                    tracing::debug!(dof = %r.dof, method = %r.method, train_s = r.train_seconds, "evaluated")
                }
                Entry::Failed(f) => {
                    tracing::debug!(dof = %f.dof, method = %f.method, error = %f.error, "method failed")
                }
            }
            bar.set_message(format!("{}/{} done", entry.dof(), entry.method()));
            if args.json && write_error.is_none() {
                // Stream each line as soon as its pair is done; long runs show progress in the output.
                let line = serde_json::to_string(entry).map_err(anyhow::Error::from);
                let written = line.and_then(|l| Ok(writeln!(stdout, "{l}")?));
                write_error = written.err();
            }
        },
    )?;
    bar.finish_and_clear();
    if let Some(e) = write_error {
        return Err(e.context("writing results"));
    }
    if !args.json {
        write!(
            stdout,
            "{}",
            report::table(&entries, args.sample_rate, config.horizon)
        )?;
    }
    stdout.flush()?;

    let failed: Vec<String> = entries
        .iter()
        .filter_map(|e| match e {
            Entry::Failed(f) => Some(format!("{}/{}: {}", f.dof, f.method, f.error)),
            Entry::Done(_) => None,
        })
        .collect();
    if let Some(first) = failed.first() {
        anyhow::bail!(
            "{} of {} evaluations failed (first: {first})",
            failed.len(),
            entries.len()
        );
    }
    Ok(())
}
