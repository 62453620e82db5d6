//! `shipcast eval`: the evaluation protocol (docs/contracts.md section 4) on a motion CSV, as a
//! table or one JSON object per (dof, method) line.

use crate::{checked, progress};
use anyhow::Context;
use shipcast_eval::{self as eval, report, Entry, EvalSettings};
use shipcast_pipeline::config::MAX_PRODUCER_RATE_HZ;
use shipcast_pipeline::limits;
use shipcast_predict::{AverageMode, Averaging, McaWeighting, Method, PredictorConfig, WienerFit};
use shipcast_series as signal;
use shipcast_series::motion_csv::MotionData;
use shipcast_wire::Dof;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Predictor options shared by `eval` and `train`. Defaults are the paper's
/// (`PredictorConfig::default()`), except the order and the Wiener fit, which `train` takes
/// from the service (its models are for the service): `PredictorArgs::config` is given the
/// defaults of its command.
#[derive(clap::Args, Debug)]
pub struct PredictorArgs {
    /// Past values per forecast (MCA: window length n, of which n - horizon are past values)
    /// [default: eval 800, the paper's; train 200, the service's].
    #[arg(long)]
    pub order: Option<usize>,
    /// Steps forecast (H).
    #[arg(long, default_value_t = PredictorConfig::default().horizon)]
    pub horizon: usize,
    /// MCA: shift between training windows.
    #[arg(long, default_value_t = PredictorConfig::default().mca_shift)]
    pub shift: usize,
    /// MCA: energy fraction of the minor components.
    #[arg(long, allow_negative_numbers = true, default_value_t = PredictorConfig::default().mca_energy)]
    pub energy: f64,
    /// MCA: ridge on B2^T B2, relative to its mean diagonal (0 = paper); with
    /// --mca-weighting inverse: eps relative to the mean eigenvalue (0 = 1e-3).
    #[arg(long, allow_negative_numbers = true, default_value_t = PredictorConfig::default().mca_ridge)]
    pub ridge: f64,
    /// MCA: choose the energy threshold by validation on the end of the training segment
    /// (inverse weighting: the ridge).
    #[arg(long)]
    pub validate_energy: bool,
    /// MCA: eigen-direction weights, paper (minor components, unweighted) or inverse
    /// (all, 1/(lambda + eps): the conditional mean; --ridge sets eps, 0 = default 1e-3).
    #[arg(long, default_value_t = PredictorConfig::default().mca_weighting)]
    pub mca_weighting: McaWeighting,
    /// Wiener: how the weights are estimated, autocorrelation (the paper's Yule-Walker),
    /// least-squares (over the training segment's forecast origins) or guarded (least squares
    /// held near the autocorrelation fit's forecast) [default: eval autocorrelation, the
    /// paper's; train guarded, the service's].
    #[arg(long)]
    pub wiener_fit: Option<WienerFit>,
    /// AR: normalised LMS instead of plain LMS.
    #[arg(long)]
    pub nlms: bool,
    /// AR: LMS step size.
    #[arg(long, allow_negative_numbers = true, default_value_t = PredictorConfig::default().lms_gain)]
    pub lms_gain: f64,
    /// MLP: Rprop epochs.
    #[arg(long, default_value_t = PredictorConfig::default().mlp_epochs)]
    pub epochs: usize,
    /// MLP: hidden tanh units.
    #[arg(long, default_value_t = PredictorConfig::default().mlp_hidden)]
    pub hidden: usize,
}

/// Largest value of the count options (`--order`, `--horizon`, `--shift`, `--stride`).
const MAX_COUNT: usize = shipcast_pipeline::config::MAX_ORDER;

use limits::{MAX_EPOCHS, MAX_GAIN, MAX_HIDDEN, MAX_RIDGE};

impl PredictorArgs {
    /// The predictor configuration, every option range-checked. Feasibility for a method
    /// (MCA needs order > horizon) is left to the method: `eval` reports it per method.
    /// `defaults` gives the order and Wiener fit of the command when they are not asked for.
    pub fn config(&self, seed: u64, defaults: &PredictorConfig) -> anyhow::Result<PredictorConfig> {
        let order = self.order.unwrap_or(defaults.order);
        Ok(PredictorConfig {
            order: checked(limits::count("--order", order, 1, MAX_COUNT))?,
            horizon: checked(limits::count("--horizon", self.horizon, 1, MAX_COUNT))?,
            mca_shift: checked(limits::count("--shift", self.shift, 1, MAX_COUNT))?,
            mca_energy: checked(limits::fraction_below_one("--energy", self.energy))?,
            mca_ridge: checked(limits::non_negative("--ridge", self.ridge, MAX_RIDGE))?,
            mca_validate_energy: self.validate_energy,
            mca_weighting: self.mca_weighting,
            lms_gain: checked(limits::positive("--lms-gain", self.lms_gain, MAX_GAIN))?,
            lms_normalized: self.nlms,
            wiener_fit: self.wiener_fit.unwrap_or(defaults.wiener_fit),
            mlp_hidden: checked(limits::count("--hidden", self.hidden, 1, MAX_HIDDEN))?,
            mlp_epochs: checked(limits::count("--epochs", self.epochs, 1, MAX_EPOCHS))?,
            seed,
        })
    }
}

