//! `shipcast train`: fit per-DOF models on a motion CSV and write one model file for the
//! predictor service.

use crate::eval::{load_resampled, sample_rate, PredictorArgs};
use shipcast_eval::model::{train_models, training_len, ModelError, TrainOptions};
use shipcast_eval::EvalError;
use shipcast_pipeline::config::{PredictorServiceConfig, WienerSettings};
use shipcast_predict::{Method, PredictorConfig};
use shipcast_wire::Dof;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Motion CSV; every DOF column present gets a model.
    #[arg(long)]
    pub input: PathBuf,
    /// Model file to write (JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Method (mca, wiener, ar, mlp, persistence, zero). The default is the service's: a
    /// Wiener predictor of order 200, fitted guarded (docs/forecasting.md); the paper's MCA-800
    /// learns one realisation's wave components and fails out of sample.
    #[arg(long, default_value = "wiener")]
    pub method: String,
    /// Rate the models forecast at [Hz]; the input is low-pass filtered and decimated to it.
    #[arg(long, allow_negative_numbers = true, default_value_t = 2.0)]
    pub sample_rate: f64,
    /// Fraction at the end of each series held out to measure the expected error (sigma).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.2)]
    pub holdout: f64,
    /// Seed of the methods' random choices.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub predictor: PredictorArgs,
}

/// The order and Wiener fit of the predictor service's own default, for options not given:
/// a model trained with the defaults is the one the service would fit.
fn service_defaults() -> PredictorConfig {
    let service = PredictorServiceConfig::default();
    PredictorConfig {
        order: service.order,
        wiener_fit: WienerSettings::default().fit,
        ..PredictorConfig::default()
    }
}

