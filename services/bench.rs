//! `shipcast bench`: benchmarks of the running system. `bench latency` measures shipcast's
//! paths and the raw transport floors one way on two pinned cores (issue 6).

use crate::progress::Bar;
use anyhow::Context;
use shipcast::bench::latency::{self, FORECAST_BYTES, MOTION_BYTES};
use shipcast::bench::pingpong_zenoh_processes::{self, PongArgs};
use shipcast::bench::plan::parse_cores;
use shipcast::bench::{ModeSelect, Plan};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand, Debug)]
enum Command {
    /// One-way latency of shipcast's paths and of raw iceoryx2 and zenoh, on two pinned cores.
    Latency(LatencyArgs),
    /// The answering side of the inter-process zenoh floor, started by `bench latency`.
    #[command(hide = true)]
    ZenohPong(ZenohPongArgs),
}

#[derive(clap::Args, Debug)]
struct ZenohPongArgs {
    /// The ping side's listen endpoint.
    #[arg(long)]
    connect: String,
    /// Key prefix of the exchange.
    #[arg(long)]
    prefix: String,
    #[arg(long)]
    bytes: usize,
    #[arg(long, value_parser = |s: &str| s.parse::<ModeSelect>())]
    mode: ModeSelect,
    #[arg(long)]
    core: usize,
    #[arg(long)]
    warmup: u64,
    /// File for the recorded legs.
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args, Debug)]
struct LatencyArgs {
    /// Measured samples (and ping-pong exchanges) per path and mode.
    #[arg(long, default_value_t = 5000)]
    samples: u64,
    /// Send rate in Hz (8 is the realistic sensor rate; thousands stress the path).
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// Receive mode: event (blocking wait, woken by notify), poll (busy polling) or both.
    #[arg(long, default_value = "both", value_parser = |s: &str| s.parse::<ModeSelect>())]
    mode: ModeSelect,
    /// Print the rows as a JSON array on stdout (the conditions and the table go to stderr).
    #[arg(long)]
    json: bool,
    /// Write an SVG of the latency distributions to this file.
    #[arg(long)]
    svg: Option<PathBuf>,
    /// Cores of the sender/producer and the receiver/predictor, as A,B.
    #[arg(long, default_value = "0,1", value_parser = |s: &str| parse_cores(s))]
    cores: (usize, usize),
    /// Unsent warm-up samples before measuring (default: 10 % of --samples, at most 200).
    #[arg(long)]
    warmup: Option<u64>,
    /// The measurements take turns this many times, each with its share of --samples, so
    /// noise from the host falls on every path alike (each round restarts the services).
    #[arg(long, default_value_t = 4)]
    rounds: u64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Latency(a) => run_latency(a),
        Command::ZenohPong(a) => {
            let &[mode] = a.mode.modes() else {
                anyhow::bail!("zenoh-pong: --mode must be event or poll");
            };
            pingpong_zenoh_processes::serve_pong(&PongArgs {
                connect: a.connect,
                prefix: a.prefix,
                bytes: a.bytes,
                mode,
                core: a.core,
                warmup: a.warmup,
                out: a.out,
            })
        }
    }
}

/// The running binary, for starting the services. /proc/self/exe still names this image when
/// the file on disk is replaced mid-run (a rebuild), which the plain path would not.
fn own_executable() -> anyhow::Result<PathBuf> {
    let proc_exe = PathBuf::from("/proc/self/exe");
    if proc_exe.exists() {
        return Ok(proc_exe);
    }
    std::env::current_exe().context("locate the shipcast executable")
}

fn run_latency(a: LatencyArgs) -> anyhow::Result<()> {
    let plan = Plan {
        samples: a.samples,
        warmup: a.warmup.unwrap_or((a.samples / 10).clamp(1, 200)),
        rounds: a.rounds,
        rate_hz: a.rate,
        cores: a.cores,
        instance: Plan::unique_instance("latency"),
        shipcast_exe: Some(own_executable()?),
    };
    let bar = Bar::new();
    let report = latency::run(&plan, a.mode.modes(), &bar);
    bar.finish();
    let report = report?;
    let targets = report.targets(MOTION_BYTES, FORECAST_BYTES, latency::forecast_json_bytes());
    if a.json {
        // The table goes to stderr too, so one run gives both the JSON and the readable form.
        eprint!("{}\n{}\n{}", report.header(), report.table(), targets);
        println!("{}", report.json().context("encode JSON")?);
    } else {
        print!("{}\n{}\n{}", report.header(), report.table(), targets);
    }
    if let Some(svg) = &a.svg {
        report.write_svg(svg)?;
        eprintln!("wrote {}", svg.display());
    }
    Ok(())
}
