//! `shipcast replay`: the predictor's engine over a recorded motion CSV, no processes, no
//! transports; every delivered forecast scored against the record (docs/contracts.md
//! section 10).

use crate::progress;
use anyhow::Context;
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::engine::replay::{replay_scored, ReplayReport};
use shipcast_pipeline::engine::startup::initial_models;
use shipcast_pipeline::limits;
use shipcast_series::motion_csv::MotionData;
use shipcast_wire::shown::fixed_or_dash;
use shipcast_wire::Dof;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Motion CSV (time_s plus any of the six DOF columns) at any integer multiple of the
    /// predictor's rate, including that rate.
    #[arg(long)]
    pub input: PathBuf,
    /// Pipeline configuration (its `[predictor]` section is what the engine runs with).
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// Start from this model file (`shipcast train`) instead of the configured start-up model.
    #[arg(long, value_name = "MODEL.json")]
    pub model: Option<PathBuf>,
    /// Score only forecasts issued at record time >= S (default: the record's first sample,
    /// so a record stamped before 0 is scored too).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub skip_s: Option<f64>,
    /// One JSON object per DOF, then one `{"decisions": ...}` per station and MOT, instead of
    /// the table.
    #[arg(long)]
    pub json: bool,
}

/// What replay runs, every value checked: built from [`Args`] by [`Config::try_from`] (the
/// configuration file, `--model` over it, then the checks). The record itself is checked when
/// it is read.
#[derive(Debug, Clone)]
pub struct Config {
    pub input: PathBuf,
    /// Its `predictor.model` is `--model` when given.
    pub pipeline: PipelineConfig,
    /// Finite; None: from the record's first sample.
    pub skip_s: Option<f64>,
    pub json: bool,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        if let Some(skip_s) = args.skip_s {
            crate::checked(limits::in_range(
                "--skip-s",
                skip_s,
                -limits::MAX_RECORD_TIME_S,
                limits::MAX_RECORD_TIME_S,
            ))?;
        }
        let mut pipeline = PipelineConfig::load_unvalidated(args.config.as_deref())?;
        if args.model.is_some() {
            pipeline.predictor.model = args.model;
        }
        pipeline.validate()?;
        Ok(Config {
            input: args.input,
            pipeline,
            skip_s: args.skip_s,
            json: args.json,
        })
    }
}

/// The DOFs the deck point's decisions are made from: its vertical displacement and velocity
/// (heave, roll and pitch at the point's lever arms) and the roll and pitch limits.
const DECK_DOFS: [Dof; 3] = [Dof::Heave, Dof::Roll, Dof::Pitch];

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        input,
        pipeline: config,
        skip_s,
        json,
    } = Config::try_from(args)?;
    let data =
        MotionData::read_path(&input).with_context(|| format!("reading {}", input.display()))?;
    data.motion_dofs()
        .with_context(|| input.display().to_string())?;
    // Skipping the whole record would score nothing and print a table of NaN.
    let start_s = data.time.first().copied().unwrap_or(0.0);
    let end_s = data.time.last().copied().unwrap_or(0.0);
    // Regression (review): the default was 0, which skips the whole of a record stamped
    // before 0, and the error named an --skip-s that was never given.
    let skip_s = skip_s.unwrap_or(start_s);
    if data.len() < 2 {
        anyhow::bail!(
            "{}: {} row: a record to replay needs at least two",
            input.display(),
            data.len()
        );
    }
    if skip_s >= end_s {
        anyhow::bail!(
            "--skip-s {skip_s} s (record time) skips the whole record: it runs from {start_s:.1} to {end_s:.1} s in {}",
            input.display()
        );
    }
    // Before the start-up model's training: a record the engine cannot take is refused at once.
    shipcast_pipeline::engine::replay::record_rate(&data.time, config.predictor.sample_rate_hz)
        .with_context(|| input.display().to_string())?;
    // The deck's decisions need the deck point's vertical motion and its roll and pitch: with
    // any of those columns absent (or misspelt) they would be scored on zeros, a calm deck
    // that never was.
    let present = data.dofs();
    let deck_missing: Vec<&str> = DECK_DOFS
        .iter()
        .filter(|d| !present.contains(d))
        .map(|d| d.csv_column())
        .collect();
    let deck = if deck_missing.is_empty() {
        Some(&config.deck)
    } else {
        tracing::warn!(
            "replay: {} has no {} column: the deck's decisions are not scored",
            input.display(),
            deck_missing.join(", ")
        );
        None
    };
    let models = initial_models(&config)?;
    let bar = progress::styled(
        data.len() as u64,
        "{elapsed_precise} [{bar:30}] {pos}/{len} samples",
    );
    let (report, _) = replay_scored(
        &data,
        &config.predictor,
        models,
        skip_s,
        false,
        deck,
        &|n| bar.inc(n),
    )?;
    bar.finish_and_clear();
    // A record too short for any forecast to be scored would print a table of NaN.
    if report.dofs.iter().all(|d| d.scored == 0) {
        anyhow::bail!(
            "{}",
            nothing_scored(&input, &report, &config.predictor, skip_s, (start_s, end_s))
        );
    }
    if report.input.lost > 0 {
        tracing::warn!(
            missing = report.input.lost,
            "replay: {} samples missing from {} (gaps in time): runs of up to {} were bridged by a straight line between the samples on either side, longer gaps restarted the history",
            report.input.lost,
            input.display(),
            shipcast_pipeline::engine::MAX_FILL
        );
    }
    let mut out = std::io::stdout().lock();
    if json {
        for d in &report.dofs {
            serde_json::to_writer(&mut out, d)?;
            writeln!(out)?;
        }
        for d in &report.decisions {
            serde_json::to_writer(&mut out, &serde_json::json!({ "decisions": d }))?;
            writeln!(out)?;
        }
    } else {
        write!(out, "{}", table(&report))?;
    }
    Ok(())
}

