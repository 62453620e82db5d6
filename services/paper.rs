//! `shipcast paper --out DIR [--quick] [--seed N] [--measured FILE.csv]`: the paper study (tables and figures of Zhao,
//! Xu and Kwan, section 4), written as `DIR/report.md` and SVG figures, with a progress bar.

use crate::progress::Bar;
use anyhow::Context;
use shipcast_paper::{self as paper, Plan};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Directory for report.md and the SVG figures (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Shorter records, smaller orders and fewer MLP epochs: a smoke test of seconds (about 3 s of CPU).
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

/// The study `paper` runs, every value checked: built from [`Args`] by [`Config::try_from`].
/// The measured record is read there, so a bad file costs no minutes of study.
pub struct Config {
    pub plan: Plan,
    /// Output directory (created by the run).
    pub out: PathBuf,
    pub measured: Option<paper::averaging::MeasuredSeries>,
    pub sections: Sections,
}

/// Which part of the study runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sections {
    All,
    AveragingOnly,
    /// Only with a measured record (`Config::measured` is then set).
    MeasuredOnly,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let sections = match (args.averaging_only, args.measured_only) {
            (true, true) => {
                anyhow::bail!("--averaging-only and --measured-only exclude each other")
            }
            (true, false) => Sections::AveragingOnly,
            (false, true) if args.measured.is_none() => {
                anyhow::bail!("--measured-only needs --measured FILE.csv")
            }
            (false, true) => Sections::MeasuredOnly,
            (false, false) => Sections::All,
        };
        if args.out.exists() && !args.out.is_dir() {
            anyhow::bail!("--out {} is a file, not a directory", args.out.display());
        }
        if let Some(record) = &args.measured {
            written_by_paper(record, &args.out)?;
        }
        let measured = args
            .measured
            .as_deref()
            .map(paper::averaging::MeasuredSeries::read)
            .transpose()?;
        Ok(Config {
            plan: if args.quick {
                Plan::quick(args.seed)
            } else {
                Plan::full(args.seed)
            },
            out: args.out,
            measured,
            sections,
        })
    }
}