/// The evaluation rate [Hz] of `eval` and `train`: the producer's range.
pub fn sample_rate(hz: f64) -> anyhow::Result<f64> {
    checked(limits::rate("--sample-rate", hz, MAX_PRODUCER_RATE_HZ))
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
    #[arg(long, allow_negative_numbers = true, default_value_t = 2.0)]
    pub sample_rate: f64,
    /// Gaussian noise added before training and testing, % of the peak amplitude.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
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

/// Largest training segment accepted [samples] (a year at 2 Hz).
const MAX_TRAIN: usize = 64_000_000;

/// Largest noise accepted [% of the peak amplitude].
const MAX_NOISE_PCT: f64 = 1000.0;

/// The evaluation `eval` runs, every value checked: built from [`Args`] by
/// [`Config::try_from`], the only place that validates them.
#[derive(Debug, Clone)]
pub struct Config {
    pub input: PathBuf,
    pub dofs: DofChoice,
    pub methods: Vec<Method>,
    pub predictor: PredictorConfig,
    pub settings: EvalSettings,
    pub json: bool,
}

/// The DOF of `--dof`: one by name, or every one the record has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DofChoice {
    All,
    One(Dof),
}

impl DofChoice {
    fn parse(text: &str) -> anyhow::Result<Self> {
        if text.trim().eq_ignore_ascii_case("all") {
            return Ok(DofChoice::All);
        }
        // The one place `all` is a choice: say so beside the DOF names.
        text.parse::<Dof>()
            .map(DofChoice::One)
            .map_err(|e| anyhow::anyhow!("--dof: {e}, or all"))
    }

    /// The DOF to evaluate in `data`: the one asked for (which must be in the file), or all
    /// present.
    pub fn in_record(self, data: &MotionData) -> anyhow::Result<Vec<Dof>> {
        match self {
            DofChoice::All => Ok(data.motion_dofs()?),
            DofChoice::One(dof) => {
                data.dof(dof)?;
                Ok(vec![dof])
            }
        }
    }
}

fn parse_methods(text: &str) -> anyhow::Result<Vec<Method>> {
    if text.trim().eq_ignore_ascii_case("all") {
        return Ok(Method::ALL.to_vec());
    }
    Ok(vec![text
        .parse::<Method>()
        .map_err(|e| anyhow::anyhow!("--method: {e}, or all"))?])
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let methods = parse_methods(&args.method)?;
        let dofs = DofChoice::parse(&args.dof)?;
        // The protocol's defaults are the paper's.
        let predictor = args
            .predictor
            .config(args.seed, &PredictorConfig::default())?;
        let settings = EvalSettings {
            // Every method needs a training segment: one clear error instead of one per method.
            train: checked(limits::count("--train", args.train, 1, MAX_TRAIN))?,
            stride: checked(limits::count("--stride", args.stride, 1, MAX_COUNT))?,
            sample_rate: sample_rate(args.sample_rate)?,
            noise_pct: checked(limits::non_negative(
                "--noise-pct",
                args.noise_pct,
                MAX_NOISE_PCT,
            ))?,
            seed: args.seed,
            average: Averaging {
                k: args.average,
                mode: args.average_mode,
            },
        };
        settings.average.validate(predictor.horizon)?;
        Ok(Config {
            input: args.input,
            dofs,
            methods,
            predictor,
            settings,
            json: args.json,
        })
    }
}