/// Leads shown in the table [s].
const TABLE_LEADS: [f64; 4] = [5.0, 10.0, 15.0, 20.0];

/// `v` as written (`limits::shown`), or "-" where it is not a number.
fn exact(v: f64) -> String {
    if v.is_finite() {
        limits::shown(v)
    } else {
        "-".to_string()
    }
}

fn table(r: &ReplayReport) -> String {
    let mut s = format!(
        "replay: {} forecasts, {} retrains ({} failed), {} swaps ({} kept the running model), {} sea changes; input {} Hz\n",
        r.counts.forecasts, r.counts.retrains, r.counts.retrain_failures, r.counts.swaps, r.counts.kept_running, r.counts.changes, r.input_rate_hz
    );
    s.push_str(&format!(
        "input: {} samples, {} missing (gaps), {} rejected; {} model failures\n",
        r.input.received,
        r.input.lost,
        r.input.rejected_nonfinite + r.input.rejected_order,
        r.counts.model_failures
    ));
    let scored = r.dofs.first().map_or(0, |d| d.scored);
    s.push_str(&format!(
        "scored: {scored} forecasts issued after --skip-s with every step inside the record"
    ));
    if r.partly_scored > 0 {
        s.push_str(&format!(
            ", {} of them partly scored (steps on samples missing from the record are not scored; the deck is judged on whole forecasts only)",
            r.partly_scored
        ));
    }
    s.push('\n');
    s.push_str(&format!(
        "leads from the forecast's time_s; its newest sample is {} s later\n",
        limits::shown(r.delay_s)
    ));
    s.push_str("dof     lead  rms      nrmse  persist  sigma    cov1   cov2\n");
    for d in &r.dofs {
        for lead in TABLE_LEADS {
            let k = (lead / r.dt_s).round() as usize;
            if k == 0 || k > d.rms.len() {
                continue;
            }
            let i = k - 1;
            s.push_str(&format!(
                "{:<7} {:>4.0}s {:<8} {:<6} {:<8} {:<8} {:<6} {:<6}\n",
                d.dof,
                lead,
                fixed_or_dash(d.rms[i], 4),
                fixed_or_dash(d.nrmse[i], 3),
                fixed_or_dash(d.persistence_rms[i], 4),
                fixed_or_dash(d.mean_sigma[i], 4),
                fixed_or_dash(d.coverage_1sigma[i], 3),
                fixed_or_dash(d.coverage_2sigma[i], 3)
            ));
        }
        s.push_str(&format!(
            "{:<7} max |error| {} ({} x the motion's std {}); {} implausible forecasts replaced\n",
            d.dof,
            fixed_or_dash(d.max_abs_error, 4),
            fixed_or_dash(d.max_abs_error / d.std, 2),
            fixed_or_dash(d.std, 4),
            d.implausible
        ));
        s.push_str(&format!(
            "{:<7} largest error {} sigma (issued at {} s, {} s ahead); {} of all steps beyond 3 sigma (Gaussian 0.0027)\n",
            d.dof,
            fixed_or_dash(d.max_abs_z, 1),
            exact(d.max_abs_z_time_s),
            exact(d.max_abs_z_lead_s),
            fixed_or_dash(d.beyond_3sigma, 4)
        ));
    }
    let horizon_s = r.dofs.first().map_or(0.0, |d| d.rms.len() as f64 * r.dt_s);
    for d in &r.decisions {
        // Regression (review): a dead heave sensor was explained as the deck waiting for
        // verified errors. Both can hold at once, so the sensors are named beside the reason,
        // not instead of it, and also where calls were made around a freeze.
        let frozen = if d.frozen_forecasts > 0 {
            let by: Vec<String> = d
                .frozen_by_dof
                .iter()
                .map(|(dof, n)| format!("{dof} {n}"))
                .collect();
            format!(
                "{} MOT {:.0}s: a deck sensor repeated its value, to the last bit, at {} of {scored} scored forecasts ({}): no probability is stated while one does\n",
                d.station,
                d.mot_s,
                d.frozen_forecasts,
                by.join(", ")
            )
        } else {
            String::new()
        };
        if d.calls == 0 {
            let too_long = d.mot_s > horizon_s + 1e-9;
            let why = if too_long {
                "the horizon is shorter than the MOT"
            } else if r.partly_scored > 0 {
                "no probability was stated in the scored part of the record: the deck is judged on whole forecasts only, and samples missing from the record left few or none whole; it states nothing before it has verified errors, about 5 minutes"
            } else {
                "no probability was stated in the scored part of the record: the deck states none before it has verified errors, about 5 minutes"
            };
            s.push_str(&format!(
                "{} MOT {:.0}s: no call ({why})\n",
                d.station, d.mot_s
            ));
            if !too_long {
                s.push_str(&frozen);
            }
            continue;
        }
        s.push_str(&format!(
            "{} MOT {:.0}s: {} calls, {} go at p >= {:.2}, false go {}, hit rate {} of {} quiet periods, Brier {} (base rate {})\n",
            d.station, d.mot_s, d.calls, d.go_calls, d.go_probability, fixed_or_dash(d.false_go_rate, 3),
            fixed_or_dash(d.hit_rate, 3), d.quiet_periods, fixed_or_dash(d.brier, 4), fixed_or_dash(d.brier_climatology, 4)
        ));
        s.push_str(&frozen);
        s.push_str(&format!(
            "  threshold  go calls  false go  hit rate announced {:?} s ahead\n",
            d.hit_leads_s
        ));
        for c in &d.curve {
            let hits: Vec<String> = c
                .hit_rate_by_lead
                .iter()
                .map(|&h| fixed_or_dash(h, 3))
                .collect();
            s.push_str(&format!(
                "  {:.2}  {:>8}  {:>8}  {}\n",
                c.threshold,
                c.go_calls,
                fixed_or_dash(c.false_go_rate, 3),
                hits.join(" ")
            ));
        }
        s.push_str("  p bin      calls  episodes  stated  observed\n");
        for b in d.reliability.iter().filter(|b| b.count > 0) {
            s.push_str(&format!(
                "  {:.1}-{:.1}  {:>7}  {:>8}  {}   {}\n",
                b.p_lo,
                b.p_hi,
                b.count,
                b.episodes,
                fixed_or_dash(b.stated, 3),
                fixed_or_dash(b.observed, 3)
            ));
        }
    }
    s
}

