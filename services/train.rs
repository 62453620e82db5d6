//! `shipcast train`: fit per-DOF models on a motion CSV and write one model file for the
//! predictor service.

use crate::eval::{load_resampled, PredictorArgs};
use shipcast_eval::model::{train_models, TrainOptions};
use shipcast_predict::Method;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Motion CSV; every DOF column present gets a model.
    #[arg(long)]
    pub input: PathBuf,
    /// Model file to write (JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Method (mca, wiener, ar, mlp, persistence, zero).
    #[arg(long, default_value = "mca")]
    pub method: String,
    /// Rate the models forecast at [Hz]; the input is low-pass filtered and decimated to it.
    #[arg(long, default_value_t = 2.0)]
    pub sample_rate: f64,
    /// Fraction at the end of each series held out to measure the expected error (sigma).
    #[arg(long, default_value_t = 0.2)]
    pub holdout: f64,
    /// Seed of the methods' random choices.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub predictor: PredictorArgs,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let method: Method = args.method.parse().map_err(anyhow::Error::msg)?;
    let data = load_resampled(&args.input, args.sample_rate)?;
    let dofs = data.dofs();
    anyhow::ensure!(
        !dofs.is_empty(),
        "{}: no DOF column (expected any of surge_m, sway_m, heave_m, roll_rad, pitch_rad, yaw_rad)",
        args.input.display()
    );
    let options = TrainOptions {
        method,
        config: args.predictor.config(args.seed),
        sample_rate: args.sample_rate,
        holdout_fraction: args.holdout,
        sigma_stride: 1,
    };
    let model = train_models(&data, &dofs, &options)?;
    model.save(&args.out)?;
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
    tracing::info!(out = %args.out.display(), method = %method, dofs = model.dofs.len(), "model file written");
    Ok(())
}