/// What `train` fits and where it writes it, every value checked: built from [`Args`] by
/// [`Config::try_from`], the only place that validates them.
#[derive(Debug, Clone)]
pub struct Config {
    pub input: PathBuf,
    /// The model file; its directory exists.
    pub out: PathBuf,
    pub options: TrainOptions,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let method: Method = args.method.parse().map_err(anyhow::Error::msg)?;
        let config = args.predictor.config(args.seed, &service_defaults())?;
        // Regression (review): `--horizon 129` trained a model that no service can load (a
        // forecast carries at most MAX_STEPS steps); `eval` alone takes longer horizons.
        crate::checked(shipcast_pipeline::limits::count(
            "--horizon",
            config.horizon,
            1,
            shipcast_wire::payload::MAX_STEPS,
        ))?;
        // Both parts must hold data: the fit and the sigma measurement.
        if !(args.holdout > 0.0 && args.holdout < 1.0) {
            anyhow::bail!(
                "--holdout must be a fraction in (0, 1), got {}",
                args.holdout
            );
        }
        // Checked now: the file is written after the training.
        crate::output_in_existing_dir("--out", &args.out)?;
        crate::output_not_input("--out", &args.out, "--input", &args.input)?;
        Ok(Config {
            input: args.input,
            out: args.out,
            options: TrainOptions {
                method,
                config,
                sample_rate: sample_rate(args.sample_rate)?,
                holdout_fraction: args.holdout,
                sigma_stride: 1,
            },
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        input,
        out,
        options,
    } = Config::try_from(args)?;
    let method = options.method;
    let data = load_resampled(&input, options.sample_rate)?;
    let dofs = data
        .motion_dofs()
        .map_err(|e| anyhow::anyhow!("{}: {e}", input.display()))?;
    if dofs.len() < Dof::ALL.len() {
        let absent: Vec<&str> = Dof::ALL
            .iter()
            .filter(|d| !dofs.contains(d))
            .map(|d| d.csv_column())
            .collect();
        tracing::warn!(
            "train: {} has no {} column: the model file holds no model for them, and the predictor forecasts them at no skill until its first fit on live data",
            input.display(),
            absent.join(", ")
        );
    }
    let holdout = options.holdout_fraction;
    let rate = options.sample_rate;
    let model = train_models(&data, &dofs, &options).map_err(|e| {
        let text = e.to_string();
        let shown = shipcast_wire::shown::number(holdout);
        if let ModelError::Eval {
            dof,
            error:
                EvalError::TooShort {
                    len,
                    order,
                    horizon,
                    ..
                },
        } = &e
        {
            // Regression (review): this was the protocol's "train N + order + horizon = M
            // samples are needed", N the record less its held-out share: given M samples, it
            // asked for M + 7, and so on.
            // Samples at the training rate: an input at a higher rate also loses the
            // decimation filter's first inputs, and the part before the held-out one must
            // still train the method (its own "too short" says how much).
            let needed = match least_record_for(order + horizon, holdout) {
                Some(least) => format!("at least {least} samples at that rate are needed for it"),
                None => "no record of any practical length is enough".to_string(),
            };
            anyhow::anyhow!(
                "{dof}: the record's {len} samples at {} Hz are too short: its held-out part, --holdout {shown} of it, must hold order {order} + horizon {horizon} values for one forecast, so {needed}; a longer record, a lower --order or --horizon, or a larger --holdout help",
                shipcast_wire::shown::number(rate)
            )
        } else if text.contains("training series too short") {
            // Regression (review): no word that --holdout had taken the rest.
            anyhow::anyhow!(
                "{text} (the training part is the record less --holdout {shown} of it; a longer record, a lower --order or a smaller --holdout help)"
            )
        } else {
            anyhow::Error::from(e)
        }
    })?;
    model.save(&out)?;
    for m in &model.dofs {
        let diagnostics = shipcast_predict::Predictor::diagnostics(&m.predictor);
        tracing::info!(
            dof = %m.dof,
            samples = m.samples,
            sigma_first_step = m.sigma[0],
            sigma_last_step = m.sigma[m.sigma.len() - 1],
            minor_components = ?diagnostics.minor_components,
            "trained"
        );
    }
    tracing::info!(out = %out.display(), method = %method, dofs = model.dofs.len(), "model file written");
    Ok(())
}

/// The fewest samples whose held-out end, as `train_models` splits them ([`training_len`]),
/// holds `values` (the rest must also train the method, which this does not count); None
/// beyond 1e12 samples (a tiny `holdout`), where the count would overflow.
fn least_record_for(values: usize, holdout: f64) -> Option<usize> {
    if !(holdout > 0.0 && values as f64 / holdout <= 1e12) {
        return None;
    }
    let held = |len: usize| len - training_len(len, holdout);
    // The held-out part is about holdout * len: the answer lies just above values / holdout.
    // Start where that part holds at most values - 1, clear of rounding.
    let mut len = ((values.saturating_sub(1) as f64 / holdout).floor() as usize)
        .saturating_sub(2)
        .max(values);
    while held(len) < values {
        len += 1;
    }
    Some(len)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(argv: &[&str]) -> String {
        crate::refused::<Args, Config>(argv)
    }

    #[test]
    fn the_least_record_is_the_shortest_whose_held_out_part_holds_the_values() {
        let held = |len: usize, h: f64| len - training_len(len, h);
        for values in [1, 7, 66, 250, 1001] {
            for h in [0.1, 0.2, 0.25, 0.3, 0.5, 0.9, 1e-3] {
                let least = least_record_for(values, h).unwrap();
                assert!(held(least, h) >= values, "{values} {h}: {least}");
                assert!(held(least - 1, h) < values, "{values} {h}: {least}");
            }
        }
        // The shipped defaults: order 200 + horizon 50 at --holdout 0.2.
        assert_eq!(least_record_for(250, 0.2), Some(1246));
        assert_eq!(least_record_for(66, 1e-300), None);
    }

    #[test]
    fn options_are_checked_before_training() {
        let c = crate::validated::<Args, Config>(&[
            "--input",
            "m.csv",
            "--out",
            "model.json",
            "--method",
            "wiener",
        ])
        .unwrap();
        assert_eq!(c.options.method, Method::Wiener);
        assert_eq!(
            (c.options.sample_rate, c.options.holdout_fraction),
            (2.0, 0.2)
        );
        for holdout in ["0", "1", "nan"] {
            assert_eq!(
                refused(&["--input", "m.csv", "--out", "m.json", "--holdout", holdout]),
                format!(
                    "--holdout must be a fraction in (0, 1), got {}",
                    holdout.replace("nan", "NaN")
                )
            );
        }
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("missing").join("m.json");
        let out = out.to_str().unwrap();
        assert_eq!(
            refused(&["--input", "m.csv", "--out", out]),
            format!(
                "--out {out}: the directory {} does not exist",
                dir.path().join("missing").display()
            )
        );
        assert_eq!(
            refused(&["--input", "m.csv", "--out", "m.json", "--order", "0"]),
            format!(
                "--order must be 1..={}, got 0",
                shipcast_pipeline::config::MAX_ORDER
            )
        );
        // Regression (review): a horizon beyond what a forecast carries made a model file
        // that nothing could load.
        assert_eq!(
            refused(&["--input", "m.csv", "--out", "m.json", "--horizon", "129"]),
            "--horizon must be 1..=128, got 129"
        );
        let d = dir.path().to_str().unwrap();
        assert_eq!(
            refused(&["--input", "m.csv", "--out", d]),
            format!("--out {d}: is a directory, not a file")
        );
    }

    /// Regression (review): `train` with no options fitted the paper's MCA-800, whose sigma
    /// was four times predicting zero's error out of sample; the service fits something else.
    #[test]
    fn the_defaults_fit_what_the_service_fits_and_options_still_override_them() {
        let c = crate::validated::<Args, Config>(&["--input", "m.csv", "--out", "m.json"]).unwrap();
        let service = PredictorServiceConfig::default();
        assert_eq!(c.options.method, service.method);
        assert_eq!(c.options.config.order, service.order);
        assert_eq!(c.options.config.horizon, service.horizon);
        assert_eq!(c.options.config.wiener_fit, WienerSettings::default().fit);
        let c = crate::validated::<Args, Config>(&[
            "--input",
            "m.csv",
            "--out",
            "m.json",
            "--method",
            "mca",
            "--order",
            "800",
            "--wiener-fit",
            "autocorrelation",
        ])
        .unwrap();
        assert_eq!(
            (c.options.method, c.options.config.order),
            (Method::Mca, 800)
        );
        assert_eq!(
            c.options.config.wiener_fit,
            shipcast_predict::WienerFit::Autocorrelation
        );
    }
}