/// Refuses a `--measured` record that the study could write over: the same file (by any
/// name, a symbolic or a hard link) as a report (`.md`) or a figure (`.svg`) in `--out`
/// (regression, review: `--measured DIR/measured.md` was replaced by the section made from
/// it, and then a link `DIR/measured.md` to the record was written through).
fn written_by_paper(record: &Path, out: &Path) -> anyhow::Result<()> {
    let Ok(entries) = std::fs::read_dir(out) else {
        // No directory yet: nothing in it is the record.
        return Ok(());
    };
    for entry in entries.flatten() {
        let name = entry.path();
        let written = name.extension().is_some_and(|e| e == "md" || e == "svg");
        if written && crate::same_file(&name, record) {
            anyhow::bail!(
                "--measured {} is {} in --out, and the study writes its reports (.md) and figures (.svg) there: writing them could destroy the record; move it or give another --out",
                record.display(),
                name.display()
            );
        }
    }
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        plan,
        out,
        measured,
        sections,
    } = Config::try_from(args)?;
    // Fail on an unusable output directory before spending minutes on the study.
    std::fs::create_dir_all(&out)
        .with_context(|| format!("creating the output directory {}", out.display()))?;
    // Regression (review): a directory that exists but takes no file (read-only) was found
    // only when the first figure was drawn, after the whole study.
    shipcast_series::atomic_file::check_writable_beside(&out.join("report.md"))
        .with_context(|| format!("the output directory {} takes no file", out.display()))?;
    // Regression (review): a report name taken by a directory failed only after the whole
    // study (up to 15 minutes).
    for name in ["report.md", "averaging.md", "measured.md"] {
        let path = out.join(name);
        if path.is_dir() {
            anyhow::bail!(
                "{} is a directory: the report cannot be written there",
                path.display()
            );
        }
    }
    match (sections, measured.as_ref()) {
        (Sections::AveragingOnly, measured) => {
            let section = paper::averaging::run_alone(&plan, measured)?;
            let path = out.join("averaging.md");
            // Written whole: a failed write cut the previous good section (review).
            shipcast_series::atomic_file::write_atomically(&path, section.as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
            tracing::info!(report = %path.display(), "averaged-forecast section written");
        }
        (Sections::MeasuredOnly, Some(record)) => {
            let section = paper::measured::run_alone(&plan, record);
            let path = out.join("measured.md");
            shipcast_series::atomic_file::write_atomically(&path, section.as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
            tracing::info!(report = %path.display(), "measured-sea section written");
        }
        (Sections::MeasuredOnly, None) => {
            anyhow::bail!("--measured-only needs --measured FILE.csv")
        }
        (Sections::All, measured) => {
            let bar = Bar::new();
            let study = paper::run_with(&plan, measured, &bar)?;
            bar.finish();
            let path = paper::report::write(&study, &out)?;
            tracing::info!(
                report = %path.display(),
                seconds = study.elapsed_seconds,
                "paper study written"
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(argv: &[&str]) -> String {
        format!(
            "{:#}",
            Config::try_from(crate::parse_args::<Args>(argv))
                .err()
                .unwrap()
        )
    }

    #[test]
    fn sections_and_the_output_directory_are_checked_first() {
        let c = Config::try_from(crate::parse_args::<Args>(&["--out", "o", "--quick"])).unwrap();
        assert_eq!(c.sections, Sections::All);
        assert!(c.measured.is_none());
        let dir = tempfile::tempdir().unwrap();
        let record = dir.path().join("m.csv");
        std::fs::write(&record, "time_s,heave_m\n0,1\n").unwrap();
        let record = record.to_str().unwrap();
        assert_eq!(
            refused(&[
                "--out",
                "o",
                "--measured",
                record,
                "--averaging-only",
                "--measured-only"
            ]),
            "--averaging-only and --measured-only exclude each other"
        );
        let file = dir.path().join("report.md");
        std::fs::write(&file, "").unwrap();
        let file = file.to_str().unwrap();
        assert_eq!(
            refused(&["--out", file]),
            format!("--out {file} is a file, not a directory")
        );
    }

    #[test]
    fn a_measured_record_the_study_would_write_over_is_refused() {
        // Regression (review): `--out DIR --measured DIR/measured.md` replaced the record by
        // the section made from it. A record in --out under another name is read as it is.
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().to_str().unwrap();
        for name in ["measured.md", "fig3_heave.svg"] {
            let record = dir.path().join(name);
            std::fs::write(&record, "time_s,heave_m\n0,1\n").unwrap();
            let record = record.to_str().unwrap();
            let e = refused(&["--out", out, "--measured", record, "--measured-only"]);
            assert!(e.starts_with(&format!("--measured {record} is ")), "{e}");
            assert!(e.contains("in --out, and the study writes"), "{e}");
            std::fs::remove_file(record).unwrap();
        }
        // Nor through a link in --out to a record elsewhere (review).
        let elsewhere = tempfile::tempdir().unwrap();
        let linked = elsewhere.path().join("rec.csv");
        std::fs::write(&linked, "time_s,heave_m\n0,1\n").unwrap();
        std::os::unix::fs::symlink(&linked, dir.path().join("measured.md")).unwrap();
        let linked = linked.to_str().unwrap();
        let e = refused(&["--out", out, "--measured", linked, "--measured-only"]);
        assert!(e.contains("in --out, and the study writes"), "{e}");
        std::fs::remove_file(dir.path().join("measured.md")).unwrap();
        let kept = dir.path().join("m.csv");
        let rows: String = (0..4000)
            .map(|i| format!("{},{}\n", i as f64 * 0.5, (i as f64 * 0.4).sin()))
            .collect();
        std::fs::write(&kept, format!("time_s,heave_m\n{rows}")).unwrap();
        let args = ["--out", out, "--measured", kept.to_str().unwrap()];
        let c = Config::try_from(crate::parse_args::<Args>(&args));
        assert!(c.is_ok(), "{:#}", c.err().unwrap());
    }
}