/// Why no forecast of a replayed record was scored, naming the cause:
/// - forecasts had all their steps inside the record, but none was issued at or after
///   `--skip-s` (the default skips nothing, so only a given `--skip-s` does this);
/// - gaps restarted the history so often that no stretch held a whole forecast (regression,
///   review: such a record was told its forecasts must come after an `--skip-s` never given);
/// - the record is too short for one.
fn nothing_scored(
    input: &std::path::Path,
    report: &shipcast_pipeline::engine::replay::ReplayReport,
    predictor: &shipcast_pipeline::config::PredictorServiceConfig,
    skip_s: f64,
    (start_s, end_s): (f64, f64),
) -> String {
    // The first forecast comes with the input that completes the decimated values it needs,
    // and is stamped the decimation filter's delay before that input (review: the message said
    // "issued 30 s into it" where a 55.5 s record was refused and a 56 s one taken).
    let factor = (report.input_rate_hz / predictor.sample_rate_hz)
        .round()
        .max(1.0) as usize;
    let inputs = shipcast_series::decimation_inputs_for(
        shipcast_pipeline::engine::MIN_VALUES_TO_PUBLISH as usize,
        factor,
    );
    let first_s = (inputs - 1) as f64 / report.input_rate_hz;
    let horizon_s = predictor.horizon as f64 / predictor.sample_rate_hz;
    let least_s = first_s - report.delay_s + horizon_s;
    // To the millisecond, and the least length rounded up (review: at 16 Hz "at least 55.9 s"
    // where 55.9375 s were needed, at 4 Hz a delay of 0.25 s shown as 0.2).
    let ms = |v: f64| shipcast_wire::shown::number((v * 1000.0).round() / 1000.0);
    let file = input.display();
    let stamped = if report.delay_s > 0.0 {
        format!(
            " and stamped {} s before that (the decimation filter's delay)",
            ms(report.delay_s)
        )
    } else {
        String::new()
    };
    let needs = format!(
        "a forecast is scored only if all {} s of its steps lie inside the record: the first is issued {} s into the record{stamped}, so at least {} s are needed",
        ms(horizon_s),
        ms(first_s),
        shipcast_wire::shown::number((least_s * 1000.0 - 1e-6).ceil() / 1000.0)
    );
    match report.last_complete_s {
        Some(last) => format!(
            "no forecast could be scored in {file}: {} had all their steps inside the record, the last issued at {last:.1} s, but none at or after --skip-s {skip_s} s",
            report.complete_forecasts
        ),
        None if report.history_restarts > 0 => format!(
            "no forecast could be scored in {file}: gaps in time longer than {} samples restarted the history {} times, and a forecast is scored only if all {} s of its steps lie inside the record; the longest history between them was {:.1} s",
            shipcast_pipeline::engine::MAX_FILL,
            report.history_restarts,
            ms(horizon_s),
            report.longest_history_s,
        ),
        None => format!(
            "no forecast could be scored in {file}: it runs from {start_s:.1} to {end_s:.1} s, and {needs}"
        ),
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_model_flag_overrides_the_configuration_and_skip_s_is_checked() {
        let c = crate::validated::<Args, Config>(&[
            "--input", "x.csv", "--model", "m.json", "--skip-s", "60", "--json",
        ])
        .unwrap();
        assert_eq!(c.pipeline.predictor.model, Some(PathBuf::from("m.json")));
        assert_eq!((c.skip_s, c.json), (Some(60.0), true));
        assert_eq!(c.input, PathBuf::from("x.csv"));
        assert!(crate::validated::<Args, Config>(&["--input", "x.csv"])
            .unwrap()
            .pipeline
            .predictor
            .model
            .is_none());
        // Record times may be negative; not infinite, nor NaN.
        assert_eq!(
            crate::validated::<Args, Config>(&["--input", "x.csv", "--skip-s", "-5000"])
                .unwrap()
                .skip_s,
            Some(-5000.0)
        );
        assert_eq!(
            crate::validated::<Args, Config>(&["--input", "x.csv"])
                .unwrap()
                .skip_s,
            None
        );
        for bad in ["-1e13", "nan", "inf"] {
            let e = crate::refused::<Args, Config>(&["--input", "x.csv", "--skip-s", bad]);
            assert!(e.starts_with("--skip-s"), "{e}");
        }
    }

    #[test]
    fn the_configuration_is_checked_after_the_model_flag() {
        // Regression: the file was checked before --model was applied, so a start-up history
        // too short to fit on was refused although the model file made it moot.
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("short.toml");
        std::fs::write(&file, "[predictor]\nwarmup_s = 60.0\n").unwrap();
        let file = file.to_str().unwrap();
        let args = ["--input", "x.csv", "--config", file];
        let e = crate::refused::<Args, Config>(&args);
        assert!(e.contains("predictor.warmup_s = 60 s"), "{e}");
        let with_model = [&args[..], &["--model", "m.json"]].concat();
        assert!(crate::validated::<Args, Config>(&with_model).is_ok());
    }
}
