//! `shipcast paper --out DIR [--quick] [--seed N] [--measured FILE.csv]`: the paper study (tables and figures of Zhao,
//! Xu and Kwan, section 4), written as `DIR/report.md` and SVG figures, with a progress bar.

use crate::progress::Bar;
use anyhow::Context;
use shipcast_paper::{self as paper, Plan};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Directory for report.md and the SVG figures (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Shorter records, smaller orders and fewer MLP epochs: a smoke test in under 2 minutes.
    #[arg(long)]
    quick: bool,
    /// A measured-sea motion CSV (time_s, heave_m at any rate the filter divides down to 2 Hz):
    /// the averaged-forecast section is also run on it, and the measured-sea section added.
    #[arg(long)]
    measured: Option<PathBuf>,
    /// Run only the averaged-forecast section and write it as DIR/averaging.md.
    #[arg(long)]
    averaging_only: bool,
    /// Run only the measured-sea section (needs --measured) and write it as DIR/measured.md.
    #[arg(long, requires = "measured")]
    measured_only: bool,
    /// Seed of the simulated seas, the noise and the MLP.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let plan = if args.quick {
        Plan::quick(args.seed)
    } else {
        Plan::full(args.seed)
    };
    // Fail on an unusable output directory before spending minutes on the study.
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating the output directory {}", args.out.display()))?;
    // Read the measured record before the study, so a bad file costs no minutes.
    let measured = args
        .measured
        .as_deref()
        .map(paper::averaging::MeasuredSeries::read)
        .transpose()?;
    if args.averaging_only {
        let section = paper::averaging::run_alone(&plan, measured.as_ref())?;
        let path = args.out.join("averaging.md");
        std::fs::write(&path, section).with_context(|| format!("writing {}", path.display()))?;
        tracing::info!(report = %path.display(), "averaged-forecast section written");
        return Ok(());
    }
    if args.measured_only {
        let Some(record) = measured.as_ref() else {
            anyhow::bail!("--measured-only needs --measured FILE.csv");
        };
        let section = paper::measured::run_alone(&plan, record);
        let path = args.out.join("measured.md");
        std::fs::write(&path, section).with_context(|| format!("writing {}", path.display()))?;
        tracing::info!(report = %path.display(), "measured-sea section written");
        return Ok(());
    }
    let bar = Bar::new();
    let study = paper::run_with(&plan, measured.as_ref(), &bar)?;
    bar.finish();
    let path = paper::report::write(&study, &args.out)?;
    tracing::info!(
        report = %path.display(),
        seconds = study.elapsed_seconds,
        "paper study written"
    );
    Ok(())
}