/// Read a motion CSV and bring it to `sample_rate` (shared with `train`).
pub fn load_resampled(path: &Path, sample_rate: f64) -> anyhow::Result<MotionData> {
    let data =
        MotionData::read_path(path).with_context(|| format!("reading {}", path.display()))?;
    warn_of_spikes(path, &data, "eval and train take them as they are");
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

/// Name the samples of each column that lie far outside the motion around them
/// (`shipcast_series::spikes`): where the column is evaluated, the forecasts are scored
/// against them and the models fitted on them as they are, so the user should know (and
/// repair the record).
/// `taken` says what the command does with them.
pub(crate) fn warn_of_spikes(path: &Path, data: &MotionData, taken: &str) {
    let Ok(rate) = shipcast_series::median_rate(&data.time) else {
        return;
    };
    let per_minute = (60.0 * rate).round() as usize;
    // Every column, `wave_m` too: the record is suspect wherever one lies.
    for column in &data.columns {
        let (count, first) = shipcast_series::spikes::find_spikes(&column.values, per_minute);
        if let Some(first) = first {
            tracing::warn!(
                input = %path.display(),
                column = %column.name,
                count,
                "{}: {count} sample(s) of {} lie more than {} robust scales from their minute's median (spikes, or a quantisation far coarser than the motion), the first at t = {} s: {taken}; repair or remove them",
                path.display(),
                column.name,
                shipcast_series::spikes::SPIKE_SCALES,
                shipcast_wire::shown::number(data.time[first])
            );
        }
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        input,
        dofs,
        methods,
        predictor: config,
        settings,
        json,
    } = Config::try_from(args)?;
    let data = load_resampled(&input, settings.sample_rate)?;
    let dofs = dofs
        .in_record(&data)
        .map_err(|e| anyhow::anyhow!("{}: {e:#}", input.display()))?;
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
            if json && write_error.is_none() {
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
    if !json {
        write!(
            stdout,
            "{}",
            report::table(&entries, settings.sample_rate, config.horizon)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(argv: &[&str]) -> String {
        let mut full = vec!["--input", "m.csv"];
        full.extend_from_slice(argv);
        crate::refused::<Args, Config>(&full)
    }

    #[test]
    fn defaults_are_the_papers_and_every_method_and_dof() {
        let c = crate::validated::<Args, Config>(&["--input", "m.csv"]).unwrap();
        assert_eq!(c.methods, Method::ALL.to_vec());
        assert_eq!(c.dofs, DofChoice::All);
        assert_eq!(c.predictor.order, PredictorConfig::default().order);
        assert_eq!((c.settings.train, c.settings.stride), (5000, 1));
        let c = crate::validated::<Args, Config>(&[
            "--input",
            "m.csv",
            "--dof",
            "pitch",
            "--method",
            "ar",
            "--order",
            "40",
            "--horizon",
            "6",
            "--average",
            "3",
        ])
        .unwrap();
        assert_eq!(
            (c.dofs, c.methods),
            (DofChoice::One(Dof::Pitch), vec![Method::Ar])
        );
        assert_eq!(
            (c.predictor.order, c.predictor.horizon, c.settings.average.k),
            (40, 6, 3)
        );
    }

    #[test]
    fn bad_options_are_refused_before_the_file_is_read() {
        assert_eq!(
            refused(&["--stride", "0"]),
            format!("--stride must be 1..={MAX_COUNT}, got 0")
        );
        assert_eq!(
            refused(&["--energy", "2"]),
            "--energy must be a number in [0, 1), got 2"
        );
        // Regression (review): 1 passed and every MCA fit failed; 0, which the method
        // takes, was refused.
        assert_eq!(
            refused(&["--energy", "1"]),
            "--energy must be a number in [0, 1), got 1"
        );
        assert!(crate::validated::<Args, Config>(&["--input", "x.csv", "--energy", "0"]).is_ok());
        assert_eq!(
            refused(&["--lms-gain", "1000"]),
            format!("--lms-gain must be a number in (0, {MAX_GAIN}], got 1000")
        );
        assert_eq!(
            refused(&["--sample-rate", "0"]),
            format!(
                "--sample-rate must be a number in [{}, {MAX_PRODUCER_RATE_HZ}], got 0",
                limits::MIN_RATE_HZ
            )
        );
        assert_eq!(
            refused(&["--noise-pct", "nan"]),
            format!("--noise-pct must be a number in [0, {MAX_NOISE_PCT}], got NaN")
        );
        assert_eq!(
            refused(&["--horizon", "6", "--average", "7"]),
            "infeasible configuration: averaging over 7 forecasts: must be between 1 and the \
             horizon 6"
        );
        // Regressions (review): --train 0 gave one error per method; a negative number was
        // "unexpected argument '-1'" instead of the range.
        assert_eq!(
            refused(&["--train", "0"]),
            format!("--train must be 1..={MAX_TRAIN}, got 0")
        );
        assert_eq!(
            refused(&["--ridge", "-1"]),
            format!("--ridge must be a number in [0, {MAX_RIDGE}], got -1")
        );
        assert_eq!(
            refused(&["--noise-pct", "-1"]),
            format!("--noise-pct must be a number in [0, {MAX_NOISE_PCT}], got -1")
        );
        assert!(refused(&["--dof", "heavy"]).contains("unknown degree of freedom 'heavy'"));
        assert!(refused(&["--method", "kalman"]).contains("unknown method 'kalman'"));
        // `all`, the default of both, is named among the choices.
        assert!(refused(&["--dof", "heavy"]).ends_with("or yaw), or all"));
        assert!(refused(&["--method", "kalman"]).ends_with("or zero), or all"));
    }

    #[test]
    fn an_infeasible_order_is_left_to_the_method() {
        // MCA needs order > horizon; eval reports that per method and runs the others.
        let c = crate::validated::<Args, Config>(&[
            "--input",
            "m.csv",
            "--order",
            "10",
            "--horizon",
            "10",
        ])
        .unwrap();
        assert_eq!((c.predictor.order, c.predictor.horizon), (10, 10));
    }
}
