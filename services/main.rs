//! The `shipcast` binary: argument parsing and dispatch to one module per service.
//! Every service is thin wiring over the library crates (`crates/`).

use clap::{Parser, Subcommand};
use std::io::Write;
use std::process::ExitCode;

mod bench;
mod certs;
mod common_args;
mod crane;
mod deck;
mod display;
mod error_text;
mod eval;
mod followed_motion;
mod logging;
mod paper;
mod predictor;
mod private_files;
mod producer;
mod progress;
mod relative;
mod replay;
mod router;
mod run;
mod simulate;
mod train;

/// Ship-motion prediction middleware: simulate, evaluate and forecast 6-DOF ship motion.
#[derive(Parser, Debug)]
#[command(name = "shipcast", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate 6-DOF motion of a ship in irregular seas and write a motion CSV.
    Simulate(simulate::Args),
    /// Evaluate predictors on a motion CSV with the fixed protocol (docs/contracts.md section 4).
    Eval(eval::Args),
    /// Fit per-DOF models for the predictor service and write them to a model file.
    Train(train::Args),
    /// Regenerate the paper's tables and figures (section 4 of Zhao, Xu, Kwan).
    Paper(paper::Args),
    /// Run the predictor's engine over a recorded motion CSV and score every forecast.
    Replay(replay::Args),
    /// Start the whole pipeline (producer, predictor, deck, crane, display; with --two-ship
    /// also the second ship and `relative`) as separate processes, with a live view.
    Run(run::Args),
    /// Publish motion samples over iceoryx2 (simulator or CSV replay).
    Producer(producer::Args),
    /// Subscribe to motion, forecast all six DOF, publish over iceoryx2 and zenoh.
    Predictor(predictor::Args),
    /// Helideck landing advisory from forecasts (co-located, iceoryx2).
    Deck(deck::Args),
    /// Crane-tip motion forecast (remote, zenoh).
    Crane(crane::Args),
    /// Ship-to-ship relative motion (crane tip against a landing spot on another vessel) with
    /// the lift go/no-go; with --crane-record/--target-record, the two-ship study.
    Relative(relative::Args),
    /// Live display: a web page of every vessel's forecasts, advisories and skill.
    Display(display::Args),
    /// Benchmarks of the running system (latency, fleet).
    Bench(bench::Args),
    /// Make a secure setup: a new CA, certificates, shipcast.toml and station zenoh configs.
    Certs(certs::Args),
    /// Run a zenoh router for a fleet (vessels connect, shore consumers subscribe).
    Router(router::Args),
}

/// A range check of `shipcast_pipeline::limits` (a one-line message naming the value) as an
/// error of the command.
fn checked<T>(check: Result<T, String>) -> anyhow::Result<T> {
    check.map_err(anyhow::Error::msg)
}

/// `path`, a file a command writes at the end of its work, must be in an existing directory
/// and not be a directory itself: checked before the work starts, so that a typo costs no
/// minutes (regression: `train --out DIR` trained first and failed at the write).
fn output_in_existing_dir(option: &str, path: &std::path::Path) -> anyhow::Result<()> {
    if path.is_dir() {
        anyhow::bail!("{option} {}: is a directory, not a file", path.display());
    }
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    match dir {
        Some(d) if !d.is_dir() => anyhow::bail!(
            "{option} {}: the directory {} does not exist",
            path.display(),
            d.display()
        ),
        _ => Ok(()),
    }
}

/// `out`, a file a command writes, must not be `input`, a file it reads: written over, a
/// measured record was lost (regression, review: `simulate --elevation x.csv --out x.csv`
/// replaced the record by its simulated motion, `train --input y.csv --out y.csv` by a model).
/// Compared as the files they are (the same device and inode: `./x.csv` and `x.csv`, a
/// symbolic or a hard link are the same file); an `out` that does not exist yet is no input.
fn output_not_input(
    option: &str,
    out: &std::path::Path,
    input_option: &str,
    input: &std::path::Path,
) -> anyhow::Result<()> {
    if same_file(out, input) {
        anyhow::bail!(
            "{option} {} is the {input_option} file: writing it would destroy what is read; give another {option}",
            out.display()
        );
    }
    Ok(())
}

/// Whether both paths name one existing file (the same device and inode).
fn same_file(a: &std::path::Path, b: &std::path::Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// Two files a command writes must differ: the second written replaced the first
/// (regression, review: `simulate --out s.csv --plot s.csv` left the figure only). The same
/// existing file, or the same name in the same directory when they do not exist yet.
fn outputs_differ(
    option: &str,
    path: &std::path::Path,
    other_option: &str,
    other: &std::path::Path,
) -> anyhow::Result<()> {
    let place = |p: &std::path::Path| {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
        let dir = dir.unwrap_or(std::path::Path::new("."));
        (
            std::fs::canonicalize(dir).ok(),
            p.file_name().map(|n| n.to_owned()),
        )
    };
    let (a, b) = (place(path), place(other));
    if same_file(path, other) || (a.0.is_some() && a.1.is_some() && a == b) {
        anyhow::bail!(
            "{option} {} is the {other_option} file: one would overwrite the other; give another {option}",
            path.display()
        );
    }
    Ok(())
}

/// The raw arguments of one command parsed from `argv` (without the command's name), as clap
/// parses them on the command line: for the unit tests of each command's validation.
#[cfg(test)]
fn parse_args<A: clap::Args>(argv: &[&str]) -> A {
    #[derive(Parser)]
    struct One<A: clap::Args> {
        #[command(flatten)]
        args: A,
    }
    let full: Vec<&str> = std::iter::once("shipcast")
        .chain(argv.iter().copied())
        .collect();
    match One::<A>::try_parse_from(&full) {
        Ok(one) => one.args,
        Err(e) => panic!("{full:?}: {e}"),
    }
}

/// The validated configuration of a command line of one command (argv without its name).
#[cfg(test)]
fn validated<A, C>(argv: &[&str]) -> anyhow::Result<C>
where
    A: clap::Args,
    C: TryFrom<A, Error = anyhow::Error>,
{
    C::try_from(parse_args::<A>(argv))
}

/// The one line a refused command line prints after `error: ` (`{:#}`, as `main` prints it).
#[cfg(test)]
fn refused<A, C>(argv: &[&str]) -> String
where
    A: clap::Args,
    C: TryFrom<A, Error = anyhow::Error> + std::fmt::Debug,
{
    format!("{:#}", validated::<A, C>(argv).unwrap_err())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    logging::init();
    let result = match cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Train(a) => train::run(a),
        Command::Paper(a) => paper::run(a),
        Command::Replay(a) => replay::run(a),
        Command::Run(a) => run::run(a),
        Command::Producer(a) => producer::run(a),
        Command::Predictor(a) => predictor::run(a),
        Command::Deck(a) => deck::run(a),
        Command::Crane(a) => crane::run(a),
        Command::Relative(a) => relative::run(a),
        Command::Display(a) => display::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Certs(a) => certs::run(a),
        Command::Router(a) => router::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line, no backtrace: the chain of causes joined by ": ". Written, not
            // eprintln!: with stderr closed (`2>&1 | head` done reading) that would panic,
            // and the exit status would be a panic's instead of the error's.
            let _ = writeln!(
                std::io::stderr(),
                "error: {}",
                error_text::one_line(&format!("{e:#}"))
            );
            ExitCode::from(2)
        }
    }
}
